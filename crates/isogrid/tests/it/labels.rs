//! Label extraction against independent references: each label's clusters must be exactly what the
//! ordinary extraction makes of that label's indicator volume (binary, or smoothed by a Gaussian
//! written out here), neighbours must cross shared edges at the same point, and files are
//! byte-identical and validated strictly.

use crate::common::Rng;
use isogrid::layout::{read_corners, BOUND_SLOT, CLUSTER_SLOTS};
use isogrid::{
    cgc, extract, extract_labels, CellGrid, ErrorKind, ExtractOptions, Iso, LabelOptions,
    LabelSelection, Precision, Volume, VolumeData,
};
use std::collections::{BTreeMap, BTreeSet};

pub(crate) const DIMS: [usize; 3] = [37, 30, 35];

/// Touching labels: a ball (1), a box against the ball and the +x border (65535), a shell piece
/// (2) meeting both, a one-voxel-thick sheet (7), a single voxel (300), a patch of random labels
/// (3, 4, 5) and background 0.
pub(crate) fn label_volume() -> Vec<u16> {
    let [nx, ny, nz] = DIMS;
    let mut rng = Rng::new(5);
    let mut v = vec![0u16; nx * ny * nz];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let d = [x as f64 - 18.0, y as f64 - 15.0, z as f64 - 17.0];
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let i = x + nx * (y + ny * z);
                v[i] = if r < 8.0 {
                    1
                } else if x >= 25 && (8..24).contains(&y) && (6..30).contains(&z) {
                    u16::MAX
                } else if r < 10.5 && y > 15 {
                    2
                } else if y == 3 && (4..30).contains(&x) && (2..20).contains(&z) {
                    7
                } else if (2..9).contains(&x) && (20..28).contains(&y) && (25..33).contains(&z) {
                    3 + rng.below(3) as u16
                } else {
                    0
                };
            }
        }
    }
    v[30 + nx * (26 + ny * 3)] = 300;
    v
}

fn volume_of(data: VolumeData) -> Volume {
    Volume::new(DIMS, data).unwrap()
}

/// Position → corner record of every active cell of `grid` in the clusters `clusters`.
fn cells_of(
    grid: &CellGrid,
    clusters: impl IntoIterator<Item = usize>,
) -> BTreeMap<[u32; 3], Vec<u8>> {
    let metacells = grid.metacells();
    let mut out = BTreeMap::new();
    for c in clusters {
        for m in &metacells[c * CLUSTER_SLOTS..c * CLUSTER_SLOTS + BOUND_SLOT] {
            let bits = (0..8).filter(|b| m.cell_mask >> b & 1 == 1);
            for (k, bit) in bits.enumerate() {
                let record = grid.cell_record(m.cell_pointer as usize + k).to_vec();
                assert!(out.insert(m.cell_position(bit), record).is_none());
            }
        }
    }
    out
}

/// The cells of label `value` in a labelled grid, found through the label index, after checking
/// that the cluster labels agree with it.
fn label_cells(grid: &CellGrid, value: u64) -> BTreeMap<[u32; 3], Vec<u8>> {
    let labels = grid.labels().unwrap();
    let l = labels.find(value).unwrap();
    let clusters: Vec<usize> = labels
        .runs_of(l)
        .iter()
        .flat_map(|r| r.clusters())
        .collect();
    let by_label: Vec<usize> = (0..grid.clusters())
        .filter(|&c| labels.cluster_labels()[c] as usize == l)
        .collect();
    assert_eq!(clusters, by_label, "label {value}: runs and cluster labels");
    cells_of(grid, clusters)
}

fn all_cells(grid: &CellGrid) -> BTreeMap<[u32; 3], Vec<u8>> {
    cells_of(grid, 0..grid.clusters())
}

fn distinct_labels(data: &[u16]) -> Vec<u64> {
    let set: BTreeSet<u64> = data.iter().map(|&v| v as u64).filter(|&v| v != 0).collect();
    set.into_iter().collect()
}

#[test]
fn each_label_is_the_extraction_of_its_indicator() {
    let data = label_volume();
    let volume = volume_of(VolumeData::U16(data.clone()));
    for precision in [
        Precision::Bits1,
        Precision::Bits4,
        Precision::Bits8,
        Precision::Bits16,
    ] {
        let mut options = LabelOptions::new(LabelSelection::All);
        options.precision = Some(precision);
        let grid = extract_labels(&volume.view(), &options).unwrap();
        let labels = grid.labels().unwrap();
        let values: Vec<u64> = labels.table().iter().map(|l| l.value).collect();
        assert_eq!(values, distinct_labels(&data));
        let mut total = 0;
        for (l, label) in labels.table().iter().enumerate() {
            let indicator: Vec<f32> = data
                .iter()
                .map(|&v| (v as u64 == label.value) as u8 as f32)
                .collect();
            let reference = extract(
                &volume_of(VolumeData::F32(indicator)).view(),
                &ExtractOptions::new(Iso::Value(0.5)).with_precision(precision),
            )
            .unwrap();
            let expected = all_cells(&reference);
            let got = label_cells(&grid, label.value);
            assert!(!expected.is_empty(), "label {} has a surface", label.value);
            assert_eq!(got, expected, "label {} at {precision:?}", label.value);
            let entry = labels.index()[l];
            assert_eq!(entry.cell_count, expected.len() as u64);
            for a in 0..3 {
                assert_eq!(entry.lo[a], expected.keys().map(|p| p[a]).min().unwrap());
                assert_eq!(
                    entry.hi[a],
                    expected.keys().map(|p| p[a] + 1).max().unwrap()
                );
            }
            total += expected.len();
        }
        assert_eq!(grid.active_cells(), total);
        assert_eq!(grid.info().mapping, reference_mapping(precision));
    }
}

/// The mapping an ordinary extraction gives an indicator volume: [0, 1] over the codes, iso ½.
fn reference_mapping(precision: Precision) -> isogrid::ValueMapping {
    let mut v = vec![0f32; 8];
    v[0] = 1.0;
    let grid = extract(
        &Volume::new([2, 2, 2], VolumeData::F32(v)).unwrap().view(),
        &ExtractOptions::new(Iso::Value(0.5)).with_precision(precision),
    )
    .unwrap();
    grid.info().mapping
}

/// The indicator of `value` smoothed by a Gaussian of σ `sigma`, written plainly in f64: weights
/// exp(−k²/2σ²) for |k| ≤ ⌈3σ⌉ normalised to 1, one axis after another, the border repeated.
fn smoothed_indicator(data: &[u16], value: u64, sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|k| (-((k * k) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = w.iter().sum();
    let w: Vec<f64> = w.iter().map(|x| x / sum).collect();
    let [nx, ny, nz] = DIMS;
    let mut f: Vec<f64> = data
        .iter()
        .map(|&v| (v as u64 == value) as u8 as f64)
        .collect();
    for axis in 0..3 {
        let mut g = vec![0.0; f.len()];
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let p = [x, y, z];
                    let mut s = 0.0;
                    for (k, wk) in w.iter().enumerate() {
                        let mut q = p.map(|c| c as i64);
                        q[axis] = (q[axis] + k as i64 - r).clamp(0, DIMS[axis] as i64 - 1);
                        s += wk * f[q[0] as usize + nx * (q[1] as usize + ny * q[2] as usize)];
                    }
                    g[x + nx * (y + ny * z)] = s;
                }
            }
        }
        f = g;
    }
    f
}

#[test]
fn smoothed_labels_are_the_extraction_of_their_smoothed_indicators() {
    let data = label_volume();
    let volume = volume_of(VolumeData::U16(data.clone()));
    let sigma = 1.0;
    let mut options = LabelOptions::new(LabelSelection::All);
    options.smooth = sigma;
    let grid = extract_labels(&volume.view(), &options).unwrap();
    assert_eq!(grid.info().precision, Precision::Bits8);
    let mapping = grid.info().mapping;
    let labels = grid.labels().unwrap();
    let mut compared = 0;
    for label in labels.table() {
        let field = smoothed_indicator(&data, label.value, sigma);
        // Samples this close to ½ may fall either side between f32 and f64 arithmetic.
        let near = |i: usize| (field[i] - 0.5).abs() < 1e-5;
        let reference = extract(
            &volume_of(VolumeData::F32(field.iter().map(|&v| v as f32).collect())).view(),
            &ExtractOptions::new(Iso::Value(0.5)).with_precision(Precision::Float32),
        )
        .unwrap();
        let expected = all_cells(&reference);
        let got = label_cells(&grid, label.value);
        let [nx, ny, _] = DIMS;
        let corner_index = |p: &[u32; 3], c: usize| {
            let q = [
                p[0] as usize + (c & 1),
                p[1] as usize + (c >> 1 & 1),
                p[2] as usize + (c >> 2 & 1),
            ];
            q[0] + nx * (q[1] + ny * q[2])
        };
        let positions: BTreeSet<_> = expected.keys().chain(got.keys()).copied().collect();
        for p in positions {
            let ambiguous = (0..8).any(|c| near(corner_index(&p, c)));
            match (expected.get(&p), got.get(&p)) {
                (Some(_), Some(record)) => {
                    let codes = read_corners(record, Precision::Bits8);
                    for (c, &code) in codes.iter().enumerate() {
                        let v = field[corner_index(&p, c)];
                        let decoded = mapping.value(code);
                        assert!(
                            (decoded - v).abs() <= 0.5 / 255.0 + 1e-5,
                            "label {} cell {p:?} corner {c}: {decoded} for {v}",
                            label.value
                        );
                        if !near(corner_index(&p, c)) {
                            assert_eq!(code >= mapping.iso_code, v >= 0.5);
                        }
                    }
                    compared += 1;
                }
                _ => assert!(
                    ambiguous,
                    "label {} cell {p:?} in one set only",
                    label.value
                ),
            }
        }
    }
    assert!(compared > 3000, "{compared}");
}

/// Crossing of the isovalue along the edge from corner `a` to corner `b` of a record.
fn crossing(codes: &[f32; 8], iso: f32, a: usize, b: usize) -> f32 {
    (iso - codes[a]) / (codes[b] - codes[a])
}

#[test]
fn touching_labels_cross_shared_edges_at_the_same_point() {
    let data = label_volume();
    let volume = volume_of(VolumeData::U16(data.clone()));
    let [nx, ny, _] = DIMS;
    let at = |p: [u32; 3]| data[p[0] as usize + nx * (p[1] as usize + ny * p[2] as usize)] as u64;
    for smooth in [0.0, 1.0] {
        // The background too, so that every label has neighbours.
        let mut options = LabelOptions::new(LabelSelection::parse("0-65535").unwrap());
        options.smooth = smooth;
        let grid = extract_labels(&volume.view(), &options).unwrap();
        let precision = grid.info().precision;
        let iso = grid.info().mapping.iso_code;
        let labels = grid.labels().unwrap();
        let cells: BTreeMap<u64, BTreeMap<[u32; 3], Vec<u8>>> = labels
            .table()
            .iter()
            .map(|l| (l.value, label_cells(&grid, l.value)))
            .collect();
        // With smoothing, the two indicators add up to 1 only where no third label is in reach.
        let reach = (3.0 * smooth).ceil() as i64;
        let only_two = |p: [u32; 3], a: u64, b: u64| {
            (-reach..=reach).all(|dz| {
                (-reach..=reach).all(|dy| {
                    (-reach..=reach).all(|dx| {
                        let q = [dx, dy, dz].map(|d| d);
                        let q = [0, 1, 2]
                            .map(|i| (p[i] as i64 + q[i]).clamp(0, DIMS[i] as i64 - 1) as u32);
                        let v = at(q);
                        v == a || v == b
                    })
                })
            })
        };
        let mut shared = 0;
        for (&a, cells_a) in &cells {
            for (&b, cells_b) in cells.range(a + 1..) {
                for (p, ra) in cells_a {
                    let Some(rb) = cells_b.get(p) else { continue };
                    let (ca, cb) = (read_corners(ra, precision), read_corners(rb, precision));
                    for (u, v) in EDGES {
                        let pu = corner(*p, u);
                        let pv = corner(*p, v);
                        let (lu, lv) = (at(pu), at(pv));
                        if !((lu == a && lv == b) || (lu == b && lv == a)) {
                            continue;
                        }
                        if smooth > 0.0 && !(only_two(pu, a, b) && only_two(pv, a, b)) {
                            continue;
                        }
                        let (ta, tb) = (crossing(&ca, iso, u, v), crossing(&cb, iso, u, v));
                        assert_eq!(
                            ta, tb,
                            "labels {a}|{b}, cell {p:?}, edge {u}-{v}, σ {smooth}"
                        );
                        shared += 1;
                    }
                }
            }
        }
        assert!(shared > 1000, "σ {smooth}: {shared} shared edges");
    }
}

const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

fn corner(p: [u32; 3], c: usize) -> [u32; 3] {
    [
        p[0] + (c & 1) as u32,
        p[1] + (c >> 1 & 1) as u32,
        p[2] + (c >> 2 & 1) as u32,
    ]
}

#[test]
fn files_are_byte_identical_across_runs_and_thread_counts_and_read_back() {
    let volume = volume_of(VolumeData::U16(label_volume()));
    for smooth in [0.0, 1.5] {
        let mut options = LabelOptions::new(LabelSelection::All);
        options.smooth = smooth;
        let bytes: Vec<Vec<u8>> = [1, 3, 3]
            .iter()
            .map(|&threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                cgc::to_bytes(
                    &pool
                        .install(|| extract_labels(&volume.view(), &options))
                        .unwrap(),
                )
            })
            .collect();
        assert!(bytes.windows(2).all(|w| w[0] == w[1]));
        let grid = cgc::read_bytes(&bytes[0]).unwrap();
        let path =
            std::env::temp_dir().join(format!("isogrid-it-labels-{}.cgc", std::process::id()));
        std::fs::write(&path, &bytes[0]).unwrap();
        for other in [cgc::read(&path).unwrap(), cgc::open(&path).unwrap()] {
            assert_eq!(other.labels(), grid.labels());
            assert_eq!(cgc::to_bytes(&other), bytes[0]);
        }
        std::fs::remove_file(&path).unwrap();
        let labels = grid.labels().unwrap();
        assert_eq!(labels.table()[0].name, "label 1");
        assert_eq!(labels.table().last().unwrap().name, "label 65535");
    }
}

#[test]
fn a_selection_keeps_only_its_labels_and_the_same_cells() {
    let data = label_volume();
    let volume = volume_of(VolumeData::U16(data));
    let all = extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    let selection = LabelSelection::parse("2, 4-7,65535,9000").unwrap();
    let some = extract_labels(&volume.view(), &LabelOptions::new(selection)).unwrap();
    let values: Vec<u64> = some
        .labels()
        .unwrap()
        .table()
        .iter()
        .map(|l| l.value)
        .collect();
    assert_eq!(values, [2, 4, 5, 7, 65535]);
    for v in values {
        assert_eq!(label_cells(&some, v), label_cells(&all, v));
    }
    // Background 0 only when asked for.
    let zero = extract_labels(
        &volume.view(),
        &LabelOptions::new(LabelSelection::parse("0").unwrap()),
    )
    .unwrap();
    assert_eq!(zero.labels().unwrap().table()[0].value, 0);
}

#[test]
fn float_volumes_are_labels_only_when_integral() {
    let data = label_volume();
    let ints = extract_labels(
        &volume_of(VolumeData::U16(data.clone())).view(),
        &LabelOptions::new(LabelSelection::All),
    )
    .unwrap();
    let floats = extract_labels(
        &volume_of(VolumeData::F32(data.iter().map(|&v| v as f32).collect())).view(),
        &LabelOptions::new(LabelSelection::All),
    )
    .unwrap();
    assert_eq!(ints.metacells(), floats.metacells());
    assert_eq!(ints.cells(), floats.cells());
    assert_eq!(ints.labels(), floats.labels());
    let mut bad: Vec<f32> = data.iter().map(|&v| v as f32).collect();
    bad[100] = 2.5;
    let err = extract_labels(
        &volume_of(VolumeData::F32(bad)).view(),
        &LabelOptions::new(LabelSelection::All),
    )
    .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::InvalidInput);
    assert!(err.to_string().contains("2.5"), "{err}");
}

#[test]
fn signed_labels_keep_their_sign() {
    let data: Vec<i16> = label_volume()
        .iter()
        .map(|&v| if v == 2 { -2 } else { (v % 1000) as i16 })
        .collect();
    let grid = extract_labels(
        &volume_of(VolumeData::I16(data)).view(),
        &LabelOptions::new(LabelSelection::parse("-2").unwrap()),
    )
    .unwrap();
    let table = grid.labels().unwrap().table();
    assert_eq!(table.len(), 1);
    assert_eq!(table[0].value, (-2i64) as u64);
    assert_eq!(table[0].name, "label -2");
}

#[test]
fn selections_parse_and_bad_ones_are_refused() {
    assert_eq!(LabelSelection::parse("all").unwrap(), LabelSelection::All);
    assert_eq!(
        LabelSelection::parse("1,5-9").unwrap(),
        LabelSelection::Values(vec![1..=1, 5..=9])
    );
    assert_eq!(
        LabelSelection::parse("-3--1").unwrap(),
        LabelSelection::Values(vec![(-3i64 as u64)..=(-1i64 as u64)])
    );
    // Across zero: a range of keys that wraps, from the negative end's two's complement to 5.
    assert_eq!(
        LabelSelection::parse("-5-5").unwrap(),
        LabelSelection::Values(vec![(-5i64 as u64)..=5])
    );
    let across = LabelSelection::parse("-3-2").unwrap();
    let selected: Vec<i64> = (-6i64..=6).filter(|&v| across.selects(v as u64)).collect();
    assert_eq!(selected, [-3, -2, -1, 0, 1, 2]);
    for (bad, why) in [
        ("", "is not a whole number"),
        ("x", "is not a whole number"),
        ("1,,2", "is not a whole number"),
        ("1-", "is not a whole number"),
        ("9-5", "runs backwards"),
        ("1--3", "runs backwards"),
        ("99999999999999999999", "beyond the 64-bit"),
        ("-9223372036854775809", "beyond the 64-bit"),
    ] {
        let err = LabelSelection::parse(bad).unwrap_err().to_string();
        assert!(err.contains(why), "{bad}: {err}");
    }
    assert_eq!(
        LabelSelection::parse("18446744073709551615").unwrap(),
        LabelSelection::Values(vec![u64::MAX..=u64::MAX])
    );
}

#[test]
fn the_palette_gives_consecutive_labels_distinct_colours() {
    let colours: Vec<[u8; 4]> = (1..=200).map(isogrid::labels::palette).collect();
    for (i, a) in colours.iter().enumerate() {
        assert_eq!(a[3], 255);
        // Neighbouring values differ clearly (sum of channel differences).
        if let Some(b) = colours.get(i + 1) {
            let d: i32 = (0..3).map(|c| (a[c] as i32 - b[c] as i32).abs()).sum();
            assert!(d > 60, "labels {} and {}: {a:?} {b:?}", i + 1, i + 2);
        }
    }
    let distinct: BTreeSet<_> = colours.iter().collect();
    assert_eq!(distinct.len(), colours.len());
    assert_eq!(
        isogrid::labels::palette(7),
        colours[6],
        "a colour depends on the value alone"
    );
}

/// A labelled grid small enough to flip every bit of.
pub fn tiny_labelled_grid() -> CellGrid {
    let mut data = vec![0u8; 4 * 4 * 3];
    data[5] = 1;
    data[6] = 2;
    data[5 + 16] = 2;
    data[10 + 16] = 9;
    let volume = Volume::new([4, 4, 3], VolumeData::U8(data)).unwrap();
    extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap()
}

#[test]
fn the_reader_refuses_label_sections_that_do_not_fit_the_grid() {
    let grid = tiny_labelled_grid();
    let bytes = cgc::to_bytes(&grid);
    let sections: Vec<Vec<u8>> = (0..6)
        .map(|e| crate::cgc::section(&bytes, e).to_vec())
        .collect();
    let kinds = [1u32, 2, 3, 5, 6, 7];
    let assemble = |parts: &[(u32, &[u8])]| {
        let with_flags: Vec<(u32, u32, &[u8])> = parts
            .iter()
            .map(|&(k, b)| (k, (k <= 3) as u32, b))
            .collect();
        crate::cgc::assemble(&bytes, &with_flags)
    };
    let all: Vec<(u32, &[u8])> = kinds
        .iter()
        .copied()
        .zip(sections.iter().map(|s| s.as_slice()))
        .collect();
    // The assembled file is the writer's byte for byte, so the changes below are what fails.
    assert_eq!(assemble(&all), bytes);
    let refuse = |parts: Vec<(u32, &[u8])>, what: &str| {
        let err = cgc::read_bytes(&assemble(&parts)).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{what}: {err}");
    };
    refuse(all[..5].to_vec(), "no label table");
    refuse([&all[..3], &all[4..]].concat(), "no cluster labels");
    let with = |e: usize, bytes: &[u8]| -> Vec<Vec<u8>> {
        let mut s = sections.clone();
        s[e] = bytes.to_vec();
        s
    };
    let parts_of = |s: &[Vec<u8>]| -> Vec<u8> {
        let parts: Vec<(u32, &[u8])> = kinds
            .iter()
            .copied()
            .zip(s.iter().map(|b| b.as_slice()))
            .collect();
        assemble(&parts)
    };
    let labels = grid.labels().unwrap();
    let n = labels.table().len();
    assert_eq!(n, 3);
    // A cluster's label out of range.
    let mut clusters = sections[3].clone();
    clusters[0..4].copy_from_slice(&(n as u32).to_le_bytes());
    // Another label for a cluster (in range, but not what the index says).
    let mut swapped = sections[3].clone();
    swapped[0] ^= 1;
    // A label's cell count off by one.
    let mut index = sections[4].clone();
    index[16] ^= 1;
    // A bound off by one.
    let mut bound = sections[4].clone();
    bound[16 + 40] ^= 1;
    // A name that is not UTF-8.
    let mut name = sections[5].clone();
    let at = 16 + 16 * n;
    name[at] = 0xff;
    // Values not increasing.
    let mut order = sections[5].clone();
    order[16..24].copy_from_slice(&u64::MAX.to_le_bytes());
    // A name length past the names.
    let mut long = sections[5].clone();
    long[28..32].copy_from_slice(&u32::MAX.to_le_bytes());
    // A huge label count that the section's length cannot hold.
    let mut huge = sections[5].clone();
    huge[0..8].copy_from_slice(&(u64::MAX / 4).to_le_bytes());
    for (e, bytes, what) in [
        (3, &clusters, "label out of range"),
        (3, &swapped, "cluster labels against the index"),
        (3, &sections[3][4..].to_vec(), "cluster labels too short"),
        (4, &index, "cell count"),
        (4, &bound, "bounds"),
        (
            4,
            &sections[4][..sections[4].len() - 8].to_vec(),
            "a run missing",
        ),
        (5, &name, "name not UTF-8"),
        (5, &order, "values out of order"),
        (5, &long, "name length"),
        (5, &huge, "label count"),
    ] {
        let err = cgc::read_bytes(&parts_of(&with(e, bytes))).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{what}: {err}");
    }
}

/// Connectomics IDs are 64-bit: the same labels moved beyond 2³² (u64) and below −2³¹ (i64) give
/// each label exactly the cells of the u16 volume's, under its own value.
#[test]
fn sixty_four_bit_labels_keep_their_values_and_cells() {
    let data = label_volume();
    let options = LabelOptions {
        selection: LabelSelection::All,
        smooth: 0.0,
        precision: None,
    };
    let narrow =
        isogrid::extract_labels(&volume_of(VolumeData::U16(data.clone())).view(), &options)
            .unwrap();
    let wide_u = (1u64 << 40) + 7;
    let wide_i = -(1i64 << 33);
    let as_u64: Vec<u64> = data
        .iter()
        .map(|&v| if v == 0 { 0 } else { wide_u + v as u64 })
        .collect();
    let as_i64: Vec<i64> = data
        .iter()
        .map(|&v| if v == 0 { 0 } else { wide_i - v as i64 })
        .collect();
    let u = isogrid::extract_labels(&volume_of(VolumeData::U64(as_u64)).view(), &options).unwrap();
    let i = isogrid::extract_labels(&volume_of(VolumeData::I64(as_i64)).view(), &options).unwrap();
    for v in distinct_labels(&data) {
        let cells = label_cells(&narrow, v);
        assert!(!cells.is_empty());
        assert_eq!(
            label_cells(&u, wide_u + v),
            cells,
            "u64 label {}",
            wide_u + v
        );
        assert_eq!(
            label_cells(&i, (wide_i - v as i64) as u64),
            cells,
            "i64 label {}",
            wide_i - v as i64
        );
    }
}

/// A second layer over the same grid: a ball (1) and a slab (2) that cut across the first
/// layer's labels, as a segmentation's overlapping segments do.
fn second_layer() -> Vec<u16> {
    let [nx, ny, nz] = DIMS;
    (0..nx * ny * nz)
        .map(|i| {
            let (x, y, z) = (i % nx, i / nx % ny, i / (nx * ny));
            let d = [x as f64 - 22.0, y as f64 - 12.0, z as f64 - 15.0];
            if d.iter().map(|c| c * c).sum::<f64>() < 49.0 {
                1
            } else if (10..14).contains(&z) {
                2
            } else {
                0
            }
        })
        .collect()
}

#[test]
fn merged_layers_keep_each_layers_cells_and_labels() {
    for smooth in [0.0, 1.0] {
        let mut options = LabelOptions::new(LabelSelection::All);
        options.smooth = smooth;
        let first =
            extract_labels(&volume_of(VolumeData::U16(label_volume())).view(), &options).unwrap();
        let second =
            extract_labels(&volume_of(VolumeData::U16(second_layer())).view(), &options).unwrap();
        // The second layer's labels follow the first's largest value, 65535.
        let renamed = |grid: &CellGrid, offset: u64| -> Vec<isogrid::Label> {
            grid.labels()
                .unwrap()
                .table()
                .iter()
                .map(|l| isogrid::Label {
                    value: l.value + offset,
                    name: format!("{} of {offset}", l.name),
                    rgba: l.rgba,
                })
                .collect()
        };
        let parts = [
            (&first, renamed(&first, 0)),
            (&second, renamed(&second, 65535)),
        ];
        let merged = isogrid::merge_label_grids(&parts).unwrap();
        let table = merged.labels().unwrap().table();
        let count = |g: &CellGrid| g.labels().unwrap().table().len();
        assert_eq!(table.len(), count(&first) + 2, "smooth {smooth}");
        assert_eq!(count(&first), distinct_labels(&label_volume()).len());
        assert_eq!(
            merged.active_cells(),
            first.active_cells() + second.active_cells()
        );
        for (grid, offset) in [(&first, 0), (&second, 65535)] {
            for (l, e) in grid
                .labels()
                .unwrap()
                .table()
                .iter()
                .zip(grid.labels().unwrap().index())
            {
                let cells = label_cells(&merged, l.value + offset);
                assert_eq!(
                    cells,
                    label_cells(grid, l.value),
                    "label {} + {offset}",
                    l.value
                );
                let m = merged.labels().unwrap();
                let entry = &m.index()[m.find(l.value + offset).unwrap()];
                assert_eq!(
                    (entry.cell_count, entry.lo, entry.hi),
                    (e.cell_count, e.lo, e.hi)
                );
                assert_eq!(
                    m.table()[m.find(l.value + offset).unwrap()].name,
                    format!("{} of {offset}", l.name)
                );
            }
        }
        // Written and read back: the reader's checks of the label sections pass.
        let bytes = cgc::to_bytes(&merged);
        let back = cgc::read_bytes(&bytes).unwrap();
        assert_eq!(back.labels(), merged.labels());
        // Values that do not increase across the grids, a table of the wrong length, and grids
        // of different volumes are refused.
        let err = isogrid::merge_label_grids(&[
            (&first, renamed(&first, 0)),
            (&second, renamed(&second, 3)),
        ])
        .unwrap_err();
        assert_eq!(err.kind(), ErrorKind::InvalidInput, "{err}");
        let err = isogrid::merge_label_grids(&[(&first, renamed(&second, 0))]).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::InvalidInput, "{err}");
    }
    let small = Volume::new([5, 5, 5], VolumeData::U16(vec![1; 125])).unwrap();
    let other = extract_labels(&small.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    let first = extract_labels(
        &volume_of(VolumeData::U16(label_volume())).view(),
        &LabelOptions::new(LabelSelection::All),
    )
    .unwrap();
    let table = |g: &CellGrid| g.labels().unwrap().table().to_vec();
    let err = isogrid::merge_label_grids(&[(&first, table(&first)), (&other, table(&other))])
        .unwrap_err();
    assert!(err.to_string().contains("header"), "{err}");
}

/// A mesh as the set of its triangles by vertex position, each rotated to start at its smallest
/// vertex (winding kept), positions as bits: equal sets are the same surface with the same
/// orientation, whatever the vertex numbering.
fn triangle_set(mesh: &isogrid::mc::McMesh) -> BTreeSet<[[u32; 3]; 3]> {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.map(|v| mesh.positions[v as usize].map(f32::to_bits));
            let first = (0..3).min_by_key(|&i| p[i]).unwrap();
            [p[first], p[(first + 1) % 3], p[(first + 2) % 3]]
        })
        .collect()
}

#[test]
fn each_labels_mesh_is_marching_cubes_of_its_indicator() {
    let data = label_volume();
    let volume = volume_of(VolumeData::U16(data.clone()))
        .with_spacing([0.5, 1.0, 2.0])
        .unwrap();
    let grid = extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    let meshes = isogrid::mc::label_meshes(&grid).unwrap();
    let labels = grid.labels().unwrap();
    assert_eq!(meshes.len(), labels.table().len());
    for (label, mesh) in labels.table().iter().zip(&meshes) {
        let indicator: Vec<u8> = data
            .iter()
            .map(|&v| (v as u64 == label.value) as u8)
            .collect();
        let reference = volume_of(VolumeData::U8(indicator))
            .with_spacing([0.5, 1.0, 2.0])
            .unwrap();
        let expected = isogrid::mc::marching_cubes(&reference.view(), 0.5);
        assert!(expected.triangle_count() > 0, "label {}", label.value);
        assert_eq!(
            mesh.vertex_count(),
            expected.vertex_count(),
            "label {}",
            label.value
        );
        assert_eq!(
            triangle_set(mesh),
            triangle_set(&expected),
            "label {}",
            label.value
        );
    }
}

//! A label volume of 10⁵ and more labels in one file (issue: "it must handle 10⁵ labels and more"):
//! every label's cell count and cell box against a brute-force count over the sample grid, a file
//! round trip, and a selection drawn through the label index.

use isogrid::{cgc, extract_labels, LabelOptions, LabelSelection, Volume, VolumeData};
use std::collections::HashMap;

/// Cubes of 2×2×2 samples, each its own u32 label (scattered over the u32 range), tiling a
/// volume of `2k` samples per axis: k³ labels, every one touching its neighbours.
fn cube_labels(k: usize) -> (Vec<u32>, [usize; 3]) {
    let n = 2 * k;
    let mut data = vec![0u32; n * n * n];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let cube = (x / 2 + k * (y / 2 + k * (z / 2))) as u64;
                // A bijection of the cube index onto odd values: distinct, never 0.
                data[x + n * (y + n * z)] = (cube.wrapping_mul(2_654_435_761) as u32) | 1;
            }
        }
    }
    (data, [n; 3])
}

/// Per label: active cells (cells whose eight samples hold the label at some but not all
/// corners) and their box [lo, hi) in cell indices, by brute force over every cell.
fn brute_force(data: &[u32], dims: [usize; 3]) -> HashMap<u32, (u64, [u32; 3], [u32; 3])> {
    let [nx, ny, nz] = dims;
    let mut out: HashMap<u32, (u64, [u32; 3], [u32; 3])> = HashMap::new();
    for z in 0..nz - 1 {
        for y in 0..ny - 1 {
            for x in 0..nx - 1 {
                let corners: Vec<u32> = (0..8)
                    .map(|c| data[x + (c & 1) + nx * (y + (c >> 1 & 1) + ny * (z + (c >> 2 & 1)))])
                    .collect();
                let mut seen: Vec<u32> = corners.clone();
                seen.sort_unstable();
                seen.dedup();
                if seen.len() < 2 {
                    continue;
                }
                let p = [x as u32, y as u32, z as u32];
                for l in seen {
                    let e = out.entry(l).or_insert((0, [u32::MAX; 3], [0; 3]));
                    e.0 += 1;
                    for a in 0..3 {
                        e.1[a] = e.1[a].min(p[a]);
                        e.2[a] = e.2[a].max(p[a] + 1);
                    }
                }
            }
        }
    }
    out
}

#[test]
fn a_hundred_thousand_labels_fit_one_file_with_exact_counts() {
    let (data, dims) = cube_labels(50);
    let expected = brute_force(&data, dims);
    assert_eq!(expected.len(), 125_000);
    let volume = Volume::new(dims, VolumeData::U32(data)).unwrap();
    let grid = extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    let bytes = cgc::to_bytes(&grid);
    let read = cgc::read_bytes(&bytes).unwrap();
    assert_eq!(cgc::to_bytes(&read), bytes, "the file reads back to itself");
    let labels = read.labels().unwrap();
    assert_eq!(labels.table().len(), expected.len());
    let mut total = 0;
    for (entry, label) in labels.index().iter().zip(labels.table()) {
        let (count, lo, hi) = expected[&(label.value as u32)];
        assert_eq!(
            (entry.cell_count, entry.lo, entry.hi),
            (count, lo, hi),
            "label {}",
            label.value
        );
        total += count;
    }
    // A cell where labels meet is stored once per label.
    assert_eq!(read.active_cells() as u64, total);

    // Every 1000th label, through the label index: exactly those labels' cells remain.
    let shown: Vec<bool> = (0..labels.table().len()).map(|l| l % 1000 == 0).collect();
    let some = read.showing_labels(&shown).unwrap();
    let kept: u64 = labels
        .index()
        .iter()
        .zip(&shown)
        .filter(|(_, &s)| s)
        .map(|(e, _)| e.cell_count)
        .sum();
    assert_eq!(some.active_cells() as u64, kept);
    let some_labels = some.labels().unwrap();
    for (l, &s) in shown.iter().enumerate() {
        let clusters: usize = some_labels
            .runs_of(l)
            .iter()
            .map(|r| r.clusters().len())
            .sum();
        assert_eq!(clusters > 0, s, "label {l} shown {s}");
    }
}

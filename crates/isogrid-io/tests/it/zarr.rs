//! Zarr v2/v3 and OME-Zarr fixtures written by zarr-python (scripts/make_zarr_fixtures.py): values,
//! geometry, levels and axes, missing and corrupt chunks, bad metadata, and streaming extraction.

use crate::common::{assert_close, fixture, TempDir};
use crate::region::{check, streams_like_memory};
use isogrid::{ErrorKind, ExtractOptions, Iso, Precision, ScalarType};
use isogrid_io::{open_region, read_volume, ReadOptions, ZarrOptions};
use std::path::Path;

const DIMS: [usize; 3] = [20, 13, 35];

/// The Zarr fixtures' formula (see scripts/make_zarr_fixtures.py).
fn f(i: usize, j: usize, k: usize) -> f64 {
    let d = |a: usize, c: usize| (a as f64 - c as f64).powi(2);
    d(i, 9) + d(j, 6) + d(k, 17) + ((i + 2 * j + 3 * k) % 4) as f64
}

fn zarr(name: &str) -> std::path::PathBuf {
    fixture("zarr").join(name)
}

pub fn options(level: usize, indices: &[(&str, u64)]) -> ReadOptions {
    ReadOptions {
        zarr: ZarrOptions {
            level,
            indices: indices.iter().map(|&(n, i)| (n.to_string(), i)).collect(),
            ..Default::default()
        },
        ..Default::default()
    }
}

fn error_of(path: &Path, opts: &ReadOptions) -> String {
    let err = match read_volume(path, opts) {
        Ok(_) => panic!("{} was read", path.display()),
        Err(e) => e.to_string(),
    };
    assert!(!err.contains('\n'), "{err}");
    assert!(err.contains(&*path.to_string_lossy()), "{err}");
    err
}

#[test]
fn zarr_v2_v3_and_sharded_arrays_hold_the_formula() {
    for name in ["v2_blosc.zarr", "v3_zstd.zarr", "v3_sharded_gzip.zarr"] {
        let v = read_volume(&zarr(name), &ReadOptions::default()).unwrap();
        assert_eq!(v.scalar_type(), ScalarType::U16, "{name}");
        check(&v, DIMS, f);
    }
    let v = read_volume(&zarr("v2_f32_gzip.zarr"), &ReadOptions::default()).unwrap();
    assert_eq!(v.scalar_type(), ScalarType::F32);
    check(&v, DIMS, |i, j, k| 0.25 * f(i, j, k) - 3.5);
}

#[test]
fn ome_zarr_levels_axes_and_transforms() {
    // 0.4, 5-D: t and c picked by index; spacing and origin from the dataset's transforms.
    let path = zarr("ome_v04.zarr");
    let v = read_volume(&path, &options(0, &[("t", 1), ("c", 0)])).unwrap();
    check(&v, DIMS, |i, j, k| f(i, j, k) + 2000.0);
    assert_close(v.spacing(), [0.25, 0.5, 2.0]);
    assert_close(v.origin(), [3.0, -5.0, 10.0]);
    let v = read_volume(&path, &options(1, &[("c", 1), ("t", 0)])).unwrap();
    check(&v, [10, 7, 18], |i, j, k| f(2 * i, 2 * j, 2 * k) + 1000.0);
    assert_close(v.spacing(), [0.5, 1.0, 4.0]);
    assert_close(v.origin(), [3.125, -4.75, 11.0]);

    // 0.5, Zarr v3: the multiscale-level scale applies after the dataset's transforms.
    let path = zarr("ome_v05.zarr");
    let v = read_volume(&path, &ReadOptions::default()).unwrap();
    check(&v, DIMS, f);
    assert_close(v.spacing(), [0.5, 1.0, 1.5]);
    assert_close(v.origin(), [0.0, 0.0, 0.0]);
    let v = read_volume(&path, &options(1, &[])).unwrap();
    check(&v, [10, 7, 18], |i, j, k| f(2 * i, 2 * j, 2 * k));
    assert_close(v.spacing(), [1.0, 2.0, 3.0]);
    assert_close(v.origin(), [0.25, 0.5, 0.75]);

    // Unnamed 4-D: the leading axis is dim0.
    let v = read_volume(&zarr("v2_4d_unnamed.zarr"), &options(0, &[("dim0", 1)])).unwrap();
    check(&v, DIMS, |i, j, k| f(i, j, k) + 100.0);
}

#[test]
fn metadata_alone_selects_as_the_reader_does() {
    // What other readers of a store (the Python package's Dask extraction) get from the metadata:
    // the level's array path, the axes and geometry `read_volume` uses, and its errors.
    use isogrid_io::region::zarr::{ome_level_path, select};
    let path = zarr("ome_v04.zarr");
    let location = path.display().to_string();
    let attrs = std::fs::read_to_string(path.join(".zattrs")).unwrap();
    assert_eq!(ome_level_path(&attrs, 1, &location).unwrap(), "1");
    let opts = options(1, &[("c", 1), ("t", 0)]);
    let picked = select(
        Some(&attrs),
        None,
        &[2, 2, 18, 7, 10],
        &opts.zarr,
        &location,
    )
    .unwrap();
    let v = read_volume(&path, &opts).unwrap();
    assert_eq!(picked.spatial, [4, 3, 2]);
    assert_eq!(picked.fixed, vec![(0, 0), (1, 1)]);
    assert_eq!(&picked.geometry, v.geometry());
    let err = select(
        Some(&attrs),
        None,
        &[2, 2, 18, 7, 10],
        &options(1, &[]).zarr,
        &location,
    );
    assert_eq!(
        err.unwrap_err().to_string(),
        error_of(&path, &options(1, &[]))
    );
    // A plain array: named axes, or z, y, x for the last three; only level 0.
    let named = Some(vec!["x".into(), "z".into(), "y".into()]);
    let picked = select(None, named, &[5, 6, 7], &ZarrOptions::default(), "a.zarr").unwrap();
    assert_eq!(picked.spatial, [0, 2, 1]);
    assert_eq!(picked.geometry.dims, [5, 7, 6]);
    let level1 = ZarrOptions {
        level: 1,
        ..Default::default()
    };
    let err = select(None, None, &[5, 6, 7], &level1, "a.zarr").unwrap_err();
    assert!(err.to_string().contains("single Zarr array"), "{err}");
}

#[test]
fn a_missing_chunk_reads_as_the_fill_value() {
    let v = read_volume(&zarr("v3_missing_chunk.zarr"), &ReadOptions::default()).unwrap();
    // Chunk (0, 0, 0) spans z 0..9, y 0..10, x 0..11 (chunks are (9, 10, 11) in z, y, x).
    check(&v, DIMS, |i, j, k| {
        if i < 11 && j < 10 && k < 9 {
            9.0
        } else {
            f(i, j, k)
        }
    });
}

#[test]
fn bad_zarr_inputs_get_one_line_naming_the_problem() {
    let err = error_of(&zarr("v2_corrupt_chunk.zarr"), &ReadOptions::default());
    assert!(err.contains("chunk 1.0.1"), "{err}");
    let err = error_of(&zarr("v2_lzma.zarr"), &ReadOptions::default());
    assert!(err.contains("lzma"), "{err}");
    let err = error_of(&zarr("ome_v04.zarr"), &ReadOptions::default());
    assert!(
        err.contains("--index") && err.contains("t (2 entries)") && err.contains("c (2 entries)"),
        "{err}"
    );
    let err = error_of(&zarr("v2_4d_unnamed.zarr"), &ReadOptions::default());
    assert!(err.contains("dim0"), "{err}");
    let err = error_of(&zarr("ome_v04.zarr"), &options(2, &[("t", 0), ("c", 0)]));
    assert!(err.contains("level 2") && err.contains("2 levels"), "{err}");
    let err = error_of(&zarr("ome_v04.zarr"), &options(0, &[("t", 5), ("c", 0)]));
    assert!(err.contains("t=5") && err.contains("out of range"), "{err}");
    let err = error_of(&zarr("ome_v04.zarr"), &options(0, &[("q", 0)]));
    assert!(err.contains("q"), "{err}");
}

#[test]
fn an_axis_indexed_twice_is_refused() {
    // `--index t=0,t=1,c=0`: which t was meant is unknown, so neither is read.
    let err = error_of(
        &zarr("ome_v04.zarr"),
        &options(0, &[("t", 0), ("t", 1), ("c", 0)]),
    );
    assert!(err.contains("axis t twice (t=0 and t=1)"), "{err}");
    let err = error_of(
        &zarr("ome_v04.zarr"),
        &options(0, &[("t", 0), ("c", 0), ("C", 1)]),
    );
    assert!(err.contains("axis C twice (c=0 and C=1)"), "{err}");
}

#[test]
fn zarr_streams_byte_identically() {
    let isos = [
        ExtractOptions::new(Iso::Normalized(0.5)),
        ExtractOptions::new(Iso::Value(60.0)).with_precision(Precision::Bits8),
    ];
    for name in [
        "v2_blosc.zarr",
        "v3_sharded_gzip.zarr",
        "v3_missing_chunk.zarr",
        "v2_f32_gzip.zarr",
    ] {
        streams_like_memory(&zarr(name), &ReadOptions::default(), &isos);
    }
    streams_like_memory(
        &zarr("ome_v04.zarr"),
        &options(0, &[("t", 1), ("c", 1)]),
        &isos,
    );
}

/// A Zarr v3 array of bytes with `shape` and `chunk_shape`, no chunk written: `x.zarr/zarr.json`.
fn v3_array_json(shape: &str, chunk_shape: &str) -> String {
    format!(
        r#"{{"zarr_format": 3, "node_type": "array", "shape": {shape}, "data_type": "uint8",
        "chunk_grid": {{"name": "regular", "configuration": {{"chunk_shape": {chunk_shape}}}}},
        "chunk_key_encoding": {{"name": "default", "configuration": {{"separator": "/"}}}},
        "fill_value": 0, "codecs": [{{"name": "bytes"}}]}}"#
    )
}

/// Writes a store of `(key, document)` pairs; returns its folder.
fn store(dir: &TempDir, docs: &[(&str, &str)]) -> std::path::PathBuf {
    let root = dir.path("x.zarr");
    for (key, doc) in docs {
        let path = root.join(key);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, doc).unwrap();
    }
    root
}

/// The error of both ways a Zarr store is read: whole (`read_volume`) and streamed (`open_region`
/// and the streaming extraction's memory plan); both must be `kind` and one line, and the first
/// names the store (the plan, in `isogrid`, knows no path).
fn errors_whole_and_streamed(root: &Path, kind: ErrorKind) -> String {
    let whole = read_volume(root, &ReadOptions::default()).expect_err("read");
    let streamed = open_region(root, &ReadOptions::default())
        .and_then(|source| {
            isogrid::extract::stream::plan(&*source.expect("a region source"), 1 << 30)
        })
        .expect_err("opened and planned");
    for err in [&whole, &streamed] {
        let text = err.to_string();
        assert_eq!(err.kind(), kind, "{text}");
        assert!(!text.contains('\n'), "{text}");
    }
    assert!(
        whole.to_string().contains(&*root.to_string_lossy()),
        "{whole}"
    );
    whole.to_string()
}

/// Declared sizes are checked before anything is allocated or planned: an empty axis, an axis
/// beyond `MAX_DIM`, a volume far larger than memory, and chunks whose size overflows u64 (no
/// chunk of any of them is stored; the reader must not need one to refuse).
#[test]
fn zarr_declared_sizes_are_refused_before_allocating() {
    let dir = TempDir::new("zarr-sizes");
    let cases = [
        (
            "[0, 13, 20]",
            "[9, 10, 11]",
            ErrorKind::Corrupt,
            "size along axis 2 is 0",
        ),
        (
            "[200000, 13, 20]",
            "[9, 10, 11]",
            ErrorKind::TooLarge,
            "exceeds the limit",
        ),
    ];
    for (shape, chunks, kind, needle) in cases {
        let root = store(&dir, &[("zarr.json", &v3_array_json(shape, chunks))]);
        let err = errors_whole_and_streamed(&root, kind);
        assert!(err.contains(needle), "{err}");
    }
    // 10^15 bytes: refused for the memory it needs, not attempted.
    let root = store(
        &dir,
        &[(
            "zarr.json",
            &v3_array_json("[100000, 100000, 100000]", "[64, 64, 64]"),
        )],
    );
    let err = read_volume(&root, &ReadOptions::default()).expect_err("read");
    assert_eq!(err.kind(), ErrorKind::TooLarge, "{err}");
    // A 20x13x35 array whose one chunk declares 2^120 elements.
    let huge = "[1099511627776, 1099511627776, 1099511627776]";
    let root = store(&dir, &[("zarr.json", &v3_array_json("[35, 13, 20]", huge))]);
    let err = errors_whole_and_streamed(&root, ErrorKind::TooLarge);
    assert!(err.contains("memory"), "{err}");
}

/// OME-Zarr transformations that leave no size or place: a zero scale, scales multiplying past
/// f64's range.
#[test]
fn ome_zarr_degenerate_transformations_are_refused() {
    let dir = TempDir::new("zarr-ome-scale");
    for scale in ["[0, 1, 1]", "[1e300, 1, 1]"] {
        let group = format!(
            r#"{{"zarr_format": 3, "node_type": "group", "attributes": {{"ome": {{"version": "0.5",
            "multiscales": [{{"axes": [{{"name": "z"}}, {{"name": "y"}}, {{"name": "x"}}],
            "datasets": [{{"path": "0", "coordinateTransformations":
                [{{"type": "scale", "scale": {scale}}}]}}],
            "coordinateTransformations": [{{"type": "scale", "scale": {scale}}}]}}]}}}}}}"#
        );
        let root = store(
            &dir,
            &[
                ("zarr.json", &group),
                ("0/zarr.json", &v3_array_json("[35, 13, 20]", "[9, 10, 11]")),
            ],
        );
        let err = errors_whole_and_streamed(&root, ErrorKind::Corrupt);
        assert!(err.contains("spacing must be positive and finite"), "{err}");
    }
}

/// A 20x13x35 u8 array stored with its axes as (x, y, z) (`dimension_names`), in uncompressed
/// 7x6x8 chunks written here: the reader must transpose it (zarrs' subset path, not the
/// chunk-row one, which needs z, y, x last).
fn transposed_store(dir: &TempDir) -> std::path::PathBuf {
    let [nx, ny, nz] = DIMS;
    let chunk = [7, 6, 8];
    let value = |i: usize, j: usize, k: usize| (f(i, j, k) as u64 % 251) as u8;
    let array = format!(
        r#"{{"zarr_format": 3, "node_type": "array", "shape": [{nx}, {ny}, {nz}],
        "data_type": "uint8", "dimension_names": ["x", "y", "z"],
        "chunk_grid": {{"name": "regular", "configuration": {{"chunk_shape": {chunk:?}}}}},
        "chunk_key_encoding": {{"name": "default", "configuration": {{"separator": "/"}}}},
        "fill_value": 0, "codecs": [{{"name": "bytes"}}]}}"#
    );
    let root = store(dir, &[("zarr.json", &array)]);
    for ci in 0..nx.div_ceil(chunk[0]) {
        for cj in 0..ny.div_ceil(chunk[1]) {
            for ck in 0..nz.div_ceil(chunk[2]) {
                // C order over the array's own axes (x, y, z); edge chunks padded with zeros.
                let mut bytes = Vec::new();
                for a in 0..chunk[0] {
                    for b in 0..chunk[1] {
                        for c in 0..chunk[2] {
                            let (i, j, k) =
                                (ci * chunk[0] + a, cj * chunk[1] + b, ck * chunk[2] + c);
                            let inside = i < nx && j < ny && k < nz;
                            bytes.push(if inside { value(i, j, k) } else { 0 });
                        }
                    }
                }
                let path = root.join(format!("c/{ci}/{cj}/{ck}"));
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                std::fs::write(path, bytes).unwrap();
            }
        }
    }
    root
}

#[test]
fn a_zarr_array_stored_as_x_y_z_reads_and_streams_transposed() {
    let dir = TempDir::new("zarr-transposed");
    let root = transposed_store(&dir);
    let v = read_volume(&root, &ReadOptions::default()).unwrap();
    check(&v, DIMS, |i, j, k| (f(i, j, k) as u64 % 251) as f64);
    streams_like_memory(
        &root,
        &ReadOptions::default(),
        &[ExtractOptions::new(Iso::Value(100.0))],
    );
}

/// Plane ranges read one after another from one opened source (overlapping by the halo plane as
/// the stream reads, back to back as the value-range pass does, and jumping back as a second
/// pass does) hold the planes of the volume read whole: the chunk row kept between reads must
/// be the right one, and a read it does not cover must decode afresh.
#[test]
fn zarr_plane_ranges_read_in_sequence_match_the_whole_volume() {
    use isogrid::extract::stream::SlabMut;
    let dir = TempDir::new("zarr-ranges");
    let cases = [
        (zarr("v2_blosc.zarr"), ReadOptions::default()),
        (zarr("v3_sharded_gzip.zarr"), ReadOptions::default()),
        (zarr("v3_missing_chunk.zarr"), ReadOptions::default()),
        (zarr("v2_f32_gzip.zarr"), ReadOptions::default()),
        (zarr("ome_v04.zarr"), options(0, &[("t", 1), ("c", 0)])),
        (transposed_store(&dir), ReadOptions::default()),
    ];
    let sequences: [&[(usize, usize)]; 5] = [
        &[(0, 17), (16, 33), (32, 35)],
        &[(0, 3), (3, 6), (6, 9), (9, 12), (12, 35)],
        &[(0, 20), (20, 35)],
        &[(0, 17), (16, 33), (0, 17), (16, 33), (32, 35)],
        &[(10, 11), (10, 30), (29, 30), (5, 35)],
    ];
    for (path, opts) in &cases {
        let whole = read_volume(path, opts).unwrap();
        let [nx, ny, _] = whole.dims();
        for sequence in sequences {
            let mut source = open_region(path, opts).unwrap().unwrap();
            for &(z0, z1) in sequence {
                let mut got = vec![0.0f32; nx * ny * (z1 - z0)];
                match whole.scalar_type() {
                    ScalarType::U16 => {
                        let mut slab = vec![0u16; got.len()];
                        source.read_planes(z0..z1, SlabMut::U16(&mut slab)).unwrap();
                        got = slab.iter().map(|&v| v as f32).collect();
                    }
                    ScalarType::F32 => {
                        source.read_planes(z0..z1, SlabMut::F32(&mut got)).unwrap();
                    }
                    ScalarType::U8 => {
                        let mut slab = vec![0u8; got.len()];
                        source.read_planes(z0..z1, SlabMut::U8(&mut slab)).unwrap();
                        got = slab.iter().map(|&v| v as f32).collect();
                    }
                    other => panic!("no fixture of type {other:?}"),
                }
                for (n, &v) in got.iter().enumerate() {
                    let (i, j, k) = (n % nx, n / nx % ny, z0 + n / (nx * ny));
                    assert_eq!(
                        v as f64,
                        whole.get(i, j, k),
                        "{}: planes {z0}..{z1} of {sequence:?}, sample ({i}, {j}, {k})",
                        path.display()
                    );
                }
            }
        }
    }
}

#[test]
fn reading_a_store_whole_counts_its_planes_and_stops_when_cancelled() {
    use isogrid_io::read_volume_with_progress;
    let path = zarr("v3_zstd.zarr");
    let progress = isogrid::Progress::new();
    let v = read_volume_with_progress(&path, &ReadOptions::default(), &progress).unwrap();
    check(&v, DIMS, f);
    assert_eq!(progress.counts(), (35, 35));
    let cancelled = isogrid::Progress::new();
    cancelled.cancel();
    let err = read_volume_with_progress(&path, &ReadOptions::default(), &cancelled).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
    assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");
}

/// A uint64 array beyond 2^53 (connectomics IDs) is kept as u64, read and streamed exactly.
#[test]
fn a_uint64_zarr_array_beyond_2_53_is_kept_exactly() {
    let dir = TempDir::new("zarr-u64");
    let [nx, ny, nz] = DIMS;
    let array = format!(
        r#"{{"zarr_format": 3, "node_type": "array", "shape": [{nz}, {ny}, {nx}],
        "data_type": "uint64",
        "chunk_grid": {{"name": "regular", "configuration": {{"chunk_shape": [{nz}, {ny}, {nx}]}}}},
        "chunk_key_encoding": {{"name": "default", "configuration": {{"separator": "/"}}}},
        "fill_value": 0, "codecs": [{{"name": "bytes", "configuration": {{"endian": "little"}}}}]}}"#
    );
    let root = store(&dir, &[("zarr.json", &array)]);
    // 2^53 + 1 and 2^53 + 2 are one f64: only a comparison in u64 tells them apart.
    let id = |i: usize, j: usize, k: usize| (1u64 << 53) + 1 + f(i, j, k) as u64 % 3;
    let mut bytes = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                bytes.extend(id(i, j, k).to_le_bytes());
            }
        }
    }
    std::fs::create_dir_all(root.join("c/0/0")).unwrap();
    std::fs::write(root.join("c/0/0/0"), bytes).unwrap();
    let v = read_volume(&root, &ReadOptions::default()).unwrap();
    let isogrid::VolumeData::U64(values) = v.data() else {
        panic!("{:?}", v.scalar_type())
    };
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                assert_eq!(values[i + nx * (j + ny * k)], id(i, j, k));
            }
        }
    }
    let iso = ExtractOptions::new(Iso::Value(((1u64 << 53) + 2) as f64));
    let mut expected = 0;
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let inside = (0..8)
                    .filter(|c| {
                        id(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)) >= (1 << 53) + 2
                    })
                    .count();
                expected += (inside != 0 && inside != 8) as usize;
            }
        }
    }
    assert!(expected > 0);
    assert_eq!(
        isogrid::extract(&v.view(), &iso).unwrap().active_cells(),
        expected
    );
    streams_like_memory(&root, &ReadOptions::default(), &[iso]);
}

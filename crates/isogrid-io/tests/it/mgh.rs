//! FreeSurfer MGH volumes: files written by nibabel (scripts/make_io_fixtures.py) and bad headers.

use crate::bad_input::expect_err;
use crate::common::{assert_close, base, check_samples, fixture, TempDir};
use crate::region::streams_like_memory;
use isogrid::extract::ExtractOptions;
use isogrid::{ErrorKind, Iso, ScalarType, WorldFrame};
use isogrid_io::{open_region, read_volume, ReadOptions, ZarrOptions};
use std::path::Path;

fn read(path: &Path, opts: &ReadOptions) -> isogrid::Volume {
    read_volume(path, opts).unwrap_or_else(|e| panic!("{e}"))
}

fn frame(t: u64) -> ReadOptions {
    ReadOptions {
        zarr: ZarrOptions {
            indices: vec![("t".into(), t)],
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Bytes written over a fixture: (offset, big-endian bytes).
type Edits<'a> = &'a [(usize, &'a [u8])];

/// The fixture's bytes with `edits` (offset, big-endian bytes) written over them.
fn patched(dir: &TempDir, name: &str, edits: Edits) -> std::path::PathBuf {
    let mut bytes = std::fs::read(fixture(name)).unwrap();
    for (at, value) in edits {
        bytes[*at..*at + value.len()].copy_from_slice(value);
    }
    dir.file(name, &bytes)
}

#[test]
fn gzip_int32_with_an_oblique_affine_as_nibabel_wrote_it() {
    let v = read(&fixture("i32.mgz"), &ReadOptions::default());
    check_samples(&v, ScalarType::I32, |i, j, k| base(i, j, k) - 150.0);
    let g = v.geometry();
    assert_eq!(g.frame, WorldFrame::Ras);
    assert_close(g.spacing, [0.5, 0.75, 2.0]);
    assert_close(g.origin, [10.0, -20.0, 30.0]);
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    assert_close(g.direction[0], [-c, -s, 0.0]);
    assert_close(g.direction[1], [0.0, 0.0, -1.0]);
    assert_close(g.direction[2], [-s, c, 0.0]);
}

#[test]
fn frames_need_an_index_and_each_reads_its_own() {
    let path = fixture("f32_frames.mgh");
    expect_err(
        &path,
        &ReadOptions::default(),
        ErrorKind::InvalidInput,
        "this is a 4-D MGH file of 2 volumes (t=0..1): pass --index t=N to read one",
    );
    expect_err(&path, &frame(2), ErrorKind::InvalidInput, "out of range");
    let first = read(&path, &frame(0));
    check_samples(&first, ScalarType::F32, |i, j, k| {
        0.25 * base(i, j, k) - 3.5
    });
    assert_close(first.spacing(), [0.5, 0.75, 2.0]);
    assert_close(first.origin(), [0.0, 0.0, 0.0]);
    let second = read(&path, &frame(1));
    check_samples(&second, ScalarType::F32, |i, j, k| {
        0.25 * base(i, j, k) - 3.5 + 1000.0
    });
    // Uncompressed: read by region, the picked frame alone, as the in-memory reader reads it.
    let iso = ExtractOptions::new(Iso::Value(1010.0));
    streams_like_memory(&path, &frame(1), &[iso]);
    // Compressed: read whole.
    assert!(open_region(&fixture("i32.mgz"), &ReadOptions::default())
        .unwrap()
        .is_none());
}

#[test]
fn unset_geometry_is_freesurfers_coronal_default() {
    // goodRASFlag 0: voxel size 1, i → left, j → inferior, k → anterior, centre at 0.
    let dir = TempDir::new("mgh-unset");
    let path = patched(&dir, "i32.mgz", &[]);
    let mut bytes = Vec::new();
    {
        use std::io::Read;
        let mut raw = Vec::new();
        flate2::read::GzDecoder::new(std::fs::File::open(&path).unwrap())
            .read_to_end(&mut raw)
            .unwrap();
        raw[28..30].copy_from_slice(&0i16.to_be_bytes());
        bytes.extend(raw);
    }
    let path = dir.file("unset.mgh", &bytes);
    let g = *read(&path, &ReadOptions::default()).geometry();
    assert_close(g.spacing, [1.0, 1.0, 1.0]);
    assert_close(g.direction[0], [-1.0, 0.0, 0.0]);
    assert_close(g.direction[1], [0.0, 0.0, -1.0]);
    assert_close(g.direction[2], [0.0, 1.0, 0.0]);
    // origin = −Σ direction[a]·dims[a]/2 with dims 7, 5, 3.
    assert_close(g.origin, [3.5, -1.5, 2.5]);
}

#[test]
fn bad_headers_are_refused_naming_the_field() {
    let dir = TempDir::new("mgh-bad");
    let none = ReadOptions::default();
    let cases: [(Edits, ErrorKind, &str); 6] = [
        (&[(0, &2i32.to_be_bytes())], ErrorKind::Corrupt, "version 2"),
        (&[(8, &0i32.to_be_bytes())], ErrorKind::Corrupt, "height 0"),
        (
            &[(16, &(-1i32).to_be_bytes())],
            ErrorKind::Corrupt,
            "frames -1",
        ),
        (
            &[(20, &6i32.to_be_bytes())],
            ErrorKind::Unsupported,
            "type 6 (tensor)",
        ),
        (&[(20, &42i32.to_be_bytes())], ErrorKind::Corrupt, "type 42"),
        // The direction of j all zeros.
        (
            &[(54, &[0; 12])],
            ErrorKind::Corrupt,
            "axis 1 give no voxel",
        ),
    ];
    for (edits, kind, needle) in cases {
        let path = patched(&dir, "f32_frames.mgh", edits);
        expect_err(&path, &frame(0), kind, needle);
    }
    // Sizes beyond the file: refused before anything is allocated.
    let path = patched(&dir, "f32_frames.mgh", &[(12, &100_000i32.to_be_bytes())]);
    expect_err(&path, &frame(0), ErrorKind::Corrupt, "truncated");
    let whole = std::fs::read(fixture("f32_frames.mgh")).unwrap();
    for keep in [0, 50, 284, 284 + 420 + 419] {
        let path = dir.file("cut.mgh", &whole[..keep]);
        let err = read_volume(&path, &frame(1)).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{keep}: {err}");
    }
    let gz = std::fs::read(fixture("i32.mgz")).unwrap();
    for keep in [10, gz.len() / 2, gz.len() - 9] {
        let path = dir.file("cut.mgz", &gz[..keep]);
        let err = read_volume(&path, &none).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{keep}: {err}");
    }
}

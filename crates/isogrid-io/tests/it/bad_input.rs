//! Malformed, truncated and absurd input: every reader returns an error with the right kind and
//! a message naming the problem, never a panic or a huge allocation.

use crate::common::{fixture, TempDir};
use isogrid::{ErrorKind, ScalarType};
use isogrid_io::{read_volume, RawSpec, ReadOptions};
use std::path::Path;

fn expect_err(path: &Path, opts: &ReadOptions, kind: ErrorKind, needle: &str) {
    let err = match read_volume(path, opts) {
        Ok(v) => panic!("{}: read {:?} instead of failing", path.display(), v.dims()),
        Err(e) => e,
    };
    let text = err.to_string();
    assert_eq!(err.kind(), kind, "{text}");
    assert!(
        text.contains(needle),
        "'{text}' does not mention '{needle}'"
    );
    assert!(!text.contains('\n'), "error is not one line: {text}");
    assert_eq!(
        err.path(),
        Some(path),
        "error does not name the file: {text}"
    );
}

fn fixture_bytes(name: &str) -> Vec<u8> {
    std::fs::read(fixture(name)).unwrap()
}

/// The fixture cut to `keep` bytes, written into `dir` under the same name.
fn truncated(dir: &TempDir, name: &str, keep: usize) -> std::path::PathBuf {
    dir.file(name, &fixture_bytes(name)[..keep])
}

#[test]
fn truncated_files_are_corrupt() {
    let dir = TempDir::new("truncated");
    let none = ReadOptions::default();
    let cases: [(&str, usize, &str); 9] = [
        ("u8.nii", 400, "truncated"),
        ("u8.nii", 200, "shorter than a NIfTI-1 header"),
        ("i16.nii.gz", 150, "truncated"),
        ("u16_raw.nrrd", 450, "truncated"),
        ("i16_gzip.nrrd", 500, "truncated"),
        ("u8_c.npy", 200, "array data needs 105 bytes"),
        ("u8_c.npy", 40, "truncated"),
        ("u8_stack.tif", 300, "truncated"),
        ("f32_stack.tif", 100, "truncated"),
    ];
    for (name, keep, needle) in cases {
        let path = truncated(&dir, name, keep);
        let err = read_volume(&path, &none).unwrap_err();
        assert!(
            matches!(err.kind(), ErrorKind::Corrupt),
            "{name} cut to {keep}: {err} ({:?})",
            err.kind()
        );
        assert!(
            err.to_string().contains(needle),
            "{name} cut to {keep}: '{err}' lacks '{needle}'"
        );
        assert_eq!(err.path(), Some(path.as_path()));
    }
}

#[test]
fn truncated_detached_data_names_the_data_file() {
    let dir = TempDir::new("nhdr-short");
    dir.file("u8_detached.nhdr", &fixture_bytes("u8_detached.nhdr"));
    let data = dir.file("u8_detached.raw", &fixture_bytes("u8_detached.raw")[..100]);
    let err = read_volume(&dir.path("u8_detached.nhdr"), &ReadOptions::default()).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Corrupt);
    assert!(
        err.message().contains("needs 105 bytes but only 100"),
        "{err}"
    );
    assert_eq!(err.path(), Some(data.as_path()));
}

#[test]
fn garbage_headers_are_corrupt() {
    let dir = TempDir::new("garbage");
    let none = ReadOptions::default();
    let noise: Vec<u8> = (0..600u32)
        .map(|x| (x.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    let mut fake_nifti = noise.clone();
    fake_nifti[..4].copy_from_slice(&348i32.to_le_bytes());
    expect_err(
        &dir.file("g.nii", &noise),
        &none,
        ErrorKind::Corrupt,
        "sizeof_hdr",
    );
    expect_err(
        &dir.file("h.nii", &fake_nifti),
        &none,
        ErrorKind::Corrupt,
        "bad magic",
    );
    expect_err(
        &dir.file("g.nrrd", &noise),
        &none,
        ErrorKind::Corrupt,
        "NRRD",
    );
    expect_err(
        &dir.file("g.npy", &noise),
        &none,
        ErrorKind::Corrupt,
        "bad magic",
    );
    expect_err(
        &dir.file("g.tif", &noise),
        &none,
        ErrorKind::Corrupt,
        "TIFF",
    );
    expect_err(
        &dir.file("g.dat", &noise),
        &none,
        ErrorKind::Unsupported,
        "unknown volume format",
    );
    expect_err(
        &dir.file(
            "h.npy",
            b"\x93NUMPY\x01\x00\x20\x00{'descr': '<f4', 'shape': (2,)}  \n",
        ),
        &none,
        ErrorKind::Corrupt,
        "fortran_order",
    );
    expect_err(
        &dir.file("h.nrrd", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nwhat is this\n\n12345678"),
        &none,
        ErrorKind::Corrupt,
        "malformed NRRD header line",
    );
    expect_err(
        &dir.file("u.nrrd", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nfancy: yes\n\n12345678"),
        &none,
        ErrorKind::Unsupported,
        "unknown NRRD field 'fancy'",
    );
    // gzip encoding over bytes that are not gzip
    expect_err(
        &dir.file("z.nrrd", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\nnot gzip at all, no"),
        &none,
        ErrorKind::Corrupt,
        "gzip",
    );
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

#[test]
fn gzip_data_longer_than_declared_or_damaged_is_corrupt() {
    let dir = TempDir::new("gzip-len");
    let none = ReadOptions::default();
    let head = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\n".to_vec();
    let long = [head.clone(), gzip(&[1u8; 9])].concat();
    expect_err(
        &dir.file("long.nrrd", &long),
        &none,
        ErrorKind::Corrupt,
        "longer than the header declares",
    );
    let short = [head.clone(), gzip(&[1u8; 7])].concat();
    expect_err(
        &dir.file("short.nrrd", &short),
        &none,
        ErrorKind::Corrupt,
        "needs 8 bytes, only 7",
    );
    // Damage the deflate payload of the nibabel-written .nii.gz past its gzip header.
    let mut nii = fixture_bytes("i16.nii.gz");
    for b in &mut nii[40..120] {
        *b ^= 0x5a;
    }
    expect_err(&dir.file("bad.nii.gz", &nii), &none, ErrorKind::Corrupt, "");
}

#[test]
fn absurd_sizes_fail_before_allocating() {
    let dir = TempDir::new("absurd");
    let none = ReadOptions::default();
    let huge = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 100000 100000 100000\n";
    expect_err(
        &dir.file(
            "huge.nrrd",
            format!("{huge}encoding: raw\n\n0123456789").as_bytes(),
        ),
        &none,
        ErrorKind::Corrupt,
        "needs 1000000000000000 bytes but only 10",
    );
    expect_err(
        &dir.file(
            "huge_gz.nrrd",
            format!("{huge}encoding: gzip\n\n0123456789").as_bytes(),
        ),
        &none,
        ErrorKind::Corrupt,
        "cannot hold",
    );
    expect_err(
        &dir.file(
            "wide.nrrd",
            b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 200000 1 1\nencoding: raw\n\n0",
        ),
        &none,
        ErrorKind::TooLarge,
        "exceeds the limit",
    );
    let dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (100000, 100000, 100000), }\n";
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    npy.extend((dict.len() as u16).to_le_bytes());
    npy.extend(dict.as_bytes());
    expect_err(
        &dir.file("huge.npy", &npy),
        &none,
        ErrorKind::Corrupt,
        "array data needs",
    );
    // NIfTI dims patched to 30000 x 30000 x 30000 (dim[] are i16 at byte 42).
    let mut nii = fixture_bytes("u8.nii");
    for d in 0..3 {
        nii[42 + 2 * d..44 + 2 * d].copy_from_slice(&30000i16.to_le_bytes());
    }
    expect_err(
        &dir.file("huge.nii", &nii),
        &none,
        ErrorKind::Corrupt,
        "truncated",
    );
    let gz = gzip(&nii[..352]);
    expect_err(
        &dir.file("huge.nii.gz", &gz),
        &none,
        ErrorKind::Corrupt,
        "cannot hold",
    );
    // TIFF width, height and rows per strip (LONG tags 256, 257, 278, in every page) patched to
    // 60000 and the strip byte count (279) to match, so the header is consistent but the file tiny.
    let mut tif = fixture_bytes("u8_stack.tif");
    for (tag, value) in [
        (256u16, 60000u32),
        (257, 60000),
        (278, 60000),
        (279, 3_600_000_000),
    ] {
        let entry = [
            &tag.to_le_bytes()[..],
            &4u16.to_le_bytes(),
            &1u32.to_le_bytes(),
        ]
        .concat();
        let hits: Vec<usize> = (0..tif.len() - 8)
            .filter(|&i| tif[i..i + 8] == entry[..])
            .collect();
        assert_eq!(hits.len(), 3, "one entry per page");
        for at in hits {
            tif[at + 8..at + 12].copy_from_slice(&value.to_le_bytes());
        }
    }
    expect_err(
        &dir.file("huge.tif", &tif),
        &none,
        ErrorKind::Corrupt,
        "cannot fit",
    );
}

#[test]
fn raw_size_mismatch_says_expected_and_actual() {
    let spec = RawSpec {
        dims: [7, 5, 4],
        scalar: ScalarType::U8,
        big_endian: false,
    };
    expect_err(
        &fixture("u8_detached.raw"),
        &ReadOptions {
            raw: Some(spec),
            ..Default::default()
        },
        ErrorKind::InvalidInput,
        "needs 140 bytes but the file has 105",
    );
    let spec = RawSpec {
        dims: [7, 5, 3],
        scalar: ScalarType::F32,
        big_endian: false,
    };
    expect_err(
        &fixture("u8_detached.raw"),
        &ReadOptions {
            raw: Some(spec),
            ..Default::default()
        },
        ErrorKind::InvalidInput,
        "420 bytes",
    );
    expect_err(
        &fixture("u8_detached.raw"),
        &ReadOptions::default(),
        ErrorKind::InvalidInput,
        "raw spec",
    );
}

#[test]
fn unsupported_content_is_named() {
    let none = ReadOptions::default();
    expect_err(
        &fixture("rgb.tif"),
        &none,
        ErrorKind::Unsupported,
        "grayscale",
    );
    let dir = TempDir::new("unsupported");
    let mut nii = fixture_bytes("u8.nii");
    nii[40..42].copy_from_slice(&4i16.to_le_bytes()); // dim[0] = 4
    nii[48..50].copy_from_slice(&2i16.to_le_bytes()); // dim[4] = 2 volumes
    expect_err(
        &dir.file("t2.nii", &nii),
        &none,
        ErrorKind::Unsupported,
        "4-D",
    );
    nii[48..50].copy_from_slice(&1i16.to_le_bytes()); // t = 1 is fine
    assert_eq!(
        read_volume(&dir.file("t1.nii", &nii), &none)
            .unwrap()
            .dims(),
        [7, 5, 3]
    );
    expect_err(
        &dir.file(
            "bz.nrrd",
            b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: bzip2\n\n",
        ),
        &none,
        ErrorKind::Unsupported,
        "bzip2",
    );
}

fn copy_series(dir: &TempDir, folder: &str) {
    for entry in std::fs::read_dir(fixture(folder)).unwrap() {
        let p = entry.unwrap().path();
        dir.file(
            p.file_name().unwrap().to_str().unwrap(),
            &std::fs::read(&p).unwrap(),
        );
    }
}

#[test]
fn dicom_folders_without_slices_are_invalid() {
    let none = ReadOptions::default();
    let empty = TempDir::new("dicom-empty");
    expect_err(
        &empty.0,
        &none,
        ErrorKind::InvalidInput,
        "no DICOM image slices",
    );
    empty.file("notes.txt", b"hello");
    expect_err(
        &empty.0,
        &none,
        ErrorKind::InvalidInput,
        "no DICOM image slices",
    );
}

#[test]
fn dicom_slices_of_different_size_are_rejected() {
    let dir = TempDir::new("dicom-size");
    copy_series(&dir, "dicom_ct");
    // Explicit VR LE element (0028,0010) Rows: tag, "US", length 2, value 5.
    let mut bytes = std::fs::read(dir.path("b.dcm")).unwrap();
    let rows = [0x28u8, 0x00, 0x10, 0x00, b'U', b'S', 2, 0, 5, 0];
    let at = bytes
        .windows(10)
        .position(|w| w == rows)
        .expect("Rows element");
    bytes[at + 8] = 4;
    dir.file("b.dcm", &bytes);
    expect_err(
        &dir.0,
        &ReadOptions::default(),
        ErrorKind::Corrupt,
        "slices differ in size",
    );
}

#[test]
fn dicom_huge_rows_and_truncated_slices_are_corrupt() {
    let dir = TempDir::new("dicom-bad");
    copy_series(&dir, "dicom_ct");
    let mut bytes = std::fs::read(dir.path("a.dcm")).unwrap();
    let rows = [0x28u8, 0x00, 0x10, 0x00, b'U', b'S', 2, 0, 5, 0];
    let at = bytes
        .windows(10)
        .position(|w| w == rows)
        .expect("Rows element");
    bytes[at + 8..at + 10].copy_from_slice(&65535u16.to_le_bytes());
    let a = dir.file("a.dcm", &bytes);
    let err = read_volume(&dir.0, &ReadOptions::default()).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
    assert!(err.message().contains("PixelData holds 70 bytes"), "{err}");
    assert_eq!(err.path(), Some(a.as_path()));

    let full = std::fs::read(fixture("dicom_ct/a.dcm")).unwrap();
    let a = dir.file("a.dcm", &full[..full.len() - 30]);
    let err = read_volume(&dir.0, &ReadOptions::default()).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
    assert_eq!(err.path(), Some(a.as_path()), "{err}");
}

//! Malformed, truncated and absurd input: every reader returns an error with the right kind and
//! a message naming the problem, never a panic or a huge allocation.

use crate::common::{fixture, TempDir};
use isogrid::{ErrorKind, ScalarType};
use isogrid_io::{read_volume, RawSpec, ReadOptions};
use std::path::Path;

pub fn expect_err(path: &Path, opts: &ReadOptions, kind: ErrorKind, needle: &str) {
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
fn damaged_gzip_that_decodes_too_long_is_invalid_gzip_not_long_data() {
    // A bit flip in a .nii.gz's deflate stream often decodes to more bytes than the header
    // declares; the gzip checksum at the end tells the two apart. Made here: the volume plus 16
    // bytes, compressed, with its CRC-32 damaged.
    let dir = TempDir::new("gzip-crc");
    let nii = fixture_bytes("u8.nii");
    let mut gz = gzip(&[nii.clone(), vec![7u8; 16]].concat());
    let crc_at = gz.len() - 8;
    gz[crc_at] ^= 0x01;
    let err = read_volume(&dir.file("flip.nii.gz", &gz), &ReadOptions::default()).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
    assert!(err.message().contains("gzip data is invalid"), "{err}");
    // With a right checksum the same bytes are long data.
    let gz = gzip(&[nii, vec![7u8; 16]].concat());
    let err = read_volume(&dir.file("long.nii.gz", &gz), &ReadOptions::default()).unwrap_err();
    assert!(
        err.message().contains("longer than the header declares"),
        "{err}"
    );
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
            ..ReadOptions::default()
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
            ..ReadOptions::default()
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
                                                      // Which volume is asked; the file holds one of the two it declares.
    let t2 = dir.file("t2.nii", &nii);
    expect_err(&t2, &none, ErrorKind::InvalidInput, "4-D");
    let mut second = ReadOptions::default();
    second.zarr.indices = vec![("t".into(), 1)];
    expect_err(&t2, &second, ErrorKind::Corrupt, "truncated");
    nii[40..42].copy_from_slice(&5i16.to_le_bytes()); // dim[0] = 5
    nii[50..52].copy_from_slice(&3i16.to_le_bytes()); // dim[5] = 3 components
    expect_err(
        &dir.file("v3.nii", &nii),
        &none,
        ErrorKind::Unsupported,
        "vector data",
    );
    nii[50..52].copy_from_slice(&1i16.to_le_bytes());
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

/// Bytes that deflate cannot shrink (a multiplicative hash stream), so a gzip stream of them is
/// as long as they are.
fn incompressible(len: usize) -> Vec<u8> {
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect()
}

/// The memory limit every test of this binary runs under once one of them set it: far above
/// what the other tests read (kilobytes), far below what the requests here need.
const TEST_MEMORY_LIMIT: u64 = 64 << 20;

#[test]
fn sizes_beyond_memory_fail_with_the_limit_before_reading() {
    isogrid::memory::set_limit(Some(TEST_MEMORY_LIMIT));
    let dir = TempDir::new("memory");
    let none = ReadOptions::default();
    // Honest headers declaring 512³ u8 = 128 MiB, with enough compressed bytes that deflate's
    // 1100:1 bound cannot reject them: only the memory check can, and must, before inflating.
    let payload = gzip(&incompressible(160 << 10));
    let nrrd = [
        &b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 512 512 512\nencoding: gzip\n\n"[..],
        &payload,
    ]
    .concat();
    expect_err(
        &dir.file("big.nrrd", &nrrd),
        &none,
        ErrorKind::TooLarge,
        "needs 128.0 MiB of memory but the memory limit set is 64.0 MiB",
    );
    let mut nii = fixture_bytes("u8.nii")[..352].to_vec();
    for d in 0..3 {
        nii[42 + 2 * d..44 + 2 * d].copy_from_slice(&512i16.to_le_bytes());
    }
    nii.extend(incompressible(160 << 10));
    expect_err(
        &dir.file("big.nii.gz", &gzip(&nii)),
        &none,
        ErrorKind::TooLarge,
        "of memory but",
    );
    // A sparse raw file: 192 MiB long, nothing stored.
    let sparse = dir.path("sparse.raw");
    std::fs::File::create(&sparse)
        .unwrap()
        .set_len(192 << 20)
        .unwrap();
    let spec = RawSpec {
        dims: [1024, 1024, 96],
        scalar: ScalarType::U16,
        big_endian: false,
    };
    expect_err(
        &sparse,
        &ReadOptions {
            raw: Some(spec),
            ..ReadOptions::default()
        },
        ErrorKind::TooLarge,
        "needs 192.0 MiB of memory",
    );
}

#[test]
fn f64_samples_are_kept_and_f32_text_beyond_its_range_is_refused() {
    let dir = TempDir::new("f64-range");
    let none = ReadOptions::default();
    let mut raw =
        b"NRRD0004\ntype: double\ndimension: 3\nsizes: 2 1 1\nencoding: raw\nendian: little\n\n"
            .to_vec();
    raw.extend(1.0f64.to_le_bytes());
    raw.extend(1e300f64.to_le_bytes());
    let v = read_volume(&dir.file("huge.nrrd", &raw), &none).unwrap();
    assert_eq!((v.get(0, 0, 0), v.get(1, 0, 0)), (1.0, 1e300));
    let ascii = b"NRRD0004\ntype: float\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\n-1e39 2\n";
    expect_err(
        &dir.file("huge_ascii.nrrd", ascii),
        &none,
        ErrorKind::Unsupported,
        "beyond the f32 range",
    );
    // Infinities are kept: they are values, not overflows.
    let inf = b"NRRD0004\ntype: double\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\ninf 2\n";
    let v = read_volume(&dir.file("inf.nrrd", inf), &none).unwrap();
    assert_eq!(v.get(0, 0, 0), f64::INFINITY);
    // An integer type cannot hold 300 or 1.5: no silent saturation.
    let u8_text = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\n1 300\n";
    expect_err(
        &dir.file("sat.nrrd", u8_text),
        &none,
        ErrorKind::Corrupt,
        "value 300 (number 1) is not an integer in [0, 255]",
    );
}

#[test]
fn spacings_that_are_no_voxel_size_are_errors_and_nan_means_unknown() {
    let dir = TempDir::new("spacings");
    let none = ReadOptions::default();
    let nrrd = |spacings: &str| {
        format!("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n{spacings}\n\n\x01\x02")
    };
    for (name, field, needle) in [
        ("zero.nrrd", "spacings: 1 0 1", "spacing 0 along axis 1"),
        ("inf.nrrd", "spacings: inf 1 1", "spacing inf along axis 0"),
        (
            "zero_vector.nrrd",
            "space dimension: 3\nspace directions: (1,0,0) (0,0,0) (0,0,1)",
            "spacing 0 along axis 1",
        ),
    ] {
        expect_err(
            &dir.file(name, nrrd(field).as_bytes()),
            &none,
            ErrorKind::Corrupt,
            needle,
        );
    }
    // The NRRD spec: `nan` = no spacing on that axis; it becomes 1.
    let v = read_volume(
        &dir.file("nan.nrrd", nrrd("spacings: 2 nan 3").as_bytes()),
        &none,
    )
    .unwrap();
    assert_eq!(v.geometry().spacing, [2.0, 1.0, 3.0]);
    // A negative spacing keeps its magnitude and flips the axis, so positions are unchanged.
    let v = read_volume(
        &dir.file("neg.nrrd", nrrd("spacings: -2 1 1").as_bytes()),
        &none,
    )
    .unwrap();
    assert_eq!(v.geometry().spacing, [2.0, 1.0, 1.0]);
    assert_eq!(v.geometry().direction[0], [-1.0, 0.0, 0.0]);

    // NIfTI pixdim[2] (byte 84) NaN or infinite: an error; 0 (unset): 1.
    let mut nii = fixture_bytes("u8.nii");
    nii[84..88].copy_from_slice(&f32::NAN.to_le_bytes());
    expect_err(
        &dir.file("nan.nii", &nii),
        &none,
        ErrorKind::Corrupt,
        "pixdim[2] is NaN",
    );
    nii[84..88].copy_from_slice(&0f32.to_le_bytes());
    let v = read_volume(&dir.file("zero.nii", &nii), &none).unwrap();
    assert_eq!(v.geometry().spacing[1], 1.0);
}

#[test]
fn directories_and_fifos_are_refused_with_their_kind() {
    let dir = TempDir::new("special");
    let none = ReadOptions::default();
    dir.file(
        "dot.nhdr",
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\ndata file: .\n",
    );
    let err = read_volume(&dir.path("dot.nhdr"), &none).unwrap_err();
    assert!(
        err.to_string()
            .contains("is a directory, not a regular file"),
        "{err}"
    );
    #[cfg(unix)]
    {
        let fifo = dir.path("fifo_data");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        dir.file(
            "fifo.nhdr",
            b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\ndata file: fifo_data\n",
        );
        let header = dir.path("fifo.nhdr");
        // Read on another thread, so that a regression blocks that thread and not the test.
        let (send, recv) = std::sync::mpsc::channel();
        let paths = [header, fifo.clone(), fifo.clone()];
        std::thread::spawn(move || {
            let raw = RawSpec {
                dims: [2, 1, 1],
                scalar: ScalarType::U8,
                big_endian: false,
            };
            for (path, opts) in [
                (&paths[0], ReadOptions::default()),
                (&paths[1], ReadOptions::default()),
                (
                    &paths[2],
                    ReadOptions {
                        raw: Some(raw),
                        ..ReadOptions::default()
                    },
                ),
            ] {
                let _ = send.send(read_volume(path, &opts).map(|_| ()).unwrap_err());
            }
        });
        for _ in 0..3 {
            let err = recv
                .recv_timeout(std::time::Duration::from_secs(20))
                .expect("reading a FIFO blocked");
            assert_eq!(err.path(), Some(fifo.as_path()), "{err}");
            assert!(err.to_string().contains("is a pipe or FIFO"), "{err}");
        }
    }
}

#[test]
fn gzip_meshes_inflate_no_further_than_the_ply_header_allows() {
    use isogrid_io::mesh::read_mesh;
    let dir = TempDir::new("ply-bomb");
    // 4 vertices and one triangle, binary: at most the header + 4·12 + 1·(1 + 255·4) bytes.
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]] {
        ply.extend(v.iter().flat_map(|c| c.to_le_bytes()));
    }
    ply.push(3);
    ply.extend([0i32, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
    assert_eq!(
        read_mesh(&dir.file("ok.ply.gz", &gzip(&ply)))
            .unwrap()
            .triangles
            .len(),
        1
    );
    // Followed by 64 MiB of zeros (64 KiB compressed): refused after at most the bound, not
    // after inflating everything (the probe's 8 GiB of zeros ran out of memory).
    let mut bomb = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut bomb, &ply).unwrap();
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..64 {
        std::io::Write::write_all(&mut bomb, &zeros).unwrap();
    }
    let path = dir.file("bomb.ply.gz", &bomb.finish().unwrap());
    let err = read_mesh(&path).unwrap_err();
    assert_eq!(err.path(), Some(path.as_path()));
    assert!(
        err.to_string().contains("inflates to more than the")
            && err.to_string().contains("the PLY header allows"),
        "{err}"
    );
}

#[test]
fn binary_stl_with_a_count_too_low_is_refused() {
    use isogrid_io::mesh::read_mesh;
    let dir = TempDir::new("stl-count");
    let mut stl = vec![b' '; 80];
    stl.extend(1u32.to_le_bytes()); // declares 1, holds 2
    for shift in [0f32, 5.0] {
        stl.extend([0u8; 12]);
        for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
            stl.extend(v.iter().flat_map(|c| (c + shift).to_le_bytes()));
        }
        stl.extend([0u8; 2]);
    }
    let path = dir.file("low.stl", &stl);
    let err = read_mesh(&path).unwrap_err();
    assert!(
        err.to_string().contains("declares 1 triangles but holds 2"),
        "{err}"
    );
    // A partial record of trailing bytes is padding, not a triangle.
    stl[80..84].copy_from_slice(&2u32.to_le_bytes());
    stl.extend([0u8; 7]);
    assert_eq!(
        read_mesh(&dir.file("pad.stl", &stl))
            .unwrap()
            .triangles
            .len(),
        2
    );
}

/// A detached NRRD's data file, or a raw file, that is a FIFO or a device: the region reader
/// (streamed extraction) said "file is truncated … only 0 are there" for /dev/zero; it must say
/// what the file is, as the whole-volume reader does.
#[cfg(unix)]
#[test]
fn data_file_that_is_a_fifo_or_a_device_is_not_a_regular_file() {
    let dir = TempDir::new("special-data-file");
    let fifo = dir.path("fifo.raw");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let header = String::from_utf8(fixture_bytes("u8_detached.nhdr")).unwrap();
    for (data, what) in [
        (fifo.as_path(), "a pipe or FIFO"),
        (Path::new("/dev/zero"), "a device"),
    ] {
        let nhdr = dir.file(
            "d.nhdr",
            header
                .replace("u8_detached.raw", data.to_str().unwrap())
                .as_bytes(),
        );
        for streamed in [true, false] {
            let result = if streamed {
                isogrid_io::open_region(&nhdr, &ReadOptions::default()).map(|_| ())
            } else {
                read_volume(&nhdr, &ReadOptions::default()).map(|_| ())
            };
            let err = result.expect_err("a special data file must not read");
            let text = err.to_string();
            assert!(
                text.contains(data.to_str().unwrap())
                    && text.contains(what)
                    && text.contains("not a regular file"),
                "streamed {streamed}: {text}"
            );
        }
        let raw = ReadOptions {
            raw: Some(RawSpec {
                dims: [7, 5, 3],
                scalar: ScalarType::U8,
                big_endian: false,
            }),
            ..ReadOptions::default()
        };
        let err = isogrid_io::open_region(data, &raw)
            .map(|_| ())
            .expect_err("raw special file");
        assert!(err.to_string().contains("not a regular file"), "{err}");
    }
}

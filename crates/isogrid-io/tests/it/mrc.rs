//! MRC / CCP4 maps: files written by mrcfile (scripts/make_io_fixtures.py) and bad headers.

use crate::bad_input::expect_err;
use crate::common::{assert_close, base, check_samples, fixture, TempDir};
use isogrid::{ErrorKind, ScalarType};
use isogrid_io::{read_volume, ReadOptions};
use std::path::Path;

fn read(path: &Path) -> isogrid::Volume {
    read_volume(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The fixture's bytes with the little-endian 32-bit word at `at` replaced.
fn patched(name: &str, edits: &[(usize, i32)]) -> Vec<u8> {
    let mut bytes = std::fs::read(fixture(name)).unwrap();
    for &(at, value) in edits {
        bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
    }
    bytes
}

#[test]
fn float_map_with_origin_fields() {
    let v = read(&fixture("f32.mrc"));
    check_samples(&v, ScalarType::F32, |i, j, k| 0.25 * base(i, j, k) - 3.5);
    assert_close(v.spacing(), [0.5, 0.75, 2.0]);
    assert_close(v.origin(), [10.0, -20.0, 30.0]);
}

#[test]
fn permuted_axes_come_back_in_xyz_order_placed_by_start_indices() {
    // Stored with columns along z and sections along x; NCSTART, NRSTART, NSSTART = 4, 2, -3.
    let v = read(&fixture("i16_zyx.map"));
    check_samples(&v, ScalarType::I16, |i, j, k| base(i, j, k) - 150.0);
    assert_close(v.spacing(), [1.5, 2.0, 2.5]);
    assert_close(v.origin(), [-3.0 * 1.5, 2.0 * 2.0, 4.0 * 2.5]);
}

#[test]
fn mode_0_is_signed_and_mode_6_big_endian_is_unsigned() {
    let v = read(&fixture("i8.mrc"));
    check_samples(&v, ScalarType::I16, |i, j, k| {
        (base(i, j, k) % 100.0) - 50.0
    });
    // No cell size: unit spacing.
    assert_close(v.spacing(), [1.0, 1.0, 1.0]);
    let v = read(&fixture("u16_big.mrc"));
    check_samples(&v, ScalarType::U16, |i, j, k| 200.0 * base(i, j, k));
}

#[test]
fn imod_unsigned_bytes_are_u8() {
    let dir = TempDir::new("mrc-imod");
    // IMOD stamp at byte 152, flags at 156 with bit 0 clear: bytes are unsigned.
    let mut bytes = patched("i8.mrc", &[(152, 1_146_047_817), (156, 0)]);
    let data_start = bytes.len() - 105;
    bytes[data_start] = 200;
    let v = read(&dir.file("imod.mrc", &bytes));
    assert_eq!(v.scalar_type(), ScalarType::U8);
    assert_eq!(v.get(0, 0, 0), 200.0);
    assert_eq!(v.get(1, 0, 0), (1i8 - 50) as u8 as f64);
}

#[test]
fn maps_are_recognised_by_content_and_image_stacks_read_as_volumes() {
    let dir = TempDir::new("mrc-sniff");
    let path = dir.file("map.dat", &std::fs::read(fixture("f32.mrc")).unwrap());
    check_samples(&read(&path), ScalarType::F32, |i, j, k| {
        0.25 * base(i, j, k) - 3.5
    });
    // ISPG 0 (an image stack, as .mrcs files are): k is the image index.
    let stack = dir.file("stack.mrcs", &patched("f32.mrc", &[(88, 0), (36, 1)]));
    assert_eq!(read(&stack).dims(), [7, 5, 3]);
}

#[test]
fn header_sizes_beyond_the_file_are_corrupt() {
    let dir = TempDir::new("mrc-sizes");
    let none = ReadOptions::default();
    let full = std::fs::read(fixture("f32.mrc")).unwrap();
    expect_err(
        &dir.file("short.mrc", &full[..1200]),
        &none,
        ErrorKind::Corrupt,
        "truncated",
    );
    expect_err(
        &dir.file("tiny.mrc", &full[..500]),
        &none,
        ErrorKind::Corrupt,
        "shorter than the 1024-byte MRC header",
    );
    // 100000^3 float samples claimed by a 1.4 KB file: refused before allocating.
    let claim = patched("f32.mrc", &[(0, 100_000), (4, 100_000), (8, 100_000)]);
    expect_err(
        &dir.file("claim.mrc", &claim),
        &none,
        ErrorKind::Corrupt,
        "truncated",
    );
    expect_err(
        &dir.file("over.mrc", &patched("f32.mrc", &[(0, 200_000)])),
        &none,
        ErrorKind::TooLarge,
        "exceeds the limit",
    );
    expect_err(
        &dir.file("neg.mrc", &patched("f32.mrc", &[(4, -5)])),
        &none,
        ErrorKind::Corrupt,
        "not all positive",
    );
    let mut ext = patched("f32.mrc", &[(92, 1 << 30)]);
    ext.extend([0u8; 4]);
    expect_err(
        &dir.file("ext.mrc", &ext),
        &none,
        ErrorKind::Corrupt,
        "truncated",
    );
    expect_err(
        &dir.file("negext.mrc", &patched("f32.mrc", &[(92, -4)])),
        &none,
        ErrorKind::Corrupt,
        "NSYMBT",
    );
}

#[test]
fn an_extended_header_is_skipped() {
    let dir = TempDir::new("mrc-ext");
    let expected = |i, j, k| 0.25 * base(i, j, k) - 3.5;
    let full = patched("f32.mrc", &[(92, 16)]);
    let with_ext = [&full[..1024], &[0xAB; 16], &full[1024..]].concat();
    check_samples(
        &read(&dir.file("ext.mrc", &with_ext)),
        ScalarType::F32,
        expected,
    );
}

#[test]
fn an_extended_header_longer_than_the_file_is_refused() {
    let dir = TempDir::new("mrc-short-ext");
    // NSYMBT = 32 in a file 32 bytes short of header + extended header + data: reading from byte
    // 1024 would take the declared extended header's bytes for samples. mrcfile refuses it.
    let short = dir.file("short.mrc", &patched("f32.mrc", &[(92, 32)]));
    expect_err(
        &short,
        &ReadOptions::default(),
        ErrorKind::Corrupt,
        "after 1056 header bytes (1024 + an extended header of NSYMBT = 32)",
    );
}

#[test]
fn bad_modes_and_axis_orders_are_refused() {
    let dir = TempDir::new("mrc-modes");
    let none = ReadOptions::default();
    expect_err(
        &dir.file("m7.mrc", &patched("f32.mrc", &[(12, 7)])),
        &none,
        ErrorKind::Corrupt,
        "MRC mode 7 is not a known mode",
    );
    expect_err(
        &dir.file("m4.mrc", &patched("f32.mrc", &[(12, 4)])),
        &none,
        ErrorKind::Unsupported,
        "complex",
    );
    expect_err(
        &dir.file(
            "axes.mrc",
            &patched("f32.mrc", &[(64, 1), (68, 1), (72, 3)]),
        ),
        &none,
        ErrorKind::Corrupt,
        "MAPC, MAPR, MAPS = 1, 1, 3 is not a permutation",
    );
    expect_err(
        &dir.file("axes4.mrc", &patched("f32.mrc", &[(72, 4)])),
        &none,
        ErrorKind::Corrupt,
        "not a permutation",
    );
    expect_err(
        &dir.file("vstack.mrc", &patched("f32.mrc", &[(88, 401), (36, 1)])),
        &none,
        ErrorKind::Unsupported,
        "stack of 3 volumes",
    );
}

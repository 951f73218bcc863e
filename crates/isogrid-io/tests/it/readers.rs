//! Each reader against fixtures written by the reference Python tools: every sample, dims,
//! spacing, origin and (where the format has it) direction.

use crate::common::{assert_close, base, check_samples, fixture, TempDir};
use isogrid::ScalarType;
use isogrid_io::{read_volume, RawSpec, ReadOptions};

fn read(name: &str) -> isogrid::Volume {
    read_volume(&fixture(name), &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn nifti_u8_uses_the_sform() {
    let v = read("u8.nii");
    check_samples(&v, ScalarType::U8, base);
    assert_close(v.spacing(), [0.5, 0.75, 2.0]);
    assert_close(v.origin(), [10.0, -20.0, 30.0]);
}

#[test]
fn nifti_gz_i16_keeps_a_flipped_axis_as_direction() {
    let v = read("i16.nii.gz");
    check_samples(&v, ScalarType::I16, |i, j, k| base(i, j, k) - 150.0);
    assert_close(v.spacing(), [1.5, 1.0, 1.25]);
    assert_close(v.origin(), [5.0, 6.0, 7.0]);
    assert_close(v.geometry().direction[0], [-1.0, 0.0, 0.0]);
}

#[test]
fn nifti_big_endian_u16() {
    let v = read("u16_big.nii");
    check_samples(&v, ScalarType::U16, |i, j, k| 200.0 * base(i, j, k));
}

#[test]
fn nifti_f32_uses_the_qform_and_qfac() {
    let v = read("f32_qform.nii");
    check_samples(&v, ScalarType::F32, |i, j, k| 0.25 * base(i, j, k) - 3.5);
    assert_close(v.spacing(), [2.0, 3.0, 4.0]);
    assert_close(v.origin(), [1.0, 2.0, 3.0]);
    assert_close(v.geometry().direction[2], [0.0, 0.0, -1.0]);
}

#[test]
fn nifti_scl_slope_and_inter_are_applied() {
    let v = read("scaled.nii");
    check_samples(&v, ScalarType::F32, |i, j, k| 0.5 * base(i, j, k) - 10.0);
}

#[test]
fn nifti_2_reads_its_64_bit_fields_in_either_byte_order() {
    let v = read("i16_v2.nii");
    check_samples(&v, ScalarType::I16, |i, j, k| base(i, j, k) - 150.0);
    assert_close(v.spacing(), [0.5, 0.75, 2.0]);
    assert_close(v.origin(), [10.0, -20.0, 30.0]);
    assert_close(v.geometry().direction[1], [0.0, -1.0, 0.0]);
    assert_eq!(v.geometry().frame, isogrid::WorldFrame::Ras);
    // Big-endian, gzip, the qform alone, and scl_slope / scl_inter as doubles.
    let v = read("scaled_v2_big.nii.gz");
    check_samples(&v, ScalarType::F32, |i, j, k| 0.25 * base(i, j, k) - 3.5);
    assert_close(v.spacing(), [2.0, 3.0, 4.0]);
    assert_eq!(v.geometry().frame, isogrid::WorldFrame::Ras);
}

#[test]
fn nrrd_attached_raw_with_spacings() {
    let v = read("u16_raw.nrrd");
    check_samples(&v, ScalarType::U16, |i, j, k| 200.0 * base(i, j, k));
    assert_close(v.spacing(), [0.5, 0.6, 0.7]);
    assert_close(v.origin(), [0.0; 3]);
}

#[test]
fn nrrd_gzip_with_space_directions_and_origin() {
    let v = read("i16_gzip.nrrd");
    check_samples(&v, ScalarType::I16, |i, j, k| base(i, j, k) - 150.0);
    assert_close(v.spacing(), [1.5, 2.0, 2.5]);
    assert_close(v.origin(), [-1.0, 2.0, 3.5]);
    assert_close(v.geometry().direction[0], [0.0, 1.0, 0.0]);
    assert_close(v.geometry().direction[1], [-1.0, 0.0, 0.0]);
}

#[test]
fn nrrd_big_endian_float() {
    let v = read("f32_big.nrrd");
    check_samples(&v, ScalarType::F32, |i, j, k| 0.25 * base(i, j, k) - 3.5);
    assert_close(v.spacing(), [1.0, 2.0, 3.0]);
}

#[test]
fn nrrd_gzip_double_stays_f64() {
    let v = read("f64_gzip.nrrd");
    check_samples(&v, ScalarType::F64, |i, j, k| 0.25 * base(i, j, k) - 3.5);
}

#[test]
fn nrrd_detached_header_and_raw_file() {
    let v = read("u8_detached.nhdr");
    check_samples(&v, ScalarType::U8, base);
}

#[test]
fn nrrd_data_file_list_and_pattern_forms() {
    // One data file per z slice, cut from the pynrrd-written raw file.
    let raw = std::fs::read(fixture("u8_detached.raw")).unwrap();
    let dir = TempDir::new("nrrd-list");
    for k in 0..3 {
        dir.file(&format!("slice{k:02}.raw"), &raw[35 * k..35 * (k + 1)]);
    }
    let head =
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 7 5 3\nencoding: raw\nspacings: 1 1 2\n";
    let list = dir.file(
        "list.nhdr",
        format!("{head}data file: LIST\nslice00.raw\nslice01.raw\nslice02.raw\n").as_bytes(),
    );
    let pattern = dir.file(
        "pattern.nhdr",
        format!("{head}data file: slice%02d.raw 0 2 1\n").as_bytes(),
    );
    for path in [list, pattern] {
        let v = read_volume(&path, &ReadOptions::default()).unwrap();
        check_samples(&v, ScalarType::U8, base);
        assert_close(v.spacing(), [1.0, 1.0, 2.0]);
    }
}

#[test]
fn nrrd_line_skip_byte_skip_and_ascii() {
    let raw = std::fs::read(fixture("u8_detached.raw")).unwrap();
    let dir = TempDir::new("nrrd-skip");
    let mut data = b"junk line\nanother\nXYZ".to_vec();
    data.extend(&raw);
    dir.file("skip.raw", &data);
    let head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 7 5 3\nencoding: raw\n";
    let skip = dir.file(
        "skip.nhdr",
        format!("{head}line skip: 2\nbyte skip: 3\ndata file: skip.raw\n").as_bytes(),
    );
    let tail = dir.file(
        "tail.nhdr",
        format!("{head}byte skip: -1\ndata file: skip.raw\n").as_bytes(),
    );
    let text: Vec<String> = raw.iter().map(|b| b.to_string()).collect();
    let ascii = dir.file(
        "ascii.nrrd",
        format!(
            "NRRD0004\ntype: unsigned char\ndimension: 3\nsizes: 7 5 3\nencoding: ascii\n\n{}\n",
            text.join(" ")
        )
        .as_bytes(),
    );
    for path in [skip, tail, ascii] {
        let v = read_volume(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        check_samples(&v, ScalarType::U8, base);
    }
}

#[test]
fn npy_c_order_has_x_fastest() {
    check_samples(&read("u8_c.npy"), ScalarType::U8, base);
}

#[test]
fn npy_fortran_order_has_x_first() {
    check_samples(&read("f32_fortran.npy"), ScalarType::F32, |i, j, k| {
        0.25 * base(i, j, k) - 3.5
    });
}

#[test]
fn npy_big_endian_u16() {
    check_samples(&read("u16_big.npy"), ScalarType::U16, |i, j, k| {
        200.0 * base(i, j, k)
    });
}

#[test]
fn npy_f64_stays_f64_and_i8_becomes_i16() {
    check_samples(&read("f64_c.npy"), ScalarType::F64, |i, j, k| {
        0.25 * base(i, j, k) - 3.5
    });
    check_samples(&read("i8_c.npy"), ScalarType::I16, |i, j, k| {
        base(i, j, k) % 100.0 - 50.0
    });
}

#[test]
fn raw_with_a_spec() {
    let spec = RawSpec {
        dims: [7, 5, 3],
        scalar: ScalarType::U8,
        big_endian: false,
    };
    let v = read_volume(
        &fixture("u8_detached.raw"),
        &ReadOptions {
            raw: Some(spec),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    check_samples(&v, ScalarType::U8, base);
    // Big-endian u16 samples written here: sample n (linear index) is 300·n.
    let dir = TempDir::new("raw");
    let be: Vec<u8> = (0..105u16).flat_map(|x| (x * 300).to_be_bytes()).collect();
    let p = dir.file("be.raw", &be);
    let spec = RawSpec {
        dims: [7, 5, 3],
        scalar: ScalarType::U16,
        big_endian: true,
    };
    let v = read_volume(
        &p,
        &ReadOptions {
            raw: Some(spec),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    check_samples(&v, ScalarType::U16, |i, j, k| {
        300.0 * (i + 7 * (j + 5 * k)) as f64
    });
}

#[test]
fn dicom_series_sorted_by_position_with_integer_rescale() {
    let v = read("dicom_ct");
    check_samples(&v, ScalarType::I16, |i, j, k| 10.0 * base(i, j, k) - 1024.0);
    assert_close(v.spacing(), [0.6, 0.8, 2.5]);
    assert_close(v.origin(), [-3.0, 4.0, 30.0]);
    assert_close(v.geometry().direction[2], [0.0, 0.0, 1.0]);
}

#[test]
fn dicom_series_without_orientation_falls_back_to_instance_number() {
    let dir = TempDir::new("dicom-instance");
    for name in ["a.dcm", "b.dcm", "c.dcm"] {
        // Renames ImageOrientationPatient (0020,0037) to an unknown tag (0020,0038).
        let mut bytes = std::fs::read(fixture(&format!("dicom_ct/{name}"))).unwrap();
        let iop = [0x20u8, 0x00, 0x37, 0x00, b'D', b'S'];
        let at = bytes
            .windows(6)
            .position(|w| w == iop)
            .expect("orientation element");
        bytes[at + 2] = 0x38;
        dir.file(name, &bytes);
    }
    let v = read_volume(&dir.0, &ReadOptions::default()).unwrap();
    // The fixture's instance numbers run against the positions (instance = 3 - k).
    check_samples(&v, ScalarType::I16, |i, j, k| {
        10.0 * base(i, j, 2 - k) - 1024.0
    });
    assert_close(v.spacing(), [0.6, 0.8, 2.5]); // SliceThickness
}

#[test]
fn dicom_series_implicit_vr_with_fractional_slope_is_f32() {
    let v = read("dicom_scaled");
    check_samples(&v, ScalarType::F32, |i, j, k| 5.0 * base(i, j, k) + 2.0);
}

#[test]
fn tiff_stacks_u8_u16_deflate_f32() {
    check_samples(&read("u8_stack.tif"), ScalarType::U8, base);
    check_samples(&read("u16_stack.tif"), ScalarType::U16, |i, j, k| {
        200.0 * base(i, j, k)
    });
    check_samples(&read("f32_stack.tif"), ScalarType::F32, |i, j, k| {
        0.25 * base(i, j, k) - 3.5
    });
}

#[test]
fn tiff_channels_of_imagej_and_ome_stacks_by_index() {
    let with_index = |indices: &[(&str, u64)]| {
        let mut options = ReadOptions::default();
        options.zarr.indices = indices.iter().map(|&(a, i)| (a.to_string(), i)).collect();
        options
    };
    for c in 0..2 {
        let options = with_index(&[("c", c)]);
        let v = read_volume(&fixture("ij_zcyx.tif"), &options).unwrap();
        check_samples(&v, ScalarType::U16, |i, j, k| {
            200.0 * base(i, j, k) + c as f64
        });
        let v = read_volume(&fixture("ome_zcyx.tif"), &options).unwrap();
        check_samples(&v, ScalarType::U32, |i, j, k| {
            16_777_216.0 + base(i, j, k) + c as f64
        });
    }
    for name in ["ij_zcyx.tif", "ome_zcyx.tif"] {
        let err = read_volume(&fixture(name), &ReadOptions::default()).unwrap_err();
        assert!(
            err.to_string()
                .contains("2 channels (c=0..1), 3 slices: pass --index c=N"),
            "{err}"
        );
        let err = read_volume(&fixture(name), &with_index(&[("c", 2)])).unwrap_err();
        assert!(
            err.to_string().contains("--index c=2 is out of range"),
            "{err}"
        );
    }
    // A plain stack takes no index.
    let err = read_volume(&fixture("u8_stack.tif"), &with_index(&[("c", 0)])).unwrap_err();
    assert!(err.to_string().contains("plain stack"), "{err}");
}

#[test]
fn unknown_extension_is_sniffed() {
    let dir = TempDir::new("sniff");
    for (fixture_name, scalar) in [
        ("u8_c.npy", ScalarType::U8),
        ("u16_raw.nrrd", ScalarType::U16),
        ("u8.nii", ScalarType::U8),
        ("i16_v2.nii", ScalarType::I16),
    ] {
        let p = dir.file("volume.dat", &std::fs::read(fixture(fixture_name)).unwrap());
        let v = read_volume(&p, &ReadOptions::default()).unwrap();
        assert_eq!(v.scalar_type(), scalar, "{fixture_name}");
    }
}

/// Each format's convention of world coordinates, from the fixtures the reference tools wrote:
/// NIfTI with an sform or qform and FreeSurfer MGH are RAS, MetaImage (ITK) and DICOM are LPS, NRRD says it in its
/// `space` field (pynrrd wrote `left-posterior-superior`; none: unknown); NumPy, MRC and TIFF
/// have none. `write_nrrd` keeps it.
#[test]
fn each_format_names_the_convention_of_its_world_coordinates() {
    use isogrid::WorldFrame::{Lps, Ras, Unknown};
    for (name, frame) in [
        ("u8.nii", Ras),
        ("f32_qform.nii", Ras),
        ("i16.nii.gz", Ras),
        ("i16_v2.nii", Ras),
        ("i32.mgz", Ras),
        ("u8.mha", Lps),
        ("i16_z.mhd", Lps),
        ("dicom_ct", Lps),
        ("i16_gzip.nrrd", Lps),
        ("u16_raw.nrrd", Unknown),
        ("u8_c.npy", Unknown),
        ("f32.mrc", Unknown),
        ("u8_stack.tif", Unknown),
    ] {
        assert_eq!(read(name).geometry().frame, frame, "{name}");
    }
    let dir = TempDir::new("frames");
    for frame in [Lps, Ras, Unknown] {
        let mut volume = read("u8_c.npy");
        let geometry = isogrid::Geometry {
            frame,
            ..*volume.geometry()
        };
        volume = isogrid::Volume::with_geometry(geometry, volume.into_data()).unwrap();
        let path = dir.path("v.nrrd");
        isogrid_io::write_nrrd(&path, &volume).unwrap();
        assert_eq!(
            read_volume(&path, &ReadOptions::default())
                .unwrap()
                .geometry()
                .frame,
            frame
        );
    }
}

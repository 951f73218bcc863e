//! Inputs read by region: TIFF slice folders and memory-mapped raw / NRRD / NIfTI (Zarr in
//! `zarr.rs`); streaming extraction from each must give the bytes of the in-memory extraction.

use crate::common::{fixture, TempDir};
use isogrid::extract::stream::{extract_planned, MemoryPlan};
use isogrid::{cgc, extract, ExtractOptions, Iso, ScalarType, Volume, VolumeData};
use isogrid_io::{open_region, read_volume, read_volume_noted, write_nrrd, ReadOptions};
use std::path::Path;

pub fn check(volume: &Volume, dims: [usize; 3], expected: impl Fn(usize, usize, usize) -> f64) {
    assert_eq!(volume.dims(), dims);
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                assert_eq!(
                    volume.get(i, j, k),
                    expected(i, j, k),
                    "sample ({i}, {j}, {k})"
                );
            }
        }
    }
}

pub fn plan(layers: usize, output_buffer: u64) -> MemoryPlan {
    MemoryPlan {
        max_memory: u64::MAX,
        slab_layers: layers,
        slab_bytes: 0,
        output_buffer,
        fixed: 0,
        minimum: 0,
    }
}

/// Streams `path` (which must open by region) over several slab sizes and compares the files
/// with the in-memory extraction of `read_volume`.
pub fn streams_like_memory(path: &Path, opts: &ReadOptions, extract_options: &[ExtractOptions]) {
    let dir = TempDir::new("stream");
    let out = dir.path("out.cgc");
    let volume = read_volume(path, opts).unwrap();
    for options in extract_options {
        let expected = cgc::to_bytes(&extract(&volume.view(), options).unwrap());
        for (layers, buffer) in [(1, 1), (2, 3000), (64, 64 << 20)] {
            let mut source = open_region(path, opts)
                .unwrap()
                .unwrap_or_else(|| panic!("{} does not open by region", path.display()));
            extract_planned(
                source.as_mut(),
                options,
                &plan(layers, buffer),
                &out,
                &isogrid::Progress::new(),
            )
            .unwrap();
            assert!(
                std::fs::read(&out).unwrap() == expected,
                "{}: {options:?} with {layers}-layer slabs",
                path.display()
            );
        }
    }
}

fn wave(dims: [usize; 3]) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                out.push((i as f64 * 0.3).sin() * (j as f64 * 0.2).cos() + (k as f64 * 0.15).sin());
            }
        }
    }
    out
}

#[test]
fn mapped_raw_nrrd_and_nifti_stream_byte_identically() {
    let dir = TempDir::new("mapped");
    let dims = [37, 21, 40];
    let values: Vec<f32> = wave(dims).into_iter().map(|v| v as f32).collect();
    let isos = [
        ExtractOptions::new(Iso::Normalized(0.5)),
        ExtractOptions::new(Iso::Value(0.2)),
    ];

    let nrrd = dir.path("wave.nrrd");
    let volume = Volume::new(dims, VolumeData::F32(values.clone()))
        .unwrap()
        .with_spacing([0.5, 1.0, 2.0])
        .unwrap();
    write_nrrd(&nrrd, &volume).unwrap();
    streams_like_memory(&nrrd, &ReadOptions::default(), &isos);

    let raw = dir.path("wave.raw");
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    std::fs::write(&raw, bytes).unwrap();
    let raw_options = ReadOptions {
        raw: Some(isogrid_io::RawSpec {
            dims,
            scalar: ScalarType::F32,
            big_endian: true,
        }),
        ..Default::default()
    };
    streams_like_memory(&raw, &raw_options, &isos);

    // int32 samples are kept as they are: read straight in like f32.
    let converted = dir.path("wave_i32.nrrd");
    let mut bytes = format!(
        "NRRD0004\ntype: int32\ndimension: 3\nsizes: {} {} {}\nencoding: raw\nendian: little\n\n",
        dims[0], dims[1], dims[2]
    )
    .into_bytes();
    bytes.extend(
        values
            .iter()
            .flat_map(|v| ((v * 1000.0) as i32).to_le_bytes()),
    );
    std::fs::write(&converted, bytes).unwrap();
    streams_like_memory(&converted, &ReadOptions::default(), &isos[..1]);
    assert_eq!(
        read_volume(&converted, &ReadOptions::default())
            .unwrap()
            .scalar_type(),
        ScalarType::I32
    );

    // Big-endian u64 beyond 2^53 (swapped in place) and i8 (widened through bounded maps).
    let wide = dir.path("wave.u64");
    let ids: Vec<u64> = values
        .iter()
        .map(|v| (1u64 << 60) + (v * 1000.0 + 2000.0) as u64)
        .collect();
    std::fs::write(
        &wide,
        ids.iter()
            .flat_map(|v| v.to_be_bytes())
            .collect::<Vec<u8>>(),
    )
    .unwrap();
    let wide_options = ReadOptions {
        raw: Some(isogrid_io::RawSpec {
            dims,
            scalar: ScalarType::U64,
            big_endian: true,
        }),
        ..Default::default()
    };
    let v = read_volume(&wide, &wide_options).unwrap();
    assert_eq!(v.data(), &VolumeData::U64(ids));
    streams_like_memory(
        &wide,
        &wide_options,
        &[ExtractOptions::new(Iso::Value(
            ((1u64 << 60) + 2000) as f64,
        ))],
    );
    let small = dir.path("wave_i8.nrrd");
    let mut bytes = format!(
        "NRRD0004\ntype: int8\ndimension: 3\nsizes: {} {} {}\nencoding: raw\n\n",
        dims[0], dims[1], dims[2]
    )
    .into_bytes();
    bytes.extend(values.iter().map(|v| (v * 60.0) as i8 as u8));
    std::fs::write(&small, bytes).unwrap();
    streams_like_memory(&small, &ReadOptions::default(), &isos[..1]);

    // Fixtures written by nibabel and pynrrd (scripts/make_io_fixtures.py), some of which convert.
    for name in ["f32_qform.nii", "f32_big.nrrd", "scaled.nii", "i16_v2.nii"] {
        let path = fixture(name);
        assert!(
            open_region(&path, &ReadOptions::default())
                .unwrap()
                .is_some(),
            "{name}"
        );
        streams_like_memory(&path, &ReadOptions::default(), &isos[..1]);
    }
    // Compressed files are read whole.
    assert!(open_region(&fixture("i16.nii.gz"), &ReadOptions::default())
        .unwrap()
        .is_none());
    assert!(
        open_region(&fixture("i16_gzip.nrrd"), &ReadOptions::default())
            .unwrap()
            .is_none()
    );
}

fn write_tiff_u16(path: &Path, width: u32, height: u32, samples: &[u16]) {
    let file = std::fs::File::create(path).unwrap();
    let mut encoder = tiff::encoder::TiffEncoder::new(file).unwrap();
    encoder
        .write_image::<tiff::encoder::colortype::Gray16>(width, height, samples)
        .unwrap();
}

#[test]
fn tiff_slice_folder_with_other_files_skips_them_with_a_notice() {
    // A readme and Windows' thumbnail cache beside the slices, and a hidden file: the folder was
    // taken for DICOM ("holds no DICOM image slices").
    let dir = TempDir::new("slices-others");
    for k in 0..3u16 {
        write_tiff_u16(&dir.path(&format!("z{k}.tif")), 4, 3, &[100 * k; 12]);
    }
    dir.file("readme.md", b"# scan of 2026-11-27\n");
    dir.file("Thumbs.db", &[0xD0, 0xCF, 0x11, 0xE0, 0, 0, 0, 0]);
    dir.file(".DS_Store", b"\0\0\0\x01Bud1");
    // Zero bytes start like a bare DICOM data set (an empty (0000,0000) element): the folder was
    // taken for DICOM again.
    dir.file("empty.bin", &[0; 200]);
    let (v, notices) =
        read_volume_noted(&dir.0, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.dims(), [4, 3, 3]);
    assert_eq!(v.get(2, 1, 2), 200.0);
    assert_eq!(notices.len(), 1, "{notices:?}");
    assert!(
        notices[0].contains("skipped 3 other files: Thumbs.db, empty.bin, readme.md"),
        "{notices:?}"
    );
    // The streamed reader reads the same slices.
    let source = open_region(&dir.0, &ReadOptions::default())
        .unwrap()
        .unwrap();
    assert_eq!(source.geometry().dims, [4, 3, 3]);
}

#[test]
fn tiff_slice_folders_sort_naturally_and_stream_byte_identically() {
    let dir = TempDir::new("slices");
    let dims = [19usize, 11, 23];
    let values = wave(dims);
    let plane = dims[0] * dims[1];
    for k in 0..dims[2] {
        let samples: Vec<u16> = values[k * plane..(k + 1) * plane]
            .iter()
            .map(|v| (v * 1000.0 + 3000.0) as u16)
            .collect();
        // slice_2 must come before slice_10: natural, not lexical, order.
        write_tiff_u16(&dir.path(&format!("slice_{k}.tif")), 19, 11, &samples);
    }
    let v = read_volume(&dir.0, &ReadOptions::default()).unwrap();
    check(&v, dims, |i, j, k| {
        (values[i + dims[0] * (j + dims[1] * k)] * 1000.0 + 3000.0) as u16 as f64
    });
    streams_like_memory(
        &dir.0,
        &ReadOptions::default(),
        &[ExtractOptions::new(Iso::Normalized(0.4))],
    );

    // A slice of another size is an error naming it.
    write_tiff_u16(&dir.path("slice_99.tif"), 5, 5, &[0; 25]);
    let mut source = open_region(&dir.0, &ReadOptions::default())
        .unwrap()
        .unwrap();
    let err = extract_planned(
        source.as_mut(),
        &ExtractOptions::new(Iso::Value(3000.0)),
        &plan(1, 1 << 20),
        &dir.path("out.cgc"),
        &isogrid::Progress::new(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("slice_99.tif") && err.contains("5x5"), "{err}");
    assert!(!dir.path("out.cgc").exists());
}

/// A data file truncated by another process after it was opened and checked ends the read in an
/// error that says so, for samples read as they are (f32) and for converted ones (int8): nothing
/// is memory-mapped, where a page past the new end would kill the process with SIGBUS.
#[test]
fn a_file_truncated_while_it_is_streamed_is_an_error_not_a_crash() {
    use isogrid::extract::stream::SlabMut;
    let dir = TempDir::new("truncated-while-read");
    let n = 32usize;
    for (kind, bytes_per_sample) in [("float", 4usize), ("int8", 1)] {
        let data = dir.path(&format!("{kind}.raw"));
        let header = dir.path(&format!("{kind}.nhdr"));
        std::fs::write(
            &header,
            format!(
                "NRRD0004\ntype: {kind}\ndimension: 3\nsizes: {n} {n} {n}\nendian: little\n\
                 encoding: raw\ndata file: {kind}.raw\n\n"
            ),
        )
        .unwrap();
        std::fs::write(&data, vec![1u8; n * n * n * bytes_per_sample]).unwrap();
        let mut source = open_region(&header, &ReadOptions::default())
            .unwrap()
            .expect("a raw NRRD opens by region");
        // Truncated after the open checked its length.
        std::fs::OpenOptions::new()
            .write(true)
            .open(&data)
            .unwrap()
            .set_len((n * n * n * bytes_per_sample / 2) as u64)
            .unwrap();
        let planes = n / 2..n;
        let err = match source.scalar_type() {
            ScalarType::F32 => {
                let mut slab = vec![0f32; n * n * planes.len()];
                source.read_planes(planes, SlabMut::F32(&mut slab))
            }
            ScalarType::I16 => {
                let mut slab = vec![0i16; n * n * planes.len()];
                source.read_planes(planes, SlabMut::I16(&mut slab))
            }
            other => panic!("{kind} kept as {other:?}"),
        }
        .expect_err("the missing half cannot be read");
        let text = err.to_string();
        assert!(
            text.contains(&format!("{kind}.raw")) && text.contains("shorter than its header"),
            "{kind}: {text}"
        );
    }
}

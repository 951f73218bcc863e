//! VTK XML image data: the `vti` fuzz target's seeds, written by VTK's own writer
//! (`fuzz/vti_seeds.py`, a rotated and flipped frame: ascii, binary, appended raw and base64 data, zlib and LZ4 blocks of 64
//! bytes, 64-bit headers, big-endian), read back sample for sample with their geometry, and every
//! truncation of them refused or read whole. `python/tests/test_vti.py` checks every type and mode
//! against VTK's reader.

use crate::common::{assert_close, TempDir};
use isogrid::ScalarType;
use isogrid_io::{read_volume, ReadOptions};
use std::path::PathBuf;

fn seeds() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus-seeds/vti");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 6);
    files
}

#[test]
fn vtk_s_files_read_with_their_samples_and_geometry() {
    for path in seeds() {
        let v = read_volume(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(v.dims(), [5, 4, 3], "{}", path.display());
        // u8 x + 5y + 20z, or that as f32 times 0.25 less 3.
        let f32 = v.scalar_type() == ScalarType::F32;
        assert!(f32 || v.scalar_type() == ScalarType::U8);
        for k in 0..3 {
            for j in 0..4 {
                for i in 0..5 {
                    let u8 = (i + 5 * j + 20 * k) as f64;
                    let want = if f32 { u8 * 0.25 - 3.0 } else { u8 };
                    assert_eq!(v.view().get(i, j, k), want, "{}", path.display());
                }
            }
        }
        // Extent from (1, 0, 2), spacing (0.5, 1.25, 3), origin (-12.5, 40, 7.25), direction
        // columns (cos 30°, sin 30°, 0), (-sin 30°, cos 30°, 0), (0, 0, -1): the first sample at
        // the origin + 0.5 × the first column + 6 × the third.
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        assert_close(v.spacing(), [0.5, 1.25, 3.0]);
        assert_close(v.origin(), [-12.5 + 0.5 * c, 40.0 + 0.5 * s, 1.25]);
        let d = v.geometry().direction;
        assert_close(d[0], [c, s, 0.0]);
        assert_close(d[1], [-s, c, 0.0]);
        assert_close(d[2], [0.0, 0.0, -1.0]);
    }
}

#[test]
fn every_truncation_is_refused_or_reads_the_whole_volume() {
    let dir = TempDir::new("vti-truncated");
    for path in seeds() {
        let bytes = std::fs::read(&path).unwrap();
        let whole = read_volume(&path, &ReadOptions::default()).unwrap();
        let cut = dir.path("cut.vti");
        let mut refused = 0;
        for len in 0..bytes.len() {
            std::fs::write(&cut, &bytes[..len]).unwrap();
            match read_volume(&cut, &ReadOptions::default()) {
                Err(e) => {
                    refused += 1;
                    let message = e.to_string();
                    assert!(
                        message.contains("cut.vti") && !message.contains('\n'),
                        "{message}"
                    );
                }
                // Only the closing tags after the data may go.
                Ok(v) => {
                    assert!(
                        v == whole,
                        "{}: {len} bytes read as another volume",
                        path.display()
                    );
                }
            }
        }
        assert!(
            refused + 60 > bytes.len(),
            "{}: {refused} of {} refused",
            path.display(),
            bytes.len()
        );
    }
}

#[test]
fn extents_beyond_any_volume_are_refused_before_anything_is_read() {
    let dir = TempDir::new("vti-extent");
    for extent in [
        "-9223372036854775808 9223372036854775807 0 0 0 0",
        "0 4000000 0 4000000 0 4000000",
    ] {
        let path = dir.file(
            "huge.vti",
            format!(
                "<VTKFile type=\"ImageData\" version=\"1.0\"><ImageData WholeExtent=\"{extent}\">\
                 <Piece Extent=\"{extent}\"><PointData><DataArray type=\"UInt8\" Name=\"v\" \
                 format=\"ascii\">1 2 3</DataArray></PointData></Piece></ImageData></VTKFile>"
            )
            .as_bytes(),
        );
        let e = read_volume(&path, &ReadOptions::default()).unwrap_err();
        assert_eq!(e.kind(), isogrid::ErrorKind::TooLarge, "{e}");
        assert!(e.to_string().contains("huge.vti"), "{e}");
    }
}

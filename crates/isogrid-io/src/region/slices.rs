//! A folder of 2-D TIFF slices, one file per z, as microscopes and synchrotron beamlines write
//! them: files sorted in natural order (`img2.tif` before `img10.tif`), each decoded only when its
//! plane is read. Every slice must have the size and sample type of the first.

use isogrid::extract::stream::{RegionSource, SlabMut};
use isogrid::{Error, Geometry, Result, ResultExt, ScalarType, VolumeData, MAX_DIM};
use std::cmp::Ordering;
use std::ops::Range;
use std::path::{Path, PathBuf};

fn is_tiff(path: &Path) -> bool {
    path.extension()
        .map(|e| e.eq_ignore_ascii_case("tif") || e.eq_ignore_ascii_case("tiff"))
        .unwrap_or(false)
}

/// The TIFF files of `dir` in natural order, and its other visible files, which are skipped (a
/// `readme.md`, Windows' `Thumbs.db`); hidden files and subfolders are skipped silently. `None`
/// when `dir` holds no TIFF file, or holds a DICOM file (then it is a DICOM folder).
pub(crate) fn tiff_slices_and_others(dir: &Path) -> Result<Option<(Vec<PathBuf>, Vec<PathBuf>)>> {
    let (mut files, mut others) = (Vec::new(), Vec::new());
    for entry in std::fs::read_dir(dir).at_path(dir)? {
        let path = entry.at_path(dir)?.path();
        let hidden = path
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'));
        if hidden || path.is_dir() {
            continue;
        }
        if is_tiff(&path) {
            files.push(path);
        } else {
            others.push(path);
        }
    }
    // Only a folder with TIFF files has its other files opened (a Zarr store's chunks are not),
    // and only regular ones: opening a FIFO would wait for a writer. A DICOM image among them
    // makes it a DICOM folder; a file that merely starts like a bare DICOM data set (zero bytes
    // do) is another file, skipped with the notice.
    if files.is_empty()
        || others
            .iter()
            .any(|p| p.is_file() && crate::dicom::is_dicom_image(p))
    {
        return Ok(None);
    }
    files.sort_by(|a, b| natural_order(&a.to_string_lossy(), &b.to_string_lossy()));
    others.sort();
    Ok(Some((files, others)))
}

/// The TIFF slices of `dir` (see [`tiff_slices_and_others`]).
pub(crate) fn tiff_slices(dir: &Path) -> Result<Option<Vec<PathBuf>>> {
    Ok(tiff_slices_and_others(dir)?.map(|(files, _)| files))
}

/// The notice for the files a TIFF slice folder holds besides its slices, if any.
pub fn skipped_files_notice(dir: &Path) -> Option<String> {
    let (_, others) = tiff_slices_and_others(dir).ok()??;
    let names: Vec<String> = others
        .iter()
        .filter_map(|p| p.file_name())
        .map(|n| n.to_string_lossy().into_owned())
        .collect();
    (!names.is_empty()).then(|| {
        format!(
            "{}: reading its TIFF slices; skipped {} other file{}: {}",
            dir.display(),
            names.len(),
            if names.len() == 1 { "" } else { "s" },
            names.join(", ")
        )
    })
}

/// Compares runs of digits by value and everything else by character.
fn natural_order(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let run = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (run(a), run(b));
                let (da, db) = (&a[..na], &b[..nb]);
                let trim = |d: &[u8]| -> usize { d.iter().take_while(|&&c| c == b'0').count() };
                let (va, vb) = (&da[trim(da)..], &db[trim(db)..]);
                let order = va.len().cmp(&vb.len()).then(va.cmp(vb)).then(na.cmp(&nb));
                if order != Ordering::Equal {
                    return order;
                }
                a = &a[na..];
                b = &b[nb..];
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

/// A folder of TIFF slices read plane by plane.
pub struct TiffSlices {
    files: Vec<PathBuf>,
    geometry: Geometry,
    scalar: ScalarType,
}

impl TiffSlices {
    /// Opens the slices of `dir` (all its visible files must be TIFF); reads the first to learn
    /// the slice size and type.
    pub fn open(dir: &Path) -> Result<Self> {
        let files = tiff_slices(dir)?.ok_or_else(|| {
            Error::invalid("not a folder of TIFF slices (it holds none, or DICOM files)")
                .with_path(dir)
        })?;
        if files.len() > MAX_DIM {
            return Err(Error::too_large(format!("more than {MAX_DIM} slices")).with_path(dir));
        }
        let (w, h, first) = crate::tiff::read_page(&files[0])?;
        Ok(TiffSlices {
            geometry: Geometry::new([w, h, files.len()]),
            scalar: first.scalar_type(),
            files,
        })
    }
}

impl RegionSource for TiffSlices {
    fn geometry(&self) -> Geometry {
        self.geometry
    }
    fn scalar_type(&self) -> ScalarType {
        self.scalar
    }
    fn read_planes(&mut self, z: Range<usize>, mut out: SlabMut<'_>) -> Result<()> {
        let [nx, ny, _] = self.geometry.dims;
        let plane = nx * ny;
        for (i, k) in z.enumerate() {
            let path = &self.files[k];
            let (w, h, data) = crate::tiff::read_page(path)?;
            if (w, h) != (nx, ny) {
                return Err(Error::corrupt(format!(
                    "slice {k} is {w}x{h} but the first slice is {nx}x{ny}"
                ))
                .with_path(path));
            }
            let at = i * plane..(i + 1) * plane;
            match (&data, &mut out) {
                (VolumeData::U8(d), SlabMut::U8(o)) => o[at].copy_from_slice(d),
                (VolumeData::U16(d), SlabMut::U16(o)) => o[at].copy_from_slice(d),
                (VolumeData::I16(d), SlabMut::I16(o)) => o[at].copy_from_slice(d),
                (VolumeData::F32(d), SlabMut::F32(o)) => o[at].copy_from_slice(d),
                (VolumeData::U32(d), SlabMut::U32(o)) => o[at].copy_from_slice(d),
                (VolumeData::I32(d), SlabMut::I32(o)) => o[at].copy_from_slice(d),
                (VolumeData::U64(d), SlabMut::U64(o)) => o[at].copy_from_slice(d),
                (VolumeData::I64(d), SlabMut::I64(o)) => o[at].copy_from_slice(d),
                (VolumeData::F64(d), SlabMut::F64(o)) => o[at].copy_from_slice(d),
                _ => {
                    return Err(Error::corrupt(format!(
                        "slice {k} holds {} samples but the first slice holds {}",
                        data.scalar_type().name(),
                        self.scalar.name()
                    ))
                    .with_path(path))
                }
            }
        }
        Ok(())
    }
    fn read_overhead(&self, _planes: usize) -> u64 {
        // One decoded slice and its conversion.
        let [nx, ny, _] = self.geometry.dims;
        (nx * ny * 8 * 2) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::natural_order;
    use std::cmp::Ordering;

    #[test]
    fn natural_order_compares_numbers_by_value() {
        let mut names = vec![
            "s10.tif",
            "s2.tif",
            "s1.tif",
            "s010b.tif",
            "a.tif",
            "s02.tif",
        ];
        names.sort_by(|a, b| natural_order(a, b));
        assert_eq!(
            names,
            vec![
                "a.tif",
                "s1.tif",
                "s2.tif",
                "s02.tif",
                "s10.tif",
                "s010b.tif"
            ]
        );
        assert_eq!(natural_order("x", "x"), Ordering::Equal);
    }
}

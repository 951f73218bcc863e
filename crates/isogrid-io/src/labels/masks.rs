//! A folder of binary masks as one label volume: TotalSegmentator's `segmentations/` (one
//! `NAME.nii.gz` per structure) or any folder whose files are all NIfTI masks of one grid.
//!
//! Mask `i`, in the byte order of the file names, is label `i + 1`, named after its file without
//! `.nii` / `.nii.gz`. A sample lies in a mask where it is non-zero (integer masks) or at least ½
//! (float masks, such as resampled ones). Masks that do not overlap share one layer; a mask that
//! overlaps the layer being filled starts the next one, so that each keeps its whole surface:
//! the layers of a layered `.seg.nrrd` (module documentation of [`super`]), whose offsets here
//! are the index of each layer's first mask. Geometry (dims, spacing, origin, directions) is the
//! masks' own, which must be the same in every file.

use super::{LabelLayer, LabelVolume};
use crate::read_options::ReadOptions;
use isogrid::{Error, Label, Result, ResultExt, Scalar, Volume, VolumeData};
use std::path::{Path, PathBuf};

/// Whether `path` is a folder of masks: a folder holding a `.nii` or `.nii.gz` file (no DICOM,
/// TIFF slice or Zarr folder does). [`read`] refuses it if it also holds anything else.
pub fn is_mask_folder(path: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(path) else {
        return false;
    };
    entries.flatten().any(|e| {
        let name = e.file_name().to_string_lossy().to_string();
        !name.starts_with('.') && is_nifti_name(&name)
    })
}

fn is_nifti_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".nii") || lower.ends_with(".nii.gz")
}

/// The mask files of the folder `path`, sorted by name; an error when it holds anything else
/// (hidden entries aside).
fn mask_files(path: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(path).map_err(|e| Error::from(e).with_path(path))? {
        let entry = entry.map_err(|e| Error::from(e).with_path(path))?;
        let name = entry.file_name().to_string_lossy().to_string();
        if name.starts_with('.') {
            continue;
        }
        if !(is_nifti_name(&name) && entry.path().is_file()) {
            return Err(Error::unsupported(format!(
                "{name} is not a NIfTI mask (.nii or .nii.gz)"
            ))
            .with_path(path));
        }
        files.push(entry.path());
    }
    files.sort();
    Ok(files)
}

/// The label name of a mask file: its name without `.nii` / `.nii.gz`.
fn mask_name(file: &Path) -> String {
    let name = file.file_name().unwrap_or_default().to_string_lossy();
    let lower = name.to_ascii_lowercase();
    let stem = lower
        .strip_suffix(".nii.gz")
        .or_else(|| lower.strip_suffix(".nii"))
        .map_or(name.len(), str::len);
    name[..stem].to_string()
}

/// The samples of `volume` that lie in its mask (see the module documentation).
fn inside(volume: &Volume) -> Vec<bool> {
    fn rule<T: Scalar>(s: &[T], float: bool) -> Vec<bool> {
        s.iter()
            .map(|v| {
                let v = v.to_f64();
                if float {
                    v >= 0.5
                } else {
                    v != 0.0
                }
            })
            .collect()
    }
    let float = !volume.scalar_type().is_integer();
    isogrid::volume::with_samples!(volume.data().samples(), s => rule(s, float))
}

/// The first field in which grid `a` differs from grid `b`, with both values, for an error.
fn differing_field(a: &isogrid::Geometry, b: &isogrid::Geometry) -> Option<String> {
    // Header fields are often f32 (NIfTI): shown as the f32 they are, not as their f64 widening.
    let show = |v: &[f64]| {
        let shown: Vec<String> = v
            .iter()
            .map(|&x| match (x as f32) as f64 == x {
                true => (x as f32).to_string(),
                false => x.to_string(),
            })
            .collect();
        format!("[{}]", shown.join(", "))
    };
    let flat = |d: &[[f64; 3]; 3]| d.concat();
    if a.dims != b.dims {
        return Some(format!("size {:?} samples (against {:?})", a.dims, b.dims));
    }
    [
        ("spacing", a.spacing.to_vec(), b.spacing.to_vec()),
        ("origin", a.origin.to_vec(), b.origin.to_vec()),
        ("direction matrix", flat(&a.direction), flat(&b.direction)),
    ]
    .into_iter()
    .find(|(_, x, y)| x != y)
    .map(|(name, x, y)| format!("{name} {} (against {})", show(&x), show(&y)))
}

/// A layer being filled: one value per sample, the masks in it numbered from 1.
enum LayerSamples {
    U8(Vec<u8>),
    U16(Vec<u16>),
}

impl LayerSamples {
    fn new(len: usize, masks: usize) -> Self {
        match masks <= u8::MAX as usize {
            true => LayerSamples::U8(vec![0; len]),
            false => LayerSamples::U16(vec![0; len]),
        }
    }
    fn is_set(&self, i: usize) -> bool {
        match self {
            LayerSamples::U8(v) => v[i] != 0,
            LayerSamples::U16(v) => v[i] != 0,
        }
    }
    /// Sets the samples `inside` to `value` (at most the mask count it was made for).
    fn set(&mut self, inside: &[bool], value: usize) {
        match self {
            LayerSamples::U8(v) => fill(v, inside, value as u8),
            LayerSamples::U16(v) => fill(v, inside, value as u16),
        }
    }
    fn into_data(self) -> VolumeData {
        match self {
            LayerSamples::U8(v) => VolumeData::U8(v),
            LayerSamples::U16(v) => VolumeData::U16(v),
        }
    }
}

fn fill<T: Copy>(samples: &mut [T], inside: &[bool], value: T) {
    for (s, _) in samples.iter_mut().zip(inside).filter(|(_, &i)| i) {
        *s = value;
    }
}

/// Reads the folder of masks `path` (see the module documentation), with a notice naming the
/// masks that are empty (TotalSegmentator writes one for every structure it did not find).
pub fn read(path: &Path, opts: &ReadOptions) -> Result<(LabelVolume, Vec<String>)> {
    let files = mask_files(path)?;
    if files.len() > u16::MAX as usize {
        return Err(Error::unsupported(format!(
            "{} masks; a folder of masks holds at most {}",
            files.len(),
            u16::MAX
        ))
        .with_path(path));
    }
    let mut layers = Vec::new();
    let mut names = Vec::with_capacity(files.len());
    let mut empty = Vec::new();
    let mut notices = Vec::new();
    // The first mask's grid, the layer being filled and the index of its first mask.
    let mut current: Option<(PathBuf, isogrid::Geometry, LayerSamples, usize)> = None;
    for (i, file) in files.iter().enumerate() {
        let (volume, noted) = crate::read_volume_noted(file, opts).at_path(file)?;
        notices.extend(noted);
        let inside = inside(&volume);
        let name = mask_name(file);
        if !inside.contains(&true) {
            empty.push(name.clone());
        }
        names.push(Label {
            name,
            ..Label::default_for(i as u64 + 1, false)
        });
        let (first, geometry, layer, offset) = current.get_or_insert_with(|| {
            let samples = LayerSamples::new(inside.len(), files.len());
            (file.clone(), *volume.geometry(), samples, 0)
        });
        if let Some(field) = differing_field(volume.geometry(), geometry) {
            return Err(Error::invalid(format!(
                "its {field} is not that of {}; the masks of a folder share one grid",
                first.display()
            ))
            .with_path(file));
        }
        let overlaps = inside
            .iter()
            .enumerate()
            .any(|(s, &m)| m && layer.is_set(s));
        if overlaps {
            isogrid::memory::ensure_fits(
                "the layers of overlapping masks",
                (layers.len() as u64 + 2) * inside.len() as u64 * 2,
            )
            .at_path(path)?;
            let full = std::mem::replace(layer, LayerSamples::new(inside.len(), files.len()));
            let volume = Volume::with_geometry(*geometry, full.into_data())?;
            layers.push(LabelLayer {
                volume,
                offset: *offset as u64,
            });
            *offset = i;
        }
        layer.set(&inside, i + 1 - *offset);
    }
    let (_, geometry, layer, offset) = current
        .ok_or_else(|| Error::unsupported("the folder holds no NIfTI mask").with_path(path))?;
    layers.push(LabelLayer {
        volume: Volume::with_geometry(geometry, layer.into_data())?,
        offset: offset as u64,
    });
    if !empty.is_empty() {
        notices.push(format!(
            "{}: {} of {} masks are empty and have no surface: {}",
            path.display(),
            empty.len(),
            files.len(),
            empty.join(", ")
        ));
    }
    Ok((LabelVolume { layers, names }, notices))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mask_is_named_after_its_file_and_a_grid_mismatch_names_its_field() {
        assert_eq!(mask_name(Path::new("seg/liver.nii.gz")), "liver");
        assert_eq!(mask_name(Path::new("seg/Kidney_Left.NII")), "Kidney_Left");
        assert_eq!(mask_name(Path::new("seg/a.b.nii")), "a.b");
        let a = isogrid::Geometry {
            spacing: [0.8f32 as f64, 0.8f32 as f64, 2.0],
            ..isogrid::Geometry::new([4, 5, 6])
        };
        assert_eq!(differing_field(&a, &a), None);
        let b = isogrid::Geometry {
            spacing: [0.8f32 as f64, 0.8f32 as f64, 2.5],
            ..a
        };
        assert_eq!(
            differing_field(&b, &a).unwrap(),
            "spacing [0.8, 0.8, 2.5] (against [0.8, 0.8, 2])"
        );
        let c = isogrid::Geometry::new([4, 5, 7]);
        assert_eq!(
            differing_field(&c, &a).unwrap(),
            "size [4, 5, 7] samples (against [4, 5, 6])"
        );
    }
}

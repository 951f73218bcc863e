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
use crate::nifti::is_nifti_name;
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

/// Samples of a mask turned into bits at a time: a multiple of 64, so that each chunk fills
/// whole words, and small enough that a mask is never held whole.
const CHUNK_SAMPLES: usize = 1 << 20;

/// Appends the bits of `samples` that lie in the mask (see the module documentation), one bit
/// each (sample `s` of the mask is bit `s % 64` of word `s / 64`), to `bits`, which holds the
/// bits of the samples before them (a whole number of words).
fn append_inside(samples: &VolumeData, bits: &mut Vec<u64>) {
    fn word<T: Scalar>(chunk: &[T], inside: impl Fn(T) -> bool) -> u64 {
        let mut flags = [0u8; 64];
        for (flag, &v) in flags.iter_mut().zip(chunk) {
            *flag = inside(v) as u8;
        }
        // Eight 0/1 bytes at a time into eight bits: the multiplier moves byte k's bit to bit
        // 56 + k, and no two of its partial products meet, so nothing carries.
        flags
            .chunks_exact(8)
            .enumerate()
            .fold(0u64, |word, (i, bytes)| {
                let eight = u64::from_le_bytes(bytes.try_into().expect("8 bytes"));
                word | (eight.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * i)
            })
    }
    fn rule<T: Scalar>(s: &[T], inside: impl Fn(T) -> bool + Copy, bits: &mut Vec<u64>) {
        bits.extend(s.chunks(64).map(|chunk| word(chunk, inside)));
    }
    fn non_zero<T: Scalar>(v: T) -> bool {
        v != <T as bytemuck::Zeroable>::zeroed()
    }
    fn at_least_half<T: Scalar>(v: T) -> bool {
        v.to_f64() >= 0.5
    }
    match samples.scalar_type().is_integer() {
        true => isogrid::volume::with_samples!(samples.samples(), s => rule(s, non_zero, bits)),
        false => {
            isogrid::volume::with_samples!(samples.samples(), s => rule(s, at_least_half, bits))
        }
    }
}

/// One mask file read: its grid and the bits of its samples inside it, the file streamed a chunk
/// at a time.
fn read_mask(file: &Path, opts: &ReadOptions) -> Result<(isogrid::Geometry, Vec<u64>)> {
    let mut bits = Vec::new();
    let geometry =
        crate::nifti::read_nifti_in_chunks(file, opts.zarr.pick(), CHUNK_SAMPLES, |samples| {
            append_inside(samples, &mut bits);
            Ok(())
        })?;
    Ok((geometry, bits))
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

/// A layer being filled: one value per sample, the masks in it numbered from 1, and which samples
/// a mask of it holds (as [`inside`]'s bits).
struct Layer {
    samples: LayerSamples,
    occupied: Vec<u64>,
    /// The index of its first mask: its offset.
    first: usize,
}

enum LayerSamples {
    U8(Vec<u8>),
    U16(Vec<u16>),
}

impl Layer {
    fn new(len: usize, masks: usize, first: usize) -> Self {
        let samples = match masks <= u8::MAX as usize {
            true => LayerSamples::U8(vec![0; len]),
            false => LayerSamples::U16(vec![0; len]),
        };
        Layer {
            samples,
            occupied: vec![0; len.div_ceil(64)],
            first,
        }
    }
    fn overlaps(&self, inside: &[u64]) -> bool {
        self.occupied.iter().zip(inside).any(|(a, b)| a & b != 0)
    }
    /// Gives the samples `inside` the value `value` (at most the mask count it was made for).
    fn set(&mut self, inside: &[u64], value: usize) {
        fn fill<T: Copy>(samples: &mut [T], inside: &[u64], value: T) {
            for (w, &word) in inside.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    samples[64 * w + bits.trailing_zeros() as usize] = value;
                    bits &= bits - 1;
                }
            }
        }
        match &mut self.samples {
            LayerSamples::U8(v) => fill(v, inside, value as u8),
            LayerSamples::U16(v) => fill(v, inside, value as u16),
        }
        for (a, b) in self.occupied.iter_mut().zip(inside) {
            *a |= b;
        }
    }
    fn into_layer(self, geometry: isogrid::Geometry) -> Result<LabelLayer> {
        let data = match self.samples {
            LayerSamples::U8(v) => VolumeData::U8(v),
            LayerSamples::U16(v) => VolumeData::U16(v),
        };
        Ok(LabelLayer {
            volume: Volume::with_geometry(geometry, data)?,
            offset: self.first as u64,
        })
    }
}

/// Reads the folder of masks `path` (see the module documentation), with a notice naming the
/// masks that are empty (TotalSegmentator writes one for every structure it did not find). The
/// masks are read and turned into bits in parallel, a batch at a time, and placed in name order.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<(LabelVolume, Vec<String>)> {
    use rayon::prelude::*;
    let files = mask_files(path)?;
    if files.len() > u16::MAX as usize {
        return Err(Error::unsupported(format!(
            "{} masks; a folder of masks holds at most {}",
            files.len(),
            u16::MAX
        ))
        .with_path(path));
    }
    let Some(first_file) = files.first() else {
        return Err(Error::unsupported("the folder holds no NIfTI mask").with_path(path));
    };
    let (geometry, first_inside) = read_mask(first_file, opts)?;
    let mut notices = Vec::new();
    let samples = geometry.dims.iter().product::<usize>();
    // One mask per thread at a time, each held as its bits and a chunk of samples.
    let batch = rayon::current_num_threads().max(1);
    let mut layers = Vec::new();
    let mut names = Vec::with_capacity(files.len());
    let mut empty = Vec::new();
    let mut layer = Layer::new(samples, files.len(), 0);
    let mut place = |i: usize, inside: Vec<u64>, layer: &mut Layer| -> Result<()> {
        let name = mask_name(&files[i]);
        if inside.iter().all(|&w| w == 0) {
            empty.push(name.clone());
        }
        names.push(Label {
            name,
            ..Label::default_for(i as u64 + 1, false)
        });
        if layer.overlaps(&inside) {
            isogrid::memory::ensure_fits(
                "the layers of overlapping masks",
                (layers.len() as u64 + 2) * samples as u64 * 2,
            )
            .at_path(path)?;
            let full = std::mem::replace(layer, Layer::new(samples, files.len(), i));
            layers.push(full.into_layer(geometry)?);
        }
        layer.set(&inside, i + 1 - layer.first);
        Ok(())
    };
    place(0, first_inside, &mut layer)?;
    for (b, chunk) in files[1..].chunks(batch).enumerate() {
        let read: Vec<Result<_>> = chunk.par_iter().map(|f| read_mask(f, opts)).collect();
        for (k, mask) in read.into_iter().enumerate() {
            let i = 1 + b * batch + k;
            let (g, inside) = mask?;
            if let Some(field) = differing_field(&g, &geometry) {
                return Err(Error::invalid(format!(
                    "its {field} is not that of {}; the masks of a folder share one grid",
                    first_file.display()
                ))
                .with_path(&files[i]));
            }
            place(i, inside, &mut layer)?;
        }
    }
    layers.push(layer.into_layer(geometry)?);
    if !empty.is_empty() {
        // A line, not a screenful: TotalSegmentator leaves most of its 117 masks empty.
        const NAMED: usize = 8;
        let more = match empty.len().saturating_sub(NAMED) {
            0 => String::new(),
            n => format!(" and {n} more"),
        };
        notices.push(format!(
            "{}: {} of {} masks are empty and have no surface: {}{more}",
            path.display(),
            empty.len(),
            files.len(),
            empty[..empty.len().min(NAMED)].join(", ")
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

    #[test]
    fn mask_bits_are_each_samples_test_in_chunks_of_whole_words() {
        // Sample s is in the mask when non-zero (integers) or at least ½ (floats), bit s % 64 of
        // word s / 64; chunks of whole words then a short last one give the bits of the whole.
        let len: usize = 64 * 3 + 37;
        let ints: Vec<u16> = (0..len).map(|s| ((s * 7919) % 5) as u16 * 300).collect();
        let floats: Vec<f32> = (0..len).map(|s| ((s * 31) % 11) as f32 / 10.0).collect();
        let cases = [
            (
                VolumeData::U16(ints.clone()),
                ints.iter().map(|&v| v != 0).collect::<Vec<_>>(),
            ),
            (
                VolumeData::F32(floats.clone()),
                floats.iter().map(|&v| v >= 0.5).collect(),
            ),
        ];
        for (samples, inside) in cases {
            let mut expected = vec![0u64; len.div_ceil(64)];
            for (s, _) in inside.iter().enumerate().filter(|(_, &i)| i) {
                expected[s / 64] |= 1 << (s % 64);
            }
            let mut bits = Vec::new();
            let split = 128;
            let (head, tail) = match &samples {
                VolumeData::U16(v) => (
                    VolumeData::U16(v[..split].to_vec()),
                    VolumeData::U16(v[split..].to_vec()),
                ),
                VolumeData::F32(v) => (
                    VolumeData::F32(v[..split].to_vec()),
                    VolumeData::F32(v[split..].to_vec()),
                ),
                _ => unreachable!(),
            };
            append_inside(&head, &mut bits);
            append_inside(&tail, &mut bits);
            assert_eq!(bits, expected);
            assert!(expected.iter().any(|&w| w != 0) && expected.iter().any(|&w| w != u64::MAX));
        }
    }
}

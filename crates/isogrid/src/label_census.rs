//! The labels a label volume holds, counted before any surface is extracted: each label value's
//! voxel count and box, in one parallel pass over the samples. `isogrid info VOLUME --labels`
//! lists them (segment volumes, as 3D Slicer's segment statistics give them).
//!
//! Index space: a box is the sample indices `[lo, hi)` per axis of the label's voxels. Values are
//! label keys ([`LabelSample::key`]: a signed volume's values as their two's complement), as the
//! label table of an extracted grid holds them.

use crate::error::{Error, Result};
use crate::labels::{check_label_samples, LabelSample};
use crate::volume::VolumeView;
use rayon::prelude::*;
use std::collections::HashMap;

/// One label value of a volume: how many voxels hold it and where they lie.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LabelCount {
    /// The label key.
    pub value: u64,
    /// Samples holding it.
    pub voxels: u64,
    /// Their box in sample indices, `[lo, hi)` per axis.
    pub lo: [u64; 3],
    pub hi: [u64; 3],
}

/// Bytes a census holds per distinct label, for the memory check: the entry and the hash
/// table's share of it.
const BYTES_PER_LABEL: u64 = 96;

/// Every label value of `volume`, background (0) included, in increasing key order. Fails on a
/// float volume holding a value that is not a label ([`check_label_samples`]), and with a
/// `TooLarge` error when the distinct values would outgrow the memory available (a volume of
/// noise given as labels).
pub fn label_census(volume: &VolumeView<'_>) -> Result<Vec<LabelCount>> {
    let dims = volume.geometry().dims;
    crate::volume::with_samples!(volume.samples(), s => census(s, dims))
}

fn census<T: LabelSample>(samples: &[T], dims: [usize; 3]) -> Result<Vec<LabelCount>> {
    check_label_samples(samples)?;
    let [nx, ny, nz] = dims;
    let threads = rayon::current_num_threads() as u64;
    // Planes in parallel; along a row, a run of one value is one update (labels come in runs).
    let counts = (0..nz)
        .into_par_iter()
        .try_fold(HashMap::<u64, LabelCount>::new, |mut counts, z| {
            for y in 0..ny {
                let row = &samples[nx * (y + ny * z)..][..nx];
                let mut x = 0;
                while x < nx {
                    let key = row[x].key();
                    let start = x;
                    while x < nx && row[x].key() == key {
                        x += 1;
                    }
                    if counts.len() == counts.capacity() && !counts.contains_key(&key) {
                        let room = (counts.capacity().max(8) * 2) as u64;
                        crate::memory::ensure_fits(
                            "counting the volume's labels",
                            room * BYTES_PER_LABEL * threads,
                        )?;
                    }
                    let [y, z] = [y, z].map(|c| c as u64);
                    add(
                        &mut counts,
                        LabelCount {
                            value: key,
                            voxels: (x - start) as u64,
                            lo: [start as u64, y, z],
                            hi: [x as u64, y + 1, z + 1],
                        },
                    );
                }
            }
            Ok::<_, Error>(counts)
        })
        .try_reduce(HashMap::new, |a, b| {
            let (mut into, from) = if a.len() < b.len() { (b, a) } else { (a, b) };
            for count in from.into_values() {
                add(&mut into, count);
            }
            Ok(into)
        })?;
    let mut counts: Vec<LabelCount> = counts.into_values().collect();
    counts.sort_unstable_by_key(|c| c.value);
    Ok(counts)
}

/// Adds `count`'s voxels and box to those `counts` holds for its value.
fn add(counts: &mut HashMap<u64, LabelCount>, count: LabelCount) {
    counts
        .entry(count.value)
        .and_modify(|c| {
            c.voxels += count.voxels;
            for a in 0..3 {
                c.lo[a] = c.lo[a].min(count.lo[a]);
                c.hi[a] = c.hi[a].max(count.hi[a]);
            }
        })
        .or_insert(count);
}

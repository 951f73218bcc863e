//! The labels a label volume holds, counted before any surface is extracted: each label value's
//! voxel count and box, in one parallel pass over the samples. `isogrid info VOLUME --labels`
//! lists them (segment volumes, as 3D Slicer's segment statistics give them).
//!
//! Index space: a box is the sample indices `[lo, hi)` per axis of the label's voxels. Values are
//! label keys ([`LabelSample::key`]: a signed volume's values as their two's complement), as the
//! label table of an extracted grid holds them.

use crate::error::{Error, Result};
use crate::labels::{check_label_samples, LabelSample};
use crate::volume::{Samples, VolumeView};
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
    let mut census = Census::default();
    census.add(volume.samples(), volume.geometry().dims, 0)?;
    Ok(census.into_counts())
}

/// Counts gathered from parts of a volume (whole, or slab by slab as
/// [`crate::extract::stream::source_label_census`] reads it).
#[derive(Default)]
pub(crate) struct Census {
    counts: HashMap<u64, LabelCount>,
}

impl Census {
    /// Adds the samples of planes `z0..` of the volume (`dims`: the part's samples per axis).
    pub(crate) fn add(&mut self, samples: Samples<'_>, dims: [usize; 3], z0: usize) -> Result<()> {
        let part = crate::volume::with_samples!(samples, s => census(s, dims, z0))?;
        let (mut into, from) = if self.counts.len() < part.len() {
            (part, std::mem::take(&mut self.counts))
        } else {
            (std::mem::take(&mut self.counts), part)
        };
        for count in from.into_values() {
            ensure_room(&into, count.value, 1)?;
            add(&mut into, count);
        }
        self.counts = into;
        Ok(())
    }

    /// The counts in increasing key order.
    pub(crate) fn into_counts(self) -> Vec<LabelCount> {
        let mut counts: Vec<LabelCount> = self.counts.into_values().collect();
        counts.sort_unstable_by_key(|c| c.value);
        counts
    }
}

/// Fails with a `TooLarge` error when adding `key` to `counts` would grow its table past the
/// memory available, counting `tables` tables of its size (one per thread while they count).
fn ensure_room(counts: &HashMap<u64, LabelCount>, key: u64, tables: u64) -> Result<()> {
    if counts.len() == counts.capacity() && !counts.contains_key(&key) {
        let room = (counts.capacity().max(8) * 2) as u64;
        crate::memory::ensure_fits(
            "counting the volume's labels",
            room * BYTES_PER_LABEL * tables,
        )?;
    }
    Ok(())
}

/// The counts of `samples` (planes of a volume of `dims`, the first being plane `z0` of it).
fn census<T: LabelSample>(
    samples: &[T],
    dims: [usize; 3],
    z0: usize,
) -> Result<HashMap<u64, LabelCount>> {
    check_label_samples(samples)?;
    let [nx, ny, nz] = dims;
    let threads = rayon::current_num_threads() as u64;
    // Planes in parallel; along a row, a run of one value is one update (labels come in runs).
    (0..nz)
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
                    ensure_room(&counts, key, threads)?;
                    let [y, z] = [y, z0 + z].map(|c| c as u64);
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
        })
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

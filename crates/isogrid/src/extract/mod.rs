//! Isosurface extraction into clustered grid cells (paper §3.1).
//!
//! Two passes over 16³ blocks, both parallel (rayon) and deterministic for any thread count:
//! `scan` sweeps the whole volume once and counts, per block, active cells and occupied
//! metacells; prefix sums then give every block a disjoint part of the exactly-sized output; `emit`
//! revisits only blocks that hold active cells and writes their records. Memory beyond the volume
//! and the output is O(blocks) plus per-thread scratch for one block row.

pub mod attribute;
mod emit;
mod file_layout;
mod label_smooth;
pub mod label_stream;
pub mod labels;
pub(crate) mod scalar;
mod scan;
pub mod stream;
pub mod tiles;

use crate::error::{Error, Result};
use crate::grid::{CellGrid, GridInfo};
use crate::layout::{Block, Metacell, Precision, BLOCK_CELLS, CLUSTER_METACELLS, CLUSTER_SLOTS};
use crate::progress::Progress;
use crate::quantize::Quantizer;
use crate::volume::VolumeView;
use rayon::prelude::*;
use scalar::ExtractScalar;

/// Asks the cache for the lines holding the first and last samples of `row`, a hint that lets
/// the misses of scattered rows overlap instead of queueing behind each other (a no-op off
/// x86-64).
#[inline(always)]
pub(crate) fn prefetch_row<T>(row: &[T]) {
    #[cfg(target_arch = "x86_64")]
    if let (Some(first), Some(last)) = (row.first(), row.last()) {
        // SAFETY: prefetch is a hint and never faults; both addresses are inside the row.
        unsafe {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            _mm_prefetch::<_MM_HINT_T0>((first as *const T).cast());
            _mm_prefetch::<_MM_HINT_T0>((last as *const T).cast());
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = row;
}

/// The isovalue, in data units or normalised to the volume's value range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Iso {
    /// In data units: a sample is inside when `value >= iso`.
    Value(f64),
    /// `min + t·(max - min)` over the volume's finite samples (the paper uses 0.5 throughout).
    Normalized(f64),
}

impl Iso {
    /// The isovalue in data units for `volume`; errors on non-finite values, a normalised value
    /// outside [0, 1], or a volume without finite samples.
    pub fn resolve(&self, volume: &VolumeView) -> Result<f64> {
        self.resolve_with_range(volume).map(|(iso, _)| iso)
    }

    /// Like [`Iso::resolve`], also returning the value range when it had to be computed.
    fn resolve_with_range(&self, volume: &VolumeView) -> Result<(f64, Option<(f64, f64)>)> {
        self.resolve_lazily(|| Ok(volume.value_range()))
    }

    /// Resolves with `value_range` (NaN-free min and max, `None` without a finite sample) called
    /// only for a normalised isovalue, after its fraction has been checked: a streaming source
    /// pays a pass over the volume for it.
    fn resolve_lazily(
        &self,
        value_range: impl FnOnce() -> Result<Option<(f64, f64)>>,
    ) -> Result<(f64, Option<(f64, f64)>)> {
        let (iso, range) = match *self {
            Iso::Value(v) => (v, None),
            Iso::Normalized(t) => {
                if !(0.0..=1.0).contains(&t) {
                    return Err(Error::invalid(format!(
                        "normalised isovalue {t} is outside [0, 1]"
                    )));
                }
                let (lo, hi) = value_range()?.ok_or_else(|| {
                    Error::invalid(
                        "the volume has no finite sample (all are NaN or infinite), so it has no value range",
                    )
                })?;
                (lo + t * (hi - lo), Some((lo, hi)))
            }
        };
        if !iso.is_finite() {
            return Err(Error::invalid(format!(
                "isovalue {iso} is not a finite number"
            )));
        }
        Ok((iso, range))
    }
}

/// What to extract.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractOptions {
    pub iso: Iso,
    /// Corner precision; `None` picks [`Precision::default_for`] the volume's type.
    pub precision: Option<Precision>,
}

impl ExtractOptions {
    pub fn new(iso: Iso) -> Self {
        ExtractOptions {
            iso,
            precision: None,
        }
    }
    pub fn with_precision(mut self, precision: Precision) -> Self {
        self.precision = Some(precision);
        self
    }
}

/// Extracts the active cells of `volume` at the isovalue into clustered grid cells.
///
/// Runs on the current rayon pool; the output is byte-identical for any pool size.
pub fn extract(volume: &VolumeView, options: &ExtractOptions) -> Result<CellGrid> {
    extract_with_progress(volume, options, &Progress::new())
}

/// [`extract`], counting in `progress` two steps per block: one when pass 1 has scanned it, one
/// when pass 2 has emitted it (blocks without active cells, which pass 2 skips, count at its
/// start). `done` reaches `total` with the grid. A [`Progress::cancel`] is honoured between the
/// passes, with an error of kind [`crate::ErrorKind::Cancelled`].
pub fn extract_with_progress(
    volume: &VolumeView,
    options: &ExtractOptions,
    progress: &Progress,
) -> Result<CellGrid> {
    crate::volume::with_samples!(volume.samples(), s => extract_typed(volume, s, options, progress))
}

fn extract_typed<T: ExtractScalar>(
    volume: &VolumeView,
    samples: &[T],
    options: &ExtractOptions,
    progress: &Progress,
) -> Result<CellGrid> {
    let geometry = volume.geometry();
    let dims = geometry.dims;
    let precision = options.precision.unwrap_or(Precision::default_for(T::TYPE));

    // A normalised isovalue needs the range before the sweep; otherwise the sweep's block ranges give it.
    let (iso, value_range) = options.iso.resolve_with_range(volume)?;
    let threshold = T::threshold(iso);

    let cell_dims = geometry.cell_dims();
    let block_dims = cell_dims.map(|c| c.div_ceil(BLOCK_CELLS));
    let [nbx, nby, nbz] = block_dims;
    let block_count = nbx * nby * nbz;
    progress.start(2 * block_count as u64);

    // Pass 1: per-block ranges and counts, block rows in block order.
    let scans = if block_count == 0 {
        Vec::new()
    } else {
        scan_blocks_counted(samples, dims, threshold, Some(progress))
    };
    progress.check()?;

    let (lo, hi) = match value_range {
        Some(r) => r,
        None if !scans.is_empty() => scans
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                (lo.min(s.min), hi.max(s.max))
            }),
        None => volume.value_range().unwrap_or((0.0, 0.0)),
    };
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (0.0, 0.0) }; // all NaN
    let quantizer = Quantizer::new(precision, T::TYPE.is_integer(), lo, hi, iso);

    // Prefix sums: each block's slots and cells.
    let mut blocks = Vec::with_capacity(block_count);
    let mut totals = Totals::default();
    for s in &scans {
        blocks.push(totals.add(s)?);
    }
    let (slot_total, cell_total) = (totals.slots, totals.cells);

    // Pass 2: emit active blocks into disjoint parts of the output.
    let record = precision.bytes_per_cell();
    let mut metacells = vec![bytemuck::Zeroable::zeroed(); slot_total as usize];
    let mut cells = vec![0u8; cell_total as usize * record];
    let mut first_cell = 0u32;
    let outputs = split_outputs(
        &blocks,
        0,
        |index| scans[index].active_cells,
        0..block_count,
        [nbx, nby],
        (&mut metacells, &mut cells),
        record,
        &mut first_cell,
        0,
    );
    progress.advance((block_count - outputs.len()) as u64);
    outputs
        .into_par_iter()
        .for_each_init(emit::BlockScratch::default, |scratch, out| {
            if progress.is_cancelled() {
                return;
            }
            emit::emit_block(samples, dims, threshold, &quantizer, out, scratch);
            progress.advance(1);
        });
    progress.check()?;

    let info = GridInfo::new(geometry, T::TYPE, [lo, hi], iso, &quantizer);
    Ok(CellGrid::from_parts(info, blocks, metacells, cells))
}

/// Pass 1 over `samples` (a whole volume, a slab of whole block layers plus its halo plane, or a
/// tile): one [`scan::BlockScan`] per block in block order, adding each scanned row's blocks to
/// `progress`. Runs on the current rayon pool.
pub(super) fn scan_blocks_counted<T: ExtractScalar>(
    samples: &[T],
    dims: [usize; 3],
    threshold: Option<T>,
    progress: Option<&Progress>,
) -> Vec<scan::BlockScan> {
    let [nbx, nby, nbz] = dims.map(|d| d.saturating_sub(1).div_ceil(BLOCK_CELLS));
    (0..nby * nbz)
        .into_par_iter()
        .map_init(scan::RowScratch::default, |scratch, row| {
            // Once cancelled, the remaining rows are skipped; the caller checks before using
            // the scans.
            if progress.is_some_and(|p| p.is_cancelled()) {
                return Vec::new();
            }
            let scans =
                scan::scan_block_row(samples, dims, row % nby, row / nby, threshold, scratch);
            if let Some(p) = progress {
                p.advance(nbx as u64);
            }
            scans
        })
        .flatten_iter()
        .collect()
}

/// Slots a block's `occupied` metacells take: whole clusters of 15 metacells and their bound.
fn metacell_slots(occupied: u32) -> u64 {
    (occupied as u64).div_ceil(CLUSTER_METACELLS as u64) * CLUSTER_SLOTS as u64
}

/// Running prefix sums over blocks in block order: where each block's slots and cells start.
#[derive(Debug, Default, Clone, Copy)]
struct Totals {
    slots: u64,
    cells: u64,
    occupied_metacells: u64,
    nonempty_blocks: u64,
}

impl Totals {
    /// The next block's record; errors past the format's 32-bit pointers.
    fn add(&mut self, s: &scan::BlockScan) -> Result<Block> {
        self.add_block(
            metacell_slots(s.occupied_metacells),
            s.active_cells,
            s.occupied_metacells,
            [s.min, s.max],
        )
    }

    /// The next block's record from its slots (whole clusters), active cells, occupied metacells
    /// and value range; errors past the format's 32-bit pointers.
    fn add_block(
        &mut self,
        slots: u64,
        active_cells: u32,
        occupied_metacells: u32,
        [min, max]: [f64; 2],
    ) -> Result<Block> {
        let block = Block {
            metacell_count: slots as u32,
            metacell_pointer: self.slots as u32,
            min: min as f32,
            max: max as f32,
        };
        self.slots += slots;
        self.cells += active_cells as u64;
        self.occupied_metacells += occupied_metacells as u64;
        self.nonempty_blocks += (slots > 0) as u64;
        if self.slots > u32::MAX as u64 || self.cells > u32::MAX as u64 {
            return Err(Error::too_large("more than 2^32 metacell slots or active cells: beyond the 32-bit pointers of the format"));
        }
        Ok(block)
    }
}

/// Splits `output` (slots, corner records) into the disjoint parts of the active blocks among
/// `range` (in block order, which is output order). `blocks[0]` is the grid's block number
/// `first_block` (0 for the whole table; a tile holds only its own layers). `next_cell` is the
/// global index of the first cell and advances past the range; `slab_block_z` is the block layer
/// where the samples the outputs will be emitted from start (see [`emit::BlockOutput`]; a tile
/// that starts at another block in x or y sets its outputs' `slab_block` itself).
#[allow(clippy::too_many_arguments)]
fn split_outputs<'a>(
    blocks: &[Block],
    first_block: usize,
    active_cells: impl Fn(usize) -> u32,
    range: std::ops::Range<usize>,
    [nbx, nby]: [usize; 2],
    output: (&'a mut [Metacell], &'a mut [u8]),
    record: usize,
    next_cell: &mut u32,
    slab_block_z: usize,
) -> Vec<emit::BlockOutput<'a>> {
    let (mut slots_rest, mut cells_rest) = output;
    let mut outputs = Vec::new();
    for index in range {
        let block = &blocks[index];
        if block.metacell_count == 0 {
            continue;
        }
        let cell_count = active_cells(index);
        let (slots, rest) =
            std::mem::take(&mut slots_rest).split_at_mut(block.metacell_count as usize);
        slots_rest = rest;
        let (cells, rest) =
            std::mem::take(&mut cells_rest).split_at_mut(cell_count as usize * record);
        cells_rest = rest;
        let grid_index = first_block + index;
        outputs.push(emit::BlockOutput {
            block: [
                grid_index % nbx,
                grid_index / nbx % nby,
                grid_index / (nbx * nby),
            ],
            slots,
            cells,
            first_cell: *next_cell,
            slab_block: [0, 0, slab_block_z],
        });
        *next_cell += cell_count;
    }
    outputs
}

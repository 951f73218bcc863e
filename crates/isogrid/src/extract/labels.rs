//! Label extraction: the surface of every selected label of a label volume, in one pass over the
//! volume, as clustered grid cells (paper §3.1) whose clusters each hold one label's cells.
//!
//! Label L's surface is the isosurface at ½ of its indicator (1 where the sample is L, 0
//! elsewhere), or of the indicator smoothed by a Gaussian of σ voxels. Every 16³ block is visited
//! once: its samples (with smoothing, plus a halo of the kernel's radius) are gathered as label
//! keys, their distinct values found, and for each selected label among them the indicator is
//! built on the block's 17³ samples and handed to the ordinary extraction's block classifier and
//! emitter (`emit.rs`), with the grid's one quantiser. A block's clusters are therefore sorted by
//! label, each label's in Morton order, and a cell on the boundary of labels A and B is stored
//! twice: once in A's clusters with A's indicator, once in B's with B's. The work grows with the
//! volume and the surface (blocks with one label in reach cost one sweep of their samples), not
//! with the number of labels.
//!
//! Blocks are processed in parallel, each into its own buffers numbered from its first cell; the
//! buffers are then taken in block order by a `LabelTally`, which gives each block its place
//! (its record, its first cell) and gathers the label table, cluster labels and index, and are
//! concatenated with their cell pointers moved, so the grid is byte-identical for any thread
//! count. The streamed and Dask extractions ([`super::label_stream`]) run the same pass on slabs
//! of planes and the same tally, so their files are byte-identical to this one's.

use super::emit::{self, BlockOutput, BlockScratch};
use super::label_smooth::{
    label_boxes, smooth_indicator, GatheredBlock, SmoothScratch, SmoothingKernel,
};
use super::scalar::ExtractScalar;
use super::{metacell_slots, Totals};
use crate::error::{Error, Result};
use crate::grid::{CellGrid, GridInfo};
use crate::labels::{
    check_label_samples, ClusterRun, GridLabels, Label, LabelEntry, LabelSample, LabelSelection,
};
use crate::layout::{Block, Metacell, Precision, BLOCK_CELLS, BOUND_SLOT, CLUSTER_SLOTS};
use crate::progress::Progress;
use crate::quantize::Quantizer;
use crate::volume::{Samples, VolumeView};
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::Range;

/// The isovalue of an indicator.
pub const LABEL_ISO: f64 = 0.5;

/// What to extract from a label volume.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelOptions {
    pub selection: LabelSelection,
    /// σ of the Gaussian that smooths each indicator, in voxels (index space); 0 for none.
    pub smooth: f64,
    /// Corner precision; `None` picks [`LabelOptions::default_precision`].
    pub precision: Option<Precision>,
}

impl LabelOptions {
    pub fn new(selection: LabelSelection) -> Self {
        LabelOptions {
            selection,
            smooth: 0.0,
            precision: None,
        }
    }
    /// 1 bit per corner for a binary indicator (its codes are its sides, 0 and 1), 8 for a
    /// smoothed one.
    pub fn default_precision(&self) -> Precision {
        if self.smooth > 0.0 {
            Precision::Bits8
        } else {
            Precision::Bits1
        }
    }
}

/// The quantiser of every label grid: the indicator's range `[0, 1]` over the precision's codes,
/// isovalue ½.
pub fn label_quantizer(precision: Precision) -> Quantizer {
    Quantizer::new(precision, false, 0.0, 1.0, LABEL_ISO)
}

/// The smoothing kernel for σ voxels: weights `exp(−k²/2σ²)` for `|k| ≤ ⌈3σ⌉`, normalised to
/// sum 1 (in f64, then rounded to f32). Applied along x, then y, then z; samples beyond the volume
/// repeat the nearest border sample.
pub fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = w.iter().sum();
    w.iter().map(|v| (v / sum) as f32).collect()
}

/// Largest σ accepted: the kernel's halo stays within a few blocks.
pub const MAX_SMOOTH: f64 = 16.0;

/// Extracts the surfaces of the labels `options` selects. Integer volumes hold labels; a float
/// volume only when every sample is an integer (see [`LabelSample`]).
pub fn extract_labels(volume: &VolumeView, options: &LabelOptions) -> Result<CellGrid> {
    extract_labels_with_progress(volume, options, &Progress::new())
}

/// [`extract_labels`], counting one step in `progress` per block as the pass finishes it; `done`
/// reaches `total` with the grid. A [`Progress::cancel`] is honoured between blocks, with an
/// error of kind [`crate::ErrorKind::Cancelled`].
pub fn extract_labels_with_progress(
    volume: &VolumeView,
    options: &LabelOptions,
    progress: &Progress,
) -> Result<CellGrid> {
    let pass = LabelPass::new(options)?;
    match volume.samples() {
        Samples::U8(s) => extract_typed(volume, s, &pass, progress),
        Samples::U16(s) => extract_typed(volume, s, &pass, progress),
        Samples::I16(s) => extract_typed(volume, s, &pass, progress),
        Samples::U32(s) => extract_typed(volume, s, &pass, progress),
        Samples::I32(s) => extract_typed(volume, s, &pass, progress),
        Samples::U64(s) => extract_typed(volume, s, &pass, progress),
        Samples::I64(s) => extract_typed(volume, s, &pass, progress),
        Samples::F32(s) => {
            check_label_samples(s)?;
            extract_typed(volume, s, &pass, progress)
        }
        Samples::F64(s) => {
            check_label_samples(s)?;
            extract_typed(volume, s, &pass, progress)
        }
    }
}

/// Samples a block of the label pass reads beyond its own on each side, along every axis: the
/// smoothing kernel's radius `⌈3σ⌉` (σ = 1 reads 3, σ = 16 reads 48), 0 without smoothing. A
/// slab of block layers `bz0..bz1` therefore needs the planes `16·bz0 − r ..= 16·bz1 + r`
/// (clipped to the volume): its own `16·(bz1 − bz0) + 1` and `r` more on each side.
pub fn label_halo(smooth: f64) -> usize {
    if smooth > 0.0 {
        gaussian_kernel(smooth).len() / 2
    } else {
        0
    }
}

/// What one block holds: its labels' clusters and cells, numbered from the block's first cell.
#[derive(Default, Debug, Clone, PartialEq)]
pub(super) struct BlockLabels {
    /// Distinct label keys among the samples gathered (selected or not), ascending.
    pub present: Vec<u64>,
    pub parts: Vec<LabelPart>,
    pub metacells: Vec<Metacell>,
    pub cells: Vec<u8>,
}

/// One label's share of a block.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LabelPart {
    pub key: u64,
    pub clusters: u32,
    pub cells: u32,
    pub occupied: u32,
    pub lo: [u32; 3],
    pub hi: [u32; 3],
    /// Smallest and largest indicator value on the block's samples.
    pub range: [f64; 2],
}

impl BlockLabels {
    /// The block's metacell slots with their cell pointers moved from the block's numbering to
    /// the grid's, where the block's first cell is `first_cell`. Cluster bounds and padding slots
    /// hold no pointer.
    pub(super) fn moved_metacells(&self, first_cell: u32) -> impl Iterator<Item = Metacell> + '_ {
        self.metacells.iter().enumerate().map(move |(s, m)| {
            let mut m = *m;
            if s % CLUSTER_SLOTS != BOUND_SLOT && !m.is_empty() {
                m.cell_pointer += first_cell;
            }
            m
        })
    }
}

/// Per-thread buffers.
#[derive(Default)]
struct Scratch {
    keys: Vec<u64>,
    binary: Vec<u8>,
    smooth: SmoothScratch,
    block: BlockScratch,
}

/// What every block of a label pass shares, whatever samples it reads: the selection, the
/// smoothing kernel and the grid's quantiser.
pub(super) struct LabelPass {
    selection: LabelSelection,
    kernel: Option<SmoothingKernel>,
    quantizer: Quantizer,
}

impl LabelPass {
    /// Checks `options` (σ within `0..=MAX_SMOOTH`) and makes the kernel and quantiser.
    pub(super) fn new(options: &LabelOptions) -> Result<Self> {
        if !(options.smooth.is_finite() && (0.0..=MAX_SMOOTH).contains(&options.smooth)) {
            return Err(Error::invalid(format!(
                "smoothing σ {} is outside 0..={MAX_SMOOTH} voxels",
                options.smooth
            )));
        }
        let precision = options.precision.unwrap_or(options.default_precision());
        Ok(LabelPass {
            selection: options.selection.clone(),
            kernel: (options.smooth > 0.0)
                .then(|| SmoothingKernel::new(gaussian_kernel(options.smooth))),
            quantizer: label_quantizer(precision),
        })
    }

    pub(super) fn selection(&self) -> &LabelSelection {
        &self.selection
    }
    pub(super) fn quantizer(&self) -> &Quantizer {
        &self.quantizer
    }
    /// Samples a block reads beyond its own on each side ([`label_halo`]).
    pub(super) fn halo(&self) -> usize {
        self.kernel.as_ref().map_or(0, SmoothingKernel::radius)
    }

    /// The blocks `blocks` (numbers in block order) of a volume of `dims` samples, in parallel on
    /// the current rayon pool, from `samples`: the sample rows `rows` (y, whole in x) of the
    /// volume's planes from plane `first_plane` on, which must hold every sample the blocks read
    /// (their own and [`Self::halo`] more on each side, clipped to the volume). One step per
    /// block in `progress`; once it is cancelled the remaining blocks come out empty (the caller
    /// checks).
    pub(super) fn blocks<T: LabelSample>(
        &self,
        samples: &[T],
        dims: [usize; 3],
        rows: Range<usize>,
        first_plane: usize,
        blocks: Range<usize>,
        progress: &Progress,
    ) -> Vec<BlockLabels> {
        let pass = Pass {
            samples,
            dims,
            rows,
            first_plane,
            block_dims: dims.map(|d| d.saturating_sub(1).div_ceil(BLOCK_CELLS)),
            shared: self,
        };
        blocks
            .into_par_iter()
            .map_init(Scratch::default, |scratch, b| {
                if progress.is_cancelled() {
                    return BlockLabels::default();
                }
                let out = pass.block(b, scratch);
                progress.advance(1);
                out
            })
            .collect()
    }
}

/// The samples one run of blocks reads.
struct Pass<'a, T> {
    samples: &'a [T],
    /// Samples per axis of the whole volume.
    dims: [usize; 3],
    /// The volume's sample rows (y) that `samples` hold of each plane: all for the whole volume
    /// and a streamed slab, those of a Dask task's block rows.
    rows: Range<usize>,
    /// The volume's plane where `samples` begin: 0 for the whole volume, a slab's first plane.
    first_plane: usize,
    block_dims: [usize; 3],
    shared: &'a LabelPass,
}

/// The label table, cluster labels, label index and block records of a label grid, gathered from
/// its blocks' [`BlockLabels`] taken one after another in block order: the one place where a
/// block gets its record and its first cell, and the labels their index, for the in-memory,
/// streamed and Dask extractions alike.
pub(super) struct LabelTally {
    selection: LabelSelection,
    totals: Totals,
    blocks: Vec<Block>,
    /// Selected keys seen (sorted and deduplicated now and then, and at the end).
    keys: Vec<u64>,
    /// Length of `keys` after its last sort.
    sorted: usize,
    /// Each label's cells and cell box so far, by key: what the index needs of its parts beyond
    /// their order, gathered as they come so a part keeps only its label and clusters.
    extents: HashMap<u64, LabelExtent>,
    /// Every part in block order: its label's key and its clusters (12 B each).
    part_keys: Vec<u64>,
    part_clusters: Vec<u32>,
}

/// A label's active cells and their box (`[lo, hi)`, index space) over the parts seen.
struct LabelExtent {
    cells: u64,
    lo: [u32; 3],
    hi: [u32; 3],
}

impl LabelTally {
    pub(super) fn new(selection: &LabelSelection, block_count: usize) -> Self {
        LabelTally {
            selection: selection.clone(),
            totals: Totals::default(),
            blocks: Vec::with_capacity(block_count),
            keys: Vec::new(),
            sorted: 0,
            extents: HashMap::new(),
            part_keys: Vec::new(),
            part_clusters: Vec::new(),
        }
    }

    /// Blocks added so far.
    pub(super) fn block_count(&self) -> usize {
        self.blocks.len()
    }

    /// Adds the next block (in block order), its labels and parts (its output need not be
    /// there: its slots are its parts' clusters); returns the grid's number of its first cell.
    /// Errors past the format's 32-bit pointers.
    pub(super) fn add(&mut self, b: &BlockLabels) -> Result<u32> {
        let first_cell = self.totals.cells as u32;
        let slots = b.parts.iter().map(|p| p.clusters as u64).sum::<u64>() * CLUSTER_SLOTS as u64;
        let cells: u32 = b.parts.iter().map(|p| p.cells).sum();
        let occupied: u32 = b.parts.iter().map(|p| p.occupied).sum();
        let range = b
            .parts
            .iter()
            .fold([f64::INFINITY, f64::NEG_INFINITY], |r, p| {
                [r[0].min(p.range[0]), r[1].max(p.range[1])]
            });
        let range = if b.parts.is_empty() { [0.0; 2] } else { range };
        let record = self.totals.add_block(slots, cells, occupied, range)?;
        self.blocks.push(record);
        let selection = &self.selection;
        self.keys
            .extend(b.present.iter().copied().filter(|&k| selection.selects(k)));
        if self.keys.len() > 2 * self.sorted + (1 << 16) {
            self.keys.sort_unstable();
            self.keys.dedup();
            self.sorted = self.keys.len();
        }
        for p in &b.parts {
            self.part_keys.push(p.key);
            self.part_clusters.push(p.clusters);
            let e = self.extents.entry(p.key).or_insert(LabelExtent {
                cells: 0,
                lo: [u32::MAX; 3],
                hi: [0; 3],
            });
            e.cells += p.cells as u64;
            for a in 0..3 {
                e.lo[a] = e.lo[a].min(p.lo[a]);
                e.hi[a] = e.hi[a].max(p.hi[a]);
            }
        }
        Ok(first_cell)
    }

    /// Slots, cells and occupied metacells of the blocks added so far.
    pub(super) fn totals(&self) -> Totals {
        self.totals
    }

    /// The block records and the labels (default names and colours, [`Label::default_for`]).
    pub(super) fn finish(mut self, signed: bool) -> Result<(Vec<Block>, GridLabels)> {
        self.keys.par_sort_unstable();
        self.keys.dedup();
        let keys = self.keys;
        if keys.len() > u32::MAX as usize {
            return Err(Error::too_large(
                "more than 2^32 labels: beyond the 32-bit cluster labels of the format",
            ));
        }
        let table: Vec<Label> = keys
            .iter()
            .map(|&k| Label::default_for(k, signed))
            .collect();
        let table_index =
            |key: u64| keys.binary_search(&key).expect("a part's label is present") as u32;
        let mut cluster_labels = Vec::with_capacity(self.totals.slots as usize / CLUSTER_SLOTS);
        let mut runs: Vec<(u32, ClusterRun)> = Vec::with_capacity(self.part_keys.len());
        let mut index: Vec<LabelEntry> = keys
            .iter()
            .map(|key| match self.extents.get(key) {
                Some(e) => LabelEntry {
                    cell_count: e.cells,
                    lo: e.lo,
                    hi: e.hi,
                    ..Default::default()
                },
                None => LabelEntry::default(),
            })
            .collect();
        drop(self.extents);
        for (&key, &clusters) in self.part_keys.iter().zip(&self.part_clusters) {
            let label = table_index(key);
            runs.push((
                label,
                ClusterRun {
                    first_cluster: cluster_labels.len() as u32,
                    cluster_count: clusters,
                },
            ));
            cluster_labels.extend(std::iter::repeat_n(label, clusters as usize));
        }
        drop((self.part_keys, self.part_clusters));
        // Each label's runs together, in cluster order (the sort is stable).
        runs.sort_by_key(|&(label, _)| label);
        let mut next = 0u64;
        for (label, e) in index.iter_mut().enumerate() {
            e.first_run = next;
            e.run_count = runs[next as usize..]
                .iter()
                .take_while(|(l, _)| *l as usize == label)
                .count() as u64;
            next += e.run_count;
            if e.cell_count == 0 {
                e.lo = [0; 3];
            }
        }
        let runs = runs.into_iter().map(|(_, r)| r).collect();
        Ok((
            self.blocks,
            GridLabels::from_parts(table, cluster_labels, index, runs),
        ))
    }
}

fn extract_typed<T: LabelSample>(
    volume: &VolumeView,
    samples: &[T],
    pass: &LabelPass,
    progress: &Progress,
) -> Result<CellGrid> {
    let geometry = volume.geometry();
    let dims = geometry.dims;
    let block_count: usize = geometry
        .cell_dims()
        .map(|c| c.div_ceil(BLOCK_CELLS))
        .iter()
        .product();
    progress.start(block_count as u64);
    let blocks = pass.blocks(samples, dims, 0..dims[1], 0, 0..block_count, progress);
    progress.check()?;

    // Each block's place, then the blocks' buffers in block order with their cell pointers moved.
    let mut tally = LabelTally::new(&pass.selection, block_count);
    let first_cells = blocks
        .iter()
        .map(|b| tally.add(b))
        .collect::<Result<Vec<u32>>>()?;
    let totals = tally.totals();
    let record = pass.quantizer.precision().bytes_per_cell();
    let mut metacells = Vec::with_capacity(totals.slots as usize);
    let mut cells = Vec::with_capacity(totals.cells as usize * record);
    for (b, &first_cell) in blocks.iter().zip(&first_cells) {
        metacells.extend(b.moved_metacells(first_cell));
        cells.extend_from_slice(&b.cells);
    }
    drop(blocks);
    let (block_records, labels) = tally.finish(crate::labels::signed_labels(T::TYPE))?;

    let info = GridInfo::new(geometry, T::TYPE, [0.0, 1.0], LABEL_ISO, &pass.quantizer);
    let grid = CellGrid::from_parts(info, block_records, metacells, cells);
    Ok(grid.with_built_labels(labels))
}

impl<T: LabelSample> Pass<'_, T> {
    /// Block `b` (in block order): its labels' clusters and cells.
    fn block(&self, b: usize, scratch: &mut Scratch) -> BlockLabels {
        let [nbx, nby, _] = self.block_dims;
        let block = [b % nbx, b / nbx % nby, b / (nbx * nby)];
        let origin = block.map(|c| c * BLOCK_CELLS);
        let cube = [0, 1, 2].map(|a| (self.dims[a] - 1 - origin[a]).min(BLOCK_CELLS) + 1);
        // The samples gathered: the block's, plus the kernel's radius where the volume goes on.
        let radius = self.shared.halo();
        let lo = origin.map(|o| o.saturating_sub(radius));
        let hi = [0, 1, 2].map(|a| (origin[a] + cube[a] - 1 + radius).min(self.dims[a] - 1));
        let region = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
        let nx = self.dims[0];
        scratch.keys.clear();
        debug_assert!(
            lo[2] >= self.first_plane && lo[1] >= self.rows.start && hi[1] < self.rows.end
        );
        let rows = self.rows.len();
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let start = lo[0] + nx * (y - self.rows.start + rows * (z - self.first_plane));
                scratch.keys.extend(
                    self.samples[start..start + region[0]]
                        .iter()
                        .map(|v| v.key()),
                );
            }
        }
        let mut out = BlockLabels {
            present: distinct(&scratch.keys),
            ..Default::default()
        };
        if out.present.len() < 2 {
            // One label in reach: its indicator is 1 on every sample, the others' 0.
            return out;
        }
        let quantizer = &self.shared.quantizer;
        let record = quantizer.precision().bytes_per_cell();
        if self.shared.kernel.is_some() {
            label_boxes(
                &scratch.keys,
                region,
                &out.present,
                &mut scratch.smooth.boxes,
            );
        }
        for i in 0..out.present.len() {
            let key = out.present[i];
            if !self.shared.selection.selects(key) {
                continue;
            }
            // The indicator on the block's samples, classified.
            let range = match &self.shared.kernel {
                None => {
                    scratch.binary.clear();
                    scratch
                        .binary
                        .extend(scratch.keys.iter().map(|&k| (k == key) as u8));
                    emit::classify_block(
                        &scratch.binary,
                        cube,
                        block,
                        block,
                        u8::threshold(LABEL_ISO),
                        &mut scratch.block,
                    );
                    [0.0, 1.0]
                }
                Some(kernel) => {
                    let gathered = GatheredBlock {
                        keys: &scratch.keys,
                        region,
                        at: [0, 1, 2].map(|a| origin[a] - lo[a]),
                        cube,
                    };
                    let support = scratch.smooth.boxes[i];
                    let range =
                        smooth_indicator(gathered, key, support, kernel, &mut scratch.smooth);
                    // Every sample of the cube on one side: no cell of the label's surface here
                    // (the common case of a label that only grazes the block's halo).
                    let threshold = f32::threshold(LABEL_ISO);
                    if threshold.is_none_or(|t| range[1] < t || range[0] >= t) {
                        continue;
                    }
                    emit::classify_block(
                        &scratch.smooth.smooth,
                        cube,
                        block,
                        block,
                        threshold,
                        &mut scratch.block,
                    );
                    range.map(f64::from)
                }
            };
            let (cells, occupied) = scratch.block.counts();
            if cells == 0 {
                continue;
            }
            let first_slot = out.metacells.len();
            let slots = metacell_slots(occupied) as usize;
            out.metacells
                .resize(first_slot + slots, bytemuck::Zeroable::zeroed());
            let first_byte = out.cells.len();
            out.cells.resize(first_byte + cells as usize * record, 0);
            let output = BlockOutput {
                block,
                slots: &mut out.metacells[first_slot..],
                cells: &mut out.cells[first_byte..],
                first_cell: (first_byte / record) as u32,
                slab_block: block,
            };
            match &self.shared.kernel {
                None => emit::emit_classified_block(
                    &scratch.binary,
                    cube,
                    quantizer,
                    output,
                    &mut scratch.block,
                ),
                Some(_) => emit::emit_classified_block(
                    &scratch.smooth.smooth,
                    cube,
                    quantizer,
                    output,
                    &mut scratch.block,
                ),
            }
            let (mut lo, mut hi) = ([u32::MAX; 3], [0u32; 3]);
            let label_slots = out.metacells[first_slot..].iter().enumerate();
            for (_, m) in
                label_slots.filter(|(s, m)| s % CLUSTER_SLOTS != BOUND_SLOT && !m.is_empty())
            {
                let (l, h) = m.cell_box();
                for a in 0..3 {
                    lo[a] = lo[a].min(l[a]);
                    hi[a] = hi[a].max(h[a]);
                }
            }
            out.parts.push(LabelPart {
                key,
                clusters: (slots / CLUSTER_SLOTS) as u32,
                cells,
                occupied,
                lo,
                hi,
                range,
            });
        }
        out
    }
}

/// The distinct values of `keys`, ascending. Samples of a block repeat their neighbours', so the
/// list of values seen is searched only when the value changes, and sorted once at the end.
fn distinct(keys: &[u64]) -> Vec<u64> {
    let mut seen: Vec<u64> = Vec::new();
    let mut last = None;
    for &k in keys {
        if last == Some(k) {
            continue;
        }
        last = Some(k);
        if !seen.contains(&k) {
            seen.push(k);
            if seen.len() > 64 {
                // Many labels in one block (supervoxels): sort the block instead.
                let mut all = keys.to_vec();
                all.sort_unstable();
                all.dedup();
                return all;
            }
        }
    }
    seen.sort_unstable();
    seen
}

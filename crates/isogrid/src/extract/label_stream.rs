//! Label extraction in bounded memory and in pieces (paper §3.1): the label pass of
//! [`super::labels`] run on slabs of sample planes, one after another within `--max-memory`
//! ([`extract_labels_to_file`]) or as independent tasks anywhere ([`label_fragment`], which the
//! Python package runs on Dask), and one [`LabelWriter`] that puts the file together.
//!
//! A block of the label pass reads its own 17³ samples plus, with smoothing, the kernel's radius
//! `r = ⌈3σ⌉` more on each side ([`super::labels::label_halo`]). A slab of block layers
//! `bz0..bz1` therefore needs the planes `16·bz0 − r ..= 16·bz1 + r` (clipped to the volume): its
//! own plus a halo of `r` planes below and `r + 1` above (one above without smoothing, as for an
//! isosurface). Given those planes its blocks come out exactly as the whole-volume pass makes
//! them. What the whole volume decides is settled afterwards, by the one `LabelTally` the
//! in-memory extraction uses, fed the blocks in block order: every block's record and first cell,
//! the label table (every selected label present anywhere), the cluster labels and the index.
//!
//! Unlike the scalar stream ([`super::stream`]), which scans first and then emits into a
//! pre-sized file, the label pass is one pass over the samples: the pass *is* the work (gathering
//! the labels in reach, one indicator and emit per label), and a scan that did not emit would
//! repeat it. So each run of blocks' metacells and corner records, numbered from each block's
//! first cell, waits in a scratch file beside the output (the tiled extraction's
//! `tiles::Spool`, unlinked at once) until the sections' sizes are known; then the file is
//! written through the one `CgcWriter`, each run read back with its cell pointers moved, then
//! the three label sections. The file is byte-identical to `cgc::write(extract_labels(volume))`
//! for any budget, thread count and tiling.
//!
//! Memory: one slab of `16·k + 1 + 2r` planes (k block layers, as [`super::stream::plan`] sizes
//! it), per-thread scratch for one block's gathered region (`(17 + 2r)³` samples as keys, and the
//! smoothing passes), one run of blocks' output (cut to the plan's output buffer), 20 B per block,
//! and, growing with the surface, 12 B per (block, label) pair with cells, 4 B per cluster and the
//! labels' extents: the label index's own order of size. Temporary disk: the output's metacells and corner records.
//! A [`label_fragment`] task holds its samples (whole planes, or for a run of block rows within one
//! layer only their rows, [`fragment_box`]) and its output up to the cap it is given.

use super::file_layout::FileLayout;
use super::labels::{BlockLabels, LabelOptions, LabelPart, LabelPass, LabelTally, LABEL_ISO};
use super::stream::{plan_slabs, MemoryPlan, RegionSource, Run, SlabCosts, SlabScalar};
use super::tiles::{Reader, Spool};
use crate::cgc::{scalar_code, CgcWriter, SectionKind};
use crate::error::{Error, Result};
use crate::grid::GridInfo;
use crate::labels::{check_label_samples, signed_labels, Label, LabelEntry, LabelSample};
use crate::layout::{Block, Metacell, BLOCK_CELLS, CLUSTER_SLOTS};
use crate::progress::Progress;
use crate::stats::GridStats;
use crate::volume::{Geometry, ScalarType, VolumeView};
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// What a streamed or pieced label extraction wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelSummary {
    pub info: GridInfo,
    pub stats: GridStats,
    /// The labels (names and colours as written) and their index entries, in table order.
    pub table: Vec<Label>,
    pub index: Vec<LabelEntry>,
}

/// Renames and recolours a label table before it is written (the values must stay).
pub type NameLabels<'a> = &'a mut dyn FnMut(&mut [Label]);

/// (block, label) pairs with cells a plan reserves room for, per block on average: supervoxels of
/// 50,000 labels in 512³ have 12.6 (413,770 in 32,768 blocks). Past that, each further pair takes
/// `PART_RECORD_BYTES` beyond the plan.
const LABEL_PARTS_PER_BLOCK: u64 = 16;
/// Bytes the run keeps per (block, label) pair with cells: its label and clusters in the tally
/// (12 B) and, while the file is written, its run in the index (12 B, then 8 B).
const PART_RECORD_BYTES: u64 = 24;

/// Plans slabs of the label pass of `options` over `source` within `max_memory` bytes: the slab
/// reads the smoothing halo besides its own planes, and each thread gathers one block's region.
pub fn plan_labels(
    source: &dyn RegionSource,
    options: &LabelOptions,
    max_memory: u64,
) -> Result<MemoryPlan> {
    let halo = LabelPass::new(options)?.halo();
    let region = (17 + 2 * halo) as u64;
    plan_slabs(
        source,
        max_memory,
        SlabCosts {
            halo,
            // Keys (8 B), the indicator and the smoothing passes (4 B each), and a sorted copy
            // of the keys for blocks of many labels, per sample of the region; and the stack.
            per_thread: region.pow(3) * 24 + (64 << 10),
            per_block: 24,
            per_volume_block: LABEL_PARTS_PER_BLOCK * PART_RECORD_BYTES,
        },
    )
}

/// Extracts the labels `options` selects from `source` into the `.cgc` file `path` within
/// `max_memory` bytes, atomically (on error, a cancel included, nothing is left under `path`, and
/// the scratch file is gone). `name` sets the labels' names and colours before the table is
/// written. The file is byte-identical to `cgc::write` of [`super::labels::extract_labels`] on the
/// same samples, named the same way.
///
/// `progress` counts two steps per block: one as the pass makes it, one as the file receives it.
/// A cancel is honoured between reads of at most [`super::stream::READ_PIECE_BYTES`], between
/// blocks and between runs written, with an error of kind [`crate::ErrorKind::Cancelled`].
pub fn extract_labels_to_file(
    source: &mut dyn RegionSource,
    options: &LabelOptions,
    max_memory: u64,
    path: &Path,
    progress: &Progress,
    name: NameLabels,
) -> Result<LabelSummary> {
    let plan = plan_labels(source, options, max_memory)?;
    extract_labels_planned(source, options, &plan, path, progress, name)
}

/// [`extract_labels_to_file`] with the slab and output-buffer sizes given (as [`plan_labels`]
/// makes them, or smaller: tests use one-layer slabs and small runs to reach every boundary).
pub fn extract_labels_planned(
    source: &mut dyn RegionSource,
    options: &LabelOptions,
    plan: &MemoryPlan,
    path: &Path,
    progress: &Progress,
    name: NameLabels,
) -> Result<LabelSummary> {
    if plan.slab_layers == 0 {
        return Err(Error::invalid("a slab needs at least one block layer"));
    }
    let geometry = source.geometry();
    geometry.validate(geometry.sample_count())?;
    let scalar_type = source.scalar_type();
    let mut writer = LabelWriter::new(geometry, scalar_type, options, &spool_dir(path))?;
    let mut run = Run::new(source, plan, progress);
    match scalar_type {
        ScalarType::U8 => stream_typed::<u8>(&mut run, &mut writer),
        ScalarType::U16 => stream_typed::<u16>(&mut run, &mut writer),
        ScalarType::I16 => stream_typed::<i16>(&mut run, &mut writer),
        ScalarType::F32 => stream_typed::<f32>(&mut run, &mut writer),
        ScalarType::U32 => stream_typed::<u32>(&mut run, &mut writer),
        ScalarType::I32 => stream_typed::<i32>(&mut run, &mut writer),
        ScalarType::U64 => stream_typed::<u64>(&mut run, &mut writer),
        ScalarType::I64 => stream_typed::<i64>(&mut run, &mut writer),
        ScalarType::F64 => stream_typed::<f64>(&mut run, &mut writer),
    }?;
    writer.write(path, progress, name)
}

/// Where the scratch file goes: beside the output, on its filesystem.
fn spool_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The pass over `run`'s slabs, block runs handed to `writer` in block order.
fn stream_typed<T: SlabScalar + LabelSample>(
    run: &mut Run,
    writer: &mut LabelWriter,
) -> Result<()> {
    let dims = run.geometry.dims;
    let [nbx, nby, nbz] = super::tiles::block_dims(dims);
    let block_count = nbx * nby * nbz;
    run.progress.start(2 * block_count as u64);
    if block_count == 0 {
        return Ok(());
    }
    let output_buffer = run.plan.output_buffer;
    let mut runs = RunSizer::new(nbx * nby * run.plan.slab_layers);
    let mut buffer: Vec<T> = Vec::new();
    for (layers, planes) in run.slabs_reaching(writer.pass.halo()) {
        run.read(planes.clone(), &mut buffer, None)?;
        if !T::TYPE.is_integer() {
            check_label_samples(&buffer)?;
        }
        let end = layers.end * nbx * nby;
        let mut at = layers.start * nbx * nby;
        while at < end {
            let blocks = at..(at + runs.blocks()).min(end);
            let out = writer.pass.blocks(
                &buffer,
                dims,
                0..dims[1],
                planes.start,
                blocks.clone(),
                run.progress,
            );
            run.progress.check()?;
            let bytes = held_bytes(&out);
            writer.add_blocks(blocks.start, out)?;
            // Each run's output leaves for the scratch file before the next, so the next run has
            // the whole buffer for room.
            runs.resize(blocks.len(), bytes, output_buffer);
            at = blocks.end;
        }
    }
    Ok(())
}

/// Blocks per run of the label pass (the cut into runs does not change the file, only how much
/// output is held at once): one per thread at first, then sized from the last run's output per
/// block to fill half the room left, keeping the other half for a run denser than the last. The
/// small first run keeps a small room from being overrun before the first measure.
struct RunSizer {
    least: usize,
    most: usize,
    blocks: usize,
}

impl RunSizer {
    fn new(most: usize) -> RunSizer {
        let least = rayon::current_num_threads().min(most).max(1);
        RunSizer {
            least,
            most: most.max(least),
            blocks: least,
        }
    }

    fn blocks(&self) -> usize {
        self.blocks
    }

    /// The next run's size, after a run of `blocks` blocks whose output held `bytes`, with
    /// `room` bytes for the next one's.
    fn resize(&mut self, blocks: usize, bytes: u64, room: u64) {
        self.blocks = match bytes {
            0 => self.blocks.saturating_mul(2),
            _ => (room as u128 / 2 * blocks as u128 / bytes as u128)
                .try_into()
                .unwrap_or(usize::MAX),
        }
        .clamp(self.least, self.most);
    }
}

/// What the blocks' output holds, not what it fills: their buffers grow by doubling, and a
/// budget pays for their capacity.
fn held_bytes(blocks: &[BlockLabels]) -> u64 {
    blocks
        .iter()
        .map(|b| (b.metacells.capacity() * size_of::<Metacell>() + b.cells.capacity()) as u64)
        .sum()
}

/// One Dask task of a label extraction: the label pass over the run of consecutive blocks
/// `blocks` (numbered x fastest, then y, then z) of a volume of `volume_dims` samples, from `slab`,
/// which holds exactly the samples those blocks read ([`fragment_box`]), whole in x.
///
/// The task stops early once its output holds `output_cap` bytes: the fragment then covers a
/// first part of `blocks` (at least one run of one block per thread), and the caller gives the
/// rest to another task. So a task holds its slab, its output up to about `output_cap`, and one
/// block's scratch per thread, however dense the surface. `progress` gets one step per block (it
/// is not started: the caller's driver sets the total). Fragments go to
/// [`LabelWriter::add_fragment`].
pub fn label_fragment(
    slab: &VolumeView,
    volume_dims: [usize; 3],
    blocks: Range<usize>,
    options: &LabelOptions,
    output_cap: u64,
    progress: &Progress,
) -> Result<LabelFragment> {
    let pass = LabelPass::new(options)?;
    let [nbx, nby, nbz] = super::tiles::block_dims(volume_dims);
    if blocks.is_empty() || blocks.end > nbx * nby * nbz {
        return Err(Error::invalid(format!(
            "blocks {}..{} are not within the volume's {}",
            blocks.start,
            blocks.end,
            nbx * nby * nbz
        )));
    }
    let [rows, planes] = fragment_box(volume_dims, blocks.clone(), options)?;
    let [sx, sy, sz] = slab.dims();
    if [sx, sy, sz] != [volume_dims[0], rows.len(), planes.len()] {
        return Err(Error::invalid(format!(
            "a slab of {sx}x{sy}x{sz} samples is not the rows {}..{} of the planes {}..{} that \
             blocks {}..{} of a {}x{}x{} volume read",
            rows.start,
            rows.end,
            planes.start,
            planes.end,
            blocks.start,
            blocks.end,
            volume_dims[0],
            volume_dims[1],
            volume_dims[2]
        )));
    }
    crate::volume::with_samples!(slab.samples(), s => {
        check_label_samples(s)?;
        let mut runs = RunSizer::new(blocks.len());
        let mut out: Vec<BlockLabels> = Vec::new();
        let mut held = 0u64;
        let mut at = blocks.start;
        while at < blocks.end {
            let run = at..(at + runs.blocks()).min(blocks.end);
            let mut made =
                pass.blocks(s, volume_dims, rows.clone(), planes.start, run.clone(), progress);
            progress.check()?;
            // Held until the fragment is encoded, so kept at their length.
            for b in &mut made {
                b.present.retain(|&k| pass.selection().selects(k));
                b.metacells.shrink_to_fit();
                b.cells.shrink_to_fit();
            }
            let bytes = held_bytes(&made);
            held += bytes;
            out.append(&mut made);
            at = run.end;
            if held >= output_cap {
                break;
            }
            runs.resize(run.len(), bytes, output_cap - held);
        }
        Ok(LabelFragment {
            scalar_type: slab.scalar_type(),
            dims: volume_dims,
            bits: pass.quantizer().precision().bits(),
            halo: pass.halo(),
            first_block: blocks.start,
            blocks: out,
        })
    })
}

/// The samples the label pass of `options` reads for the run of blocks `blocks` of a volume of
/// `dims` samples, whole in x: `[rows, planes]`, the sample indices (index space) of the rows (y)
/// and planes (z) of the block rows and layers it meets, and the smoothing halo, clipped to the
/// volume. A run within one block layer reads only its block rows' samples; a run across layers
/// reads whole planes.
pub fn fragment_box(
    dims: [usize; 3],
    blocks: Range<usize>,
    options: &LabelOptions,
) -> Result<[Range<usize>; 2]> {
    let [nbx, nby, _] = super::tiles::block_dims(dims);
    let per_layer = (nbx * nby).max(1);
    let layers = blocks.start / per_layer..blocks.end.div_ceil(per_layer);
    let halo = LabelPass::new(options)?.halo();
    let reach = |cells: Range<usize>, n: usize| {
        (BLOCK_CELLS * cells.start).saturating_sub(halo)
            ..(BLOCK_CELLS * cells.end + 1 + halo).min(n)
    };
    let rows = if layers.len() == 1 && !blocks.is_empty() {
        let row = |b: usize| b % per_layer / nbx.max(1);
        reach(row(blocks.start)..row(blocks.end - 1) + 1, dims[1])
    } else {
        0..dims[1]
    };
    Ok([rows, reach(layers, dims[2])])
}

const FRAGMENT_TAG: &[u8; 4] = b"IGLF";
/// Bytes of one part in a fragment: key, clusters, cells, occupied, lo, hi, range.
const PART_BYTES: usize = 8 + 4 * 3 + 12 * 2 + 16;
/// Bytes of a fragment's head: tag, sample type, dimensions, precision, halo, first block, count.
const FRAGMENT_HEAD_BYTES: usize = FRAGMENT_TAG.len() + 4 * 8;

/// The output of one [`label_fragment`] task, before it is encoded for the trip to the driver.
pub struct LabelFragment {
    scalar_type: ScalarType,
    dims: [usize; 3],
    bits: u32,
    halo: usize,
    first_block: usize,
    /// The blocks from `first_block` on, their labels already cut to the selection.
    blocks: Vec<BlockLabels>,
}

impl LabelFragment {
    /// The blocks it covers, from the first one asked for.
    pub fn blocks(&self) -> Range<usize> {
        self.first_block..self.first_block + self.blocks.len()
    }

    /// The length of its encoding.
    pub fn encoded_len(&self) -> usize {
        FRAGMENT_HEAD_BYTES
            + self
                .blocks
                .iter()
                .map(|b| {
                    8 + 8 * b.present.len()
                        + PART_BYTES * b.parts.len()
                        + b.metacells.len() * size_of::<Metacell>()
                        + b.cells.len()
                })
                .sum::<usize>()
    }

    /// Encodes it into `out`, exactly [`Self::encoded_len`] bytes (a buffer the caller owns, such
    /// as a Python `bytes` being made), freeing each block's output once it is copied: the task
    /// holds its output about once, not twice.
    pub fn encode_into(mut self, out: &mut [u8]) {
        assert_eq!(out.len(), self.encoded_len(), "a label fragment's buffer");
        let mut w = out;
        let mut put = |bytes: &[u8]| {
            let (head, rest) = std::mem::take(&mut w).split_at_mut(bytes.len());
            head.copy_from_slice(bytes);
            w = rest;
        };
        let head = [
            scalar_code(self.scalar_type),
            self.dims[0] as u32,
            self.dims[1] as u32,
            self.dims[2] as u32,
            self.bits,
            self.halo as u32,
            self.first_block as u32,
            self.blocks.len() as u32,
        ];
        put(FRAGMENT_TAG);
        head.iter().for_each(|v| put(&v.to_le_bytes()));
        for b in &self.blocks {
            put(&(b.present.len() as u32).to_le_bytes());
            b.present.iter().for_each(|k| put(&k.to_le_bytes()));
            put(&(b.parts.len() as u32).to_le_bytes());
            for p in &b.parts {
                put(&p.key.to_le_bytes());
                [p.clusters, p.cells, p.occupied]
                    .iter()
                    .chain(&p.lo)
                    .chain(&p.hi)
                    .for_each(|v| put(&v.to_le_bytes()));
                p.range.iter().for_each(|v| put(&v.to_le_bytes()));
            }
        }
        for b in &mut self.blocks {
            put(bytemuck::cast_slice(&std::mem::take(&mut b.metacells)));
        }
        for b in &mut self.blocks {
            put(&std::mem::take(&mut b.cells));
        }
    }

    /// Its encoding in a new buffer.
    pub fn encode(self) -> Vec<u8> {
        let mut out = vec![0; self.encoded_len()];
        self.encode_into(&mut out);
        out
    }
}

/// A run of consecutive blocks handed to the writer, its output in the scratch file.
struct BlockRun {
    first_block: usize,
    block_count: usize,
    /// Where its output is in the scratch file: its blocks' slots, then their corner records.
    spool_at: u64,
    slot_count: u64,
    cell_bytes: u64,
}

/// Puts a label grid's file together from runs of consecutive blocks in any order (each block
/// exactly once): their output waits in a scratch file, and runs are tallied as soon as the
/// blocks in front of them are (a run that arrives early keeps its labels' counts in memory
/// until then).
pub struct LabelWriter {
    geometry: Geometry,
    scalar_type: ScalarType,
    pass: LabelPass,
    block_count: usize,
    tally: LabelTally,
    /// Each tallied block's first cell.
    first_cells: Vec<u32>,
    /// Runs not yet tallied, by first block: their blocks without output, and the run.
    waiting: BTreeMap<usize, (Vec<BlockLabels>, BlockRun)>,
    runs: Vec<BlockRun>,
    spool_dir: PathBuf,
    spool: Option<Spool>,
}

impl LabelWriter {
    /// A writer of a label grid of a volume of `geometry` and `scalar_type`, extracted with
    /// `options`; its scratch file goes in the folder `spool_dir` (best beside the output).
    pub fn new(
        geometry: Geometry,
        scalar_type: ScalarType,
        options: &LabelOptions,
        spool_dir: &Path,
    ) -> Result<Self> {
        geometry.validate(geometry.sample_count())?;
        if !scalar_type.is_integer() && !matches!(scalar_type, ScalarType::F32 | ScalarType::F64) {
            return Err(Error::invalid("not a label sample type"));
        }
        let block_count = super::tiles::block_dims(geometry.dims).iter().product();
        Ok(LabelWriter {
            geometry,
            scalar_type,
            pass: LabelPass::new(options)?,
            block_count,
            tally: LabelTally::new(&options.selection, block_count),
            first_cells: Vec::with_capacity(block_count),
            waiting: BTreeMap::new(),
            runs: Vec::new(),
            spool_dir: spool_dir.to_path_buf(),
            spool: None,
        })
    }

    /// Blocks of the volume (in block order, x fastest), for a driver that cuts tasks.
    pub fn block_count(&self) -> usize {
        self.block_count
    }

    /// Adds a [`label_fragment`] (fragments in any order; together they must cover every block
    /// exactly once). Checked against this volume and options, and for consistency, before any
    /// of it is kept.
    pub fn add_fragment(&mut self, fragment: &[u8]) -> Result<()> {
        let what = "label fragment";
        let mut r = Reader::new(fragment, FRAGMENT_TAG, what)?;
        let (scalar, dims) = (r.u32()?, [r.u32()?, r.u32()?, r.u32()?]);
        let (bits, halo) = (r.u32()?, r.u32()?);
        if scalar != scalar_code(self.scalar_type)
            || dims != self.geometry.dims.map(|d| d as u32)
            || bits != self.pass.quantizer().precision().bits()
            || halo as usize != self.pass.halo()
        {
            return Err(Error::invalid(format!(
                "{what} of another volume or other options (sample type, dimensions, precision \
                 or smoothing differ)"
            )));
        }
        let (first, count) = (r.u32()? as usize, r.u32()? as usize);
        if count == 0
            || first
                .checked_add(count)
                .is_none_or(|e| e > self.block_count)
        {
            return Err(Error::corrupt(format!(
                "{what} of blocks outside the volume"
            )));
        }
        let record = self.pass.quantizer().precision().bytes_per_cell();
        let bad = |why: &str| Error::corrupt(format!("{what}: {why}"));
        let mut blocks = Vec::with_capacity(count);
        let (mut slot_total, mut cell_total) = (0usize, 0usize);
        for _ in 0..count {
            let n = r.u32()? as usize;
            let keys = r.bytes(n.checked_mul(8).ok_or_else(|| bad("too many keys"))?)?;
            let present: Vec<u64> = keys
                .chunks_exact(8)
                .map(|k| u64::from_le_bytes(k.try_into().unwrap()))
                .collect();
            if present.windows(2).any(|w| w[0] >= w[1]) {
                return Err(bad("labels not in increasing order"));
            }
            let n = r.u32()? as usize;
            let bytes = r.bytes(
                n.checked_mul(PART_BYTES)
                    .ok_or_else(|| bad("too many parts"))?,
            )?;
            let mut parts = Vec::with_capacity(n);
            for p in bytes.chunks_exact(PART_BYTES) {
                let u32_at =
                    |i: usize| u32::from_le_bytes(p[8 + 4 * i..12 + 4 * i].try_into().unwrap());
                let f64_at =
                    |i: usize| f64::from_le_bytes(p[44 + 8 * i..52 + 8 * i].try_into().unwrap());
                let part = LabelPart {
                    key: u64::from_le_bytes(p[..8].try_into().unwrap()),
                    clusters: u32_at(0),
                    cells: u32_at(1),
                    occupied: u32_at(2),
                    lo: [u32_at(3), u32_at(4), u32_at(5)],
                    hi: [u32_at(6), u32_at(7), u32_at(8)],
                    range: [f64_at(0), f64_at(1)],
                };
                if present.binary_search(&part.key).is_err()
                    || part.clusters > 512
                    || part.cells > 4096
                {
                    return Err(bad(
                        "a part of a label not in its block, or impossible counts",
                    ));
                }
                slot_total += part.clusters as usize * CLUSTER_SLOTS;
                cell_total += part.cells as usize * record;
                parts.push(part);
            }
            // The output follows every block's labels and parts, sized by the parts.
            blocks.push(BlockLabels {
                present,
                parts,
                metacells: Vec::new(),
                cells: Vec::new(),
            });
        }
        let output = r.rest(slot_total * size_of::<Metacell>() + cell_total)?;
        self.add_output(first, blocks, output, slot_total as u64, cell_total as u64)
    }

    /// Adds the blocks from `first_block` on, as the label pass made them. Their metacells, then
    /// their corner records, go to the scratch file block by block: gathered into one buffer
    /// first, the run's output would be held twice.
    fn add_blocks(&mut self, first_block: usize, mut blocks: Vec<BlockLabels>) -> Result<()> {
        self.check_new_blocks(first_block, blocks.len())?;
        let slots: usize = blocks.iter().map(|b| b.metacells.len()).sum();
        let cell_bytes: usize = blocks.iter().map(|b| b.cells.len()).sum();
        let pieces = blocks
            .iter()
            .map(|b| bytemuck::cast_slice::<Metacell, u8>(&b.metacells))
            .chain(blocks.iter().map(|b| b.cells.as_slice()));
        let spool_at = self.spool_pieces(pieces)?;
        for b in &mut blocks {
            b.metacells = Vec::new();
            b.cells = Vec::new();
        }
        self.add_spooled(
            first_block,
            blocks,
            spool_at,
            slots as u64,
            cell_bytes as u64,
        )
    }

    /// Spools a run's output (`output`, its metacells then its corner records), then tallies it.
    /// `blocks` hold the labels and parts, without output.
    fn add_output(
        &mut self,
        first_block: usize,
        blocks: Vec<BlockLabels>,
        output: &[u8],
        slot_count: u64,
        cell_bytes: u64,
    ) -> Result<()> {
        self.check_new_blocks(first_block, blocks.len())?;
        let spool_at = self.spool_pieces([output])?;
        self.add_spooled(first_block, blocks, spool_at, slot_count, cell_bytes)
    }

    /// Refuses blocks `first_block..+count` where some were already given.
    fn check_new_blocks(&self, first_block: usize, count: usize) -> Result<()> {
        let end = first_block + count;
        let overlaps = first_block < self.tally.block_count()
            || self
                .waiting
                .range(..end)
                .next_back()
                .is_some_and(|(&s, (b, _))| s + b.len() > first_block);
        if overlaps {
            return Err(Error::invalid(format!(
                "blocks {first_block}..{end} were already given"
            )));
        }
        Ok(())
    }

    /// Appends `pieces` to the scratch file, one after another; where they start.
    fn spool_pieces<'a>(&mut self, pieces: impl IntoIterator<Item = &'a [u8]>) -> Result<u64> {
        if self.spool.is_none() {
            self.spool = Some(Spool::create(&self.spool_dir)?);
        }
        let spool = self.spool.as_mut().expect("created above");
        let mut pieces = pieces.into_iter();
        let at = spool.append(pieces.next().unwrap_or_default())?;
        for piece in pieces {
            spool.append(piece)?;
        }
        Ok(at)
    }

    /// Tallies a spooled run (and the runs it unblocks) if the blocks in front of it are tallied.
    fn add_spooled(
        &mut self,
        first_block: usize,
        blocks: Vec<BlockLabels>,
        spool_at: u64,
        slot_count: u64,
        cell_bytes: u64,
    ) -> Result<()> {
        let run = BlockRun {
            first_block,
            block_count: blocks.len(),
            spool_at,
            slot_count,
            cell_bytes,
        };
        self.waiting.insert(first_block, (blocks, run));
        while let Some(entry) = self.waiting.first_entry() {
            if *entry.key() != self.tally.block_count() {
                break;
            }
            let (blocks, run) = entry.remove();
            for b in &blocks {
                let first_cell = self.tally.add(b)?;
                self.first_cells.push(first_cell);
            }
            self.runs.push(run);
        }
        Ok(())
    }

    /// Writes the file `path` (atomically), the labels named by `name` first. Every block must
    /// have been given. `progress` gets one step per block written.
    pub fn write(self, path: &Path, progress: &Progress, name: NameLabels) -> Result<LabelSummary> {
        if self.tally.block_count() != self.block_count {
            return Err(Error::invalid(format!(
                "{} of {} blocks given",
                self.tally.block_count(),
                self.block_count
            )));
        }
        let totals = self.tally.totals();
        let (blocks, mut labels) = self.tally.finish(signed_labels(self.scalar_type))?;
        let mut table = labels.table().to_vec();
        name(&mut table);
        labels.set_table(table)?;
        let sections = labels.section_bytes();
        let mut layout = FileLayout::with_quantizer(
            &self.geometry,
            self.scalar_type,
            *self.pass.quantizer(),
            [0.0, 1.0],
            LABEL_ISO,
            self.block_count as u64,
            &totals,
        );
        layout.more = SectionKind::LABELS
            .into_iter()
            .zip(&sections)
            .map(|(kind, bytes)| (kind, bytes.len() as u64))
            .collect();
        let record = self.pass.quantizer().precision().bytes_per_cell() as u64;
        let slot_size = size_of::<Metacell>() as u64;
        crate::fs::write_atomic_file(path, |file| {
            let mut writer = CgcWriter::new(file, layout.plan())?;
            writer.put(SectionKind::Blocks, 0, bytemuck::cast_slice(&blocks))?;
            let mut output = Vec::new();
            for run in &self.runs {
                progress.check()?;
                let spool = self.spool.as_ref().expect("runs were spooled");
                output.resize((run.slot_count * slot_size + run.cell_bytes) as usize, 0);
                spool.read(run.spool_at, &mut output)?;
                let (slots, cells) = output.split_at_mut((run.slot_count * slot_size) as usize);
                move_cell_pointers(
                    slots,
                    &blocks[run.first_block..run.first_block + run.block_count],
                    &self.first_cells[run.first_block..],
                );
                let first: &Block = &blocks[run.first_block];
                let cell_at = self.first_cells[run.first_block] as u64 * record;
                writer.put(
                    SectionKind::Metacells,
                    first.metacell_pointer as u64 * slot_size,
                    slots,
                )?;
                writer.put(SectionKind::Cells, cell_at, cells)?;
                progress.advance(run.block_count as u64);
            }
            for (kind, bytes) in SectionKind::LABELS.into_iter().zip(&sections) {
                writer.put(kind, 0, bytes)?;
            }
            writer.finish(&layout.info, &layout.counts)
        })?;
        Ok(LabelSummary {
            info: layout.info,
            stats: layout.stats,
            table: labels.table().to_vec(),
            index: labels.index().to_vec(),
        })
    }
}

/// Moves the cell pointers of consecutive blocks' slots (`slots`, their bytes one block after
/// another, each block's numbered from its first cell) to the grid's numbering, `first_cells[i]`
/// being block i's first cell.
fn move_cell_pointers(slots: &mut [u8], blocks: &[Block], first_cells: &[u32]) {
    let slot_size = size_of::<Metacell>();
    let mut rest = slots;
    for (block, &first_cell) in blocks.iter().zip(first_cells) {
        let here;
        (here, rest) =
            std::mem::take(&mut rest).split_at_mut(block.metacell_count as usize * slot_size);
        let metacells: Vec<Metacell> = here
            .chunks_exact(slot_size)
            .map(bytemuck::pod_read_unaligned)
            .collect();
        let block_labels = BlockLabels {
            metacells,
            ..Default::default()
        };
        for (slot, m) in here
            .chunks_exact_mut(slot_size)
            .zip(block_labels.moved_metacells(first_cell))
        {
            slot.copy_from_slice(bytemuck::bytes_of(&m));
        }
    }
}

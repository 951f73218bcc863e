//! Streaming extraction (paper §3.1) in bounded memory: volumes larger than RAM, read slab by slab.
//!
//! Every cell belongs to exactly one 16³ block, and a block reads only its own samples plus one
//! more on its high sides. A *slab* of whole block layers `bz0..bz1` therefore needs exactly the
//! sample planes `16·bz0 ..= 16·bz1` (the last one, the *halo*, is re-read as the first plane of
//! the next slab), and its blocks come out exactly as the whole-volume extraction makes them: there
//! is no seam to stitch and nothing to de-duplicate.
//!
//! What the whole volume still decides — the value range behind the quantiser and every block's
//! place in the output — is settled before anything is emitted, so the design is a two-pass plan
//! into a pre-sized file rather than sections spooled to temporary files and concatenated:
//!
//! 1. (`Iso::Normalized` only) a pass over the planes for the value range;
//! 2. *scan*: slab by slab, [`super::scan`] counts each block's active cells and occupied metacells
//!    and records its value range; prefix sums then fix every block's record and the exact size of
//!    each section, and the block section is written;
//! 3. *emit*: slab by slab again, the blocks with active cells are emitted by [`super::emit`] in
//!    groups whose output fits a bounded buffer, and each group's metacells and corner records are
//!    written at their final offsets; the section checksums are accumulated in file order, and the
//!    header goes last.
//!
//! Both passes use the same scan and emit code as [`super::extract`], and blocks and groups are
//! written in block order whatever the thread count, so the file is byte-identical to
//! `cgc::write(extract(volume))` for any budget and any pool size. Spooling instead would need
//! the output's size again in temporary space, and a copy, for no gain: the scan pass is the
//! cheaper of the two and reads the volume once.
//!
//! Memory: the block table (20 B per block), one slab of `16·k + 1` planes, one output group and
//! per-thread scratch. [`plan`] picks the largest `k` that fits a budget, or says the least budget
//! that works. A [`RegionSource`] reads planes into the caller's buffer; its own transient memory
//! (decoded chunks) it declares through [`RegionSource::read_overhead`].
//!
//! The distributed extraction ([`super::tiles`]) reuses the same split: tiles scan independently,
//! the prefix sums are global, emit jobs write independently into their ranges of the sections.
//! The label stream ([`super::label_stream`]) reads its slabs through the same `Run` (with the
//! smoothing halo's planes, [`Run::slabs_reaching`]) and sizes them with the same planner
//! (`plan_slabs`, its costs given).

use super::file_layout::FileLayout;
use super::scalar::ExtractScalar;
use super::{emit, scan_blocks_counted, split_outputs, ExtractOptions, Totals};
use crate::cgc::{CgcWriter, SectionKind};
use crate::error::{Error, Result};
use crate::grid::GridInfo;
use crate::layout::{Block, Metacell, Precision, BLOCK_CELLS};
use crate::progress::Progress;
use crate::quantize::Quantizer;
use crate::stats::GridStats;
use crate::volume::{Geometry, Samples, ScalarType, VolumeView};
use rayon::prelude::*;
use std::ops::Range;
use std::path::Path;

/// Resident memory of the process before any volume data: code, allocator, thread stacks. Counted
/// in every budget so that `--max-memory` bounds the process, not only the buffers.
pub const PROCESS_BASELINE: u64 = 48 << 20;

/// Output buffer bounds: one block's worst case is ~140 KB (4096 cells × 32 B plus its slots).
const OUTPUT_BUFFER_MIN: u64 = 1 << 20;
const OUTPUT_BUFFER_MAX: u64 = 64 << 20;

/// Reads of a slab go in pieces of about this many bytes, so that a cancel waits for one piece,
/// not a whole slab (which may be gigabytes).
pub const READ_PIECE_BYTES: u64 = 64 << 20;

/// Bytes of the block table kept for the whole run: the block record and its active cell count.
const BLOCK_TABLE_BYTES: u64 = 16 + 4;
/// Bytes per block of one slab's scan results (freed after each slab).
const BLOCK_SCAN_BYTES: u64 = 24;

/// Mutable samples of one of the supported types: where a [`RegionSource`] writes a slab.
#[derive(Debug)]
pub enum SlabMut<'a> {
    U8(&'a mut [u8]),
    U16(&'a mut [u16]),
    I16(&'a mut [i16]),
    F32(&'a mut [f32]),
    U32(&'a mut [u32]),
    I32(&'a mut [i32]),
    U64(&'a mut [u64]),
    I64(&'a mut [i64]),
    F64(&'a mut [f64]),
}

impl SlabMut<'_> {
    pub fn len(&self) -> usize {
        match self {
            SlabMut::U8(s) => s.len(),
            SlabMut::U16(s) => s.len(),
            SlabMut::I16(s) => s.len(),
            SlabMut::F32(s) => s.len(),
            SlabMut::U32(s) => s.len(),
            SlabMut::I32(s) => s.len(),
            SlabMut::U64(s) => s.len(),
            SlabMut::I64(s) => s.len(),
            SlabMut::F64(s) => s.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn scalar_type(&self) -> ScalarType {
        match self {
            SlabMut::U8(_) => ScalarType::U8,
            SlabMut::U16(_) => ScalarType::U16,
            SlabMut::I16(_) => ScalarType::I16,
            SlabMut::F32(_) => ScalarType::F32,
            SlabMut::U32(_) => ScalarType::U32,
            SlabMut::I32(_) => ScalarType::I32,
            SlabMut::U64(_) => ScalarType::U64,
            SlabMut::I64(_) => ScalarType::I64,
            SlabMut::F64(_) => ScalarType::F64,
        }
    }
    /// The buffer as bytes in native byte order (for sources that copy stored bytes in).
    pub fn as_bytes_mut(&mut self) -> &mut [u8] {
        match self {
            SlabMut::U8(s) => s,
            SlabMut::U16(s) => bytemuck::cast_slice_mut(s),
            SlabMut::I16(s) => bytemuck::cast_slice_mut(s),
            SlabMut::F32(s) => bytemuck::cast_slice_mut(s),
            SlabMut::U32(s) => bytemuck::cast_slice_mut(s),
            SlabMut::I32(s) => bytemuck::cast_slice_mut(s),
            SlabMut::U64(s) => bytemuck::cast_slice_mut(s),
            SlabMut::I64(s) => bytemuck::cast_slice_mut(s),
            SlabMut::F64(s) => bytemuck::cast_slice_mut(s),
        }
    }
    /// Swaps every sample's bytes (stored byte order differs from the machine's).
    pub fn swap_bytes(&mut self) {
        match self {
            SlabMut::U8(_) => {}
            SlabMut::U16(s) => s.iter_mut().for_each(|v| *v = v.swap_bytes()),
            SlabMut::I16(s) => s.iter_mut().for_each(|v| *v = v.swap_bytes()),
            SlabMut::F32(s) => s
                .iter_mut()
                .for_each(|v| *v = f32::from_bits(v.to_bits().swap_bytes())),
            SlabMut::U32(s) => s.iter_mut().for_each(|v| *v = v.swap_bytes()),
            SlabMut::I32(s) => s.iter_mut().for_each(|v| *v = v.swap_bytes()),
            SlabMut::U64(s) => s.iter_mut().for_each(|v| *v = v.swap_bytes()),
            SlabMut::I64(s) => s.iter_mut().for_each(|v| *v = v.swap_bytes()),
            SlabMut::F64(s) => s
                .iter_mut()
                .for_each(|v| *v = f64::from_bits(v.to_bits().swap_bytes())),
        }
    }
}

/// A volume that can be read plane range by plane range without holding all of it.
pub trait RegionSource {
    /// Dimensions, spacing, origin and direction of the whole volume.
    fn geometry(&self) -> Geometry;
    /// The type samples are delivered in.
    fn scalar_type(&self) -> ScalarType;
    /// Reads the sample planes `z` (whole x-y planes, x fastest) into `out`, which holds exactly
    /// `nx·ny·z.len()` samples of [`RegionSource::scalar_type`].
    fn read_planes(&mut self, z: Range<usize>, out: SlabMut<'_>) -> Result<()>;
    /// Resident bytes a read of `planes` planes may take beyond `out` (decoded chunks, caches).
    fn read_overhead(&self, planes: usize) -> u64 {
        let _ = planes;
        0
    }
    /// Reads planes `z` as [`RegionSource::read_planes`] does, except that only the samples of
    /// the blocks `wanted` marks (each block's 17 samples along x and y, halo included) must come
    /// out right; the others may hold anything. The emit pass reads its slabs this way: it reads
    /// no sample outside an active block, and a chunked store need not decode the chunks that
    /// hold none.
    fn read_planes_within(
        &mut self,
        z: Range<usize>,
        out: SlabMut<'_>,
        wanted: &BlockMask,
    ) -> Result<()> {
        let _ = wanted;
        self.read_planes(z, out)
    }
    /// Reads are cheapest in multiples of this many planes (a Zarr chunk row's depth): a caller
    /// free to split a long read splits it there.
    fn plane_granularity(&self) -> usize {
        1
    }
}

/// The blocks of one x-y layer that a read must deliver (any of the slab's layers), by block
/// column `bx` and row `by`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockMask {
    block_dims: [usize; 2],
    wanted: Vec<bool>,
}

impl BlockMask {
    /// No block wanted, over `nbx` × `nby` blocks.
    pub fn new(block_dims: [usize; 2]) -> Self {
        BlockMask {
            block_dims,
            wanted: vec![false; block_dims[0] * block_dims[1]],
        }
    }
    pub fn want(&mut self, bx: usize, by: usize) {
        self.wanted[bx + self.block_dims[0] * by] = true;
    }
    pub fn is_wanted(&self, bx: usize, by: usize) -> bool {
        self.wanted[bx + self.block_dims[0] * by]
    }
    /// Whether a wanted block reads a sample of columns `xs` and rows `ys` (a block reads
    /// samples `16·b ..= 16·b + 16`).
    pub fn touches(&self, xs: Range<usize>, ys: Range<usize>) -> bool {
        let blocks = |r: Range<usize>, n: usize| {
            r.start.saturating_sub(1) / BLOCK_CELLS..r.end.div_ceil(BLOCK_CELLS).min(n)
        };
        let [nbx, nby] = self.block_dims;
        if xs.is_empty() || ys.is_empty() {
            return false;
        }
        blocks(ys, nby).any(|by| blocks(xs.clone(), nbx).any(|bx| self.is_wanted(bx, by)))
    }
}

/// An in-memory volume read plane range by plane range: the reference the streaming tests compare
/// against, and a way to stream arrays that are already resident.
impl RegionSource for VolumeView<'_> {
    fn geometry(&self) -> Geometry {
        *VolumeView::geometry(self)
    }
    fn scalar_type(&self) -> ScalarType {
        VolumeView::scalar_type(self)
    }
    fn read_planes(&mut self, z: Range<usize>, out: SlabMut<'_>) -> Result<()> {
        let [nx, ny, _] = self.dims();
        let span = nx * ny * z.start..nx * ny * z.end;
        match (self.samples(), out) {
            (Samples::U8(s), SlabMut::U8(o)) => o.copy_from_slice(&s[span]),
            (Samples::U16(s), SlabMut::U16(o)) => o.copy_from_slice(&s[span]),
            (Samples::I16(s), SlabMut::I16(o)) => o.copy_from_slice(&s[span]),
            (Samples::F32(s), SlabMut::F32(o)) => o.copy_from_slice(&s[span]),
            (Samples::U32(s), SlabMut::U32(o)) => o.copy_from_slice(&s[span]),
            (Samples::I32(s), SlabMut::I32(o)) => o.copy_from_slice(&s[span]),
            (Samples::U64(s), SlabMut::U64(o)) => o.copy_from_slice(&s[span]),
            (Samples::I64(s), SlabMut::I64(o)) => o.copy_from_slice(&s[span]),
            (Samples::F64(s), SlabMut::F64(o)) => o.copy_from_slice(&s[span]),
            _ => return Err(Error::invalid("slab buffer type differs from the volume's")),
        }
        Ok(())
    }
}

/// How a budget is spent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryPlan {
    /// The budget asked for, bytes.
    pub max_memory: u64,
    /// Block layers (16 cells of z) per slab.
    pub slab_layers: usize,
    /// Bytes of one slab's samples and scan results, plus the source's read overhead.
    pub slab_bytes: u64,
    /// Bytes of the output group buffer.
    pub output_buffer: u64,
    /// Bytes that do not depend on the slab: process baseline, block table, per-thread scratch.
    pub fixed: u64,
    /// The least budget that works for this volume (one block layer per slab).
    pub minimum: u64,
}

/// Plans slabs for `source` within `max_memory` bytes on the current rayon pool; errors with
/// the least budget that works when even one block layer does not fit.
pub fn plan(source: &dyn RegionSource, max_memory: u64) -> Result<MemoryPlan> {
    let nx = source.geometry().dims[0] as u64;
    let size = source.scalar_type().size() as u64;
    // Pass 1 per thread: inside and active bit rows of one block row (`scan::RowScratch`), the
    // lane ranges, and the stack the thread touches.
    let per_thread = nx.div_ceil(64) * 8 * (17 * 17 + 16 * 16) + nx * 8 * size + (64 << 10);
    plan_slabs(
        source,
        max_memory,
        SlabCosts {
            halo: 0,
            per_thread,
            per_block: BLOCK_SCAN_BYTES,
            per_volume_block: 0,
        },
    )
}

/// What a pass over slabs spends besides the slab's own planes.
#[derive(Debug, Clone, Copy)]
pub(super) struct SlabCosts {
    /// Planes read beyond a slab's own on each side (its blocks' reach past their samples).
    pub halo: usize,
    /// Scratch bytes per thread of the pool.
    pub per_thread: u64,
    /// Bytes per block of the slab held while it is processed.
    pub per_block: u64,
    /// Bytes per block of the whole volume held for the whole run, besides the block table.
    pub per_volume_block: u64,
}

/// [`plan`] for a pass of `costs`: the largest slab that fits, or the least budget that works.
pub(super) fn plan_slabs(
    source: &dyn RegionSource,
    max_memory: u64,
    costs: SlabCosts,
) -> Result<MemoryPlan> {
    let geometry = source.geometry();
    let [nx, ny, nz] = geometry.dims.map(|d| d as u64);
    let size = source.scalar_type().size() as u64;
    let [nbx, nby, nbz] = geometry.cell_dims().map(|c| c.div_ceil(BLOCK_CELLS) as u64);
    let threads = rayon::current_num_threads() as u64;
    let scratch = threads * costs.per_thread;
    let fixed =
        PROCESS_BASELINE + nbx * nby * nbz * (BLOCK_TABLE_BYTES + costs.per_volume_block) + scratch;
    let slab_cost = |layers: u64| -> u64 {
        let planes = (16 * layers + 1 + 2 * costs.halo as u64).min(nz);
        // Saturating: a source may declare an overhead no budget holds (a huge Zarr chunk).
        (nx * ny * planes * size + nbx * nby * layers * costs.per_block)
            .saturating_add(source.read_overhead(planes as usize))
    };
    let minimum = (fixed + OUTPUT_BUFFER_MIN).saturating_add(slab_cost(1));
    if max_memory < minimum {
        return Err(Error::too_large(format!(
            "a memory budget of {} is too small for one slab of {}x{}x{} samples; the least that works is {}",
            format_bytes(max_memory),
            nx,
            ny,
            (17 + 2 * costs.halo as u64).min(nz),
            format_bytes_at_least(minimum.checked_next_multiple_of(1 << 20).unwrap_or(minimum))
        )));
    }
    let spare = max_memory - fixed;
    let output_buffer = (spare / 8).clamp(OUTPUT_BUFFER_MIN, OUTPUT_BUFFER_MAX);
    let for_slabs = spare - output_buffer;
    // Largest layer count that fits (slab cost grows with layers), at most the volume's.
    let (mut lo, mut hi) = (1u64, nbz.max(1));
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if slab_cost(mid) <= for_slabs {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    Ok(MemoryPlan {
        max_memory,
        slab_layers: lo as usize,
        slab_bytes: slab_cost(lo),
        output_buffer,
        fixed,
        minimum,
    })
}

/// Bytes as `512 MiB`, `3.2 GiB` (binary units, as `--max-memory` reads them), to the nearest
/// figure shown.
pub fn format_bytes(bytes: u64) -> String {
    format_bytes_rounded(bytes, f64::round)
}

/// [`format_bytes`] rounded up, for a least amount: a budget of the figure shown is enough.
pub fn format_bytes_at_least(bytes: u64) -> String {
    format_bytes_rounded(bytes, f64::ceil)
}

fn format_bytes_rounded(bytes: u64, round: fn(f64) -> f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    let whole = unit == 0 || value >= 100.0 || value.fract() == 0.0;
    let shown = if whole {
        round(value)
    } else {
        round(value * 10.0) / 10.0
    };
    if whole {
        format!("{shown:.0} {}", UNITS[unit])
    } else {
        format!("{shown:.1} {}", UNITS[unit])
    }
}

/// What a streaming extraction wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamSummary {
    pub info: GridInfo,
    pub stats: GridStats,
    pub plan: MemoryPlan,
}

/// Extracts `source` at `options` into the `.cgc` file `path` within `max_memory` bytes, writing
/// as it goes (atomically: on error, a cancel included, no file is left under `path` and no
/// temporary file beside it). The file is byte-identical to `cgc::write` of [`super::extract`] on
/// the same samples.
///
/// `progress` counts blocks: one step per block in each pass over the samples (two, or three
/// with the value-range pass of a normalised isovalue), so `done` only grows and reaches `total`
/// with the file. A [`Progress::cancel`] is honoured between reads of at most
/// [`READ_PIECE_BYTES`], between block rows of the scan and between blocks of the emit, with an
/// error of kind [`crate::ErrorKind::Cancelled`].
pub fn extract_to_file(
    source: &mut dyn RegionSource,
    options: &ExtractOptions,
    max_memory: u64,
    path: &Path,
    progress: &Progress,
) -> Result<StreamSummary> {
    let plan = plan(source, max_memory)?;
    extract_planned(source, options, &plan, path, progress)
}

/// [`extract_to_file`] with slab and output-buffer sizes given (as [`plan`] makes them, or
/// smaller: tests use one-layer slabs and one-block groups to reach every boundary).
pub fn extract_planned(
    source: &mut dyn RegionSource,
    options: &ExtractOptions,
    plan: &MemoryPlan,
    path: &Path,
    progress: &Progress,
) -> Result<StreamSummary> {
    if plan.slab_layers == 0 {
        return Err(Error::invalid("a slab needs at least one block layer"));
    }
    let geometry = source.geometry();
    geometry.validate(geometry.sample_count())?;
    let mut run = Run {
        source,
        geometry,
        plan: *plan,
        progress,
        held: None,
    };
    match run.source.scalar_type() {
        ScalarType::U8 => run.extract::<u8>(options, path),
        ScalarType::U16 => run.extract::<u16>(options, path),
        ScalarType::I16 => run.extract::<i16>(options, path),
        ScalarType::F32 => run.extract::<f32>(options, path),
        ScalarType::U32 => run.extract::<u32>(options, path),
        ScalarType::I32 => run.extract::<i32>(options, path),
        ScalarType::U64 => run.extract::<u64>(options, path),
        ScalarType::I64 => run.extract::<i64>(options, path),
        ScalarType::F64 => run.extract::<f64>(options, path),
    }
}

/// The NaN-free (min, max) of every sample of `source` (`None` without one), read slab by slab
/// within `max_memory` as [`extract_to_file`] plans its reads: what
/// [`crate::VolumeView::value_range`] gives of the volume read whole, for a volume that need not
/// fit in memory. Counts blocks in `progress` and stops once it is cancelled.
pub fn source_value_range(
    source: &mut dyn RegionSource,
    max_memory: u64,
    progress: &Progress,
) -> Result<Option<(f64, f64)>> {
    let mut range: Option<(f64, f64)> = None;
    each_source_slab(source, max_memory, progress, &mut |samples, _| {
        if let Some((lo, hi)) = samples.value_range() {
            range = Some(range.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
        Ok(())
    })?;
    Ok(range)
}

/// Every label value of `source` with its voxel count and box, as
/// [`crate::label_census::label_census`] gives them of the volume read whole, read slab by slab
/// as [`source_value_range`] reads them: a connectomics volume need not fit in memory to be
/// counted.
pub fn source_label_census(
    source: &mut dyn RegionSource,
    max_memory: u64,
    progress: &Progress,
) -> Result<Vec<crate::label_census::LabelCount>> {
    let [nx, ny, _] = source.geometry().dims;
    let mut census = crate::label_census::Census::default();
    each_source_slab(source, max_memory, progress, &mut |samples, z| {
        census.add(samples, [nx, ny, z.len()], z.start)
    })?;
    Ok(census.into_counts())
}

/// Reads every sample of `source` once, in slabs of whole block layers planned within
/// `max_memory` as [`extract_to_file`] plans its reads, handing each slab's samples and planes to
/// `take`; counts blocks in `progress` (starting it at the volume's block count) and stops once
/// it is cancelled.
fn each_source_slab(
    source: &mut dyn RegionSource,
    max_memory: u64,
    progress: &Progress,
    take: &mut dyn FnMut(Samples<'_>, Range<usize>) -> Result<()>,
) -> Result<()> {
    let plan = plan(source, max_memory)?;
    let geometry = source.geometry();
    geometry.validate(geometry.sample_count())?;
    let [nbx, nby, nbz] = geometry.cell_dims().map(|c| c.div_ceil(BLOCK_CELLS));
    progress.start((nbx * nby * nbz) as u64);
    let mut run = Run {
        source,
        geometry,
        plan,
        progress,
        held: None,
    };
    match run.source.scalar_type() {
        ScalarType::U8 => run.each_slab::<u8>(&mut Vec::new(), take),
        ScalarType::U16 => run.each_slab::<u16>(&mut Vec::new(), take),
        ScalarType::I16 => run.each_slab::<i16>(&mut Vec::new(), take),
        ScalarType::F32 => run.each_slab::<f32>(&mut Vec::new(), take),
        ScalarType::U32 => run.each_slab::<u32>(&mut Vec::new(), take),
        ScalarType::I32 => run.each_slab::<i32>(&mut Vec::new(), take),
        ScalarType::U64 => run.each_slab::<u64>(&mut Vec::new(), take),
        ScalarType::I64 => run.each_slab::<i64>(&mut Vec::new(), take),
        ScalarType::F64 => run.each_slab::<f64>(&mut Vec::new(), take),
    }
}

/// Sample types a slab buffer can hold.
pub(super) trait SlabScalar: ExtractScalar + Default {
    /// The buffer as a [`RegionSource`] fills it.
    fn slab(samples: &mut [Self]) -> SlabMut<'_>;
    fn samples(samples: &[Self]) -> Samples<'_>;
}

macro_rules! slab_scalar {
    ($t:ty, $variant:ident) => {
        impl SlabScalar for $t {
            fn slab(samples: &mut [Self]) -> SlabMut<'_> {
                SlabMut::$variant(samples)
            }
            fn samples(samples: &[Self]) -> Samples<'_> {
                Samples::$variant(samples)
            }
        }
    };
}
slab_scalar!(u8, U8);
slab_scalar!(u16, U16);
slab_scalar!(i16, I16);
slab_scalar!(f32, F32);
slab_scalar!(u32, U32);
slab_scalar!(i32, I32);
slab_scalar!(u64, U64);
slab_scalar!(i64, I64);
slab_scalar!(f64, F64);

pub(super) struct Run<'a> {
    pub source: &'a mut dyn RegionSource,
    pub geometry: Geometry,
    pub plan: MemoryPlan,
    pub progress: &'a Progress,
    /// The planes the slab buffer holds (the run has one buffer), so that a pass asking for
    /// the planes the previous one ended on does not read them again: a volume that fits one
    /// slab is read once, not once per pass.
    held: Option<Range<usize>>,
}

impl<'a> Run<'a> {
    pub(super) fn new(
        source: &'a mut dyn RegionSource,
        plan: &MemoryPlan,
        progress: &'a Progress,
    ) -> Self {
        Run {
            geometry: source.geometry(),
            source,
            plan: *plan,
            progress,
            held: None,
        }
    }

    /// Reads planes `z` into `buffer`: all their samples, or (`wanted`) those of the marked
    /// blocks only. Long reads go in pieces of about [`READ_PIECE_BYTES`] (cut at the source's
    /// plane granularity), with a cancel check before each.
    pub(super) fn read<T: SlabScalar>(
        &mut self,
        z: Range<usize>,
        buffer: &mut Vec<T>,
        wanted: Option<&BlockMask>,
    ) -> Result<()> {
        if self.held.as_ref() == Some(&z) {
            return Ok(());
        }
        let [nx, ny, _] = self.geometry.dims;
        let plane = nx * ny;
        self.held = None;
        // Exactly the slab: a slab longer than the last (the first slab's halo is clipped by the
        // volume's edge) would otherwise double the buffer's capacity past the plan.
        let len = plane * z.len();
        buffer.reserve_exact(len.saturating_sub(buffer.len()));
        buffer.resize(len, T::default());
        let granularity = self.source.plane_granularity().max(1);
        let piece = (READ_PIECE_BYTES as usize / (plane * size_of::<T>()).max(1))
            .max(1)
            .next_multiple_of(granularity);
        let mut at = z.start;
        while at < z.end {
            self.progress.check()?;
            // Pieces after the first start on a multiple of the granularity.
            let end = (at + piece).next_multiple_of(granularity).min(z.end);
            let out = T::slab(&mut buffer[plane * (at - z.start)..plane * (end - z.start)]);
            match wanted {
                Some(mask) => self.source.read_planes_within(at..end, out, mask)?,
                None => self.source.read_planes(at..end, out)?,
            }
            at = end;
        }
        if wanted.is_none() {
            self.held = Some(z);
        }
        Ok(())
    }

    /// Slabs as block layer ranges, and the sample planes each reads (its layers plus the halo).
    fn slabs(&self) -> Vec<(Range<usize>, Range<usize>)> {
        self.slabs_reaching(0)
    }

    /// [`Self::slabs`] for blocks that read `reach` samples past their own on each side: each
    /// slab's planes reach that much further down and up (clipped to the volume).
    pub(super) fn slabs_reaching(&self, reach: usize) -> Vec<(Range<usize>, Range<usize>)> {
        let nz = self.geometry.dims[2];
        let nbz = (nz - 1).div_ceil(BLOCK_CELLS);
        let k = self.plan.slab_layers;
        (0..nbz)
            .step_by(k)
            .map(|bz0| {
                let bz1 = (bz0 + k).min(nbz);
                let first = (BLOCK_CELLS * bz0).saturating_sub(reach);
                (bz0..bz1, first..(BLOCK_CELLS * bz1 + 1 + reach).min(nz))
            })
            .collect()
    }

    /// NaN-free (min, max) over all samples, `None` without one: the in-memory `value_range`.
    /// Counts a block in `progress` once the planes it reads are all read.
    fn value_range<T: SlabScalar>(&mut self, buffer: &mut Vec<T>) -> Result<Option<(f64, f64)>> {
        let mut range: Option<(f64, f64)> = None;
        self.each_slab(buffer, |samples, _| {
            if let Some((lo, hi)) = samples.value_range() {
                range = Some(range.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
            Ok(())
        })?;
        Ok(range)
    }

    /// Reads the volume in slabs of whole block layers that do not overlap (every sample once)
    /// and hands each to `take` with its planes, counting its blocks in the progress.
    fn each_slab<T: SlabScalar>(
        &mut self,
        buffer: &mut Vec<T>,
        mut take: impl FnMut(Samples<'_>, Range<usize>) -> Result<()>,
    ) -> Result<()> {
        let nz = self.geometry.dims[2];
        let [nbx, nby, nbz] = self.geometry.cell_dims().map(|c| c.div_ceil(BLOCK_CELLS));
        let step = BLOCK_CELLS * self.plan.slab_layers + 1;
        let mut layers_done = 0;
        for z0 in (0..nz).step_by(step) {
            let z = z0..(z0 + step).min(nz);
            self.read(z.clone(), buffer, None)?;
            take(T::samples(buffer), z.clone())?;
            // Layer b reads planes 16·b ..= 16·b + 16.
            let layers = if z.end == nz {
                nbz
            } else {
                (z.end - 1) / BLOCK_CELLS
            };
            self.progress
                .advance(((layers - layers_done) * nbx * nby) as u64);
            layers_done = layers;
        }
        Ok(())
    }

    fn extract<T: SlabScalar>(
        &mut self,
        options: &ExtractOptions,
        path: &Path,
    ) -> Result<StreamSummary> {
        let [nx, ny, _] = self.geometry.dims;
        let precision = options.precision.unwrap_or(Precision::default_for(T::TYPE));
        let mut buffer: Vec<T> = Vec::new();
        let [nbx, nby, nbz] = self.geometry.cell_dims().map(|c| c.div_ceil(BLOCK_CELLS));
        let block_count = nbx * nby * nbz;
        let passes = 2 + matches!(options.iso, super::Iso::Normalized(_)) as u64;
        self.progress.start(passes * block_count as u64);

        let (iso, value_range) = options
            .iso
            .resolve_lazily(|| self.value_range(&mut buffer))?;
        let threshold = T::threshold(iso);
        let slabs = if block_count == 0 {
            Vec::new()
        } else {
            self.slabs()
        };

        // Pass 1: counts and ranges, slab by slab, into the block table.
        let mut blocks: Vec<Block> = Vec::with_capacity(block_count);
        let mut active_cells: Vec<u32> = Vec::with_capacity(block_count);
        let mut totals = Totals::default();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (layers, planes) in &slabs {
            self.read(planes.clone(), &mut buffer, None)?;
            let scans = scan_blocks_counted(
                &buffer,
                [nx, ny, planes.len()],
                threshold,
                Some(self.progress),
            );
            self.progress.check()?;
            debug_assert_eq!(scans.len(), nbx * nby * layers.len());
            for s in &scans {
                (lo, hi) = (lo.min(s.min), hi.max(s.max));
                blocks.push(totals.add(s)?);
                active_cells.push(s.active_cells);
            }
        }

        let (lo, hi) = match value_range {
            Some(r) => r,
            None if block_count > 0 => (lo, hi),
            None => self.value_range(&mut buffer)?.unwrap_or((0.0, 0.0)),
        };
        let layout = FileLayout::new(
            &self.geometry,
            T::TYPE,
            precision,
            iso,
            (lo, hi),
            block_count as u64,
            &totals,
        );
        let record = precision.bytes_per_cell() as u64;

        // Everything pass 2 allocates, allocated before the output's temporary file exists: the
        // largest group's output (the slab buffer is already as large as it gets). An allocation
        // the allocator cannot give aborts the process, which no guard survives; here it is an
        // error of kind TooLarge, and no file has been made.
        let mut groups = GroupBuffers::default();
        let group_bytes = groups.reserve(
            &slabs,
            &blocks,
            &active_cells,
            [nbx, nby],
            record,
            self.plan.output_buffer,
        )?;

        crate::fs::write_atomic_file(path, |file| {
            let mut writer = CgcWriter::new(file, layout.plan())?;
            writer.put(SectionKind::Blocks, 0, bytemuck::cast_slice(&blocks))?;

            // Pass 2: emit slab by slab, in block order, into the pre-sized sections.
            let (mut slot_at, mut cell_at) = (0u64, 0u64);
            let mut next_cell = 0u32;
            for (layers, planes) in &slabs {
                self.progress.check()?;
                let first = layers.start * nbx * nby;
                let end = layers.end * nbx * nby;
                // Blocks without cells count once the slab is done.
                let idle = blocks[first..end]
                    .iter()
                    .filter(|b| b.metacell_count == 0)
                    .count() as u64;
                if idle == (end - first) as u64 {
                    self.progress.advance(idle);
                    continue;
                }
                // Only active blocks are emitted, and each reads its own samples alone.
                let mut wanted = BlockMask::new([nbx, nby]);
                for (i, block) in blocks[first..end].iter().enumerate() {
                    if block.metacell_count > 0 {
                        wanted.want(i % nbx, i / nbx % nby);
                    }
                }
                self.read(planes.clone(), &mut buffer, Some(&wanted))?;
                let slab = SlabView {
                    samples: &buffer,
                    dims: [nx, ny, planes.len()],
                    first_layer: layers.start,
                    block_dims: [nbx, nby],
                    table_start: 0,
                };
                let mut index = first;
                while index < end {
                    let group = next_group(&blocks, &active_cells, index..end, record, group_bytes);
                    groups.emit(
                        &slab,
                        &blocks,
                        &active_cells,
                        group.clone(),
                        &mut next_cell,
                        threshold,
                        &layout.quantizer,
                        record as usize,
                        self.progress,
                    );
                    self.progress.check()?;
                    let slots: &[u8] = bytemuck::cast_slice(&groups.slots);
                    writer.put(SectionKind::Metacells, slot_at, slots)?;
                    writer.put(SectionKind::Cells, cell_at, &groups.cells)?;
                    slot_at += slots.len() as u64;
                    cell_at += groups.cells.len() as u64;
                    index = group.end;
                }
                self.progress.advance(idle);
            }
            writer.finish(&layout.info, &layout.counts)
        })?;

        Ok(StreamSummary {
            info: layout.info,
            stats: layout.stats,
            plan: self.plan,
        })
    }
}

/// One slab's samples and where it sits among the blocks.
pub(super) struct SlabView<'a, T> {
    pub samples: &'a [T],
    /// Samples per axis of the slab (its planes, halo included).
    pub dims: [usize; 3],
    pub first_layer: usize,
    pub block_dims: [usize; 2],
    /// The grid's block number of the first entry of the block table passed along with the slab
    /// (0 for the whole table; a tile holds only its own layers).
    pub table_start: usize,
}

/// The next run of blocks in `range`, starting at its first block, whose output fits `capacity`
/// bytes (at least one block, whatever its size).
fn next_group(
    blocks: &[Block],
    active_cells: &[u32],
    range: Range<usize>,
    record: u64,
    capacity: u64,
) -> Range<usize> {
    let mut bytes = 0u64;
    let mut end = range.start;
    while end < range.end {
        let out = blocks[end].metacell_count as u64 * std::mem::size_of::<Metacell>() as u64
            + active_cells[end] as u64 * record;
        if end > range.start && bytes + out > capacity {
            break;
        }
        bytes += out;
        end += 1;
    }
    range.start..end
}

/// Metacell slots and active cells of the blocks `group`.
fn group_size(blocks: &[Block], active_cells: &[u32], group: Range<usize>) -> (usize, usize) {
    let slots = blocks[group.clone()]
        .iter()
        .map(|b| b.metacell_count as usize)
        .sum();
    let cells = active_cells[group].iter().map(|&c| c as usize).sum();
    (slots, cells)
}

/// The output of one group of blocks, reused from group to group.
#[derive(Default)]
pub(super) struct GroupBuffers {
    pub slots: Vec<Metacell>,
    pub cells: Vec<u8>,
}

impl GroupBuffers {
    /// Allocates room for the largest group the emit pass over `slabs` makes (as
    /// [`next_group`] cuts them within `capacity` bytes), so that emitting allocates nothing, and
    /// returns the capacity to cut groups with: `capacity`, or less (down to
    /// `OUTPUT_BUFFER_MIN`) where [`crate::memory::available`] says less may be allocated now.
    /// Fails with kind TooLarge, instead of aborting, where not even that can be had.
    pub(super) fn reserve(
        &mut self,
        slabs: &[(Range<usize>, Range<usize>)],
        blocks: &[Block],
        active_cells: &[u32],
        block_dims: [usize; 2],
        record: u64,
        capacity: u64,
    ) -> Result<u64> {
        // The largest group's slots and corner bytes when groups are cut within `capacity`.
        let largest = |capacity: u64| {
            let (mut most_slots, mut most_cells) = (0usize, 0usize);
            let layer = block_dims[0] * block_dims[1];
            for (layers, _) in slabs {
                let end = layers.end * layer;
                let mut index = layers.start * layer;
                while index < end {
                    let group = next_group(blocks, active_cells, index..end, record, capacity);
                    let (slots, cells) = group_size(blocks, active_cells, group.clone());
                    most_slots = most_slots.max(slots);
                    most_cells = most_cells.max(cells * record as usize);
                    index = group.end;
                }
            }
            (most_slots, most_cells)
        };
        let bytes = |(slots, cells): (usize, usize)| (slots * size_of::<Metacell>() + cells) as u64;
        let mut capacity = capacity;
        let mut most = largest(capacity);
        while capacity > OUTPUT_BUFFER_MIN && crate::memory::ensure_fits("", bytes(most)).is_err() {
            capacity = (capacity / 2).max(OUTPUT_BUFFER_MIN);
            most = largest(capacity);
        }
        let need = bytes(most);
        crate::memory::ensure_fits("the streamed extraction's output buffer", need)?;
        let failed = |_| {
            Error::too_large(format!(
                "the streamed extraction's output buffer needs {}, which cannot be allocated",
                crate::memory::show_bytes(need)
            ))
        };
        self.slots.try_reserve_exact(most.0).map_err(failed)?;
        self.cells.try_reserve_exact(most.1).map_err(failed)?;
        Ok(capacity)
    }

    /// Emits the blocks of `group` into the buffers, counting each in `progress`; once it is
    /// cancelled the remaining blocks are skipped (the caller checks it before using the output).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn emit<T: SlabScalar>(
        &mut self,
        slab: &SlabView<'_, T>,
        blocks: &[Block],
        active_cells: &[u32],
        group: Range<usize>,
        next_cell: &mut u32,
        threshold: Option<T>,
        quantizer: &Quantizer,
        record: usize,
        progress: &Progress,
    ) {
        let (slot_count, cell_count) = group_size(blocks, active_cells, group.clone());
        // Padding slots must be zero, as in the in-memory output.
        self.slots.clear();
        self.slots.resize(slot_count, bytemuck::Zeroable::zeroed());
        self.cells.clear();
        self.cells.resize(cell_count * record, 0);
        let outputs = split_outputs(
            blocks,
            slab.table_start,
            |index| active_cells[index],
            group,
            slab.block_dims,
            (&mut self.slots, &mut self.cells),
            record,
            next_cell,
            slab.first_layer,
        );
        outputs
            .into_par_iter()
            .for_each_init(emit::BlockScratch::default, |scratch, out| {
                if progress.is_cancelled() {
                    return;
                }
                emit::emit_block(slab.samples, slab.dims, threshold, quantizer, out, scratch);
                progress.advance(1);
            });
    }
}

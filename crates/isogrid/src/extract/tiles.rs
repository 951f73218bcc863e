//! Extraction in independent tiles of whole blocks (paper §3.1), for runs spread over processes or
//! machines (the Python package drives it on a Dask cluster).
//!
//! Every cell belongs to exactly one 16³ block and a block reads only its own samples plus one
//! more on its high sides. So a *tile*, a box of whole blocks `bx0..bx1 × by0..by1 × bz0..bz1`,
//! needs exactly the samples `16·b0 ..= 16·b1` along each axis (its own plus a one-sample *halo*
//! on its high sides, clipped to the volume), and its blocks come out as the whole-volume
//! extraction makes them. There is no seam to stitch and nothing to de-duplicate; what the whole
//! volume decides (the value range behind the quantiser, every block's place in the file) is
//! settled between two rounds of tasks:
//!
//! 1. [`scan_tile`] on every tile, anywhere: a *scan fragment* with each block's active cells,
//!    occupied metacells and value range (16 bytes a block);
//! 2. [`TileExtraction::add_scan`], in any order, on the machine that writes the file; then
//!    [`TileExtraction::plan_emits`] takes prefix sums in block order (every block's record and
//!    place, the file's exact size) and cuts the tiles that hold active cells into *emit jobs*
//!    whose samples and output fit a budget;
//! 3. [`emit_tile`] on every job, anywhere: an *output fragment* holding the job's metacell slots
//!    and corner records. A job's blocks are not one run of the block table unless it spans the
//!    volume's width (and height, for several layers): each of its block rows (fixed y and z) is
//!    one run of the table, and of each output section;
//! 4. [`TileExtraction::write`] places each row's output at its offsets as fragments arrive, in
//!    whatever order (a retried task gives the same bytes), combines the section checksums in
//!    file order and writes the header last, atomically.
//!
//! Scan and emit are [`super::scan_blocks`] and [`super::emit::emit_block`], the code of the
//! in-memory and streaming extractions, run on the tile's samples, so the file is byte-identical
//! to `cgc::write(extract(volume))` whatever the tiling and the order tasks finish in.
//!
//! Fragments are plain little-endian bytes (they cross processes and machines); each starts with a
//! four-byte tag and is checked against what the receiver expects before use.

use super::file_layout::FileLayout;
use super::scalar::ExtractScalar;
use super::stream::write_at;
use super::{emit, scan, scan_blocks, split_outputs, ExtractOptions, Totals};
use crate::cgc::{header_bytes, scalar_code};
use crate::error::{Error, Result};
use crate::grid::GridInfo;
use crate::layout::{Block, Metacell, Precision, BLOCK_CELLS};
use crate::quantize::Quantizer;
use crate::stats::GridStats;
use crate::volume::{Geometry, Samples, ScalarType, VolumeView};
use rayon::prelude::*;
use std::ops::Range;
use std::path::Path;

const SCAN_TAG: &[u8; 4] = b"IGTS";
const JOB_TAG: &[u8; 4] = b"IGTJ";
const OUTPUT_TAG: &[u8; 4] = b"IGTO";

/// Bytes per block of a scan fragment: occupied metacells, active cells, min, max.
const SCAN_RECORD: usize = 16;
/// Bytes per block of an emit job: metacell slots, active cells.
const JOB_RECORD: usize = 8;

/// A box of whole blocks: block ranges along x, y and z.
pub type BlockBox = [Range<usize>; 3];

/// Blocks per axis (x, y, z) of a volume of `dims` samples (none along an axis of one sample).
pub fn block_dims(dims: [usize; 3]) -> [usize; 3] {
    dims.map(|d| d.saturating_sub(1).div_ceil(BLOCK_CELLS))
}

/// The samples (x, y, z ranges) the blocks `blocks` read: their own and the halo sample after
/// them along each axis, clipped to the volume's `dims`.
pub fn tile_samples(blocks: &BlockBox, dims: [usize; 3]) -> [Range<usize>; 3] {
    [0, 1, 2].map(|a| BLOCK_CELLS * blocks[a].start..(BLOCK_CELLS * blocks[a].end + 1).min(dims[a]))
}

/// The tiles of `tile_blocks` blocks (x, y, z; the last along each axis may be smaller) that cover
/// a volume of `dims` samples, in block order (x fastest). None when the volume has no block.
pub fn tiles(dims: [usize; 3], tile_blocks: [usize; 3]) -> Result<Vec<BlockBox>> {
    if tile_blocks.contains(&0) {
        return Err(Error::invalid(
            "a tile must hold at least one block along each axis",
        ));
    }
    let nb = block_dims(dims);
    if nb.contains(&0) {
        return Ok(Vec::new());
    }
    let cuts = |a: usize| -> Vec<Range<usize>> {
        (0..nb[a])
            .step_by(tile_blocks[a])
            .map(|b| b..(b + tile_blocks[a]).min(nb[a]))
            .collect()
    };
    let (xs, ys, zs) = (cuts(0), cuts(1), cuts(2));
    let mut out = Vec::with_capacity(xs.len() * ys.len() * zs.len());
    for z in &zs {
        for y in &ys {
            for x in &xs {
                out.push([x.clone(), y.clone(), z.clone()]);
            }
        }
    }
    Ok(out)
}

/// Pass 1 of one tile: the scan fragment of the blocks from `first_block` (x, y, z) on of a
/// volume of `volume_dims` samples, whose [`tile_samples`] `tile` holds, at the isovalue `iso`
/// (data units, resolved for the whole volume).
pub fn scan_tile(
    tile: &VolumeView,
    volume_dims: [usize; 3],
    first_block: [usize; 3],
    iso: f64,
) -> Result<Vec<u8>> {
    let blocks = tile_blocks(tile.dims(), volume_dims, first_block)?;
    let mut out = Vec::new();
    put_header(&mut out, SCAN_TAG, tile.scalar_type(), volume_dims, &blocks);
    let scans = match tile.samples() {
        Samples::U8(s) => scan_blocks(s, tile.dims(), u8::threshold(iso)),
        Samples::U16(s) => scan_blocks(s, tile.dims(), u16::threshold(iso)),
        Samples::I16(s) => scan_blocks(s, tile.dims(), i16::threshold(iso)),
        Samples::F32(s) => scan_blocks(s, tile.dims(), f32::threshold(iso)),
    };
    out.reserve(scans.len() * SCAN_RECORD);
    for s in &scans {
        put_u32(&mut out, s.occupied_metacells);
        put_u32(&mut out, s.active_cells);
        // Exact: every supported sample type is exactly an f32.
        out.extend_from_slice(&(s.min as f32).to_le_bytes());
        out.extend_from_slice(&(s.max as f32).to_le_bytes());
    }
    Ok(out)
}

/// The blocks a tile of `tile_dims` samples starting at block `first_block` covers; errors
/// unless it is exactly the samples [`tile_samples`] names for them.
fn tile_blocks(
    tile_dims: [usize; 3],
    volume_dims: [usize; 3],
    first_block: [usize; 3],
) -> Result<BlockBox> {
    let nb = block_dims(volume_dims);
    let blocks = [0, 1, 2].map(|a| {
        first_block[a]..first_block[a] + tile_dims[a].saturating_sub(1).div_ceil(BLOCK_CELLS)
    });
    let samples = tile_samples(&blocks, volume_dims);
    let fits = (0..3).all(|a| {
        !blocks[a].is_empty() && blocks[a].end <= nb[a] && samples[a].len() == tile_dims[a]
    });
    if !fits {
        let [nx, ny, nz] = volume_dims;
        let [bx, by, bz] = first_block;
        return Err(Error::invalid(format!(
            "a tile of {}x{}x{} samples is not whole blocks from block ({bx}, {by}, {bz}) of a \
             {nx}x{ny}x{nz} volume (each tile holds 16 samples per block along each axis plus \
             the next one)",
            tile_dims[0], tile_dims[1], tile_dims[2]
        )));
    }
    Ok(blocks)
}

/// One emit job: a box of blocks, each of whose block rows is one run of metacell slots and one
/// of corner records.
#[derive(Debug, Clone, PartialEq)]
pub struct EmitJob {
    /// Blocks emitted.
    pub blocks: BlockBox,
    /// The samples (x, y, z ranges) the job reads ([`tile_samples`] of its blocks).
    pub samples: [Range<usize>; 3],
    /// Per block row that has output, in block order: the metacell slots and corner records it
    /// writes (indices into their sections).
    pub runs: Vec<(Range<u64>, Range<u64>)>,
    /// What [`emit_tile`] needs besides the samples.
    pub bytes: Vec<u8>,
}

/// What a tiled extraction wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct TileSummary {
    pub info: GridInfo,
    pub stats: GridStats,
}

/// The coordinating side of a tiled extraction: collects scan fragments, plans emit jobs and
/// writes the file from their output fragments.
#[derive(Debug)]
pub struct TileExtraction {
    geometry: Geometry,
    scalar_type: ScalarType,
    precision: Precision,
    iso: f64,
    /// The whole volume's value range when it had to be known beforehand.
    value_range: Option<(f64, f64)>,
    /// The block table. While scanning, `metacell_count` holds the block's occupied metacells
    /// (slots and pointers come with the prefix sums).
    blocks: Vec<Block>,
    /// Active cells per block while scanning; then the index of each block's first cell.
    cells: Vec<u32>,
    /// Which blocks a scan fragment covered (emptied once settled).
    scanned: Vec<bool>,
    scanned_count: usize,
    /// Totals and NaN-free range over the blocks, once settled.
    settled: Option<(Totals, (f64, f64))>,
}

impl TileExtraction {
    /// Starts an extraction of a volume of `geometry` and `scalar_type`. `value_range` is the
    /// NaN-free (min, max) of all samples (`None` when none is finite), as
    /// [`crate::Samples::value_range`] gives it; it is needed for a normalised isovalue and for
    /// a volume without blocks (one sample thick), and ignored otherwise.
    pub fn new(
        geometry: Geometry,
        scalar_type: ScalarType,
        options: &ExtractOptions,
        value_range: Option<Option<(f64, f64)>>,
    ) -> Result<Self> {
        geometry.validate(geometry.sample_count())?;
        let block_count = block_dims(geometry.dims).iter().product::<usize>();
        let needs_range = matches!(options.iso, super::Iso::Normalized(_)) || block_count == 0;
        let range = match value_range {
            Some(r) => r,
            None if needs_range => {
                return Err(Error::invalid(
                    "this extraction needs the volume's value range (a normalised isovalue, or a volume one sample thick)",
                ))
            }
            None => None,
        };
        let (iso, _) = options.iso.resolve_lazily(|| Ok(range))?;
        Ok(TileExtraction {
            geometry,
            scalar_type,
            precision: options
                .precision
                .unwrap_or(Precision::default_for(scalar_type)),
            iso,
            value_range: if needs_range { range } else { None },
            blocks: vec![bytemuck::Zeroable::zeroed(); block_count],
            cells: vec![0; block_count],
            scanned: vec![false; block_count],
            scanned_count: 0,
            settled: None,
        })
    }

    /// The isovalue in data units, for [`scan_tile`].
    pub fn iso(&self) -> f64 {
        self.iso
    }

    fn block_index(&self, [x, y, z]: [usize; 3]) -> usize {
        let [nbx, nby, _] = block_dims(self.geometry.dims);
        x + nbx * (y + nby * z)
    }

    /// Adds a tile's scan fragment (tiles in any order; together they must cover every block
    /// exactly once).
    pub fn add_scan(&mut self, fragment: &[u8]) -> Result<()> {
        if self.settled.is_some() {
            return Err(Error::invalid(
                "scan fragment after the emit jobs were planned",
            ));
        }
        let mut r = Reader::new(fragment, SCAN_TAG, "scan fragment")?;
        let blocks = self.read_header(&mut r, "scan fragment")?;
        let count = blocks.iter().map(|b| b.len()).product::<usize>();
        let mut records = r.rest(count * SCAN_RECORD)?.chunks_exact(SCAN_RECORD);
        let word =
            |record: &[u8], i: usize| <[u8; 4]>::try_from(&record[4 * i..4 * i + 4]).unwrap();
        // Checked whole before anything is stored, so a refused fragment changes nothing.
        for record in records.clone() {
            let (occupied, active) = (word(record, 0), word(record, 1));
            if u32::from_le_bytes(occupied) > 512 || u32::from_le_bytes(active) > 4096 {
                return Err(Error::corrupt("scan fragment with impossible block counts"));
            }
        }
        let rows = || {
            blocks[2]
                .clone()
                .flat_map(|z| blocks[1].clone().map(move |y| (y, z)))
        };
        for (y, z) in rows() {
            let start = self.block_index([blocks[0].start, y, z]);
            if self.scanned[start..start + blocks[0].len()].contains(&true) {
                let [x, y, z] = blocks.clone().map(|b| (b.start, b.end));
                return Err(Error::invalid(format!(
                    "scan fragment of blocks x {}..{}, y {}..{}, z {}..{} overlaps blocks \
                     already scanned",
                    x.0, x.1, y.0, y.1, z.0, z.1
                )));
            }
        }
        for (y, z) in rows() {
            let start = self.block_index([blocks[0].start, y, z]);
            for i in start..start + blocks[0].len() {
                let record = records.next().unwrap();
                self.blocks[i] = Block {
                    metacell_count: u32::from_le_bytes(word(record, 0)),
                    metacell_pointer: 0,
                    min: f32::from_le_bytes(word(record, 2)),
                    max: f32::from_le_bytes(word(record, 3)),
                };
                self.cells[i] = u32::from_le_bytes(word(record, 1));
                self.scanned[i] = true;
            }
        }
        self.scanned_count += count;
        Ok(())
    }

    /// Reads and checks the sample type, volume and blocks a scan fragment or job names.
    fn read_header(&self, r: &mut Reader, what: &str) -> Result<BlockBox> {
        let (scalar, dims) = (r.u32()?, [r.u32()?, r.u32()?, r.u32()?]);
        if scalar != scalar_code(self.scalar_type) || dims != self.geometry.dims.map(|d| d as u32) {
            return Err(Error::invalid(format!(
                "{what} of another volume (sample type or dimensions differ)"
            )));
        }
        read_box(r, block_dims(self.geometry.dims), what)
    }

    /// Prefix sums in block order, once every block is scanned: each block's slots and first cell.
    fn settle(&mut self) -> Result<(Totals, (f64, f64))> {
        if let Some(settled) = self.settled {
            return Ok(settled);
        }
        if self.scanned_count != self.blocks.len() {
            return Err(Error::invalid(format!(
                "{} of {} blocks scanned",
                self.scanned_count,
                self.blocks.len()
            )));
        }
        let scan_of = |block: &Block, active_cells: u32| scan::BlockScan {
            occupied_metacells: block.metacell_count,
            active_cells,
            min: block.min as f64,
            max: block.max as f64,
        };
        // A first pass only checks the 32-bit limits, so that an error leaves the table as it was.
        let mut totals = Totals::default();
        for (block, &active) in self.blocks.iter().zip(&self.cells) {
            totals.add(&scan_of(block, active))?;
        }
        let mut totals = Totals::default();
        let mut range = (f64::INFINITY, f64::NEG_INFINITY);
        for (block, cells) in self.blocks.iter_mut().zip(&mut self.cells) {
            let scan = scan_of(block, *cells);
            range = (range.0.min(scan.min), range.1.max(scan.max));
            *cells = totals.cells as u32;
            *block = totals.add(&scan)?;
        }
        self.scanned = Vec::new();
        self.settled = Some((totals, range));
        Ok((totals, range))
    }

    /// Active cells of block `index`, once settled.
    fn active_cells(&self, index: usize, totals: &Totals) -> u32 {
        let end = self
            .cells
            .get(index + 1)
            .copied()
            .unwrap_or(totals.cells as u32);
        end - self.cells[index]
    }

    /// Header, counts and sizes; errors until every block is scanned.
    fn layout(&self) -> Result<(FileLayout, Totals)> {
        let (totals, scanned) = self
            .settled
            .ok_or_else(|| Error::invalid("the emit jobs are not planned yet"))?;
        let block_count = self.blocks.len() as u64;
        let range = match self.value_range {
            Some(r) => r,
            None if block_count > 0 => scanned,
            None => (0.0, 0.0),
        };
        let layout = FileLayout::new(
            &self.geometry,
            self.scalar_type,
            self.precision,
            self.iso,
            range,
            block_count,
            &totals,
        );
        Ok((layout, totals))
    }

    /// Settles every block's place in the file (every block must be scanned), then cuts the tiles
    /// of `tile_blocks` blocks (x, y, z, as [`tiles`] cuts them) that hold active cells into emit
    /// jobs whose samples plus output stay within `job_bytes` where one block allows: a tile over
    /// the budget is halved (along z while it has several layers, then y, then x) until it fits.
    /// Tiles and halves without active cells get no job.
    pub fn plan_emits(&mut self, tile_blocks: [usize; 3], job_bytes: u64) -> Result<Vec<EmitJob>> {
        let tiles = tiles(self.geometry.dims, tile_blocks)?;
        self.settle()?;
        let (layout, totals) = self.layout()?;
        let mut jobs = Vec::new();
        for tile in tiles {
            self.plan_box(tile, job_bytes, &layout, &totals, &mut jobs);
        }
        Ok(jobs)
    }

    fn plan_box(
        &self,
        blocks: BlockBox,
        job_bytes: u64,
        layout: &FileLayout,
        totals: &Totals,
        jobs: &mut Vec<EmitJob>,
    ) {
        let record = self.precision.bytes_per_cell() as u64;
        let (mut slots, mut cells) = (0u64, 0u64);
        for (y, z) in box_rows(&blocks) {
            let start = self.block_index([blocks[0].start, y, z]);
            for i in start..start + blocks[0].len() {
                slots += self.blocks[i].metacell_count as u64;
                cells += self.active_cells(i, totals) as u64;
            }
        }
        if slots == 0 {
            return;
        }
        let samples = tile_samples(&blocks, self.geometry.dims);
        let cost = samples.iter().map(|s| s.len() as u64).product::<u64>()
            * self.scalar_type.size() as u64
            + slots * size_of::<Metacell>() as u64
            + cells * record;
        // Along z first, then y, then x: the halves keep whole rows (one run of the table each)
        // as long as they can, and the source's chunks are often whole rows too.
        let axis = [2, 1, 0]
            .into_iter()
            .find(|&a| blocks[a].len() > 1)
            .unwrap_or(0);
        if cost > job_bytes && blocks[axis].len() > 1 {
            let middle = blocks[axis].start + blocks[axis].len() / 2;
            let (mut low, mut high) = (blocks.clone(), blocks);
            low[axis].end = middle;
            high[axis].start = middle;
            self.plan_box(low, job_bytes, layout, totals, jobs);
            self.plan_box(high, job_bytes, layout, totals, jobs);
            return;
        }
        jobs.push(self.job(blocks, samples, layout, totals));
    }

    fn job(
        &self,
        blocks: BlockBox,
        samples: [Range<usize>; 3],
        layout: &FileLayout,
        totals: &Totals,
    ) -> EmitJob {
        let count = blocks.iter().map(|b| b.len()).product::<usize>();
        let mut bytes = Vec::with_capacity(96 + count * JOB_RECORD);
        put_header(
            &mut bytes,
            JOB_TAG,
            self.scalar_type,
            self.geometry.dims,
            &blocks,
        );
        put_u32(&mut bytes, self.precision.bits());
        let [lo, hi] = layout.info.value_range;
        for v in [self.iso, lo, hi] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let mut runs = Vec::new();
        for (y, z) in box_rows(&blocks) {
            let start = self.block_index([blocks[0].start, y, z]);
            let row = start..start + blocks[0].len();
            let first_cell = self.cells[start];
            put_u32(&mut bytes, first_cell);
            let (mut slots, mut cells) = (0u64, 0u64);
            for i in row {
                let active = self.active_cells(i, totals);
                put_u32(&mut bytes, self.blocks[i].metacell_count);
                put_u32(&mut bytes, active);
                slots += self.blocks[i].metacell_count as u64;
                cells += active as u64;
            }
            if slots > 0 {
                let slot = self.blocks[start].metacell_pointer as u64;
                let cell = first_cell as u64;
                runs.push((slot..slot + slots, cell..cell + cells));
            }
        }
        EmitJob {
            blocks,
            samples,
            runs,
            bytes,
        }
    }

    /// Writes the `.cgc` file `path` from the output fragments of `jobs` (as [`Self::plan_emits`]
    /// made them), which `next_fragment` returns in any order, then `None`. Atomic: on any error
    /// (a fragment missing, repeated with other bytes, or of another job) no file is left under
    /// `path`.
    pub fn write(
        &self,
        path: &Path,
        jobs: &[EmitJob],
        next_fragment: &mut dyn FnMut() -> Result<Option<Vec<u8>>>,
    ) -> Result<TileSummary> {
        let (layout, totals) = self.layout()?;
        let sections = layout.sections;
        let record = self.precision.bytes_per_cell() as u64;
        let slot_size = size_of::<Metacell>() as u64;
        crate::fs::write_atomic_file(path, |file| {
            let (cells_at, cells_len) = sections[2];
            file.set_len(cells_at + cells_len)?;
            let block_bytes: &[u8] = bytemuck::cast_slice(&self.blocks);
            write_at(file, sections[0].0, block_bytes)?;
            // Per job, once written: the checksum of its fragment and of each run's slots and cells.
            type Written = (u32, Vec<[crc32fast::Hasher; 2]>);
            let mut written: Vec<Option<Written>> = vec![None; jobs.len()];
            while let Some(fragment) = next_fragment()? {
                let mut r = Reader::new(&fragment, OUTPUT_TAG, "output fragment")?;
                let index = r.u32()? as usize;
                let job = jobs.get(index).ok_or_else(|| {
                    Error::invalid(format!("output fragment of job {index}, beyond the plan"))
                })?;
                let slot_bytes: u64 = job
                    .runs
                    .iter()
                    .map(|(s, _)| (s.end - s.start) * slot_size)
                    .sum();
                let cell_bytes: u64 = job
                    .runs
                    .iter()
                    .map(|(_, c)| (c.end - c.start) * record)
                    .sum();
                let payload = r.rest((slot_bytes + cell_bytes) as usize)?;
                let crc = crc32fast::hash(payload);
                if let Some((seen, _)) = &written[index] {
                    // A retried task delivered twice: only the same bytes are acceptable.
                    if *seen != crc {
                        return Err(Error::invalid(format!(
                            "job {index} delivered twice with different bytes"
                        )));
                    }
                    continue;
                }
                let (mut slots, mut cells) = payload.split_at(slot_bytes as usize);
                let mut crcs = Vec::with_capacity(job.runs.len());
                for (slot_run, cell_run) in &job.runs {
                    let here;
                    (here, slots) =
                        slots.split_at(((slot_run.end - slot_run.start) * slot_size) as usize);
                    write_at(file, sections[1].0 + slot_run.start * slot_size, here)?;
                    let mut slot_crc = crc32fast::Hasher::new();
                    slot_crc.update(here);
                    let here;
                    (here, cells) =
                        cells.split_at(((cell_run.end - cell_run.start) * record) as usize);
                    write_at(file, sections[2].0 + cell_run.start * record, here)?;
                    let mut cell_crc = crc32fast::Hasher::new();
                    cell_crc.update(here);
                    crcs.push([slot_crc, cell_crc]);
                }
                written[index] = Some((crc, crcs));
            }
            // Runs in file order must cover every slot and cell exactly once.
            let mut runs = Vec::new();
            for (index, (job, done)) in jobs.iter().zip(&written).enumerate() {
                let (_, crcs) = done.as_ref().ok_or_else(|| {
                    Error::invalid(format!("the output of job {index} never arrived"))
                })?;
                runs.extend(job.runs.iter().zip(crcs));
            }
            runs.sort_by_key(|((slots, _), _)| slots.start);
            let mut section_crcs = [crc32fast::Hasher::new(), crc32fast::Hasher::new()];
            let (mut slot_end, mut cell_end) = (0, 0);
            for ((slot_run, cell_run), crcs) in runs {
                if slot_run.start != slot_end || cell_run.start != cell_end {
                    return Err(Error::invalid(
                        "the emit jobs do not cover the output exactly once",
                    ));
                }
                (slot_end, cell_end) = (slot_run.end, cell_run.end);
                section_crcs[0].combine(&crcs[0]);
                section_crcs[1].combine(&crcs[1]);
            }
            if slot_end != totals.slots || cell_end != totals.cells {
                return Err(Error::invalid(
                    "the emit jobs do not cover the output exactly once",
                ));
            }
            let [slot_crc, cell_crc] = section_crcs.map(|h| h.finalize());
            let crcs = [crc32fast::hash(block_bytes), slot_crc, cell_crc];
            write_at(
                file,
                0,
                &header_bytes(&layout.info, &layout.counts, sections, crcs),
            )?;
            Ok(())
        })?;
        Ok(TileSummary {
            info: layout.info,
            stats: layout.stats,
        })
    }
}

/// The block rows (y, z) of a box, in block order.
fn box_rows(blocks: &BlockBox) -> impl Iterator<Item = (usize, usize)> + '_ {
    blocks[2]
        .clone()
        .flat_map(move |z| blocks[1].clone().map(move |y| (y, z)))
}

/// Pass 2 of one emit job: its output fragment, from `tile`, the samples [`EmitJob::samples`] of
/// the volume.
pub fn emit_tile(tile: &VolumeView, job: &[u8], index: u32) -> Result<Vec<u8>> {
    let mut r = Reader::new(job, JOB_TAG, "emit job")?;
    let scalar = r.u32()?;
    let volume_dims = [r.u32()?, r.u32()?, r.u32()?].map(|d| d as usize);
    let blocks = read_box(&mut r, block_dims(volume_dims), "emit job")?;
    let precision = Precision::from_bits(r.u32()?)
        .ok_or_else(|| Error::corrupt("emit job with an unknown precision"))?;
    let [iso, lo, hi] = [r.f64()?, r.f64()?, r.f64()?];
    if scalar != scalar_code(tile.scalar_type()) {
        return Err(Error::invalid(
            "the tile's sample type differs from the scanned volume's",
        ));
    }
    let first = blocks.clone().map(|b| b.start);
    if tile_blocks(tile.dims(), volume_dims, first)? != blocks {
        return Err(Error::invalid("the tile's samples differ from the job's"));
    }
    let [kx, ky, kz] = blocks.clone().map(|b| b.len());
    let records = r.rest(ky * kz * (4 + kx * JOB_RECORD))?;
    let mut first_cells = Vec::with_capacity(ky * kz);
    let mut table = Vec::with_capacity(kx * ky * kz);
    let mut active_cells = Vec::with_capacity(kx * ky * kz);
    let word =
        |bytes: &[u8], i: usize| u32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap());
    for row in records.chunks_exact(4 + kx * JOB_RECORD) {
        first_cells.push(word(row, 0));
        for rec in row[4..].chunks_exact(JOB_RECORD) {
            table.push(Block {
                metacell_count: word(rec, 0),
                metacell_pointer: 0,
                min: 0.0,
                max: 0.0,
            });
            active_cells.push(word(rec, 1));
        }
    }
    let quantizer = Quantizer::new(precision, tile.scalar_type().is_integer(), lo, hi, iso);
    let job = TileJob {
        dims: tile.dims(),
        first_block: first,
        box_dims: [kx, ky],
        blocks: &table,
        active_cells: &active_cells,
        first_cells: &first_cells,
        iso,
        quantizer: &quantizer,
    };
    let (slots, cells) = match tile.samples() {
        Samples::U8(s) => job.emit(s),
        Samples::U16(s) => job.emit(s),
        Samples::I16(s) => job.emit(s),
        Samples::F32(s) => job.emit(s),
    };
    let slots: &[u8] = bytemuck::cast_slice(&slots);
    let mut fragment = Vec::with_capacity(8 + slots.len() + cells.len());
    put_tag(&mut fragment, OUTPUT_TAG);
    put_u32(&mut fragment, index);
    fragment.extend_from_slice(slots);
    fragment.extend_from_slice(&cells);
    Ok(fragment)
}

/// An emit job decoded, waiting for its samples. Its tables hold the box's blocks in block order.
struct TileJob<'a> {
    dims: [usize; 3],
    first_block: [usize; 3],
    box_dims: [usize; 2],
    blocks: &'a [Block],
    active_cells: &'a [u32],
    /// The index of each block row's first cell in the whole grid.
    first_cells: &'a [u32],
    iso: f64,
    quantizer: &'a Quantizer,
}

impl TileJob<'_> {
    /// The slots and then the corner records of the box's block rows, each row's where the
    /// previous one's end, as [`TileExtraction::write`] expects them.
    fn emit<T: ExtractScalar>(&self, samples: &[T]) -> (Vec<Metacell>, Vec<u8>) {
        let record = self.quantizer.precision().bytes_per_cell();
        let slot_count = self.blocks.iter().map(|b| b.metacell_count as usize).sum();
        let cell_count: usize = self.active_cells.iter().map(|&c| c as usize).sum();
        // Padding slots must be zero, as in the in-memory output.
        let mut slots = vec![bytemuck::Zeroable::zeroed(); slot_count];
        let mut cells = vec![0u8; cell_count * record];
        let mut outputs = Vec::new();
        let (mut slots_rest, mut cells_rest) = (&mut slots[..], &mut cells[..]);
        let kx = self.box_dims[0];
        for (row, &first_cell) in self.first_cells.iter().enumerate() {
            let range = row * kx..(row + 1) * kx;
            let row_slots = self.blocks[range.clone()]
                .iter()
                .map(|b| b.metacell_count as usize)
                .sum();
            let row_cells: usize = self.active_cells[range.clone()]
                .iter()
                .map(|&c| c as usize)
                .sum();
            let (row_slots, rest) = std::mem::take(&mut slots_rest).split_at_mut(row_slots);
            slots_rest = rest;
            let (row_cells, rest) =
                std::mem::take(&mut cells_rest).split_at_mut(row_cells * record);
            cells_rest = rest;
            let mut next_cell = first_cell;
            // Blocks numbered within the box; moved to the grid's numbers and the tile's origin.
            let row_outputs = split_outputs(
                self.blocks,
                0,
                |index| self.active_cells[index],
                range,
                self.box_dims,
                (row_slots, row_cells),
                record,
                &mut next_cell,
                0,
            );
            outputs.extend(row_outputs.into_iter().map(|mut out| {
                out.block = [0, 1, 2].map(|a| out.block[a] + self.first_block[a]);
                out.slab_block = self.first_block;
                out
            }));
        }
        let threshold = T::threshold(self.iso);
        outputs
            .into_par_iter()
            .for_each_init(emit::BlockScratch::default, |scratch, out| {
                emit::emit_block(samples, self.dims, threshold, self.quantizer, out, scratch)
            });
        (slots, cells)
    }
}

/// Writes a fragment's tag, sample type, volume dimensions and box of blocks.
fn put_header(
    out: &mut Vec<u8>,
    tag: &[u8; 4],
    scalar_type: ScalarType,
    dims: [usize; 3],
    blocks: &BlockBox,
) {
    put_tag(out, tag);
    put_u32(out, scalar_code(scalar_type));
    dims.iter().for_each(|&d| put_u32(out, d as u32));
    blocks.iter().for_each(|b| put_u32(out, b.start as u32));
    blocks.iter().for_each(|b| put_u32(out, b.len() as u32));
}

/// Reads a box of blocks (first blocks, then counts), which must lie inside `block_dims`.
fn read_box(r: &mut Reader, block_dims: [usize; 3], what: &str) -> Result<BlockBox> {
    let first = [r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    let count = [r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    if (0..3).any(|a| count[a] == 0 || first[a] + count[a] > block_dims[a]) {
        return Err(Error::corrupt(format!(
            "{what} of blocks outside the volume's {}x{}x{}",
            block_dims[0], block_dims[1], block_dims[2]
        )));
    }
    Ok([0, 1, 2].map(|a| first[a]..first[a] + count[a]))
}

fn put_tag(out: &mut Vec<u8>, tag: &[u8; 4]) {
    out.extend_from_slice(tag);
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Reads a fragment's fields, checking its tag and length.
struct Reader<'a> {
    bytes: &'a [u8],
    what: &'static str,
}

impl<'a> Reader<'a> {
    fn new(bytes: &'a [u8], tag: &[u8; 4], what: &'static str) -> Result<Self> {
        match bytes.split_first_chunk::<4>() {
            Some((t, rest)) if t == tag => Ok(Reader { bytes: rest, what }),
            _ => Err(Error::corrupt(format!("not a valid {what}"))),
        }
    }
    fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        let (head, rest) = self
            .bytes
            .split_first_chunk::<N>()
            .ok_or_else(|| Error::corrupt(format!("{} is truncated", self.what)))?;
        self.bytes = rest;
        Ok(*head)
    }
    fn u32(&mut self) -> Result<u32> {
        self.take().map(u32::from_le_bytes)
    }
    fn f64(&mut self) -> Result<f64> {
        self.take().map(f64::from_le_bytes)
    }
    /// The rest, which must be exactly `len` bytes.
    fn rest(self, len: usize) -> Result<&'a [u8]> {
        if self.bytes.len() != len {
            return Err(Error::corrupt(format!(
                "{} holds {} bytes of records where {len} were expected",
                self.what,
                self.bytes.len()
            )));
        }
        Ok(self.bytes)
    }
}

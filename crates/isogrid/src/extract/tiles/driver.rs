//! The coordinating side of a tiled extraction, on the machine that writes the file: collects the
//! tiles' scan records (and one-pass output, spooled), settles every block's place, plans emit
//! jobs and writes the `.cgc` file from the fragments, in whatever order they come.

use super::geometry::{block_dims, box_rows, tile_samples, tiles, BlockBox};
use super::spool::Spool;
use super::wire::*;
use crate::cgc::{scalar_code, CgcWriter, SectionKind};
use crate::error::{Error, Result};
use crate::extract::file_layout::FileLayout;
use crate::extract::{metacell_slots, scan, ExtractOptions, Totals};
use crate::grid::GridInfo;
use crate::layout::{Block, Metacell, Precision, BOUND_SLOT, CLUSTER_SLOTS};
use crate::quantize::Quantizer;
use crate::stats::GridStats;
use crate::volume::{Geometry, ScalarType};
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

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
    /// What [`super::emit_tile`] needs besides the samples.
    pub bytes: Vec<u8>,
}

impl EmitJob {
    /// Bytes of the job's output: its metacell slots, then its corner records.
    fn output_len(&self, slot_size: u64, record: u64) -> u64 {
        self.runs
            .iter()
            .map(|(s, c)| (s.end - s.start) * slot_size + (c.end - c.start) * record)
            .sum()
    }

    /// Moves the cell pointers of a one-pass tile's output (`payload`, as [`super::extract_tile`] made
    /// it: each block row's cells numbered from 0) to the grid's numbering. Cluster bounds and
    /// padding slots (mask 0) hold no pointer.
    fn number_cells(&self, payload: &mut [u8]) -> Result<()> {
        let slot_size = size_of::<Metacell>();
        let mut slots = &mut payload[..];
        for (slot_run, cell_run) in &self.runs {
            let row;
            (row, slots) = std::mem::take(&mut slots)
                .split_at_mut((slot_run.end - slot_run.start) as usize * slot_size);
            let row_cells = cell_run.end - cell_run.start;
            for (k, slot) in row.chunks_exact_mut(slot_size).enumerate() {
                // The payload is bytes of any alignment: each slot is read and written whole.
                let mut metacell: Metacell = bytemuck::pod_read_unaligned(slot);
                if k % CLUSTER_SLOTS == BOUND_SLOT || metacell.is_empty() {
                    continue;
                }
                let local = metacell.cell_pointer as u64;
                if local + metacell.active_cells() as u64 > row_cells {
                    return Err(Error::corrupt(
                        "spooled tile output whose cells lie outside its block row",
                    ));
                }
                metacell.cell_pointer = (cell_run.start + local) as u32;
                slot.copy_from_slice(bytemuck::bytes_of(&metacell));
            }
        }
        Ok(())
    }
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
    /// Each block's (min, max) in f64 while scanning: the file's f32 block bounds would round the
    /// header's value range of 32- and 64-bit samples.
    ranges: Vec<[f64; 2]>,
    /// Active cells per block while scanning; then the index of each block's first cell.
    cells: Vec<u32>,
    /// Which blocks a scan fragment covered (emptied once settled).
    scanned: Vec<bool>,
    scanned_count: usize,
    /// Totals and NaN-free range over the blocks, once settled.
    settled: Option<(Totals, (f64, f64))>,
    /// Where one-pass tiles' output is kept until the file is written: the folder, the file
    /// (made at the first output), and each tile's offset in it.
    spool_dir: Option<PathBuf>,
    spool: Option<Spool>,
    spooled: HashMap<BlockBox, u64>,
    /// The spooled tiles as emit jobs, with their offsets, once planned.
    spooled_jobs: Vec<(EmitJob, u64)>,
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
        let needs_range =
            matches!(options.iso, crate::extract::Iso::Normalized(_)) || block_count == 0;
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
            ranges: vec![[0.0; 2]; block_count],
            cells: vec![0; block_count],
            scanned: vec![false; block_count],
            scanned_count: 0,
            settled: None,
            spool_dir: None,
            spool: None,
            spooled: HashMap::new(),
            spooled_jobs: Vec::new(),
        })
    }

    /// The isovalue in data units, for [`super::scan_tile`].
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
        let mut r = Reader::new(fragment, SCAN_TAG, "scan fragment")?;
        let (blocks, records) = self.read_scan(&mut r)?;
        r.rest(0)?;
        self.store_scan(&blocks, records);
        Ok(())
    }

    /// The task [`super::extract_tile`] runs on every tile when the run can be one pass over the
    /// samples: when the quantiser that stores corner values is known before any tile is scanned,
    /// because the value range was given (see [`TileExtraction::new`]) or the codes do not depend
    /// on it (u8 at 8 bits or more, u16 at 16 bits or more, 32-bit values). `None` otherwise:
    /// scan every tile with [`super::scan_tile`], then emit.
    pub fn one_pass_task(&self) -> Option<Vec<u8>> {
        let (lo, hi) = self.one_pass_range()?;
        let mut bytes = Vec::with_capacity(60);
        put_tag(&mut bytes, TASK_TAG);
        put_u32(&mut bytes, scalar_code(self.scalar_type));
        self.geometry
            .dims
            .iter()
            .for_each(|&d| put_u32(&mut bytes, d as u32));
        put_u32(&mut bytes, self.precision.bits());
        for v in [self.iso, lo, hi] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        Some(bytes)
    }

    /// The value range one-pass tasks build their quantiser from, if they can (see
    /// [`Self::one_pass_task`]); checked against the file's quantiser before any of their output
    /// is written.
    fn one_pass_range(&self) -> Option<(f64, f64)> {
        if let Some((lo, hi)) = self.value_range {
            // As the file's header stores it (see `FileLayout::new`).
            return Some(if lo <= hi { (lo, hi) } else { (0.0, 0.0) });
        }
        let free = match self.precision.max_code() {
            None => true,
            Some(max) => match self.scalar_type {
                ScalarType::U8 => max >= u8::MAX as u32,
                ScalarType::U16 => max >= u16::MAX as u32,
                _ => false,
            },
        };
        free.then_some((0.0, 0.0))
    }

    /// Keeps one-pass tiles' output in a scratch file in the folder `dir` (best beside the
    /// output: it holds up to the output's size until [`Self::write`] copies it into place).
    pub fn spool_in(&mut self, dir: &Path) {
        self.spool_dir = Some(dir.to_path_buf());
    }

    /// Adds a tile's [`super::extract_tile`] fragment (tiles in any order, together covering every
    /// block exactly once, as scan fragments do): its scan records and, if it has any, its output,
    /// which waits in the spool (see [`Self::spool_in`]) until the file is written. Emit jobs
    /// must then be planned with the same tiles, and cover the tiles that gave no output.
    pub fn add_tile(&mut self, fragment: &[u8]) -> Result<()> {
        let mut r = Reader::new(fragment, TILE_TAG, "tile fragment")?;
        let (blocks, records) = self.read_scan(&mut r)?;
        let output = match r.u32()? {
            0 => None,
            1 => {
                let record = self.precision.bytes_per_cell() as u64;
                let (mut slots, mut cells) = (0u64, 0u64);
                for rec in records.chunks_exact(SCAN_RECORD) {
                    let word =
                        |i: usize| u32::from_le_bytes(rec[4 * i..4 * i + 4].try_into().unwrap());
                    slots += metacell_slots(word(0));
                    cells += word(1) as u64;
                }
                let len = slots * size_of::<Metacell>() as u64 + cells * record;
                Some(r.rest(len as usize)?)
            }
            _ => return Err(Error::corrupt("tile fragment with an unknown kind")),
        };
        if let Some(output) = output.filter(|o| !o.is_empty()) {
            // Spooled first: an I/O error leaves the block table as it was.
            if self.spool.is_none() {
                let dir = self.spool_dir.as_deref().ok_or_else(|| {
                    Error::invalid("a tile fragment with output, but no spool folder was set")
                })?;
                self.spool = Some(Spool::create(dir)?);
            }
            let offset = self.spool.as_mut().unwrap().append(output)?;
            self.spooled.insert(blocks.clone(), offset);
        }
        self.store_scan(&blocks, records);
        Ok(())
    }

    /// Reads a scan or tile fragment's header and scan records, checking that they fit this
    /// volume and cover only blocks not yet scanned.
    fn read_scan<'f>(&self, r: &mut Reader<'f>) -> Result<(BlockBox, &'f [u8])> {
        let what = r.what;
        if self.settled.is_some() {
            return Err(Error::invalid(format!(
                "{what} after the emit jobs were planned"
            )));
        }
        let blocks = self.read_header(r, what)?;
        let count = blocks.iter().map(|b| b.len()).product::<usize>();
        let records = r.bytes(count * SCAN_RECORD)?;
        let word = |record: &[u8], i: usize| {
            u32::from_le_bytes(record[4 * i..4 * i + 4].try_into().unwrap())
        };
        for record in records.chunks_exact(SCAN_RECORD) {
            if word(record, 0) > 512 || word(record, 1) > 4096 {
                return Err(Error::corrupt(format!(
                    "{what} with impossible block counts"
                )));
            }
        }
        for (y, z) in box_rows(&blocks) {
            let start = self.block_index([blocks[0].start, y, z]);
            if self.scanned[start..start + blocks[0].len()].contains(&true) {
                let [x, y, z] = blocks.clone().map(|b| (b.start, b.end));
                return Err(Error::invalid(format!(
                    "{what} of blocks x {}..{}, y {}..{}, z {}..{} overlaps blocks \
                     already scanned",
                    x.0, x.1, y.0, y.1, z.0, z.1
                )));
            }
        }
        Ok((blocks, records))
    }

    /// Stores scan records [`Self::read_scan`] checked.
    fn store_scan(&mut self, blocks: &BlockBox, records: &[u8]) {
        let word =
            |record: &[u8], i: usize| <[u8; 4]>::try_from(&record[4 * i..4 * i + 4]).unwrap();
        let mut records = records.chunks_exact(SCAN_RECORD);
        for (y, z) in box_rows(blocks) {
            let start = self.block_index([blocks[0].start, y, z]);
            for i in start..start + blocks[0].len() {
                let record = records.next().unwrap();
                let f64_at = |at: usize| f64::from_le_bytes(record[at..at + 8].try_into().unwrap());
                self.ranges[i] = [f64_at(8), f64_at(16)];
                self.blocks[i] = Block {
                    metacell_count: u32::from_le_bytes(word(record, 0)),
                    ..bytemuck::Zeroable::zeroed()
                };
                self.cells[i] = u32::from_le_bytes(word(record, 1));
                self.scanned[i] = true;
            }
        }
        self.scanned_count += blocks.iter().map(|b| b.len()).product::<usize>();
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
        let scan_of = |block: &Block, &[min, max]: &[f64; 2], active_cells: u32| scan::BlockScan {
            occupied_metacells: block.metacell_count,
            active_cells,
            min,
            max,
        };
        // A first pass only checks the 32-bit limits, so that an error leaves the table as it was.
        let mut totals = Totals::default();
        for ((block, r), &active) in self.blocks.iter().zip(&self.ranges).zip(&self.cells) {
            totals.add(&scan_of(block, r, active))?;
        }
        let mut totals = Totals::default();
        let mut range = (f64::INFINITY, f64::NEG_INFINITY);
        for ((block, r), cells) in self
            .blocks
            .iter_mut()
            .zip(&self.ranges)
            .zip(&mut self.cells)
        {
            let scan = scan_of(block, r, *cells);
            range = (range.0.min(scan.min), range.1.max(scan.max));
            *cells = totals.cells as u32;
            *block = totals.add(&scan)?;
        }
        self.scanned = Vec::new();
        self.ranges = Vec::new();
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
    /// Tiles and halves without active cells get no job, nor do tiles whose output a one-pass
    /// task gave (see [`Self::add_tile`]): those must be tiles of `tile_blocks` too.
    pub fn plan_emits(&mut self, tile_blocks: [usize; 3], job_bytes: u64) -> Result<Vec<EmitJob>> {
        let tiles = tiles(self.geometry.dims, tile_blocks)?;
        self.settle()?;
        let (layout, totals) = self.layout()?;
        let mut spooled = std::mem::take(&mut self.spooled);
        let mut spooled_jobs = Vec::with_capacity(spooled.len());
        let mut jobs = Vec::new();
        for tile in tiles {
            match spooled.remove(&tile) {
                Some(offset) => {
                    let samples = tile_samples(&tile, self.geometry.dims);
                    spooled_jobs.push((self.job(tile, samples, &layout, &totals), offset));
                }
                None => self.plan_box(tile, job_bytes, &layout, &totals, &mut jobs),
            }
        }
        if !spooled.is_empty() {
            return Err(Error::invalid(
                "one-pass tiles that are not tiles of the plan: plan the emit jobs with the \
                 tiles that were extracted",
            ));
        }
        self.spooled_jobs = spooled_jobs;
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
        let record = self.precision.bytes_per_cell() as u64;
        let slot_size = size_of::<Metacell>() as u64;
        crate::fs::write_atomic_file(path, |file| {
            let mut writer = CgcWriter::new(file, layout.plan())?;
            writer.put(SectionKind::Blocks, 0, bytemuck::cast_slice(&self.blocks))?;
            // Writes a job's output (its slots, then its cells) at its runs' places.
            let place = |writer: &mut CgcWriter, job: &EmitJob, payload: &[u8]| {
                let slot_total: u64 = job
                    .runs
                    .iter()
                    .map(|(s, _)| (s.end - s.start) * slot_size)
                    .sum();
                let (mut slots, mut cells) = payload.split_at(slot_total as usize);
                for (slot_run, cell_run) in &job.runs {
                    let here;
                    (here, slots) =
                        slots.split_at(((slot_run.end - slot_run.start) * slot_size) as usize);
                    writer.put(SectionKind::Metacells, slot_run.start * slot_size, here)?;
                    let here;
                    (here, cells) =
                        cells.split_at(((cell_run.end - cell_run.start) * record) as usize);
                    writer.put(SectionKind::Cells, cell_run.start * record, here)?;
                }
                Ok::<_, Error>(())
            };
            // One-pass tiles' output, from the spool, its cells moved to their place.
            if !self.spooled_jobs.is_empty() {
                let (lo, hi) = self.one_pass_range().unwrap_or((f64::NAN, f64::NAN));
                let tasks = Quantizer::new(
                    self.precision,
                    self.scalar_type.is_integer(),
                    lo,
                    hi,
                    self.iso,
                );
                if tasks.mapping() != layout.quantizer.mapping() {
                    return Err(Error::invalid(
                        "the one-pass tiles were quantised otherwise than the file",
                    ));
                }
                let spool = self.spool.as_ref().ok_or_else(|| {
                    Error::invalid("one-pass tiles were planned but none was spooled")
                })?;
                for (job, offset) in &self.spooled_jobs {
                    let mut payload = vec![0u8; job.output_len(slot_size, record) as usize];
                    spool.read(*offset, &mut payload)?;
                    job.number_cells(&mut payload)?;
                    place(&mut writer, job, &payload)?;
                }
            }
            // Per job, once written: the checksum of its fragment.
            let mut written: Vec<Option<u32>> = vec![None; jobs.len()];
            while let Some(fragment) = next_fragment()? {
                let mut r = Reader::new(&fragment, OUTPUT_TAG, "output fragment")?;
                let index = r.u32()? as usize;
                let job = jobs.get(index).ok_or_else(|| {
                    Error::invalid(format!("output fragment of job {index}, beyond the plan"))
                })?;
                let payload = r.rest(job.output_len(slot_size, record) as usize)?;
                let crc = crc32fast::hash(payload);
                if let Some(seen) = written[index] {
                    // A retried task delivered twice: only the same bytes are acceptable.
                    if seen != crc {
                        return Err(Error::invalid(format!(
                            "job {index} delivered twice with different bytes"
                        )));
                    }
                    continue;
                }
                place(&mut writer, job, payload)?;
                written[index] = Some(crc);
            }
            if let Some(index) = written.iter().position(Option::is_none) {
                return Err(Error::invalid(format!(
                    "the output of job {index} never arrived"
                )));
            }
            // The writer checks that the runs covered every slot and cell exactly once.
            debug_assert_eq!(
                layout.lengths[1..],
                [totals.slots * slot_size, totals.cells * record]
            );
            writer.finish(&layout.info, &layout.counts)
        })?;
        Ok(TileSummary {
            info: layout.info,
            stats: layout.stats,
        })
    }
}

//! Extraction in independent tiles of whole block layers (paper §3.1), for runs spread over
//! processes or machines (the Python package drives it on a Dask cluster).
//!
//! The same split as [`super::stream`], with the slabs handed out instead of read in a loop:
//! every cell belongs to exactly one 16³ block and a block reads only its own samples plus one
//! more on its high sides, so a *tile* of block layers `bz0..bz1` needs exactly the sample planes
//! `16·bz0 ..= 16·bz1` and its blocks come out as the whole-volume extraction makes them. There is
//! no seam to stitch and nothing to de-duplicate; what the whole volume decides (the value range
//! behind the quantiser, every block's place in the file) is settled between two rounds of tasks:
//!
//! 1. [`scan_tile`] on every tile, anywhere: a *scan fragment* with each block's active cells,
//!    occupied metacells and value range (16 bytes a block);
//! 2. [`TileExtraction::add_scan`], in layer order, on the machine that writes the file: prefix
//!    sums give every block its record and the file its exact size, then
//!    [`TileExtraction::plan_emits`] cuts the layers that hold active cells into *emit jobs*
//!    whose samples and output fit a budget;
//! 3. [`emit_tile`] on every job, anywhere: an *output fragment* holding the job's metacell slots
//!    and corner records exactly as they lie in the file;
//! 4. [`TileExtraction::write`] places output fragments at their offsets in whatever order they
//!    arrive (a retried task gives the same bytes), combines the section checksums in file order
//!    and writes the header last, atomically.
//!
//! Scan and emit are [`super::scan_blocks`] and [`super::stream::GroupBuffers`], the code of the
//! in-memory and streaming extractions, so the file is byte-identical to
//! `cgc::write(extract(volume))` whatever the tiling and the order tasks finish in.
//!
//! Fragments are plain little-endian bytes (they cross processes and machines); each starts with a
//! four-byte tag and is checked against what the receiver expects before use.

use super::file_layout::FileLayout;
use super::scalar::ExtractScalar as _;
use super::stream::{write_at, GroupBuffers, SlabScalar, SlabView};
use super::{scan_blocks, ExtractOptions, Totals};
use crate::cgc::{header_bytes, scalar_code};
use crate::error::{Error, Result};
use crate::grid::GridInfo;
use crate::layout::{Block, Metacell, Precision, BLOCK_CELLS};
use crate::quantize::Quantizer;
use crate::stats::GridStats;
use crate::volume::{Geometry, Samples, ScalarType, VolumeView};
use std::ops::Range;
use std::path::Path;

const SCAN_TAG: &[u8; 4] = b"IGTS";
const JOB_TAG: &[u8; 4] = b"IGTJ";
const OUTPUT_TAG: &[u8; 4] = b"IGTO";

/// Bytes per block of a scan fragment: occupied metacells, active cells, min, max.
const SCAN_RECORD: usize = 16;
/// Bytes per block of an emit job: metacell slots, active cells.
const JOB_RECORD: usize = 8;

/// Block layers (16 cells of z) of a volume of `nz` samples.
pub fn block_layers(nz: usize) -> usize {
    nz.saturating_sub(1).div_ceil(BLOCK_CELLS)
}

/// The sample planes block layers `layers` read: their own and the halo plane above them.
pub fn tile_planes(layers: &Range<usize>, nz: usize) -> Range<usize> {
    BLOCK_CELLS * layers.start..(BLOCK_CELLS * layers.end + 1).min(nz)
}

/// Pass 1 of one tile: the scan fragment of block layers `first_layer..` of a volume of
/// `volume_dims` samples, whose planes [`tile_planes`] `tile` holds, at the isovalue `iso` (data
/// units, resolved for the whole volume).
pub fn scan_tile(
    tile: &VolumeView,
    volume_dims: [usize; 3],
    first_layer: usize,
    iso: f64,
) -> Result<Vec<u8>> {
    let layers = tile_layers(tile.dims(), volume_dims, first_layer)?;
    let mut out = Vec::new();
    put_tag(&mut out, SCAN_TAG);
    put_u32(&mut out, scalar_code(tile.scalar_type()));
    volume_dims
        .iter()
        .for_each(|&d| put_u32(&mut out, d as u32));
    put_u32(&mut out, layers.start as u32);
    put_u32(&mut out, layers.len() as u32);
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

/// The block layers a tile of `tile_dims` samples starting at `first_layer` covers; errors unless
/// it is exactly the planes [`tile_planes`] names for them.
fn tile_layers(
    tile_dims: [usize; 3],
    volume_dims: [usize; 3],
    first_layer: usize,
) -> Result<Range<usize>> {
    let [nx, ny, nz] = volume_dims;
    let nbz = block_layers(nz);
    let planes = tile_dims[2];
    let layers = planes.saturating_sub(1).div_ceil(BLOCK_CELLS);
    let range = first_layer..first_layer + layers;
    if tile_dims[..2] != [nx, ny]
        || layers == 0
        || range.end > nbz
        || tile_planes(&range, nz).len() != planes
    {
        return Err(Error::invalid(format!(
            "a tile of {}x{}x{} samples is not whole block layers from layer {first_layer} of a \
             {nx}x{ny}x{nz} volume (each tile holds 16 planes per layer plus the next plane)",
            tile_dims[0], tile_dims[1], tile_dims[2]
        )));
    }
    Ok(range)
}

/// One emit job: block layers whose slots and corner records are one contiguous piece of each
/// section.
#[derive(Debug, Clone, PartialEq)]
pub struct EmitJob {
    /// Block layers emitted.
    pub layers: Range<usize>,
    /// The sample planes the job reads ([`tile_planes`] of its layers).
    pub planes: Range<usize>,
    /// Metacell slots and corner records it writes (indices into their sections).
    pub slots: Range<u64>,
    pub cells: Range<u64>,
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
    blocks: Vec<Block>,
    active_cells: Vec<u32>,
    totals: Totals,
    /// NaN-free range over the scanned blocks.
    scanned: (f64, f64),
    next_layer: usize,
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
        let block_count = geometry
            .cell_dims()
            .map(|c| c.div_ceil(BLOCK_CELLS))
            .iter()
            .product::<usize>();
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
            blocks: Vec::with_capacity(block_count),
            active_cells: Vec::with_capacity(block_count),
            totals: Totals::default(),
            scanned: (f64::INFINITY, f64::NEG_INFINITY),
            // Without blocks (an axis of one sample) there is nothing to scan.
            next_layer: if block_count == 0 {
                geometry.cell_dims()[2].div_ceil(BLOCK_CELLS)
            } else {
                0
            },
        })
    }

    /// The isovalue in data units, for [`scan_tile`].
    pub fn iso(&self) -> f64 {
        self.iso
    }

    fn block_dims(&self) -> [usize; 3] {
        self.geometry.cell_dims().map(|c| c.div_ceil(BLOCK_CELLS))
    }

    /// Adds the scan fragment of the next tile (tiles in layer order, each starting where the
    /// last ended).
    pub fn add_scan(&mut self, fragment: &[u8]) -> Result<()> {
        let [nbx, nby, nbz] = self.block_dims();
        let mut r = Reader::new(fragment, SCAN_TAG, "scan fragment")?;
        let (scalar, dims) = (r.u32()?, [r.u32()?, r.u32()?, r.u32()?]);
        let (first, layers) = (r.u32()? as usize, r.u32()? as usize);
        if scalar != scalar_code(self.scalar_type) || dims != self.geometry.dims.map(|d| d as u32) {
            return Err(Error::invalid(
                "scan fragment of another volume (sample type or dimensions differ)",
            ));
        }
        if first != self.next_layer || first + layers > nbz {
            return Err(Error::invalid(format!(
                "scan fragment of layers {first}..{} arrives where layer {} of {nbz} is next",
                first + layers,
                self.next_layer
            )));
        }
        let records = r.rest(layers * nbx * nby * SCAN_RECORD)?;
        for record in records.chunks_exact(SCAN_RECORD) {
            let word = |i: usize| <[u8; 4]>::try_from(&record[4 * i..4 * i + 4]).unwrap();
            let scan = super::scan::BlockScan {
                occupied_metacells: u32::from_le_bytes(word(0)),
                active_cells: u32::from_le_bytes(word(1)),
                min: f32::from_le_bytes(word(2)) as f64,
                max: f32::from_le_bytes(word(3)) as f64,
            };
            if scan.occupied_metacells > 512 || scan.active_cells > 4096 {
                return Err(Error::corrupt("scan fragment with impossible block counts"));
            }
            self.scanned = (self.scanned.0.min(scan.min), self.scanned.1.max(scan.max));
            self.blocks.push(self.totals.add(&scan)?);
            self.active_cells.push(scan.active_cells);
        }
        self.next_layer = first + layers;
        Ok(())
    }

    /// Header, counts and sizes; errors until every layer is scanned.
    fn layout(&self) -> Result<FileLayout> {
        let nbz = self.block_dims()[2];
        if self.next_layer != nbz {
            return Err(Error::invalid(format!(
                "{} of {nbz} block layers scanned",
                self.next_layer
            )));
        }
        let block_count = self.blocks.len() as u64;
        let range = match self.value_range {
            Some(r) => r,
            None if block_count > 0 => self.scanned,
            None => (0.0, 0.0),
        };
        Ok(FileLayout::new(
            &self.geometry,
            self.scalar_type,
            self.precision,
            self.iso,
            range,
            block_count,
            &self.totals,
        ))
    }

    /// Cuts the layers that hold active cells into emit jobs of consecutive layers whose samples
    /// plus output stay within `job_bytes` where one layer allows (a layer is never split).
    /// Layers without active cells get no job. Errors until every layer is scanned.
    pub fn plan_emits(&self, job_bytes: u64) -> Result<Vec<EmitJob>> {
        let layout = self.layout()?;
        let [nx, ny, nz] = self.geometry.dims;
        let [nbx, nby, nbz] = self.block_dims();
        let layer_blocks = nbx * nby;
        let record = self.precision.bytes_per_cell() as u64;
        let plane_bytes = (nx * ny * self.scalar_type.size()) as u64;
        // Per layer: slots and cells it writes.
        let per_layer: Vec<(u64, u64)> = (0..nbz)
            .map(|bz| {
                let range = bz * layer_blocks..(bz + 1) * layer_blocks;
                let slots = self.blocks[range.clone()]
                    .iter()
                    .map(|b| b.metacell_count as u64)
                    .sum();
                let cells = self.active_cells[range].iter().map(|&c| c as u64).sum();
                (slots, cells)
            })
            .collect();
        let cost = |layers: &Range<usize>| {
            let (slots, cells) = per_layer[layers.clone()]
                .iter()
                .fold((0, 0), |(s, c), l| (s + l.0, c + l.1));
            tile_planes(layers, nz).len() as u64 * plane_bytes
                + slots * size_of::<Metacell>() as u64
                + cells * record
        };
        let mut jobs = Vec::new();
        let (mut slot, mut cell) = (0u64, 0u64);
        let mut bz = 0;
        while bz < nbz {
            if per_layer[bz].0 == 0 {
                bz += 1;
                continue;
            }
            let mut end = bz + 1;
            while end < nbz && per_layer[end].0 > 0 && cost(&(bz..end + 1)) <= job_bytes {
                end += 1;
            }
            let layers = bz..end;
            let (slots, cells) = per_layer[layers.clone()]
                .iter()
                .fold((0, 0), |(s, c), l| (s + l.0, c + l.1));
            let blocks = layers.start * layer_blocks..layers.end * layer_blocks;
            let mut bytes = Vec::with_capacity(64 + blocks.len() * JOB_RECORD);
            put_tag(&mut bytes, JOB_TAG);
            put_u32(&mut bytes, scalar_code(self.scalar_type));
            self.geometry
                .dims
                .iter()
                .for_each(|&d| put_u32(&mut bytes, d as u32));
            put_u32(&mut bytes, layers.start as u32);
            put_u32(&mut bytes, layers.len() as u32);
            put_u32(&mut bytes, self.precision.bits());
            let [lo, hi] = layout.info.value_range;
            for v in [self.iso, lo, hi] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            put_u32(&mut bytes, cell as u32);
            for b in blocks {
                put_u32(&mut bytes, self.blocks[b].metacell_count);
                put_u32(&mut bytes, self.active_cells[b]);
            }
            jobs.push(EmitJob {
                planes: tile_planes(&layers, nz),
                layers,
                slots: slot..slot + slots,
                cells: cell..cell + cells,
                bytes,
            });
            (slot, cell) = (slot + slots, cell + cells);
            bz = end;
        }
        Ok(jobs)
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
        let layout = self.layout()?;
        let sections = layout.sections;
        let record = self.precision.bytes_per_cell() as u64;
        crate::fs::write_atomic_file(path, |file| {
            let (cells_at, cells_len) = sections[2];
            file.set_len(cells_at + cells_len)?;
            let block_bytes: &[u8] = bytemuck::cast_slice(&self.blocks);
            write_at(file, sections[0].0, block_bytes)?;
            // Per job, once written: the checksums of its slots and cells.
            let mut written: Vec<Option<[crc32fast::Hasher; 2]>> = vec![None; jobs.len()];
            while let Some(fragment) = next_fragment()? {
                let mut r = Reader::new(&fragment, OUTPUT_TAG, "output fragment")?;
                let index = r.u32()? as usize;
                let job = jobs.get(index).ok_or_else(|| {
                    Error::invalid(format!("output fragment of job {index}, beyond the plan"))
                })?;
                let slot_bytes = (job.slots.end - job.slots.start) * size_of::<Metacell>() as u64;
                let cell_bytes = (job.cells.end - job.cells.start) * record;
                let (slots, cells) = r
                    .rest((slot_bytes + cell_bytes) as usize)?
                    .split_at(slot_bytes as usize);
                let crcs = [slots, cells].map(|bytes| {
                    let mut h = crc32fast::Hasher::new();
                    h.update(bytes);
                    h
                });
                if let Some(seen) = &written[index] {
                    // A retried task delivered twice: only the same bytes are acceptable.
                    if seen.clone().map(|h| h.finalize()) != crcs.clone().map(|h| h.finalize()) {
                        return Err(Error::invalid(format!(
                            "job {index} delivered twice with different bytes"
                        )));
                    }
                    continue;
                }
                write_at(
                    file,
                    sections[1].0 + job.slots.start * size_of::<Metacell>() as u64,
                    slots,
                )?;
                write_at(file, sections[2].0 + job.cells.start * record, cells)?;
                written[index] = Some(crcs);
            }
            // Jobs lie in file order and cover every slot and cell between them.
            let mut section_crcs = [crc32fast::Hasher::new(), crc32fast::Hasher::new()];
            for (index, crcs) in written.iter().enumerate() {
                let crcs = crcs.as_ref().ok_or_else(|| {
                    Error::invalid(format!("the output of job {index} never arrived"))
                })?;
                section_crcs[0].combine(&crcs[0]);
                section_crcs[1].combine(&crcs[1]);
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

/// Pass 2 of one emit job: its output fragment, from `tile`, the sample planes
/// [`EmitJob::planes`] of the volume.
pub fn emit_tile(tile: &VolumeView, job: &[u8], index: u32) -> Result<Vec<u8>> {
    let mut r = Reader::new(job, JOB_TAG, "emit job")?;
    let scalar = r.u32()?;
    let volume_dims = [r.u32()?, r.u32()?, r.u32()?].map(|d| d as usize);
    let (first, layers) = (r.u32()? as usize, r.u32()? as usize);
    let precision = Precision::from_bits(r.u32()?)
        .ok_or_else(|| Error::corrupt("emit job with an unknown precision"))?;
    let [iso, lo, hi] = [r.f64()?, r.f64()?, r.f64()?];
    let first_cell = r.u32()?;
    if scalar != scalar_code(tile.scalar_type()) {
        return Err(Error::invalid(
            "the tile's sample type differs from the scanned volume's",
        ));
    }
    if tile_layers(tile.dims(), volume_dims, first)? != (first..first + layers) {
        return Err(Error::invalid("the tile's planes differ from the job's"));
    }
    let [nx, ny, _] = volume_dims;
    let [nbx, nby] = [nx, ny].map(|n| (n - 1).div_ceil(BLOCK_CELLS));
    let records = r.rest(layers * nbx * nby * JOB_RECORD)?;
    let (blocks, active_cells): (Vec<Block>, Vec<u32>) = records
        .chunks_exact(JOB_RECORD)
        .map(|rec| {
            let word = |i: usize| u32::from_le_bytes(rec[4 * i..4 * i + 4].try_into().unwrap());
            let block = Block {
                metacell_count: word(0),
                metacell_pointer: 0,
                min: 0.0,
                max: 0.0,
            };
            (block, word(1))
        })
        .unzip();
    let quantizer = Quantizer::new(precision, tile.scalar_type().is_integer(), lo, hi, iso);
    let job = TileJob {
        dims: tile.dims(),
        first_layer: first,
        block_dims: [nbx, nby],
        blocks: &blocks,
        active_cells: &active_cells,
        first_cell,
        iso,
        quantizer: &quantizer,
    };
    let out = match tile.samples() {
        Samples::U8(s) => job.emit(s),
        Samples::U16(s) => job.emit(s),
        Samples::I16(s) => job.emit(s),
        Samples::F32(s) => job.emit(s),
    };
    let slots: &[u8] = bytemuck::cast_slice(&out.slots);
    let mut fragment = Vec::with_capacity(8 + slots.len() + out.cells.len());
    put_tag(&mut fragment, OUTPUT_TAG);
    put_u32(&mut fragment, index);
    fragment.extend_from_slice(slots);
    fragment.extend_from_slice(&out.cells);
    Ok(fragment)
}

/// An emit job decoded, waiting for its samples.
struct TileJob<'a> {
    dims: [usize; 3],
    first_layer: usize,
    block_dims: [usize; 2],
    blocks: &'a [Block],
    active_cells: &'a [u32],
    first_cell: u32,
    iso: f64,
    quantizer: &'a Quantizer,
}

impl TileJob<'_> {
    fn emit<T: SlabScalar>(&self, samples: &[T]) -> GroupBuffers {
        let [nbx, nby] = self.block_dims;
        let slab = SlabView {
            samples,
            dims: self.dims,
            first_layer: self.first_layer,
            block_dims: self.block_dims,
            table_start: self.first_layer * nbx * nby,
        };
        let mut out = GroupBuffers::default();
        let mut next_cell = self.first_cell;
        out.emit(
            &slab,
            self.blocks,
            self.active_cells,
            0..self.blocks.len(),
            &mut next_cell,
            T::threshold(self.iso),
            self.quantizer,
            self.quantizer.precision().bytes_per_cell(),
        );
        out
    }
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

//! What runs on one tile's samples, on any machine: the scan (pass 1), the emit of a planned job
//! (pass 2), or both in one pass where the quantiser is known up front.
//!
//! Each takes a [`Progress`] and adds one step per block and pass (a scan, an emit) as it goes,
//! without [`Progress::start`]ing it: a caller running many tiles on one `Progress` sets the total.
//! A cancel is honoured between block rows of the scan and between blocks of the emit, with an
//! error of kind [`crate::ErrorKind::Cancelled`] and no fragment.

use super::geometry::{block_dims, tile_samples, BlockBox};
use super::wire::*;
use crate::cgc::scalar_code;
use crate::error::{Error, Result};
use crate::extract::scalar::ExtractScalar;
use crate::extract::{emit, scan, scan_blocks_counted, split_outputs, Totals};
use crate::layout::{Block, Metacell, Precision, BLOCK_CELLS};
use crate::progress::Progress;
use crate::quantize::Quantizer;
use crate::volume::{Samples, VolumeView};
use rayon::prelude::*;

/// Pass 1 of one tile: the scan fragment of the blocks from `first_block` (x, y, z) on of a
/// volume of `volume_dims` samples, whose [`tile_samples`] `tile` holds, at the isovalue `iso`
/// (data units, resolved for the whole volume).
pub fn scan_tile(
    tile: &VolumeView,
    volume_dims: [usize; 3],
    first_block: [usize; 3],
    iso: f64,
    progress: &Progress,
) -> Result<Vec<u8>> {
    let blocks = tile_blocks(tile.dims(), volume_dims, first_block)?;
    let mut out = Vec::new();
    scan_records(
        tile,
        volume_dims,
        &blocks,
        iso,
        SCAN_TAG,
        &mut out,
        progress,
    )?;
    Ok(out)
}

/// Scans `tile` (the samples of `blocks`) and writes the fragment header under `tag` and the
/// blocks' scan records to `out`; returns the scans.
fn scan_records(
    tile: &VolumeView,
    volume_dims: [usize; 3],
    blocks: &BlockBox,
    iso: f64,
    tag: &[u8; 4],
    out: &mut Vec<u8>,
    progress: &Progress,
) -> Result<Vec<scan::BlockScan>> {
    put_header(out, tag, tile.scalar_type(), volume_dims, blocks);
    let p = Some(progress);
    let scans = match tile.samples() {
        Samples::U8(s) => scan_blocks_counted(s, tile.dims(), u8::threshold(iso), p),
        Samples::U16(s) => scan_blocks_counted(s, tile.dims(), u16::threshold(iso), p),
        Samples::I16(s) => scan_blocks_counted(s, tile.dims(), i16::threshold(iso), p),
        Samples::F32(s) => scan_blocks_counted(s, tile.dims(), f32::threshold(iso), p),
        Samples::U32(s) => scan_blocks_counted(s, tile.dims(), u32::threshold(iso), p),
        Samples::I32(s) => scan_blocks_counted(s, tile.dims(), i32::threshold(iso), p),
        Samples::U64(s) => scan_blocks_counted(s, tile.dims(), u64::threshold(iso), p),
        Samples::I64(s) => scan_blocks_counted(s, tile.dims(), i64::threshold(iso), p),
        Samples::F64(s) => scan_blocks_counted(s, tile.dims(), f64::threshold(iso), p),
    };
    progress.check()?;
    out.reserve(scans.len() * SCAN_RECORD);
    for s in &scans {
        put_u32(out, s.occupied_metacells);
        put_u32(out, s.active_cells);
        out.extend_from_slice(&s.min.to_le_bytes());
        out.extend_from_slice(&s.max.to_le_bytes());
    }
    Ok(scans)
}

/// One pass over one tile, for a run whose quantiser is known before any tile is scanned (see
/// [`super::TileExtraction::one_pass_task`]): the tile's scan records and, when its metacell slots and
/// corner records fit `output_bytes`, that output too, each block row's cells numbered from 0
/// ([`super::TileExtraction::add_tile`] moves them to their place in the grid). A tile whose output
/// does not fit returns its scan records alone and is emitted later, as a scanned tile is.
pub fn extract_tile(
    tile: &VolumeView,
    task: &[u8],
    first_block: [usize; 3],
    output_bytes: u64,
    progress: &Progress,
) -> Result<Vec<u8>> {
    let mut r = Reader::new(task, TASK_TAG, "tile task")?;
    let scalar = r.u32()?;
    let volume_dims = [r.u32()?, r.u32()?, r.u32()?].map(|d| d as usize);
    let precision = Precision::from_bits(r.u32()?)
        .ok_or_else(|| Error::corrupt("tile task with an unknown precision"))?;
    let [iso, lo, hi] = [r.f64()?, r.f64()?, r.f64()?];
    r.rest(0)?;
    if scalar != scalar_code(tile.scalar_type()) {
        return Err(Error::invalid(
            "the tile's sample type differs from the task's",
        ));
    }
    let blocks = tile_blocks(tile.dims(), volume_dims, first_block)?;
    let mut out = Vec::new();
    let scans = scan_records(
        tile,
        volume_dims,
        &blocks,
        iso,
        TILE_TAG,
        &mut out,
        progress,
    )?;
    // The box's block table as an emit job holds it: slot counts, and active cells per block.
    let mut totals = Totals::default();
    let mut table = Vec::with_capacity(scans.len());
    for s in &scans {
        table.push(totals.add(s)?);
    }
    let active_cells: Vec<u32> = scans.iter().map(|s| s.active_cells).collect();
    let record = precision.bytes_per_cell() as u64;
    if totals.slots * size_of::<Metacell>() as u64 + totals.cells * record > output_bytes {
        put_u32(&mut out, 0);
        return Ok(out);
    }
    put_u32(&mut out, 1);
    let [kx, ky, kz] = blocks.clone().map(|b| b.len());
    let first_cells = vec![0; ky * kz];
    let quantizer = Quantizer::new(precision, tile.scalar_type().is_integer(), lo, hi, iso);
    let job = TileJob {
        dims: tile.dims(),
        first_block,
        box_dims: [kx, ky],
        blocks: &table,
        active_cells: &active_cells,
        first_cells: &first_cells,
        iso,
        quantizer: &quantizer,
    };
    let (slots, cells) = job.emit_view(tile, progress)?;
    out.extend_from_slice(bytemuck::cast_slice(&slots));
    out.extend_from_slice(&cells);
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

/// Pass 2 of one emit job: its output fragment, from `tile`, the samples [`super::EmitJob::samples`] of
/// the volume.
pub fn emit_tile(
    tile: &VolumeView,
    job: &[u8],
    index: u32,
    progress: &Progress,
) -> Result<Vec<u8>> {
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
    let (slots, cells) = job.emit_view(tile, progress)?;
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
    /// [`Self::emit`] on `tile`'s samples, whatever their type.
    fn emit_view(
        &self,
        tile: &VolumeView,
        progress: &Progress,
    ) -> Result<(Vec<Metacell>, Vec<u8>)> {
        let out = crate::volume::with_samples!(tile.samples(), s => self.emit(s, progress));
        progress.check()?;
        Ok(out)
    }

    /// The slots and then the corner records of the box's block rows, each row's where the
    /// previous one's end, as [`super::TileExtraction::write`] expects them. Blocks without
    /// cells count in `progress` at the start; once it is cancelled the rest are skipped.
    fn emit<T: ExtractScalar>(
        &self,
        samples: &[T],
        progress: &Progress,
    ) -> (Vec<Metacell>, Vec<u8>) {
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
        progress.advance((self.blocks.len() - outputs.len()) as u64);
        outputs
            .into_par_iter()
            .for_each_init(emit::BlockScratch::default, |scratch, out| {
                if progress.is_cancelled() {
                    return;
                }
                emit::emit_block(samples, self.dims, threshold, self.quantizer, out, scratch);
                progress.advance(1);
            });
        (slots, cells)
    }
}

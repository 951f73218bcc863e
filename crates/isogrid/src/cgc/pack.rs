//! The packed transfer form of a `.cgc` file (`.cgcz`): what a browser downloads instead of the
//! file when bytes on the wire matter more than ranges (`docs/design/web.md`). It rebuilds the
//! `.cgc` byte for byte, so the reader that takes it in validates it as it validates any file.
//!
//! The `.cgc` stores a sample once in every active cell that has it as a corner (about four times
//! over, `docs/benchmarks-web.md`), and everything in its metacells and blocks besides the cells'
//! positions and masks follows from them. The packed form sends each corner sample once, predicted
//! from its neighbours, and the positions as Morton steps, every field range-coded under a model of
//! its own ([`super::range_coder`]). It holds the surface, its cell attribute, its labels and its
//! world frame.
//!
//! Layout, all little-endian. A 56-byte head:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `\x89CGZ\r\n\x1a\n` |
//! | 8 | 4 | version, u32 = 2 |
//! | 12 | 4 | `H`, u32: bytes of the `.cgc`'s header and section table (320 + 32 per section) |
//! | 16 | 8 | length of the `.cgc`, u64 |
//! | 24 | 8 | length of the preamble's deflate stream, u64 |
//! | 32 | 8 | length of the preamble once inflated, u64 |
//! | 40 | 8 | length of the block stream, u64 |
//! | 48 | 4 | CRC-32 of bytes 0..48 followed by the `H` bytes below |
//! | 52 | 4 | reserved, zero |
//!
//! then the `.cgc`'s first `H` bytes as they are, then a raw deflate stream (RFC 1951) of the
//! preamble, then the block stream, which ends the file. The preamble, inflated:
//!
//! | part | bytes |
//! |---|---|
//! | every block's `min`, `max` (f32 each) | 8 per block |
//! | every block's cluster count | a LEB128 varint per block |
//! | the cell attribute's head, when the file has one | 96 |
//! | the cluster labels, label index and label table sections, when the file has labels | their lengths |
//! | the world frame section, when the file has one | 8 |
//!
//! The block stream is chunks, each a varint count of blocks, a varint length and that many bytes
//! of range coder output (its first byte zero), which codes those blocks (the blocks with
//! clusters, in block order) one after another. The models carry on from chunk to chunk; the coder
//! starts afresh in each. A block codes, under the models of `range_coder::BlockModels`:
//!
//! - for each cluster its metacell count (1..=15), and for each metacell the step from the
//!   previous metacell's Morton code in the block (the first steps from −1; zigzagged, by length,
//!   in the context of the previous step's length) and its cell mask (in the context of the
//!   previous mask);
//! - then its *new samples*: the corner samples of its active cells (in block-local sample
//!   coordinates `q` in `0..=16`, index space: sample `16·b + q` of block `b`) that no earlier
//!   neighbour block sent: the predictor mode (0 or 1, in the context of the previous mode; absent
//!   at 1 bit per corner, where it is 0), then in z, y, x order each sample's residual against
//!   `predict` (below) in that mode, modulo 2^bits (a 32-bit corner is its float's bit pattern),
//!   folded to the nearer of ±, zigzagged and coded by length in the context of the previous
//!   residual's length and the spread of the sample's known neighbours. In a file with labels one
//!   sample is a corner of several labels' cells with a different code in each: there the new
//!   samples go per label of the block's clusters (labels in the order of their first cluster in
//!   the block), each label's starting from none known;
//! - then the block's cells' stored attribute values, byte by byte, each in the context of the same
//!   byte of the value before.
//!
//! The rest of the `.cgc` follows: a block's metacell count and pointer from the cluster counts,
//! a metacell's position from its block and Morton code, its cell pointer from the masks before
//! it, a cluster's bound from its metacells, padding slots and the gaps between sections zero,
//! and each corner record from the samples. The web viewer's `web/src/packed.ts` rebuilds it; its
//! test checks that it gives back the `.cgc` of every fixture byte for byte.

use super::range_coder::{bit_length, fold_residual, residual_context, BlockModels, RangeEncoder};
use crate::error::{Error, Result};
use crate::grid::CellGrid;
use crate::layout::{Precision, BLOCK_CELLS, CLUSTER_METACELLS, CLUSTER_SLOTS};
use crate::morton;
use crate::progress::Progress;
use std::collections::{HashMap, VecDeque};
use std::io::{Seek, SeekFrom, Write};

/// The magic of a `.cgcz` file, PNG-style like the `.cgc`'s.
pub const PACKED_MAGIC: [u8; 8] = *b"\x89CGZ\r\n\x1a\n";
/// The version this build writes.
pub const PACKED_VERSION: u32 = 2;
/// Bytes of the `.cgcz` head before the `.cgc`'s header.
pub const PACKED_HEAD_SIZE: usize = 56;
/// Coded bytes after which the block stream ends a chunk (at the end of a block).
const CHUNK_BYTES: usize = 1 << 16;

/// Samples along a block's edge, its high face (shared with the next block) included.
const SIDE: usize = BLOCK_CELLS + 1;
/// Samples of one block.
const BOX: usize = SIDE * SIDE * SIDE;

/// The predicted code of the new sample at block-local `(x, y, z)` from the samples of its box
/// known so far (`-1`: not known). Mode 0: the mean of the planar predictions `a + b − ab` (each
/// clamped to `0..=max`) of the xy, xz and yz planes whose three samples at −1 are known; else the
/// mean of the known samples at −1 along x, y, z; else `last`, the group's previous new sample (or
/// half the range before the first). Mode 1, for fields that change steadily across the
/// surface's band: the median of the linear extrapolations `2a − aa` (clamped) along the axes
/// whose samples at −1 and −2 are known (of two, their mean), else mode 0. The packer takes, per group, the mode whose
/// residuals are smaller (the hairball packs 12 % smaller than in mode 0 alone; MNI, noisier,
/// keeps mode 0 almost everywhere). Means round half up. Integers only: `web/src/packed.ts`
/// computes the same.
fn predict(known: &[i64; BOX], [x, y, z]: [usize; 3], max: i64, last: i64, mode: u8) -> i64 {
    let at = |dx: usize, dy: usize, dz: usize| {
        if x < dx || y < dy || z < dz {
            -1
        } else {
            known[(z - dz) * SIDE * SIDE + (y - dy) * SIDE + (x - dx)]
        }
    };
    let (a, b, c) = (at(1, 0, 0), at(0, 1, 0), at(0, 0, 1));
    let (mut sum, mut n) = (0i64, 0i64);
    if mode == 1 {
        let mut lines = [0i64; 3];
        let mut k = 0;
        for (p, pp) in [(a, at(2, 0, 0)), (b, at(0, 2, 0)), (c, at(0, 0, 2))] {
            if p >= 0 && pp >= 0 {
                lines[k] = (2 * p - pp).clamp(0, max);
                k += 1;
            }
        }
        let lines = &mut lines[..k];
        lines.sort_unstable();
        match lines {
            [one] => return *one,
            [lo, hi] => return (*lo + *hi + 1) / 2,
            [_, mid, _] => return *mid,
            _ => {}
        }
    }
    for (p, q, pq) in [
        (a, b, at(1, 1, 0)),
        (a, c, at(1, 0, 1)),
        (b, c, at(0, 1, 1)),
    ] {
        if p >= 0 && q >= 0 && pq >= 0 {
            sum += (p + q - pq).clamp(0, max);
            n += 1;
        }
    }
    if n == 0 {
        for p in [a, b, c] {
            if p >= 0 {
                sum += p;
                n += 1;
            }
        }
    }
    if n == 0 {
        return last;
    }
    (2 * sum + n) / (2 * n)
}

/// Corner `c`'s code in a corner record: an unsigned integer below 2^bits (a float's bit pattern
/// at 32 bits).
fn corner_code(record: &[u8], precision: Precision, c: usize) -> i64 {
    match precision {
        Precision::Bits1 => (record[0] >> c & 1) as i64,
        Precision::Bits4 => (record[c / 2] >> (4 * (c % 2)) & 15) as i64,
        Precision::Bits8 => record[c] as i64,
        Precision::Bits16 => u16::from_le_bytes([record[2 * c], record[2 * c + 1]]) as i64,
        Precision::Float32 => {
            u32::from_le_bytes(record[4 * c..4 * c + 4].try_into().unwrap()) as i64
        }
    }
}

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Block-local sample boxes of the blocks a later block may share samples with: those at most one
/// block away, which in x-fastest order all lie within `reach` blocks before it.
struct KnownSamples {
    boxes: HashMap<usize, Box<[i64; BOX]>>,
    order: VecDeque<usize>,
    block_dims: [usize; 3],
}

impl KnownSamples {
    /// The box of block `index` with every sample an earlier neighbour sent; boxes no later block
    /// can reach are dropped.
    fn start(&mut self, index: usize) -> Box<[i64; BOX]> {
        let [nx, ny, _] = self.block_dims;
        let reach = nx * ny + nx + 1;
        while self.order.front().is_some_and(|&i| i + reach < index) {
            self.boxes.remove(&self.order.pop_front().unwrap());
        }
        let mut known = Box::new([-1i64; BOX]);
        let b = [index % nx, index / nx % ny, index / (nx * ny)];
        for dz in -1i64..=1 {
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let n = [b[0] as i64 + dx, b[1] as i64 + dy, b[2] as i64 + dz];
                    if n.iter()
                        .zip(&self.block_dims)
                        .any(|(&v, &d)| v < 0 || v >= d as i64)
                    {
                        continue;
                    }
                    let ni = (n[0] + nx as i64 * (n[1] + ny as i64 * n[2])) as usize;
                    let Some(other) = (ni < index).then(|| self.boxes.get(&ni)).flatten() else {
                        continue;
                    };
                    // Local sample q of this block is q − 16·d in the neighbour's box.
                    let span = |d: i64| -> std::ops::Range<usize> {
                        match d {
                            -1 => 0..1,
                            0 => 0..SIDE,
                            _ => BLOCK_CELLS..SIDE,
                        }
                    };
                    let shift = |q: usize, d: i64| (q as i64 - BLOCK_CELLS as i64 * d) as usize;
                    for z in span(dz) {
                        for y in span(dy) {
                            for x in span(dx) {
                                let v = other[shift(z, dz) * SIDE * SIDE
                                    + shift(y, dy) * SIDE
                                    + shift(x, dx)];
                                if v >= 0 {
                                    known[z * SIDE * SIDE + y * SIDE + x] = v;
                                }
                            }
                        }
                    }
                }
            }
        }
        known
    }
    fn finish(&mut self, index: usize, known: Box<[i64; BOX]>) {
        self.boxes.insert(index, known);
        self.order.push_back(index);
    }
}

/// One label's samples in the block being packed (the whole block's, in a file without labels).
struct Group {
    label: u32,
    /// Samples known before this block's new ones are read (sent by earlier neighbour blocks), then
    /// as they are read.
    known: Box<[i64; BOX]>,
    /// The codes of the group's cells' corners.
    corners: Box<[i64; BOX]>,
}

/// Counts the bytes that pass to the writer it wraps.
struct Counted<W> {
    inner: W,
    count: u64,
}

impl<W: Write> Write for Counted<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.count += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// The sizes of a packed file and of the `.cgc` it rebuilds, in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PackedSizes {
    pub packed: u64,
    pub cgc: u64,
}

/// The packed form of `grid`'s `.cgc` file ([`super::write::to_bytes`]) as bytes.
pub fn pack(grid: &CellGrid) -> Result<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    pack_into(grid, &mut out)?;
    Ok(out.into_inner())
}

/// Writes the packed form of `grid`'s `.cgc` file to `out`, from its current position: the head
/// last, once the stream's lengths are known. Holds neither the file nor the body: the grid (a
/// memory-mapped file stays on disk), the samples of the blocks within reach of the next, the
/// preamble's deflate window and one chunk of coder output.
pub fn pack_into<W: Write + Seek>(grid: &CellGrid, out: &mut W) -> Result<PackedSizes> {
    pack_into_with_progress(grid, out, &Progress::new())
}

/// [`pack_into`], counting the blocks packed in `progress` and stopping with an error of kind
/// [`crate::ErrorKind::Cancelled`] once it is cancelled (what was written to `out` is then
/// incomplete: write into a file that is removed on failure).
pub fn pack_into_with_progress<W: Write + Seek>(
    grid: &CellGrid,
    out: &mut W,
    progress: &Progress,
) -> Result<PackedSizes> {
    progress.start(grid.blocks().len() as u64);
    let (head, file_len) = super::write::head_of(grid);
    let start = out.stream_position().map_err(Error::io)?;
    out.write_all(&[0; PACKED_HEAD_SIZE]).map_err(Error::io)?;
    out.write_all(&head).map_err(Error::io)?;
    let mut deflate = flate2::write::DeflateEncoder::new(
        Counted {
            inner: &mut *out,
            count: 0,
        },
        flate2::Compression::best(),
    );
    let inflated_len = write_preamble(grid, &mut deflate).map_err(Error::io)?;
    let stream_len = deflate.finish().map_err(Error::io)?.count;
    let mut coded = Counted {
        inner: &mut *out,
        count: 0,
    };
    write_blocks(grid, &mut coded, progress).map_err(|e| match e.downcast::<Error>() {
        Ok(e) => e,
        Err(e) => Error::io(e),
    })?;
    let coded_len = coded.count;

    let mut h = Vec::with_capacity(PACKED_HEAD_SIZE);
    h.extend_from_slice(&PACKED_MAGIC);
    h.extend_from_slice(&PACKED_VERSION.to_le_bytes());
    h.extend_from_slice(&(head.len() as u32).to_le_bytes());
    h.extend_from_slice(&file_len.to_le_bytes());
    h.extend_from_slice(&stream_len.to_le_bytes());
    h.extend_from_slice(&inflated_len.to_le_bytes());
    h.extend_from_slice(&coded_len.to_le_bytes());
    let mut crc = crc32fast::Hasher::new();
    crc.update(&h);
    crc.update(&head);
    h.extend_from_slice(&crc.finalize().to_le_bytes());
    h.extend_from_slice(&[0; 4]);
    let end = out.stream_position().map_err(Error::io)?;
    out.seek(SeekFrom::Start(start)).map_err(Error::io)?;
    out.write_all(&h).map_err(Error::io)?;
    out.seek(SeekFrom::Start(end)).map_err(Error::io)?;
    Ok(PackedSizes {
        packed: end - start,
        cgc: file_len,
    })
}

/// Writes the preamble (the module doc's first table) to `body`; returns its length.
fn write_preamble(grid: &CellGrid, body: &mut impl Write) -> std::io::Result<u64> {
    let blocks = grid.blocks();
    let mut preamble = Vec::with_capacity(9 * blocks.len());
    for b in blocks {
        preamble.extend_from_slice(&b.min.to_le_bytes());
        preamble.extend_from_slice(&b.max.to_le_bytes());
    }
    for b in blocks {
        varint(&mut preamble, b.cluster_count() as u64);
    }
    if let Some(a) = grid.attribute() {
        preamble.extend_from_slice(a.head_bytes());
    }
    body.write_all(&preamble)?;
    let mut length = preamble.len() as u64;
    if let Some(labels) = grid.labels() {
        for bytes in labels.section_bytes() {
            body.write_all(&bytes)?;
            length += bytes.len() as u64;
        }
    }
    if let Some(bytes) = super::format::world_frame_bytes(grid.info().frame) {
        body.write_all(&bytes)?;
        length += bytes.len() as u64;
    }
    Ok(length)
}

/// Writes the block stream (the module doc's chunks) to `out`. An error that is not the
/// writer's comes back as an [`Error`] inside the `io::Error`.
fn write_blocks(grid: &CellGrid, out: &mut impl Write, progress: &Progress) -> std::io::Result<()> {
    let attribute = grid.attribute();
    let cluster_labels = grid.labels().map(|l| l.cluster_labels());
    let info = grid.info();
    let precision = info.precision;
    let record = precision.bytes_per_cell();
    let bits = precision.bits();
    let max = if bits == 32 {
        u32::MAX as i64
    } else {
        (1i64 << bits) - 1
    };
    let attribute_width = attribute.map_or(0, |a| a.info().precision.bytes());
    let blocks = grid.blocks();
    let metacells = grid.metacells();
    let cells = grid.cells();
    let block_dims = info.block_dims().map(|d| d as usize);
    let mut coder = RangeEncoder::new();
    let mut models = BlockModels::new(bits, attribute_width);
    let mut chunk_blocks = 0u64;
    let mut previous_mode = 0usize;
    let mut previous_value = [0u8; 4];
    let mut end_chunk = |coder: &mut RangeEncoder, blocks: &mut u64| -> std::io::Result<()> {
        let bytes = coder.finish_chunk();
        let mut record = Vec::with_capacity(20);
        varint(&mut record, *blocks);
        varint(&mut record, bytes.len() as u64);
        out.write_all(&record)?;
        out.write_all(&bytes)?;
        *blocks = 0;
        Ok(())
    };
    let mut known_samples = KnownSamples {
        boxes: HashMap::new(),
        order: VecDeque::new(),
        block_dims,
    };
    let mut groups: Vec<Group> = Vec::new();
    // A group's residuals under each predictor mode, and each new sample's neighbour spread.
    let mut residuals: [Vec<i64>; 2] = [Vec::new(), Vec::new()];
    let mut spreads: Vec<u64> = Vec::new();
    let mut spare: Vec<Box<[i64; BOX]>> = Vec::new();
    for (index, block) in blocks.iter().enumerate() {
        progress.advance(1);
        if block.cluster_count() == 0 {
            continue;
        }
        progress.check().map_err(std::io::Error::other)?;
        for g in groups.drain(..) {
            spare.push(g.known);
            spare.push(g.corners);
        }
        let origin = [
            index % block_dims[0],
            index / block_dims[0] % block_dims[1],
            index / (block_dims[0] * block_dims[1]),
        ]
        .map(|b| (b * BLOCK_CELLS / 2) as u32);
        let mut previous = -1i64;
        let (mut step_context, mut previous_mask) = (0usize, 0usize);
        let mut first_cell = None;
        let mut cell_end = 0;
        let first_cluster = block.metacell_pointer as usize / CLUSTER_SLOTS;
        for (k, cluster) in block
            .slots()
            .collect::<Vec<_>>()
            .chunks(CLUSTER_SLOTS)
            .enumerate()
        {
            let label = cluster_labels.map_or(0, |l| l[first_cluster + k]);
            let g = match groups.iter().position(|g| g.label == label) {
                Some(g) => g,
                None => {
                    // Samples are shared across blocks in a file without labels; in one with labels
                    // a block's label groups start empty (a box per label per block kept for the
                    // blocks still to come would be far more memory than the samples it saves).
                    let known = if cluster_labels.is_none() {
                        known_samples.start(index)
                    } else {
                        let mut b = spare.pop().unwrap_or_else(|| Box::new([-1; BOX]));
                        b.fill(-1);
                        b
                    };
                    let mut corners = spare.pop().unwrap_or_else(|| Box::new([-1; BOX]));
                    corners.fill(-1);
                    groups.push(Group {
                        label,
                        known,
                        corners,
                    });
                    groups.len() - 1
                }
            };
            let Group { known, corners, .. } = &mut groups[g];
            let used: Vec<_> = cluster[..CLUSTER_METACELLS]
                .iter()
                .map(|&s| metacells[s])
                .take_while(|m| !m.is_empty())
                .collect();
            models.counts.encode(&mut coder, 0, used.len() as u32);
            for m in &used {
                let local = [0, 1, 2].map(|a| m.position[a] as u32 - origin[a]);
                let code = morton::metacell_code(local[0], local[1], local[2]) as i64;
                let step = code - previous;
                previous = code;
                let folded = ((step << 1) ^ (step >> 63)) as u64;
                models.steps.encode(&mut coder, step_context, folded);
                step_context = 1 + bit_length(folded).min(11) as usize;
                models
                    .masks
                    .encode(&mut coder, previous_mask, m.cell_mask as u32);
                previous_mask = m.cell_mask as usize;
                let mut pointer = m.cell_pointer as usize;
                first_cell.get_or_insert(pointer);
                for bit in 0..8u32 {
                    if m.cell_mask >> bit & 1 == 0 {
                        continue;
                    }
                    let rec = &cells[pointer * record..(pointer + 1) * record];
                    let cell = [0, 1, 2].map(|a| 2 * local[a] as usize + (bit as usize >> a & 1));
                    for c in 0..8 {
                        let at = (cell[2] + (c >> 2 & 1)) * SIDE * SIDE
                            + (cell[1] + (c >> 1 & 1)) * SIDE
                            + cell[0]
                            + (c & 1);
                        let v = corner_code(rec, precision, c);
                        let seen = if known[at] >= 0 {
                            known[at]
                        } else {
                            corners[at]
                        };
                        if seen >= 0 && seen != v {
                            return Err(std::io::Error::other(Error::unsupported(format!(
                                "cells of block {index} disagree on a corner sample's code: the file has no packed form"
                            ))));
                        }
                        corners[at] = v;
                    }
                    pointer += 1;
                }
                cell_end = pointer;
            }
        }
        // Each group's new samples, groups in the order of their first cluster: the predictor
        // whose residuals are smaller, then the residuals.
        for Group { known, corners, .. } in &mut groups {
            let mut last = (max + 1) / 2;
            residuals.iter_mut().for_each(Vec::clear);
            spreads.clear();
            for z in 0..SIDE {
                for y in 0..SIDE {
                    for x in 0..SIDE {
                        let at = z * SIDE * SIDE + y * SIDE + x;
                        if corners[at] < 0 || known[at] >= 0 {
                            continue;
                        }
                        let v = corners[at];
                        spreads.push(neighbour_spread(known, [x, y, z]));
                        for (mode, r) in residuals.iter_mut().enumerate() {
                            let p = predict(known, [x, y, z], max, last, mode as u8);
                            r.push((v - p).rem_euclid(max + 1));
                        }
                        known[at] = v;
                        last = v;
                    }
                }
            }
            // 1-bit codes (a binary indicator) have no slope to follow: no mode byte, mode 0.
            let cost = |r: &Vec<i64>| r.iter().map(|&d| d.min(max + 1 - d)).sum::<i64>();
            let mode = (bits > 1 && cost(&residuals[1]) < cost(&residuals[0])) as usize;
            if bits > 1 {
                models.modes.encode(&mut coder, previous_mode, mode as u32);
                previous_mode = mode;
            }
            let mut previous_length = 0;
            for (&r, &spread) in residuals[mode].iter().zip(&spreads) {
                let u = fold_residual(r as u64, max as u64);
                let context = residual_context(previous_length, spread);
                models.residuals.encode(&mut coder, context, u);
                previous_length = bit_length(u);
            }
        }
        if let (Some(a), Some(first)) = (attribute, first_cell) {
            let values = &a.value_bytes()[first * attribute_width..cell_end * attribute_width];
            for value in values.chunks_exact(attribute_width) {
                for (lane, &byte) in value.iter().enumerate() {
                    let context = lane * 256 + previous_value[lane] as usize;
                    models.attribute.encode(&mut coder, context, byte as u32);
                    previous_value[lane] = byte;
                }
            }
        }
        if cluster_labels.is_none() {
            let g = groups.pop().expect("a block with clusters has a group");
            spare.push(g.corners);
            known_samples.finish(index, g.known);
        }
        chunk_blocks += 1;
        if coder.len() >= CHUNK_BYTES {
            end_chunk(&mut coder, &mut chunk_blocks)?;
        }
    }
    if chunk_blocks > 0 {
        end_chunk(&mut coder, &mut chunk_blocks)?;
    }
    Ok(())
}

/// The spread (largest minus smallest) of the known samples at −1 along x, y and z of block-local
/// `(x, y, z)`: 0 with fewer than two known. The context of its residual (`range_coder`).
fn neighbour_spread(known: &[i64; BOX], [x, y, z]: [usize; 3]) -> u64 {
    let at = z * SIDE * SIDE + y * SIDE + x;
    let (mut lo, mut hi, mut n) = (i64::MAX, i64::MIN, 0);
    for (inside, offset) in [(x > 0, 1), (y > 0, SIDE), (z > 0, SIDE * SIDE)] {
        if inside && known[at - offset] >= 0 {
            lo = lo.min(known[at - offset]);
            hi = hi.max(known[at - offset]);
            n += 1;
        }
    }
    if n < 2 {
        0
    } else {
        (hi - lo) as u64
    }
}

//! Pass 2 of the extraction (paper §3.1): writes one block's metacells, cluster bounds and corner
//! records into its pre-sized, disjoint part of the output.
//!
//! Inside a block, metacells are visited in Morton order and, inside a metacell, cells in mask-bit
//! order, which together is the Morton order of the cells. Every 15 metacells close a cluster whose
//! 16th slot receives the bound; the last cluster is padded with empty (all-zero) slots.

use super::scalar::ExtractScalar;
use crate::layout::{
    ClusterBound, Metacell, Precision, BLOCK_CELLS, BLOCK_METACELLS, BOUND_SLOT, CLUSTER_METACELLS,
    CLUSTER_SLOTS,
};
use crate::morton;
use crate::quantize::Quantizer;

/// Per-thread scratch for one block.
pub(crate) struct BlockScratch {
    /// Inside bits per sample row (17 bits used), index `ly + 17·lz`.
    inside: [u32; 17 * 17],
    /// Active-cell mask per metacell, by Morton code.
    metacell_masks: [u8; BLOCK_METACELLS * BLOCK_METACELLS * BLOCK_METACELLS],
}

impl Default for BlockScratch {
    fn default() -> Self {
        BlockScratch {
            inside: [0; 17 * 17],
            metacell_masks: [0; 512],
        }
    }
}

/// Where one block's output goes.
pub(crate) struct BlockOutput<'a> {
    pub block: [usize; 3],
    /// Exactly the block's metacell slots (a multiple of 16).
    pub slots: &'a mut [Metacell],
    /// Exactly the block's corner records.
    pub cells: &'a mut [u8],
    /// Global index of the block's first active cell.
    pub first_cell: u32,
    /// The block where the caller's samples start: 0 for a whole volume, the slab's first layer
    /// (z) when streaming, a tile's first block in every axis. Sample (x, y, z) of the caller's
    /// samples is the volume's sample (x, y, z) - 16·`slab_block`.
    pub slab_block: [usize; 3],
}

/// Emits one block. The counts must match what pass 1 found (checked in debug builds).
pub(crate) fn emit_block<T: ExtractScalar>(
    samples: &[T],
    dims: [usize; 3],
    threshold: Option<T>,
    quantizer: &Quantizer,
    out: BlockOutput<'_>,
    scratch: &mut BlockScratch,
) {
    classify_block(samples, dims, out.block, out.slab_block, threshold, scratch);
    emit_classified_block(samples, dims, quantizer, out, scratch);
}

/// Sample offsets of block `block` inside samples that start at block `slab_block` (see
/// [`BlockOutput::slab_block`]), and the block's cells per axis.
fn block_extent(
    dims: [usize; 3],
    block: [usize; 3],
    slab_block: [usize; 3],
) -> ([usize; 3], [usize; 3]) {
    let origin = [0, 1, 2].map(|a| (block[a] - slab_block[a]) * BLOCK_CELLS);
    let cells = [0, 1, 2].map(|a| (dims[a] - 1 - origin[a]).min(BLOCK_CELLS));
    (origin, cells)
}

/// The first half of [`emit_block`]: the block's inside bits and Morton-ordered metacell masks,
/// into `scratch`. [`BlockScratch::counts`] then gives what pass 1 counts for the block.
pub(crate) fn classify_block<T: ExtractScalar>(
    samples: &[T],
    dims: [usize; 3],
    block: [usize; 3],
    slab_block: [usize; 3],
    threshold: Option<T>,
    scratch: &mut BlockScratch,
) {
    let [nx, ny, _] = dims;
    let (origin, cells) = block_extent(dims, block, slab_block);
    // The block's 17×17 sample rows are scattered over the volume and were last read in pass 1:
    // ask for all of them up front so the misses overlap instead of queueing behind each other.
    for lz in 0..=cells[2] {
        for ly in 0..=cells[1] {
            let start = origin[0] + nx * (origin[1] + ly + ny * (origin[2] + lz));
            super::prefetch_row(&samples[start..=start + cells[0]]);
        }
    }

    // Inside bits of the block's samples: 16 at a time where the block is full width.
    for lz in 0..=cells[2] {
        for ly in 0..=cells[1] {
            let start = origin[0] + nx * (origin[1] + ly + ny * (origin[2] + lz));
            let row = &samples[start..=start + cells[0]];
            let mut bits = 0u32;
            if let Some(t) = threshold {
                if let Some((chunk, rest)) = row.split_first_chunk::<16>() {
                    bits = T::mask_chunk(chunk, t) as u32;
                    for (i, &v) in rest.iter().enumerate() {
                        bits |= ((v >= t) as u32) << (16 + i);
                    }
                } else {
                    for (i, &v) in row.iter().enumerate() {
                        bits |= ((v >= t) as u32) << i;
                    }
                }
            }
            scratch.inside[ly + 17 * lz] = bits;
        }
    }

    // Active cells scattered into Morton-ordered metacell masks.
    scratch.metacell_masks.fill(0);
    let cell_bits = (1u32 << cells[0]) - 1;
    for cz in 0..cells[2] {
        for cy in 0..cells[1] {
            let ins = &scratch.inside;
            let (a, b, c, d) = (
                ins[cy + 17 * cz],
                ins[cy + 1 + 17 * cz],
                ins[cy + 17 * (cz + 1)],
                ins[cy + 1 + 17 * (cz + 1)],
            );
            let all_in = a & b & c & d;
            let any_in = a | b | c | d;
            let mut act = !(all_in & all_in >> 1) & (any_in | any_in >> 1) & cell_bits;
            while act != 0 {
                let cx = act.trailing_zeros();
                act &= act - 1;
                let code = morton::cell_code(cx, cy as u32, cz as u32);
                scratch.metacell_masks[(code >> 3) as usize] |= 1 << (code & 7);
            }
        }
    }
}

impl BlockScratch {
    /// Active cells and occupied metacells of the block last classified.
    pub(crate) fn counts(&self) -> (u32, u32) {
        self.metacell_masks
            .iter()
            .fold((0, 0), |(cells, occupied), &m| {
                (cells + m.count_ones(), occupied + (m != 0) as u32)
            })
    }
}

/// The second half of [`emit_block`]: writes the block `scratch` holds the classification of.
pub(crate) fn emit_classified_block<T: ExtractScalar>(
    samples: &[T],
    dims: [usize; 3],
    quantizer: &Quantizer,
    out: BlockOutput<'_>,
    scratch: &mut BlockScratch,
) {
    let [nx, ny, _] = dims;
    let (origin, _) = block_extent(dims, out.block, out.slab_block);
    let slab = nx * ny;
    // Metacells, bounds and corner records in Morton order.
    let block_mc = out.block.map(|b| (b * BLOCK_METACELLS) as u16);
    let record = quantizer.precision().bytes_per_cell();
    let exact_offset = quantizer.exact_integer_offset();
    let mut slot = 0usize;
    let mut cell = 0usize;
    let mut bound = ClusterBound {
        lo: [u16::MAX; 3],
        hi: [0; 3],
    };
    let close_cluster = |slots: &mut [Metacell], slot: &mut usize, bound: &mut ClusterBound| {
        let cluster_start = *slot - *slot % CLUSTER_SLOTS;
        *slot = cluster_start + BOUND_SLOT;
        slots[*slot] = bound.into_slot();
        *slot += 1;
        *bound = ClusterBound {
            lo: [u16::MAX; 3],
            hi: [0; 3],
        };
    };
    for code in 0..scratch.metacell_masks.len() as u32 {
        let mask = scratch.metacell_masks[code as usize];
        if mask == 0 {
            continue;
        }
        let local = morton::decode(code);
        let position = [0, 1, 2].map(|a| block_mc[a] + local[a] as u16);
        out.slots[slot] = Metacell {
            position,
            cell_mask: mask as u16,
            cell_pointer: out.first_cell + cell as u32,
        };
        for (a, &p) in position.iter().enumerate() {
            bound.lo[a] = bound.lo[a].min(p);
            bound.hi[a] = bound.hi[a].max(p);
        }
        slot += 1;

        let mut bits = mask;
        while bits != 0 {
            let b = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            // Cell position inside the block, then in the grid.
            let lx = 2 * local[0] as usize + (b & 1);
            let ly = 2 * local[1] as usize + (b >> 1 & 1);
            let lz = 2 * local[2] as usize + (b >> 2 & 1);
            let base = origin[0] + lx + nx * (origin[1] + ly + ny * (origin[2] + lz));
            let corners = &samples[base..=base + slab + nx + 1];
            let values: [T; 8] = [
                corners[0],
                corners[1],
                corners[nx],
                corners[nx + 1],
                corners[slab],
                corners[slab + 1],
                corners[slab + nx],
                corners[slab + nx + 1],
            ];
            let ins = &scratch.inside;
            let row_bits = |dy: usize, dz: usize| ins[ly + dy + 17 * (lz + dz)] >> lx & 3;
            let inside =
                (row_bits(0, 0) | row_bits(1, 0) << 2 | row_bits(0, 1) << 4 | row_bits(1, 1) << 6)
                    as u8;
            encode_cell(
                quantizer,
                exact_offset,
                &values,
                inside,
                &mut out.cells[cell * record..(cell + 1) * record],
            );
            cell += 1;
        }
        if slot % CLUSTER_SLOTS == CLUSTER_METACELLS {
            close_cluster(out.slots, &mut slot, &mut bound);
        }
    }
    if !slot.is_multiple_of(CLUSTER_SLOTS) {
        // Padding slots were zeroed when the output was allocated.
        close_cluster(out.slots, &mut slot, &mut bound);
    }
    debug_assert_eq!(
        slot,
        out.slots.len(),
        "pass 1 and pass 2 disagree on metacells"
    );
    debug_assert_eq!(
        cell * record,
        out.cells.len(),
        "pass 1 and pass 2 disagree on cells"
    );
}

/// Writes one corner record. Integer data stored exactly skips floating point altogether (the
/// common u8-at-8-bit and 16-bit cases); everything else goes through the quantiser.
#[inline]
fn encode_cell<T: ExtractScalar>(
    quantizer: &Quantizer,
    exact_offset: Option<i64>,
    values: &[T; 8],
    inside: u8,
    out: &mut [u8],
) {
    match (exact_offset, quantizer.precision()) {
        (Some(offset), Precision::Bits8) => {
            for c in 0..8 {
                out[c] = values[c].exact_code(offset) as u8;
            }
        }
        (Some(offset), Precision::Bits16) => {
            for c in 0..8 {
                out[2 * c..2 * c + 2]
                    .copy_from_slice(&(values[c].exact_code(offset) as u16).to_le_bytes());
            }
        }
        (_, Precision::Float32) => quantizer.encode_cell(&values.map(|v| v.to_f64()), inside, out),
        _ => match values.map(|v| v.as_u8()) {
            [Some(a), Some(b), Some(c), Some(d), Some(e), Some(f), Some(g), Some(h)] => {
                quantizer.encode_u8_cell(&[a, b, c, d, e, f, g, h], out)
            }
            _ => quantizer.encode_cell(&values.map(|v| v.to_f64()), inside, out),
        },
    }
}

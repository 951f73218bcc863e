//! Pass 1 of the extraction (paper §3.1): one sweep over the volume that finds, per 16³ block, its
//! value range and how many active cells and occupied metacells it holds — without storing anything
//! per voxel.
//!
//! Work is split into rows of blocks along x (fixed block y and z). For each of the (up to) 17×17
//! sample rows a block row spans, the samples are turned into an *inside* bitmask (one bit per
//! sample, `value >= iso`). A cell is active when the 8 corner bits are not all equal, which for a
//! whole row of cells at once is a handful of word-wide AND/OR/shift operations on the four sample
//! rows around it. Blocks whose cells are all on one side cost nothing beyond this sweep.

use super::scalar::ExtractScalar;
use crate::layout::BLOCK_CELLS;

/// What pass 1 learns about one block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BlockScan {
    pub min: f64,
    pub max: f64,
    pub active_cells: u32,
    pub occupied_metacells: u32,
}

/// Reusable per-thread buffers for one block row.
#[derive(Default)]
pub(crate) struct RowScratch {
    inside: Vec<u64>,
    active: Vec<u64>,
    row_min: Vec<f64>,
    row_max: Vec<f64>,
}

/// Inside bits of `row` into `out` (bit x of word x/64). Written for autovectorisation: 64 compares
/// fold into one word.
#[inline]
fn inside_mask<T: ExtractScalar>(row: &[T], threshold: Option<T>, out: &mut [u64]) {
    let Some(t) = threshold else {
        out.fill(0);
        return;
    };
    let mut chunks = row.chunks_exact(64);
    for (word, chunk) in out.iter_mut().zip(&mut chunks) {
        let mut m = 0u64;
        for (i, &v) in chunk.iter().enumerate() {
            m |= ((v >= t) as u64) << i;
        }
        *word = m;
    }
    let rest = chunks.remainder();
    if !rest.is_empty() {
        let mut m = 0u64;
        for (i, &v) in rest.iter().enumerate() {
            m |= ((v >= t) as u64) << i;
        }
        out[row.len() / 64] = m;
    }
}

/// Min and max of each block's 17-sample segment of `row` (NaN ignored), folded into `mins`/`maxs`.
#[inline]
fn segment_ranges<T: ExtractScalar>(row: &[T], mins: &mut [f64], maxs: &mut [f64]) {
    let last = row.len() - 1;
    for (bx, (lo_out, hi_out)) in mins.iter_mut().zip(maxs.iter_mut()).enumerate() {
        let start = bx * BLOCK_CELLS;
        let seg = &row[start..=(start + BLOCK_CELLS).min(last)];
        let (mut lo, mut hi) = (T::HIGHEST, T::LOWEST);
        for &v in seg {
            lo = if v < lo { v } else { lo };
            hi = if v > hi { v } else { hi };
        }
        *lo_out = lo_out.min(lo.to_f64());
        *hi_out = hi_out.max(hi.to_f64());
    }
}

/// Scans the block row (by, bz) of a volume with `dims` samples; returns one [`BlockScan`] per bx.
pub(crate) fn scan_block_row<T: ExtractScalar>(
    samples: &[T],
    dims: [usize; 3],
    by: usize,
    bz: usize,
    threshold: Option<T>,
    scratch: &mut RowScratch,
) -> Vec<BlockScan> {
    let [nx, ny, nz] = dims;
    let nbx = (nx - 1).div_ceil(BLOCK_CELLS);
    let words = nx.div_ceil(64);
    let y0 = by * BLOCK_CELLS;
    let z0 = bz * BLOCK_CELLS;
    let cells_y = (ny - 1 - y0).min(BLOCK_CELLS);
    let cells_z = (nz - 1 - z0).min(BLOCK_CELLS);
    let rows_y = cells_y + 1;

    scratch.inside.clear();
    scratch.inside.resize(words * rows_y * (cells_z + 1), 0);
    scratch.row_min.clear();
    scratch.row_min.resize(nbx, f64::INFINITY);
    scratch.row_max.clear();
    scratch.row_max.resize(nbx, f64::NEG_INFINITY);
    for lz in 0..=cells_z {
        for ly in 0..rows_y {
            let start = nx * (y0 + ly + ny * (z0 + lz));
            let row = &samples[start..start + nx];
            let r = (lz * rows_y + ly) * words;
            inside_mask(row, threshold, &mut scratch.inside[r..r + words]);
            segment_ranges(row, &mut scratch.row_min, &mut scratch.row_max);
        }
    }

    // Active cells of each cell row (cy, cz): corners disagree somewhere.
    let valid_cells_last_word = match (nx - 1) % 64 {
        0 => u64::MAX,
        r => (1u64 << r) - 1,
    };
    scratch.active.clear();
    scratch.active.resize(words * BLOCK_CELLS * BLOCK_CELLS, 0);
    let cell_words = (nx - 1).div_ceil(64);
    for cz in 0..cells_z {
        for cy in 0..cells_y {
            let row = |y: usize, z: usize| &scratch.inside[(z * rows_y + y) * words..][..words];
            let (a, b, c, d) = (
                row(cy, cz),
                row(cy + 1, cz),
                row(cy, cz + 1),
                row(cy + 1, cz + 1),
            );
            let out = &mut scratch.active[(cz * BLOCK_CELLS + cy) * words..][..words];
            for w in 0..cell_words {
                let all_in = a[w] & b[w] & c[w] & d[w];
                let any_in = a[w] | b[w] | c[w] | d[w];
                let (next_all, next_any) = if w + 1 < words {
                    let n = w + 1;
                    (a[n] & b[n] & c[n] & d[n], a[n] | b[n] | c[n] | d[n])
                } else {
                    (0, 0)
                };
                let all_in_right = all_in >> 1 | next_all << 63;
                let any_in_right = any_in >> 1 | next_any << 63;
                let mut act = !(all_in & all_in_right) & (any_in | any_in_right);
                if w + 1 == cell_words {
                    act &= valid_cells_last_word;
                }
                out[w] = act;
            }
        }
    }

    let active = &scratch.active;
    let segment = |cy: usize, cz: usize, bx: usize| -> u32 {
        let bit = bx * BLOCK_CELLS;
        ((active[(cz * BLOCK_CELLS + cy) * words + bit / 64] >> (bit % 64)) & 0xffff) as u32
    };
    (0..nbx)
        .map(|bx| {
            let mut active_cells = 0;
            let mut occupied_metacells = 0;
            for mz in 0..cells_z.div_ceil(2) {
                for my in 0..cells_y.div_ceil(2) {
                    let mut m = 0;
                    for (dy, dz) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (cy, cz) = (2 * my + dy, 2 * mz + dz);
                        if cy < cells_y && cz < cells_z {
                            let s = segment(cy, cz, bx);
                            active_cells += s.count_ones();
                            m |= s;
                        }
                    }
                    occupied_metacells += ((m | m >> 1) & 0x5555).count_ones();
                }
            }
            BlockScan {
                min: scratch.row_min[bx],
                max: scratch.row_max[bx],
                active_cells,
                occupied_metacells,
            }
        })
        .collect()
}

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
}

/// Per-block running minima and maxima of one block row, kept as 16 lanes per block so the
/// per-sample work is element-wise (vectorised) and lanes are folded once per block row.
struct LaneRanges<T> {
    lo: Vec<[T; 16]>,
    hi: Vec<[T; 16]>,
    /// Range of each block's 17th sample column (x = 16·bx + 16), shared with the next block.
    edge_lo: Vec<T>,
    edge_hi: Vec<T>,
}

impl<T: ExtractScalar> LaneRanges<T> {
    fn new(blocks: usize) -> Self {
        LaneRanges {
            lo: vec![[T::HIGHEST; 16]; blocks],
            hi: vec![[T::LOWEST; 16]; blocks],
            edge_lo: vec![T::HIGHEST; blocks],
            edge_hi: vec![T::LOWEST; blocks],
        }
    }
    /// (min, max) of block `bx` in the sample type, NaN ignored.
    fn block_native(&self, bx: usize) -> (T, T) {
        let fold = |init: T, lanes: &[T; 16], pick: fn(T, T) -> T| {
            lanes.iter().fold(init, |a, &b| pick(a, b))
        };
        let lo = fold(
            self.edge_lo[bx],
            &self.lo[bx],
            |a, b| if b < a { b } else { a },
        );
        let hi = fold(
            self.edge_hi[bx],
            &self.hi[bx],
            |a, b| if b > a { b } else { a },
        );
        (lo, hi)
    }
    /// (min, max) of block `bx` as f64 (rounded to nearest for 64-bit integers beyond 2^53).
    fn block(&self, bx: usize) -> (f64, f64) {
        let (lo, hi) = self.block_native(bx);
        (lo.to_f64(), hi.to_f64())
    }
}

/// One sample row: inside bits into `words` (bit x of word x/64, words zeroed by the caller) and
/// block ranges into `ranges`. Written so that each 16-sample chunk compiles to a few SIMD
/// instructions (compare to bitmask, lane-wise min and max).
#[inline]
fn scan_row<T: ExtractScalar>(
    row: &[T],
    threshold: Option<T>,
    words: &mut [u64],
    ranges: &mut LaneRanges<T>,
) {
    let t = threshold.unwrap_or(T::HIGHEST);
    let mut chunks = row.chunks_exact(16);
    for (c, chunk) in (&mut chunks).enumerate() {
        let chunk: &[T; 16] = chunk.try_into().unwrap();
        // nx / 16 full chunks never exceed the ceil((nx - 1) / 16) blocks, so chunk c is block c.
        let m = T::scan_chunk(chunk, t, &mut ranges.lo[c], &mut ranges.hi[c]) as u64;
        words[c / 4] |= m << (16 * (c % 4));
    }
    let full = row.len() / 16;
    for (i, &v) in chunks.remainder().iter().enumerate() {
        let x = 16 * full + i;
        words[x / 64] |= ((v >= t) as u64) << (x % 64);
        // A lone sample after the last full chunk is only the last block's edge (below).
        if let (Some(lo), Some(hi)) = (ranges.lo.get_mut(full), ranges.hi.get_mut(full)) {
            lo[i] = if v < lo[i] { v } else { lo[i] };
            hi[i] = if v > hi[i] { v } else { hi[i] };
        }
    }
    // The 17th sample of block bx is the first of chunk bx + 1.
    for bx in 0..ranges.edge_lo.len() {
        if let Some(&v) = row.get(16 * bx + 16) {
            ranges.edge_lo[bx] = if v < ranges.edge_lo[bx] {
                v
            } else {
                ranges.edge_lo[bx]
            };
            ranges.edge_hi[bx] = if v > ranges.edge_hi[bx] {
                v
            } else {
                ranges.edge_hi[bx]
            };
        }
    }
    if threshold.is_none() {
        words.fill(0);
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
    let mut ranges = LaneRanges::<T>::new(nbx);
    for lz in 0..=cells_z {
        for ly in 0..rows_y {
            let start = nx * (y0 + ly + ny * (z0 + lz));
            let row = &samples[start..start + nx];
            let r = (lz * rows_y + ly) * words;
            scan_row(
                row,
                threshold,
                &mut scratch.inside[r..r + words],
                &mut ranges,
            );
        }
    }

    // Blocks entirely on one side need no cell-level work. NaN (outside, but invisible to the
    // range) only allows the "all outside" shortcut. Compared in the sample type: as f64, a
    // 64-bit block minimum could round up onto the threshold.
    let uniform: Vec<bool> = (0..nbx)
        .map(|bx| {
            let (min, max) = ranges.block_native(bx);
            let all_outside = threshold.is_none_or(|t| max < t);
            let all_inside = !T::MAY_BE_NAN && threshold.is_some_and(|t| min >= t);
            all_outside || all_inside
        })
        .collect();
    if uniform.iter().all(|&u| u) {
        return (0..nbx)
            .map(|bx| {
                let (min, max) = ranges.block(bx);
                BlockScan {
                    min,
                    max,
                    active_cells: 0,
                    occupied_metacells: 0,
                }
            })
            .collect();
    }

    // Active cells of each cell row (cy, cz): corners disagree somewhere. Only the 64-bit words
    // that overlap a block with both sides present are computed.
    let valid_cells_last_word = match (nx - 1) % 64 {
        0 => u64::MAX,
        r => (1u64 << r) - 1,
    };
    let cell_words = (nx - 1).div_ceil(64);
    let needed: Vec<usize> = (0..cell_words)
        .filter(|&w| (4 * w..(4 * w + 4).min(nbx)).any(|bx| !uniform[bx]))
        .collect();
    scratch.active.clear();
    scratch.active.resize(words * BLOCK_CELLS * BLOCK_CELLS, 0);
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
            for &w in &needed {
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
            let (min, max) = ranges.block(bx);
            if uniform[bx] {
                return BlockScan {
                    min,
                    max,
                    active_cells: 0,
                    occupied_metacells: 0,
                };
            }
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
            let (min, max) = ranges.block(bx);
            BlockScan {
                min,
                max,
                active_cells,
                occupied_metacells,
            }
        })
        .collect()
}

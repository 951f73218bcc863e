//! Turns ray toggles into solid fine voxels, one fine z-slice at a time, with bit planes.
//!
//! Each fine voxel gets three inside/outside votes, one per ray axis: the parity of the toggles
//! before it along a ray from −∞ ([`super::raster`]). For a closed surface all three agree. A
//! scanned mesh with holes breaks parity only along rays that pass through a hole, and such a
//! ray's column has an odd total number of crossings, so we know it is unreliable: the vote is
//! taken among the axes whose column is closed (even total), and when those tie or none is, the
//! plain majority of all three decides.
//!
//! Storage is one bit per fine voxel of the *current* slice only: x-ray parity comes from a
//! prefix-XOR along each row, y-ray parity from a prefix-XOR down the rows, z-ray parity from a
//! plane carried from slice to slice. Memory is O(fine nx · fine ny / 8) bytes.

use rayon::prelude::*;

/// A 2D array of bits, rows of `words_per_row` u64 words; bit `x` of row `y` is voxel `(x, y)`.
#[derive(Clone)]
pub(super) struct BitPlane {
    words_per_row: usize,
    words: Vec<u64>,
}

impl BitPlane {
    pub(super) fn new(words_per_row: usize, rows: usize) -> Self {
        BitPlane {
            words_per_row,
            words: vec![0; words_per_row * rows],
        }
    }

    fn clear(&mut self) {
        self.words.fill(0);
    }

    fn toggle(&mut self, x: usize, y: usize) {
        self.words[y * self.words_per_row + x / 64] ^= 1 << (x % 64);
    }

    pub(super) fn row(&self, y: usize) -> &[u64] {
        &self.words[y * self.words_per_row..(y + 1) * self.words_per_row]
    }
}

/// Bit `i` of the result is the XOR of bits `0..=i` of `x`.
fn prefix_xor(mut x: u64) -> u64 {
    x ^= x << 1;
    x ^= x << 2;
    x ^= x << 4;
    x ^= x << 8;
    x ^= x << 16;
    x ^= x << 32;
    x
}

/// The vote for 64 voxels at once: `v*` are the three parities, `r*` say which are reliable.
fn vote(vx: u64, rx: u64, vy: u64, ry: u64, vz: u64, rz: u64) -> u64 {
    let (ix, iy, iz) = (vx & rx, vy & ry, vz & rz);
    let (ox, oy, oz) = (!vx & rx, !vy & ry, !vz & rz);
    // Bit-sliced 2-bit counts of reliable "inside" (c1 c0) and "outside" (d1 d0) votes.
    let c0 = ix ^ iy ^ iz;
    let c1 = (ix & iy) | (iz & (ix ^ iy));
    let d0 = ox ^ oy ^ oz;
    let d1 = (ox & oy) | (oz & (ox ^ oy));
    let more_inside = (c1 & !d1) | (!(c1 ^ d1) & c0 & !d0);
    let tie = !(c1 ^ d1) & !(c0 ^ d0);
    let majority = (vx & vy) | (vz & (vx ^ vy));
    more_inside | (tie & majority)
}

/// Per-voxel decisions for consecutive fine z-slices of a grid `fine = [nx, ny, nz]` (fine
/// voxels). Toggle coordinates may equal the grid size on the ray axis (a crossing beyond the
/// last centre): such toggles change no voxel but count towards the column's total parity.
pub(super) struct SliceVoter {
    nx: usize,
    ny: usize,
    words_per_row: usize,
    /// X-ray toggles of the current slice (nx + 1 bits per row, ny rows).
    x_toggles: BitPlane,
    /// Y-ray toggles, then parities, of the current slice (ny + 1 rows; the last is the total).
    y_parity: BitPlane,
    /// Z-ray parity up to the current slice.
    z_parity: BitPlane,
    /// Z-ray total parity per column, from [`SliceVoter::add_z_total`].
    z_total: BitPlane,
}

impl SliceVoter {
    pub(super) fn new(fine: [usize; 3]) -> Self {
        let [nx, ny, _] = fine;
        let words_per_row = (nx + 1).div_ceil(64);
        SliceVoter {
            nx,
            ny,
            words_per_row,
            x_toggles: BitPlane::new(words_per_row, ny),
            y_parity: BitPlane::new(words_per_row, ny + 1),
            z_parity: BitPlane::new(words_per_row, ny),
            z_total: BitPlane::new(words_per_row, ny),
        }
    }

    pub(super) fn words_per_row(&self) -> usize {
        self.words_per_row
    }

    /// A plane shaped for [`SliceVoter::decide_slice`]'s output.
    pub(super) fn new_plane(&self) -> BitPlane {
        BitPlane::new(self.words_per_row, self.ny)
    }

    /// Records a z-ray crossing of column `(x, y)` for the total parity (any order, before the
    /// first slice is decided).
    pub(super) fn add_z_total(&mut self, x: usize, y: usize) {
        self.z_total.toggle(x, y);
    }

    /// Decides the next fine slice. `x_toggles`, `y_toggles` and `z_toggles` are the `(x, y)`
    /// toggle positions of this slice for rays along x, y and z. Writes one bit per voxel to
    /// `out` (1 = solid); bits past `nx` are zero.
    pub(super) fn decide_slice(
        &mut self,
        x_toggles: impl Iterator<Item = (usize, usize)>,
        y_toggles: impl Iterator<Item = (usize, usize)>,
        z_toggles: impl Iterator<Item = (usize, usize)>,
        out: &mut BitPlane,
    ) {
        self.x_toggles.clear();
        for (x, y) in x_toggles {
            self.x_toggles.toggle(x, y);
        }
        self.y_parity.clear();
        for (x, y) in y_toggles {
            self.y_parity.toggle(x, y);
        }
        let w = self.words_per_row;
        for y in 1..=self.ny {
            let (done, rest) = self.y_parity.words.split_at_mut(y * w);
            for (cur, prev) in rest[..w].iter_mut().zip(&done[(y - 1) * w..]) {
                *cur ^= prev;
            }
        }
        for (x, y) in z_toggles {
            self.z_parity.toggle(x, y);
        }

        let nx = self.nx;
        let last_word_mask = |i: usize| {
            let bits = nx.saturating_sub(i * 64).min(64);
            if bits == 64 {
                !0
            } else {
                (1u64 << bits) - 1
            }
        };
        let y_total = self.y_parity.row(self.ny);
        let (x_toggles, y_parity, z_parity, z_total) = (
            &self.x_toggles,
            &self.y_parity,
            &self.z_parity,
            &self.z_total,
        );
        out.words
            .par_chunks_mut(w)
            .enumerate()
            .with_min_len(16)
            .for_each_init(
                || vec![0u64; w],
                |x_parity, (y, out_row)| {
                    let mut carry = 0u64;
                    for (p, &t) in x_parity.iter_mut().zip(x_toggles.row(y)) {
                        *p = if t == 0 { carry } else { prefix_xor(t) ^ carry };
                        carry = 0u64.wrapping_sub(*p >> 63);
                    }
                    // The x-ray's total parity is its parity after the last toggle slot, nx.
                    let x_open = (x_parity[nx / 64] >> (nx % 64)) & 1;
                    let rx = 0u64.wrapping_sub(1 - x_open);
                    let (vy, vz, z_open) = (y_parity.row(y), z_parity.row(y), z_total.row(y));
                    for (i, o) in out_row.iter_mut().enumerate() {
                        let (x, y, z) = (x_parity[i], vy[i], vz[i]);
                        // Agreement (empty space, solid interior) needs no vote.
                        let solid = if (x ^ y) | (y ^ z) == 0 {
                            x
                        } else {
                            vote(x, rx, y, !y_total[i], z, !z_open[i])
                        };
                        *o = solid & last_word_mask(i);
                    }
                },
            );
    }
}

/// Scratch space for [`coverage_row`], one per worker.
pub(super) struct CoverageScratch {
    all: Vec<u64>,
    any: Vec<u64>,
}

impl CoverageScratch {
    pub(super) fn new(words_per_row: usize) -> Self {
        CoverageScratch {
            all: vec![0; words_per_row],
            any: vec![0; words_per_row],
        }
    }
}

/// The `len ≤ 64` bits of `words` starting at bit `start`, in the low bits.
fn bit_field(words: &[u64], start: usize, len: usize) -> u64 {
    let (w, off) = (start / 64, start % 64);
    let mut bits = words[w] >> off;
    if off + len > 64 {
        bits |= words[w + 1] << (64 - off);
    }
    if len == 64 {
        bits
    } else {
        bits & ((1u64 << len) - 1)
    }
}

/// Coverage of one output row: output voxel `i` of row `j` covers fine voxels
/// `[i·s, (i+1)·s) × [j·s, (j+1)·s)` of each of the `s` planes. Writes `round(255 · solid / s³)`.
///
/// Most of a volume is empty or solid: the AND and OR of the `s²` fine rows settle whole words at
/// once, and fine bits are counted only for samples on the surface.
pub(super) fn coverage_row(
    planes: &[BitPlane],
    j: usize,
    scratch: &mut CoverageScratch,
    out: &mut [u8],
) {
    let s = planes.len();
    let fine_rows = || {
        planes
            .iter()
            .flat_map(move |plane| (j * s..(j + 1) * s).map(move |fy| plane.row(fy)))
    };
    scratch.all.fill(!0);
    scratch.any.fill(0);
    for row in fine_rows() {
        for ((all, any), &word) in scratch.all.iter_mut().zip(scratch.any.iter_mut()).zip(row) {
            *all &= word;
            *any |= word;
        }
    }
    let full = (s * s * s) as u32;
    let exact = |start: usize| {
        let count: u32 = fine_rows()
            .map(|row| bit_field(row, start, s).count_ones())
            .sum();
        ((count * 255 + full / 2) / full) as u8
    };
    let field_mask = if s == 64 { !0 } else { (1u64 << s) - 1 };
    let (all, any) = (&scratch.all, &scratch.any);
    let sample = |start: usize| {
        if bit_field(any, start, s) == 0 {
            0
        } else if bit_field(all, start, s) == field_mask {
            255
        } else {
            exact(start)
        }
    };
    let nx = out.len();
    let mut i = 0;
    while i < nx {
        let word = i * s / 64;
        // Samples whose fine bits all lie in this word.
        let end = ((word + 1) * 64 / s).min(nx);
        if end <= i {
            out[i] = sample(i * s);
            i += 1;
        } else if any[word] == 0 {
            out[i..end].fill(0);
            i = end;
        } else if all[word] == !0 {
            out[i..end].fill(255);
            i = end;
        } else {
            for (o, n) in out[i..end].iter_mut().zip(i..end) {
                *o = sample(n * s);
            }
            i = end;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefix_xor_is_a_running_parity() {
        let x = 0b1001_0100u64;
        let expected = (0..64).fold(0u64, |acc, i| {
            let parity = (x & ((2u64 << i).wrapping_sub(1))).count_ones() as u64 & 1;
            acc | (parity << i)
        });
        assert_eq!(prefix_xor(x), expected);
        assert_eq!(prefix_xor(1), !0);
    }

    /// The bit-sliced vote against the rule written out case by case.
    #[test]
    fn vote_matches_reference() {
        for case in 0..64u64 {
            let bit = |k: u32| (case >> k) & 1;
            let (v, r) = ([bit(0), bit(1), bit(2)], [bit(3), bit(4), bit(5)]);
            let inside = (0..3).filter(|&a| r[a] == 1 && v[a] == 1).count();
            let outside = (0..3).filter(|&a| r[a] == 1 && v[a] == 0).count();
            let majority = v.iter().sum::<u64>() >= 2;
            let expected = inside > outside || (inside == outside && majority);
            let mask = |b: u64| 0u64.wrapping_sub(b);
            let got = vote(
                mask(v[0]),
                mask(r[0]),
                mask(v[1]),
                mask(r[1]),
                mask(v[2]),
                mask(r[2]),
            );
            assert_eq!(got, mask(expected as u64), "v {v:?} r {r:?}");
        }
    }

    /// A 3×2×2-voxel solid box in a 70×4×4 grid (wide enough to span two words): toggles where
    /// each ray enters and leaves it.
    #[test]
    fn box_from_toggles() {
        let fine = [70, 4, 4];
        let (x0, x1, y0, y1, z0, z1) = (62, 65, 1, 3, 1, 3);
        let mut voter = SliceVoter::new(fine);
        for x in x0..x1 {
            for y in y0..y1 {
                voter.add_z_total(x, y);
                voter.add_z_total(x, y);
            }
        }
        let mut plane = voter.new_plane();
        for z in 0..4 {
            let in_z = (z0..z1).contains(&z);
            let xt: Vec<_> = (y0..y1)
                .filter(|_| in_z)
                .flat_map(|y| [(x0, y), (x1, y)])
                .collect();
            let yt: Vec<_> = (x0..x1)
                .filter(|_| in_z)
                .flat_map(|x| [(x, y0), (x, y1)])
                .collect();
            let zt: Vec<_> = if z == z0 || z == z1 {
                (x0..x1)
                    .flat_map(|x| (y0..y1).map(move |y| (x, y)))
                    .collect()
            } else {
                Vec::new()
            };
            voter.decide_slice(xt.into_iter(), yt.into_iter(), zt.into_iter(), &mut plane);
            for y in 0..4 {
                for x in 0..70 {
                    let solid = (plane.row(y)[x / 64] >> (x % 64)) & 1 == 1;
                    let expected = in_z && (x0..x1).contains(&x) && (y0..y1).contains(&y);
                    assert_eq!(solid, expected, "({x},{y},{z})");
                }
            }
        }
    }

    /// Rays that enter but never leave (holes in the far wall) lose to a closed one even when
    /// they are two against one: plain majority would call these voxels solid.
    #[test]
    fn open_columns_are_outvoted_by_closed_ones() {
        let mut voter = SliceVoter::new([8, 1, 1]);
        let mut plane = voter.new_plane();
        // The x-ray enters at 2, the y-rays enter at row 0 of every column; neither leaves.
        let y_entries: Vec<_> = (0..8).map(|x| (x, 0)).collect();
        voter.decide_slice(
            [(2, 0)].into_iter(),
            y_entries.into_iter(),
            std::iter::empty(),
            &mut plane,
        );
        assert_eq!(plane.row(0)[0], 0);
    }

    #[test]
    fn coverage_counts_fine_voxels() {
        // s = 2: two planes of 4×2 fine voxels → output row of 2 voxels.
        let mut planes = vec![BitPlane::new(1, 2), BitPlane::new(1, 2)];
        planes[0].words = vec![0b0011, 0b0001];
        planes[1].words = vec![0b0111, 0b1000];
        let mut out = vec![0u8; 2];
        coverage_row(&planes, 0, &mut CoverageScratch::new(1), &mut out);
        // Voxel 0: fine x 0..2 → 2 + 1 + 2 + 0 = 5 of 8; voxel 1: 0 + 0 + 1 + 1 = 2 of 8.
        assert_eq!(out, vec![159, 64]);
    }
}

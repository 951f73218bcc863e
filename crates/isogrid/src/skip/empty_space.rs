//! Symmetric empty-space distances for a block DDA: for every 16³-cell block, the Chebyshev (L∞)
//! distance, in blocks, to the nearest block that holds active cells.
//!
//! A block at distance `d ≥ 1` sits at the centre of a cube of `(2d − 1)³` blocks that are all
//! empty, so a ray inside it can leap straight to where it leaves that cube instead of stepping
//! block by block (distance-map space skipping in the manner of Cohen & Sheffer 1994, "Proximity
//! clouds"): one byte per block, built in two chamfer passes.
//!
//! Neither tracer leaps by it any more: both use [`super::octant_space`], whose cubes start at the
//! block and grow towards the ray's octant only, so they reach further ahead (a ray that misses
//! the dragon makes 2.3 block moves instead of 4.2). This map stays as the reference the
//! tests hold the octant map's leaps against.

use crate::layout::Block;

/// Distances saturate here; a saturated entry still promises `MAX_DISTANCE − 1` empty blocks
/// around it, which is all a leap needs.
pub const MAX_DISTANCE: u8 = u8::MAX;

/// Per-block Chebyshev distance to the nearest non-empty block (0 for non-empty blocks), blocks
/// outside the grid counting as empty. Indexed like the block array: `x + nx·(y + ny·z)`.
#[derive(Debug, Clone)]
pub struct EmptySpaceMap {
    distance: Vec<u8>,
}

impl EmptySpaceMap {
    /// Builds the map for `blocks` laid out on `dims` blocks (x fastest).
    ///
    /// # Panics
    /// When `blocks.len()` is not the product of `dims` (a [`crate::CellGrid`] guarantees it).
    pub fn new(blocks: &[Block], dims: [usize; 3]) -> Self {
        assert_eq!(
            blocks.len(),
            dims[0] * dims[1] * dims[2],
            "one block per grid position"
        );
        let [nx, ny, nz] = dims;
        let mut distance: Vec<u8> = blocks
            .iter()
            .map(|b| {
                if b.metacell_count > 0 {
                    0
                } else {
                    MAX_DISTANCE
                }
            })
            .collect();
        // The chessboard distance is exactly what a two-pass chamfer transform with unit weights
        // over all 26 neighbours computes (Rosenfeld & Pfaltz 1966): a forward raster pass looks
        // at the 13 neighbours already visited, a backward pass at the other 13.
        let index = |x: usize, y: usize, z: usize| x + nx * (y + ny * z);
        let relax = |x: usize, y: usize, z: usize, backward: bool, distance: &mut [u8]| {
            let here = index(x, y, z);
            if distance[here] == 0 {
                return;
            }
            let mut best = distance[here];
            for (dx, dy, dz) in HALF_NEIGHBOURHOOD {
                let (dx, dy, dz) = if backward {
                    (-dx, -dy, -dz)
                } else {
                    (dx, dy, dz)
                };
                let (Some(px), Some(py), Some(pz)) = (
                    x.checked_add_signed(dx).filter(|&v| v < nx),
                    y.checked_add_signed(dy).filter(|&v| v < ny),
                    z.checked_add_signed(dz).filter(|&v| v < nz),
                ) else {
                    continue;
                };
                best = best.min(distance[index(px, py, pz)].saturating_add(1));
            }
            distance[here] = best;
        };
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    relax(x, y, z, false, &mut distance);
                }
            }
        }
        for z in (0..nz).rev() {
            for y in (0..ny).rev() {
                for x in (0..nx).rev() {
                    relax(x, y, z, true, &mut distance);
                }
            }
        }
        EmptySpaceMap { distance }
    }

    /// The distance of block `index` (0: it holds active cells).
    #[inline(always)]
    pub fn distance(&self, index: usize) -> u8 {
        self.distance[index]
    }

    /// Bytes the map occupies.
    pub fn bytes(&self) -> usize {
        self.distance.len()
    }
}

/// The 13 neighbours that precede a block in x-fastest raster order (the forward chamfer mask);
/// negated, the 13 that follow it.
const HALF_NEIGHBOURHOOD: [(isize, isize, isize); 13] = [
    (-1, -1, -1),
    (0, -1, -1),
    (1, -1, -1),
    (-1, 0, -1),
    (0, 0, -1),
    (1, 0, -1),
    (-1, 1, -1),
    (0, 1, -1),
    (1, 1, -1),
    (-1, -1, 0),
    (0, -1, 0),
    (1, -1, 0),
    (-1, 0, 0),
];

/// Test support shared with `octant_space`'s tests: random block occupancies.
#[cfg(test)]
pub(super) mod test_blocks {
    use crate::layout::Block;

    /// A block with slots when `occupied`, else an empty one.
    pub fn block(occupied: bool) -> Block {
        Block {
            metacell_count: if occupied { 16 } else { 0 },
            metacell_pointer: 0,
            min: 0.0,
            max: 0.0,
        }
    }

    /// Each of the `dims` blocks occupied with probability `density` (xorshift from `state`):
    /// the occupancy and the blocks.
    pub fn random_blocks(
        dims: [usize; 3],
        density: f64,
        state: &mut u64,
    ) -> (Vec<bool>, Vec<Block>) {
        let occupied: Vec<bool> = (0..dims.iter().product())
            .map(|_| {
                *state ^= *state << 13;
                *state ^= *state >> 7;
                *state ^= *state << 17;
                (*state % 1000) as f64 / 1000.0 < density
            })
            .collect();
        let blocks = occupied.iter().map(|&o| block(o)).collect();
        (occupied, blocks)
    }
}

#[cfg(test)]
mod tests {
    use super::test_blocks::{block, random_blocks};
    use super::*;

    /// Brute force over all pairs, with the same saturation.
    fn brute_force(occupied: &[bool], dims: [usize; 3]) -> Vec<u8> {
        let [nx, ny, _] = dims;
        let position = |i: usize| [i % nx, (i / nx) % ny, i / (nx * ny)];
        (0..occupied.len())
            .map(|i| {
                let p = position(i);
                occupied
                    .iter()
                    .enumerate()
                    .filter(|(_, &o)| o)
                    .map(|(j, _)| {
                        let q = position(j);
                        (0..3).map(|a| p[a].abs_diff(q[a])).max().unwrap()
                    })
                    .min()
                    .map_or(MAX_DISTANCE, |d| d.min(MAX_DISTANCE as usize) as u8)
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_on_random_occupancy() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for (dims, density) in [([7, 5, 9], 0.05), ([12, 3, 4], 0.2), ([6, 6, 6], 0.01)] {
            let (occupied, blocks) = random_blocks(dims, density, &mut state);
            let map = EmptySpaceMap::new(&blocks, dims);
            let expected = brute_force(&occupied, dims);
            for (i, &e) in expected.iter().enumerate() {
                assert_eq!(map.distance(i), e, "block {i} of {dims:?}");
            }
        }
    }

    #[test]
    fn saturates_when_everything_is_empty() {
        let blocks = vec![block(false); 8];
        let map = EmptySpaceMap::new(&blocks, [2, 2, 2]);
        assert!((0..8).all(|i| map.distance(i) == MAX_DISTANCE));
    }
}

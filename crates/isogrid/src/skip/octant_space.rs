//! Directional empty-space skipping for the tracers' block DDAs (`block_walk.rs` in
//! `isogrid-trace`, `trace.wgsl` in `isogrid-gpu`): for every 16³-cell block and each of the
//! eight ray octants, the side (in blocks) of the largest cube of empty blocks that has the block
//! as its corner and extends towards that octant.
//!
//! The symmetric [`EmptySpaceMap`] promises a cube centred on the block, so a ray can only leap
//! `d − 1` blocks ahead however far the empty space reaches in its direction: a block just beside
//! the surface (distance 1) gives no leap at all, even to a ray moving away from it. A ray only
//! ever moves towards its own octant, so the cube it may leap across can start at its block and
//! grow forwards only. The side is at least the symmetric distance, and usually much more near
//! the surface. This is the 3D form of the largest-empty-square recurrence: the cube of side `s` at
//! `p` is empty iff `p` is and the seven cubes of side `s − 1` at `p`'s forward neighbours are.
//!
//! 8 bytes per block. Blocks outside the grid count as empty, as in [`EmptySpaceMap`].
//!
//! [`EmptySpaceMap`]: super::empty_space::EmptySpaceMap

use crate::layout::Block;

/// Sides saturate here; a saturated side still promises a cube of that many empty blocks.
pub const MAX_SIDE: u8 = u8::MAX;

/// Per octant, per block: the side of the largest empty cube with the block at its corner towards
/// that octant (0 for a non-empty block). Octant `o` has bit `a` set when the ray runs towards
/// +axis `a` (direction ≥ 0); blocks are indexed like the block array, `x + nx·(y + ny·z)`.
#[derive(Debug, Clone)]
pub struct OctantSpaceMap {
    /// Eight maps one after another, so that one ray reads only its own octant's bytes.
    sides: Vec<u8>,
    blocks: usize,
}

impl OctantSpaceMap {
    /// Builds the map for `blocks` laid out on `dims` blocks (x fastest), in time linear in the
    /// block count.
    ///
    /// # Panics
    /// When `blocks.len()` is not the product of `dims` (a [`crate::CellGrid`] guarantees it).
    pub fn new(blocks: &[Block], dims: [usize; 3]) -> Self {
        let count = dims[0] * dims[1] * dims[2];
        assert_eq!(blocks.len(), count, "one block per grid position");
        let mut sides = vec![0u8; 8 * count];
        for (octant, map) in sides.chunks_exact_mut(count.max(1)).enumerate().take(8) {
            fill_octant(blocks, dims, octant, map);
        }
        OctantSpaceMap {
            sides,
            blocks: count,
        }
    }

    /// The sides of every block for rays in `octant` (see [`OctantSpaceMap`]).
    #[inline(always)]
    pub fn octant(&self, octant: usize) -> &[u8] {
        let start = (octant & 7) * self.blocks;
        &self.sides[start..start + self.blocks]
    }

    /// Bytes the map occupies.
    pub fn bytes(&self) -> usize {
        self.sides.len()
    }
}

/// One octant's sides: blocks are visited from the octant's far corner back, so each block's seven
/// forward neighbours are final before it.
fn fill_octant(blocks: &[Block], dims: [usize; 3], octant: usize, map: &mut [u8]) {
    let [nx, ny, nz] = dims;
    let forward = [octant & 1 != 0, octant & 2 != 0, octant & 4 != 0];
    let order = |n: usize, forward: bool| -> Box<dyn Iterator<Item = usize>> {
        if forward {
            Box::new((0..n).rev())
        } else {
            Box::new(0..n)
        }
    };
    let ahead = |v: usize, n: usize, forward: bool| -> Option<usize> {
        if forward {
            (v + 1 < n).then_some(v + 1)
        } else {
            v.checked_sub(1)
        }
    };
    for z in order(nz, forward[2]) {
        for y in order(ny, forward[1]) {
            for x in order(nx, forward[0]) {
                let here = x + nx * (y + ny * z);
                if blocks[here].metacell_count > 0 {
                    map[here] = 0;
                    continue;
                }
                let mut smallest = MAX_SIDE;
                for e in 1..8usize {
                    let step = |v: usize, n: usize, a: usize| {
                        if e >> a & 1 == 1 {
                            ahead(v, n, forward[a])
                        } else {
                            Some(v)
                        }
                    };
                    // Outside the grid everything is empty: no limit from that neighbour.
                    if let (Some(px), Some(py), Some(pz)) =
                        (step(x, nx, 0), step(y, ny, 1), step(z, nz, 2))
                    {
                        smallest = smallest.min(map[px + nx * (py + ny * pz)]);
                    }
                }
                map[here] = smallest.saturating_add(1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skip::empty_space::test_blocks::{block, random_blocks};

    /// Brute force over all pairs: an occupied block `q` ahead of `p` in the octant (offsets
    /// `≥ 0` on every axis) lies in every cube from `p` whose side exceeds its largest offset.
    fn brute_force(occupied: &[bool], dims: [usize; 3], octant: usize) -> Vec<u8> {
        let [nx, ny, _] = dims;
        let position = |i: usize| [i % nx, (i / nx) % ny, i / (nx * ny)];
        (0..occupied.len())
            .map(|i| {
                let p = position(i);
                occupied
                    .iter()
                    .enumerate()
                    .filter(|(_, &o)| o)
                    .filter_map(|(j, _)| {
                        let q = position(j);
                        let offsets = [0, 1, 2].map(|a| {
                            if octant >> a & 1 == 1 {
                                q[a] as i64 - p[a] as i64
                            } else {
                                p[a] as i64 - q[a] as i64
                            }
                        });
                        offsets
                            .iter()
                            .all(|&o| o >= 0)
                            .then(|| *offsets.iter().max().unwrap())
                    })
                    .min()
                    .map_or(MAX_SIDE, |d| d.min(MAX_SIDE as i64) as u8)
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_on_random_occupancy() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for (dims, density) in [([7, 5, 9], 0.05), ([12, 3, 4], 0.2), ([6, 6, 6], 0.01)] {
            let (occupied, blocks) = random_blocks(dims, density, &mut state);
            let map = OctantSpaceMap::new(&blocks, dims);
            for octant in 0..8 {
                let expected = brute_force(&occupied, dims, octant);
                let got = map.octant(octant);
                for (i, &e) in expected.iter().enumerate() {
                    assert_eq!(got[i], e, "block {i} octant {octant} of {dims:?}");
                }
            }
        }
    }

    #[test]
    fn one_occupied_block_limits_each_octant_from_its_own_side() {
        // 5×5×5 blocks with only the centre occupied: the corner block (0, 0, 0) reaches 2 blocks
        // towards +x+y+z, and nothing stops it towards any octant that points away.
        let mut blocks = vec![block(false); 125];
        blocks[2 + 5 * (2 + 5 * 2)] = block(true);
        let map = OctantSpaceMap::new(&blocks, [5, 5, 5]);
        assert_eq!(map.octant(7)[0], 2);
        assert!((0..7).all(|o| map.octant(o)[0] == MAX_SIDE));
        assert_eq!(map.octant(7)[2 + 5 * (2 + 5 * 2)], 0);
        assert_eq!(map.octant(0)[4 + 5 * (4 + 5 * 4)], 2);
    }
}

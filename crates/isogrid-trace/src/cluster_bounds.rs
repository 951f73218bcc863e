//! A compact copy of the cluster bounds (paper §3.1: slot 15 of every cluster) for the
//! block walk ([`crate::Tracer`]): 4 bytes per cluster, a block's clusters side by side.
//!
//! In the packed layout a block's cluster bounds lie 192 bytes apart, so testing them all touched
//! one cache line per cluster, and a ray near the surface tests a few blocks' worth. Packed, a
//! block's (at most 35) bounds take at most 140 bytes. A bound is stored relative to its block
//! (which spans 8 metacells per axis), 3 bits per field:
//!
//! | bits | field |
//! |---|---|
//! | 0–8 | `lo` x, y, z: smallest metacell position minus the block's first, 3 bits each |
//! | 9–17 | `hi` x, y, z: largest (inclusive), likewise |
//! | 18–31 | zero |

use isogrid::layout::{Block, Metacell, BLOCK_METACELLS, BOUND_SLOT, CLUSTER_SLOTS};

/// An empty box (`lo` = 7 > `hi` = 0 on every axis), for lanes past a block's last cluster.
const EMPTY: u32 = 0o777;

/// See the module docs. Indexed by global cluster index (first slot / 16).
#[derive(Debug, Clone)]
pub struct PackedClusterBounds {
    bounds: Vec<u32>,
}

impl PackedClusterBounds {
    /// Packs the bound of every cluster of `blocks` (laid out on `block_dims`, x fastest).
    pub fn new(blocks: &[Block], metacells: &[Metacell], block_dims: [usize; 3]) -> Self {
        let mut bounds = vec![EMPTY; metacells.len() / CLUSTER_SLOTS];
        let [nx, ny, _] = block_dims;
        for (index, block) in blocks.iter().enumerate() {
            let origin = [index % nx, index / nx % ny, index / (nx * ny)]
                .map(|b| (b * BLOCK_METACELLS) as i64);
            let Some(slots) = metacells.get(block.slots()) else {
                continue;
            };
            let first = block.metacell_pointer as usize / CLUSTER_SLOTS;
            for (c, cluster) in slots.chunks_exact(CLUSTER_SLOTS).enumerate() {
                let bound = cluster[BOUND_SLOT].as_bound();
                // Clamped to the block: a cluster never leaves its block.
                let local = |v: u16, a: usize| {
                    (v as i64 - origin[a]).clamp(0, BLOCK_METACELLS as i64 - 1) as u32
                };
                let mut packed = 0;
                for a in 0..3 {
                    packed |= local(bound.lo[a], a) << (3 * a);
                    packed |= local(bound.hi[a], a) << (9 + 3 * a);
                }
                if let Some(b) = bounds.get_mut(first + c) {
                    *b = packed;
                }
            }
        }
        PackedClusterBounds { bounds }
    }

    /// The packed bounds of `block`'s clusters (empty when the block's slots are out of range).
    #[inline(always)]
    pub fn of_block(&self, block: &Block) -> &[u32] {
        let first = block.metacell_pointer as usize / CLUSTER_SLOTS;
        let count = block.metacell_count as usize / CLUSTER_SLOTS;
        self.bounds.get(first..first + count).unwrap_or(&[])
    }

    /// Bytes the copy occupies.
    pub fn bytes(&self) -> usize {
        self.bounds.len() * 4
    }
}

/// Clusters `first..first + 4` of `packed` (lanes past its end are empty boxes) as `lo` and `hi`
/// metacell positions per axis in f32 lanes, `origin` being the block's first metacell.
#[inline(always)]
pub fn unpack4(packed: &[u32], first: usize, origin: [f32; 3]) -> ([[f32; 4]; 3], [[f32; 4]; 3]) {
    let lanes: [u32; 4] = match packed.get(first..first + 4) {
        Some(whole) => whole.try_into().unwrap_or([EMPTY; 4]),
        None => std::array::from_fn(|k| packed.get(first + k).copied().unwrap_or(EMPTY)),
    };
    let mut lo = [[0f32; 4]; 3];
    let mut hi = [[0f32; 4]; 3];
    for a in 0..3 {
        for k in 0..4 {
            lo[a][k] = origin[a] + (lanes[k] >> (3 * a) & 7) as f32;
            hi[a][k] = origin[a] + (lanes[k] >> (9 + 3 * a) & 7) as f32;
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unpacks_the_bounds_it_packed() {
        // One block at block position (1, 0, 2) of a 2×1×3 block grid holding two clusters.
        let origin = [8u16, 0, 16];
        let mut metacells = vec![<Metacell as bytemuck::Zeroable>::zeroed(); 2 * CLUSTER_SLOTS];
        let bounds = [([9, 0, 17], [15, 3, 16]), ([8, 7, 23], [8, 7, 23])];
        for (c, (lo, hi)) in bounds.iter().enumerate() {
            metacells[c * CLUSTER_SLOTS + BOUND_SLOT] =
                isogrid::layout::ClusterBound { lo: *lo, hi: *hi }.into_slot();
        }
        let mut blocks = vec![<Block as bytemuck::Zeroable>::zeroed(); 6];
        blocks[1 + 2 * 2] = Block {
            metacell_count: 2 * CLUSTER_SLOTS as u32,
            metacell_pointer: 0,
            min: 0.0,
            max: 1.0,
        };
        let packed = PackedClusterBounds::new(&blocks, &metacells, [2, 1, 3]);
        let of_block = packed.of_block(&blocks[5]);
        assert_eq!(of_block.len(), 2);
        let (lo, hi) = unpack4(of_block, 0, origin.map(|v| v as f32));
        for (c, (l, h)) in bounds.iter().enumerate() {
            for a in 0..3 {
                assert_eq!(lo[a][c], l[a] as f32, "cluster {c} axis {a}");
                assert_eq!(hi[a][c], h[a] as f32, "cluster {c} axis {a}");
            }
        }
        // Lanes past the end are empty boxes.
        assert!((0..3).all(|a| lo[a][2] > hi[a][2] && lo[a][3] > hi[a][3]));
    }
}

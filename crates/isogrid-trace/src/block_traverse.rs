//! The block walk, the paper's traversal of clustered grid cells (§3.6): a 3D DDA over the dense
//! 16³-cell block grid, which leaps across empty space with an [`OctantSpaceMap`]
//! (`block_walk.rs`); inside a non-empty block every cluster bound (slot 15, read from a packed
//! copy, [`PackedClusterBounds`]), then each entered cluster's metacell boxes (from a 64-byte
//! record per cluster, eight at a time with AVX2 or four with SSE2, `cluster_boxes.rs` and
//! `lanes.rs`), are tested with the slab test (as §3.2); a candidate metacell's active cells are
//! visited nearest first by crossing its three mid-planes, and searched for the isosurface
//! crossing ([`crate::crossing`]). The search inside a cluster, shared with the cluster BVH, is
//! `cluster_search.rs`.
//!
//! Beyond the paper's records the tracer holds 8 bytes per block and 68 bytes per cluster (about
//! an eighth of the grid on the dragon and MNI; [`Tracer::extra_bytes`]), all built in [`Tracer::new`].
//!
//! Units: rays are in world space (sample (i, j, k) at (i·sx, j·sy, k·sz)) with unit directions,
//! and `t` is the world distance along the ray. Internally the ray is rescaled into cell units
//! (world / spacing per axis) with the same parameter `t`, so boxes need no spacing.
//!
//! Closest hit: every cell of a block that the ray reaches before the best hit so far is tested and
//! the minimum kept; a block is finished before the DDA moves on, and traversal stops once the best
//! hit lies before the exit of the current block — all later blocks start after it.

use crate::block_walk::BlockWalk;
use crate::cell_ray::{widen_f32, CellRay};
use crate::cluster_bounds::{unpack4, PackedClusterBounds};
use crate::cluster_search::{prefetch_slice, Best, ClusterSearch, Hit, Occlusion};
use crate::crossing::Crossing;
use crate::lanes::{Baseline, Lanes};
use isogrid::camera::Ray;
use isogrid::grid::CellGrid;
use isogrid::layout::{Block, Metacell, BLOCK_CELLS, CLUSTER_SLOTS};
use isogrid::skip::octant_space::OctantSpaceMap;
use rayon::prelude::*;

/// Traces rays through one grid. Shares the grid's buffers and adds 8 bytes per block (an
/// [`OctantSpaceMap`]) and 68 per cluster ([`PackedClusterBounds`] and the metacell records of
/// `cluster_boxes.rs`), built in `new` in time linear in the grid's size; `Sync`.
#[derive(Debug, Clone)]
pub struct Tracer<'g> {
    blocks: &'g [Block],
    metacells: &'g [Metacell],
    cell_dims: [f64; 3],
    block_dims: [i64; 3],
    empty_space: OctantSpaceMap,
    cluster_bounds: PackedClusterBounds,
    search: ClusterSearch<'g>,
}

/// Clusters a block can hold: 16³ cells = 512 metacells in clusters of 15.
const MAX_BLOCK_CLUSTERS: usize = (BLOCK_CELLS / 2).pow(3).div_ceil(CLUSTER_SLOTS - 1);
/// [`MAX_BLOCK_CLUSTERS`] rounded up to whole groups of 4 f32 lanes.
const CLUSTER_LANES: usize = MAX_BLOCK_CLUSTERS.div_ceil(4) * 4;

/// Bit `c` set when the ray may pass through the bound of cluster `c` of a block (`packed`, the
/// block's first metacell at `origin`) within the widened `t` range, with each bound's
/// (conservative) entry `t` in `entry`.
#[inline(always)]
fn cluster_hits(
    r: &CellRay,
    packed: &[u32],
    origin: [f32; 3],
    t: (f32, f32),
    entry: &mut [f32; CLUSTER_LANES],
) -> u64 {
    let clusters = packed.len().min(MAX_BLOCK_CLUSTERS);
    let mut mask = 0;
    for chunk in 0..clusters.div_ceil(4) {
        let (lo, hi) = unpack4(packed, chunk * 4, origin);
        let (hits, near) = r.faces().boxes4(&lo, &hi, t);
        entry[chunk * 4..chunk * 4 + 4].copy_from_slice(&near);
        mask |= (hits as u64) << (chunk * 4);
    }
    mask
}

impl<'g> Tracer<'g> {
    pub fn new(grid: &'g CellGrid, crossing: Crossing) -> Self {
        let info = grid.info();
        let walk_dims = info.block_dims().map(|b| b as usize);
        Tracer {
            blocks: grid.blocks(),
            metacells: grid.metacells(),
            cell_dims: info.cell_dims().map(|c| c as f64),
            block_dims: walk_dims.map(|b| b as i64),
            empty_space: OctantSpaceMap::new(grid.blocks(), walk_dims),
            cluster_bounds: PackedClusterBounds::new(grid.blocks(), grid.metacells(), walk_dims),
            search: ClusterSearch::new(grid, crossing, grid.metacells()),
        }
    }

    pub fn crossing(&self) -> Crossing {
        self.search.crossing()
    }

    /// Bytes the tracer adds to the grid's own buffers (its [`OctantSpaceMap`],
    /// [`PackedClusterBounds`] and per-cluster metacell records).
    pub fn extra_bytes(&self) -> usize {
        self.empty_space.bytes() + self.cluster_bounds.bytes() + self.search.extra_bytes()
    }

    /// The closest crossing of the isosurface with `t ∈ [tmin, tmax]`, or `None`.
    pub fn closest_hit(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.search.lanes().avx2 {
            // SAFETY: an `Avx2` exists only where the CPU runs all of its set (`Avx2::detect`).
            return unsafe { self.closest_hit_avx2(avx2, ray, tmin, tmax) };
        }
        self.closest_hit_with(Baseline, ray, tmin, tmax)
    }

    /// [`Self::closest_hit`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must run what `Avx2::detect` checks (AVX2, FMA and bit instructions).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    pub(crate) unsafe fn closest_hit_avx2(
        &self,
        avx2: crate::lanes::Avx2,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        self.closest_hit_with(avx2, ray, tmin, tmax)
    }

    /// The SIMD set of the box tests: "avx2" where the CPU runs AVX2, FMA and the bit
    /// instructions, else "baseline" (SSE2 on x86-64); `ISOGRID_NO_AVX2=1` forces the baseline.
    pub fn simd(&self) -> &'static str {
        self.search.lanes().name()
    }

    #[inline(always)]
    pub(crate) fn closest_hit_with<L: Lanes>(
        &self,
        lanes: L,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        let r = self.search.cell_ray(ray);
        let mut best = Best::new(tmax);
        self.walk_blocks(&r, tmin, tmax, |block, origin| {
            self.closest_in_block(lanes, &r, block, origin, tmin, &mut best);
            best.t
        });
        self.search.hit_of(ray, &best, |cluster, _| cluster)
    }

    /// Whether anything blocks the ray within `[tmin, tmax]`, by `occlusion` (see [`Occlusion`]).
    pub fn any_hit(&self, ray: &Ray, tmin: f64, tmax: f64, occlusion: Occlusion) -> bool {
        if occlusion == Occlusion::Surface {
            return self.closest_hit(ray, tmin, tmax).is_some();
        }
        let r = self.search.cell_ray(ray);
        let mut hit = false;
        self.walk_blocks(&r, tmin, tmax, |block, origin| {
            if self.any_box_in_block(Baseline, &r, block, origin, tmin, tmax) {
                hit = true;
                f64::NEG_INFINITY
            } else {
                f64::INFINITY
            }
        });
        hit
    }

    /// Walks the blocks of `[tmin, tmax]` in order ([`BlockWalk`]). `visit(block, its first
    /// metacell)` handles a non-empty block and returns the best hit `t` so far; the walk stops
    /// once that is no later than the block's exit.
    #[inline(always)]
    fn walk_blocks(
        &self,
        r: &CellRay,
        tmin: f64,
        tmax: f64,
        mut visit: impl FnMut(&Block, [f32; 3]) -> f64,
    ) {
        let Some(mut walk) = BlockWalk::new(r, self.cell_dims, self.block_dims, tmin, tmax) else {
            return;
        };
        // The walk moves towards +axis `a` where the direction is ≥ 0 (as in `BlockWalk`).
        let octant = (0..3).fold(0, |o, a| o | ((r.direction[a] >= 0.0) as usize) << a);
        let sides = self.empty_space.octant(octant);
        while self.walk_once(r, &mut walk, sides, &mut visit) {}
    }

    /// One move of `walk`: a leap across empty space, or a visit of the current block (when it
    /// holds active cells) followed by a step. `sides` is the [`OctantSpaceMap`] of the ray's
    /// octant. False when the walk is over.
    #[inline(always)]
    fn walk_once(
        &self,
        r: &CellRay,
        walk: &mut BlockWalk,
        sides: &[u8],
        visit: &mut impl FnMut(&Block, [f32; 3]) -> f64,
    ) -> bool {
        let index = walk.index();
        let side = sides[index];
        if side > 1 {
            return walk.leap(r, side);
        }
        if side == 0 && visit(&self.blocks[index], walk.first_metacell()) <= walk.exit() {
            return false;
        }
        walk.step()
    }

    #[inline(always)]
    fn closest_in_block<L: Lanes>(
        &self,
        lanes: L,
        r: &CellRay,
        block: &Block,
        origin: [f32; 3],
        tmin: f64,
        best: &mut Best,
    ) {
        // A block holds at most 512 metacells, so at most 35 clusters of one isosurface; a label
        // grid holds a run of clusters per label there, so its clusters go in groups of 35.
        let packed = self.cluster_bounds.of_block(block);
        if packed.len() <= MAX_BLOCK_CLUSTERS {
            return self.closest_in_clusters(lanes, r, block, 0, packed, origin, tmin, best);
        }
        for first in (0..packed.len()).step_by(MAX_BLOCK_CLUSTERS) {
            let group = &packed[first..packed.len().min(first + MAX_BLOCK_CLUSTERS)];
            self.closest_in_clusters(lanes, r, block, first, group, origin, tmin, best);
        }
    }

    /// The closest-hit search in `block`'s clusters `first..first + packed.len()` (`packed`: their
    /// packed bounds, at most [`MAX_BLOCK_CLUSTERS`]).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn closest_in_clusters<L: Lanes>(
        &self,
        lanes: L,
        r: &CellRay,
        block: &Block,
        first: usize,
        packed: &[u32],
        origin: [f32; 3],
        tmin: f64,
        best: &mut Best,
    ) {
        let slots = &self.metacells[block.slots()][first * CLUSTER_SLOTS..];
        let first_cluster = block.metacell_pointer as usize / CLUSTER_SLOTS + first;
        // Clusters whose bound the ray enters, nearest first, so that the search can stop at the
        // first cluster that starts behind the best hit.
        let mut order = [(0.0f32, 0u16); MAX_BLOCK_CLUSTERS];
        let mut count = 0;
        let mut entry = [0f32; CLUSTER_LANES];
        let mut hits = cluster_hits(r, packed, origin, widen_f32(tmin, best.t), &mut entry);
        while hits != 0 {
            let ci = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let near = entry[ci];
            let mut k = count;
            while k > 0 && order[k - 1].0 > near {
                order[k] = order[k - 1];
                k -= 1;
            }
            order[k] = (near, ci as u16);
            count += 1;
        }
        // The records are the tracer's cache misses; ask for them all before waiting on any.
        for &(_, ci) in &order[..count] {
            let cluster = &slots[ci as usize * CLUSTER_SLOTS..][..CLUSTER_SLOTS];
            self.search.prefetch_cluster(first_cluster + ci as usize);
            prefetch_slice(cluster);
        }
        for &(near, ci) in &order[..count] {
            if near > widen_f32(tmin, best.t).1 {
                break;
            }
            let ci = ci as usize;
            let cluster = &slots[ci * CLUSTER_SLOTS..(ci + 1) * CLUSTER_SLOTS];
            let index = (first_cluster + ci) as u32;
            self.search
                .closest_in_cluster(lanes, r, cluster, index, tmin, best);
        }
    }

    fn any_box_in_block<L: Lanes>(
        &self,
        lanes: L,
        r: &CellRay,
        block: &Block,
        origin: [f32; 3],
        tmin: f64,
        tmax: f64,
    ) -> bool {
        let slots = &self.metacells[block.slots()];
        let mut entry = [0f32; CLUSTER_LANES];
        let packed = self.cluster_bounds.of_block(block);
        // In groups of at most 35 clusters, as `closest_in_block`.
        for first in (0..packed.len()).step_by(MAX_BLOCK_CLUSTERS) {
            let group = &packed[first..packed.len().min(first + MAX_BLOCK_CLUSTERS)];
            let mut hits = cluster_hits(r, group, origin, widen_f32(tmin, tmax), &mut entry);
            while hits != 0 {
                let ci = first + hits.trailing_zeros() as usize;
                hits &= hits - 1;
                let cluster = &slots[ci * CLUSTER_SLOTS..(ci + 1) * CLUSTER_SLOTS];
                let index = (block.metacell_pointer as usize / CLUSTER_SLOTS + ci) as u32;
                if self
                    .search
                    .any_box_in_cluster(lanes, r, cluster, index, tmin, tmax)
                {
                    return true;
                }
            }
        }
        false
    }
}

/// Closest hits of many rays in parallel (`t ∈ [0, ∞)`); `out[i]` answers `rays[i]`.
///
/// # Panics
/// When `out` and `rays` differ in length.
pub fn closest_hits(tracer: &Tracer, rays: &[Ray], out: &mut [Option<Hit>]) {
    assert_eq!(rays.len(), out.len(), "one output per ray");
    out.par_iter_mut()
        .zip(rays.par_iter())
        .with_min_len(256)
        .for_each(|(o, r)| *o = tracer.closest_hit(r, 0.0, f64::INFINITY));
}

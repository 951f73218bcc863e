//! Hierarchical ray traversal of clustered grid cells (paper §3.6): a 3D DDA over the dense
//! 16³-cell block grid, which leaps across empty space with an [`OctantSpaceMap`]
//! (`block_walk.rs`); inside a non-empty block every cluster bound (slot 15, read from a packed
//! copy, [`PackedClusterBounds`]), then each entered cluster's metacell boxes (from a 64-byte
//! record per cluster, eight at a time with AVX2 or four with SSE2, `cluster_boxes.rs` and
//! `lanes.rs`), are tested with the slab test (as §3.2); a candidate metacell's active cells are
//! visited nearest first by crossing its three mid-planes, and searched for the isosurface
//! crossing ([`super::crossing`]). The search inside a cluster, shared with the cluster BVH, is in
//! `traverse/cluster_search.rs`.
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

use super::block_walk::BlockWalk;
use super::cell_ray::CellRay;
use super::cluster_bounds::{unpack4, PackedClusterBounds};
use super::cluster_boxes::AllClusterBoxes;
use super::crossing::Crossing;
use super::lanes::{Baseline, Chosen, Lanes};
pub(super) use cluster_search::Best;
use cluster_search::{prefetch_slice, widened_f32};
use isogrid::camera::Ray;
use isogrid::grid::CellGrid;
use isogrid::layout::{Block, Metacell, Precision, BLOCK_CELLS, CLUSTER_SLOTS};
use isogrid::skip::octant_space::OctantSpaceMap;

mod cluster_search;

/// The closest intersection of a ray with the isosurface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// World distance along the (unit-direction) ray.
    pub t: f64,
    /// Index of the hit cell's corner record in [`CellGrid::cells`].
    pub cell: u32,
    /// Grid index (x, y, z) of the hit cell.
    pub position: [u32; 3],
    /// Index of the cluster holding the cell.
    pub cluster: u32,
    /// Unit world-space normal −∇f/|∇f| at the hit (f = the trilinear interpolant of the codes,
    /// inside where f ≥ iso), so it points out of the solid. −direction where ∇f vanishes.
    pub normal: [f64; 3],
}

/// What an any-hit (shadow / occlusion) query tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Occlusion {
    /// Any active cell box the ray passes through counts as a hit: only block and metacell data
    /// (masks and positions) are read, never corner records, as §3.6 suggests for shadow and AO
    /// rays. Conservative: it reports occlusion a little early (up to one cell before the surface)
    /// and for rays that graze an active cell without crossing the surface.
    #[default]
    CellBoxes,
    /// The surface itself, with the tracer's crossing mode: agrees with [`Tracer::closest_hit`].
    Surface,
}

/// Traces rays through one grid. Shares the grid's buffers and adds 8 bytes per block (an
/// [`OctantSpaceMap`]) and 68 per cluster ([`PackedClusterBounds`] and the metacell records of
/// `cluster_boxes.rs`), built in `new` in time linear in the grid's size; `Sync`.
#[derive(Debug, Clone)]
pub struct Tracer<'g> {
    blocks: &'g [Block],
    metacells: &'g [Metacell],
    cells: &'g [u8],
    precision: Precision,
    /// [`Precision::bytes_per_cell`], read per traced cell.
    cell_bytes: usize,
    iso_code: f64,
    spacing: [f64; 3],
    cell_dims: [f64; 3],
    block_dims: [i64; 3],
    crossing: Crossing,
    margin: f64,
    empty_space: OctantSpaceMap,
    cluster_bounds: PackedClusterBounds,
    cluster_boxes: AllClusterBoxes,
    lanes: Chosen,
}

/// Clusters a block can hold: 16³ cells = 512 metacells in clusters of 15.
const MAX_BLOCK_CLUSTERS: usize = (BLOCK_CELLS / 2).pow(3).div_ceil(CLUSTER_SLOTS - 1);
/// [`MAX_BLOCK_CLUSTERS`] rounded up to whole groups of 4 f32 lanes.
const CLUSTER_LANES: usize = MAX_BLOCK_CLUSTERS.div_ceil(4) * 4;

/// Margin (cells) by which the f32 metacell test grows each box so that rounding never culls a
/// box the ray really touches; exact f64 tests follow for the cells.
fn metacell_margin(cell_dims: [f64; 3]) -> f64 {
    let largest = cell_dims[0].max(cell_dims[1]).max(cell_dims[2]);
    (1e-3f64).max(largest * 1e-5)
}

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
        Self::build(grid, crossing, None)
    }

    /// A tracer for the per-cluster searches only (`closest_in_cluster`, `any_box_in_cluster`,
    /// `cell_ray`, `hit_of`) in the clusters `leaves` (16 slots each, as in the grid; cluster
    /// indices are then indices into `leaves`), without the block walk's empty-space map and
    /// packed cluster bounds: what [`super::BvhTracer`] uses, so that it neither builds nor holds
    /// them. [`Tracer::closest_hit`] and [`Tracer::any_hit`] of such a tracer find nothing.
    pub(super) fn for_leaves(grid: &'g CellGrid, crossing: Crossing, leaves: &[Metacell]) -> Self {
        Self::build(grid, crossing, Some(leaves))
    }

    /// `leaves`: see [`Self::for_leaves`]; `None` for the block walk over the grid's clusters.
    fn build(grid: &'g CellGrid, crossing: Crossing, leaves: Option<&[Metacell]>) -> Self {
        let block_walk = leaves.is_none();
        let info = grid.info();
        let bd = info.block_dims();
        // Without the block walk, no blocks: the walk then ends before reading either structure.
        let (blocks, walk_dims) = if block_walk {
            (grid.blocks(), bd.map(|b| b as usize))
        } else {
            (&[][..], [0; 3])
        };
        Tracer {
            blocks,
            metacells: grid.metacells(),
            cells: grid.cells(),
            precision: info.precision,
            cell_bytes: info.precision.bytes_per_cell(),
            iso_code: info.mapping.iso_code as f64,
            spacing: info.spacing,
            cell_dims: info.cell_dims().map(|c| c as f64),
            block_dims: walk_dims.map(|b| b as i64),
            crossing,
            margin: metacell_margin(info.cell_dims().map(|c| c as f64)),
            empty_space: OctantSpaceMap::new(blocks, walk_dims),
            // Sized by the metacells it is given: none without the block walk, its only reader.
            cluster_bounds: PackedClusterBounds::new(
                blocks,
                if block_walk { grid.metacells() } else { &[] },
                walk_dims,
            ),
            cluster_boxes: AllClusterBoxes::new(leaves.unwrap_or(grid.metacells())),
            lanes: Chosen::detect(),
        }
    }

    pub fn crossing(&self) -> Crossing {
        self.crossing
    }

    /// Bytes the tracer adds to the grid's own buffers (its [`OctantSpaceMap`],
    /// [`PackedClusterBounds`] and per-cluster metacell records).
    pub fn extra_bytes(&self) -> usize {
        self.empty_space.bytes() + self.cluster_bounds.bytes() + self.cluster_boxes.bytes()
    }

    /// Sample spacing (world units per cell) per axis.
    pub(super) fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    pub(super) fn cell_ray(&self, ray: &Ray) -> CellRay {
        CellRay::new(ray, self.spacing, self.margin)
    }

    /// As [`Self::cell_ray`], from the ray's [`super::cell_ray::cell_units`].
    #[inline(always)]
    pub(super) fn cell_ray_of_units(&self, units: super::cell_ray::CellUnits) -> CellRay {
        CellRay::from_units(units, self.margin)
    }

    /// The closest crossing of the isosurface with `t ∈ [tmin, tmax]`, or `None`.
    pub fn closest_hit(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.lanes.avx2 {
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
    pub(super) unsafe fn closest_hit_avx2(
        &self,
        avx2: super::lanes::Avx2,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        self.closest_hit_with(avx2, ray, tmin, tmax)
    }

    /// The SIMD set of the box tests: "avx2" where the CPU runs AVX2, FMA and the bit
    /// instructions, else "baseline" (SSE2 on x86-64); `ISOGRID_NO_AVX2=1` forces the baseline.
    pub fn simd(&self) -> &'static str {
        self.lanes.name()
    }

    pub(super) fn lanes(&self) -> Chosen {
        self.lanes
    }

    #[inline(always)]
    pub(super) fn closest_hit_with<L: Lanes>(
        &self,
        lanes: L,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        let r = self.cell_ray(ray);
        let mut best = Best::new(tmax);
        self.walk_blocks(&r, tmin, tmax, |block, origin| {
            self.closest_in_block(lanes, &r, block, origin, tmin, &mut best);
            best.t
        });
        self.hit_of(ray, &best, |cluster, _| cluster)
    }

    /// Whether anything blocks the ray within `[tmin, tmax]`, by `occlusion` (see [`Occlusion`]).
    pub fn any_hit(&self, ray: &Ray, tmin: f64, tmax: f64, occlusion: Occlusion) -> bool {
        if occlusion == Occlusion::Surface {
            return self.closest_hit(ray, tmin, tmax).is_some();
        }
        let r = self.cell_ray(ray);
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
        let slots = &self.metacells[block.slots()];
        let first_cluster = block.metacell_pointer as usize / CLUSTER_SLOTS;
        // Clusters whose bound the ray enters, nearest first, so that the search can stop at the
        // first cluster that starts behind the best hit. A block holds at most 512 metacells, so
        // at most 35 clusters.
        let mut order = [(0.0f32, 0u16); MAX_BLOCK_CLUSTERS];
        let mut count = 0;
        let mut entry = [0f32; CLUSTER_LANES];
        let packed = self.cluster_bounds.of_block(block);
        let mut hits = cluster_hits(r, packed, origin, widened_f32(tmin, best.t), &mut entry);
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
            self.prefetch_cluster(first_cluster + ci as usize);
            prefetch_slice(cluster);
        }
        for &(near, ci) in &order[..count] {
            if near > widened_f32(tmin, best.t).1 {
                break;
            }
            let ci = ci as usize;
            let cluster = &slots[ci * CLUSTER_SLOTS..(ci + 1) * CLUSTER_SLOTS];
            let index = (first_cluster + ci) as u32;
            self.closest_in_cluster(lanes, r, cluster, index, tmin, best);
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
        let mut hits = cluster_hits(r, packed, origin, widened_f32(tmin, tmax), &mut entry);
        while hits != 0 {
            let ci = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let cluster = &slots[ci * CLUSTER_SLOTS..(ci + 1) * CLUSTER_SLOTS];
            let index = (block.metacell_pointer as usize / CLUSTER_SLOTS + ci) as u32;
            if self.any_box_in_cluster(lanes, r, cluster, index, tmin, tmax) {
                return true;
            }
        }
        false
    }
}

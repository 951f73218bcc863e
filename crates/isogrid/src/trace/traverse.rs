//! Hierarchical ray traversal of clustered grid cells (paper §3.6): a 3D DDA over the dense
//! 16³-cell block grid, which leaps across empty space with an [`OctantSpaceMap`]
//! (`block_walk.rs`); inside a non-empty block every cluster bound (slot 15, read from a packed
//! copy, [`PackedClusterBounds`]), then each entered cluster's metacell boxes (from a 64-byte
//! record per cluster, eight at a time with AVX2 or four with SSE2, `cluster_boxes.rs` and
//! `lanes.rs`), are tested with the slab test (as §3.2); a candidate metacell's active cells are
//! visited nearest first by crossing its three mid-planes, and searched for the isosurface
//! crossing ([`super::crossing`]).
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
use super::cell_ray::{min, xyz, BoxFaces, CellRay};
use super::cluster_bounds::{unpack4, PackedClusterBounds};
use super::cluster_boxes::AllClusterBoxes;
use super::crossing::{Crossing, Trilinear};
use super::lanes::{Baseline, Chosen, Lanes};
use super::octant_space::OctantSpaceMap;
use crate::camera::Ray;
use crate::grid::CellGrid;
use crate::layout::{read_corners, Block, Metacell, Precision, BLOCK_CELLS, CLUSTER_SLOTS};

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

/// Hints the CPU to load the cache lines of `data` (no-op off x86-64). Never faults.
#[inline(always)]
pub(super) fn prefetch_slice<T>(data: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let bytes = std::mem::size_of_val(data);
        let base = data.as_ptr().cast::<i8>();
        let mut offset = 0;
        while offset < bytes {
            // SAFETY: prefetch is a hint and never faults; the address lies inside `data`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(base.add(offset)) };
            offset += 64;
        }
        if bytes > 0 {
            // The last line too when `data` does not start on a line boundary.
            // SAFETY: as above.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(base.add(bytes - 1)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = data;
}

/// `[tmin, tmax]` widened for the f32 lane tests (t itself is rounded to f32 there).
#[inline(always)]
fn widened_f32(tmin: f64, tmax: f64) -> (f32, f32) {
    let lo = (tmin - 1e-3 - 1e-5 * tmin.abs()) as f32;
    let hi = min(tmax + 1e-3 + 1e-5 * tmax.abs(), f32::MAX as f64) as f32;
    (lo, hi)
}

/// Bit `i` set when the ray may pass through metacell slot `i` (0–14) of `cluster` within the
/// widened `t` range (see [`BoxFaces::boxes4`]). Empty slots are not excluded.
#[inline(always)]
fn metacell_hits(faces: &BoxFaces, cluster: &[Metacell], t: (f32, f32)) -> u32 {
    let (quads, _) = cluster.as_chunks::<4>();
    let mut mask = 0;
    for (chunk, quad) in quads.iter().take(CLUSTER_SLOTS / 4).enumerate() {
        let p = metacell_positions4(quad);
        let (hits, _) = faces.boxes4(&p, &p, t);
        mask |= hits << (chunk * 4);
    }
    mask & 0x7fff
}

/// Positions of four metacell slots as f32 lanes per axis. Slot 15 of a cluster is its bound,
/// not a metacell: its lane holds the bound's fields and must be masked off.
#[inline(always)]
fn metacell_positions4(slots: &[Metacell; 4]) -> [[f32; 4]; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline. Each 8-byte load reads the first 8 of a
        // 12-byte record of `slots` (position x, y, z and the cell mask), inside the slice.
        unsafe {
            let record = |k: usize| _mm_loadl_epi64(slots.as_ptr().add(k).cast());
            // Transpose four (x, y, z, mask) u16 quadruples into one u16 lane group per field,
            // then widen to i32 and convert: 14 instructions instead of twelve scalar loads,
            // conversions and stores.
            let xy01_z01 = _mm_unpacklo_epi16(record(0), record(1));
            let xy23_z23 = _mm_unpacklo_epi16(record(2), record(3));
            let xy = _mm_unpacklo_epi32(xy01_z01, xy23_z23);
            let zm = _mm_unpackhi_epi32(xy01_z01, xy23_z23);
            let zero = _mm_setzero_si128();
            let mut lanes = [[0f32; 4]; 3];
            for (lane, v) in lanes.iter_mut().zip([
                _mm_unpacklo_epi16(xy, zero),
                _mm_unpackhi_epi16(xy, zero),
                _mm_unpacklo_epi16(zm, zero),
            ]) {
                _mm_storeu_ps(lane.as_mut_ptr(), _mm_cvtepi32_ps(v));
            }
            lanes
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        xyz(|a| std::array::from_fn(|k| slots[k].position[a] as f32))
    }
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

    /// The [`Hit`] (with its normal) of the search result `best` of `ray`; `cluster_of` maps where
    /// the hit metacell was found (index of the searched cluster, slot in it) to the grid's
    /// cluster.
    #[inline(always)]
    pub(super) fn hit_of(
        &self,
        ray: &Ray,
        best: &Best,
        cluster_of: impl FnOnce(u32, u32) -> u32,
    ) -> Option<Hit> {
        let (t, cell, position, (cluster, slot), tri, u) = best.found?;
        let g = tri.gradient(u);
        let gw = xyz(|a| g[a] / self.spacing[a]);
        let len = (gw[0] * gw[0] + gw[1] * gw[1] + gw[2] * gw[2]).sqrt();
        let normal = if len > 0.0 && len.is_finite() {
            gw.map(|v| -v / len)
        } else {
            ray.direction.map(|v| -v)
        };
        Some(Hit {
            t,
            cell,
            position,
            cluster: cluster_of(cluster, slot),
            normal,
        })
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

    /// The closest-hit search inside one cluster (`cluster`: its 16 slots, `cluster_index`: its global
    /// cluster index): its metacell boxes, then the cells of each candidate metacell nearest
    /// first, keeping the closest crossing before `best.t` in `best`.
    #[inline(always)]
    pub(super) fn closest_in_cluster<L: Lanes>(
        &self,
        lanes: L,
        r: &CellRay,
        cluster: &[Metacell],
        cluster_index: u32,
        tmin: f64,
        best: &mut Best,
    ) {
        let t = widened_f32(tmin, best.t);
        self.closest_in_cluster_by(lanes, r.faces(), t, r, cluster, cluster_index, tmin, best);
    }

    /// As [`Self::closest_in_cluster`], with the metacell boxes tested by `faces` within `t`
    /// (widened for f32 lanes, and measured as `faces` measure it): the hierarchy tests them with
    /// the constants and the window of its node tests, which it holds already.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn closest_in_cluster_by<L: Lanes>(
        &self,
        lanes: L,
        faces: &BoxFaces,
        t: (f32, f32),
        r: &CellRay,
        cluster: &[Metacell],
        cluster_index: u32,
        tmin: f64,
        best: &mut Best,
    ) {
        let mut candidates = self.metacell_candidates(lanes, faces, cluster, cluster_index, t);
        // The corner records are the search's cache misses; ask for them all before waiting on any.
        let mut pending = candidates;
        while pending != 0 {
            let m = &cluster[pending.trailing_zeros() as usize];
            pending &= pending - 1;
            let n = self.cell_bytes;
            let start = (m.cell_pointer as usize * n).min(self.cells.len());
            let end = (start + m.active_cells() as usize * n).min(self.cells.len());
            prefetch_slice(&self.cells[start..end]);
        }
        while candidates != 0 {
            let k = candidates.trailing_zeros();
            candidates &= candidates - 1;
            let found_in = (cluster_index, k);
            self.closest_in_metacell(r, &cluster[k as usize], found_in, tmin, best);
        }
    }

    /// The closest-hit search inside one metacell `m` (found in `found_in`: index of the searched
    /// cluster, slot in it): its cells nearest first, keeping the first crossing before `best.t`
    /// in `best`.
    #[inline(always)]
    fn closest_in_metacell(
        &self,
        r: &CellRay,
        m: &Metacell,
        found_in: (u32, u32),
        tmin: f64,
        best: &mut Best,
    ) {
        if m.cell_mask == 0 {
            return;
        }
        let mask = m.cell_mask & 0xff;
        let lo = xyz(|a| 2.0 * m.position[a] as f64);
        for (t0, t1, bit) in r.metacell_cells(lo, mask, tmin, best.t) {
            // Cells come nearest first, so the first crossing is this metacell's closest.
            let t1 = min(t1, best.t);
            if !(t0 < t1) {
                break;
            }
            let pos = m.cell_position(bit);
            let cell_lo = xyz(|a| pos[a] as f64);
            let index = m.cell_pointer + (mask & ((1u16 << bit) - 1)).count_ones();
            let tri = Trilinear::new(&self.corners(index));
            let start = r.at(t0);
            let end = r.at(t1);
            let start_local = xyz(|a| start[a] - cell_lo[a]);
            let delta = xyz(|a| end[a] - start[a]);
            let cubic = tri.along(start_local, delta, self.iso_code);
            if let Some(s) = cubic.first_crossing(self.crossing) {
                let t = t0 + s * (t1 - t0);
                if t < best.t || best.found.is_none() {
                    let u = xyz(|a| (start_local[a] + s * delta[a]).clamp(0.0, 1.0));
                    best.t = t;
                    best.found = Some((t, index, pos, found_in, tri, u));
                }
                break;
            }
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

    /// Whether the ray passes through an active cell box of `cluster` (its 16 slots, global index
    /// `cluster_index`) within `[tmin, tmax]`.
    #[inline(always)]
    pub(super) fn any_box_in_cluster<L: Lanes>(
        &self,
        lanes: L,
        r: &CellRay,
        cluster: &[Metacell],
        cluster_index: u32,
        tmin: f64,
        tmax: f64,
    ) -> bool {
        let mut candidates = self.metacell_candidates(
            lanes,
            r.faces(),
            cluster,
            cluster_index,
            widened_f32(tmin, tmax),
        );
        while candidates != 0 {
            let m = &cluster[candidates.trailing_zeros() as usize];
            candidates &= candidates - 1;
            if m.cell_mask == 0 {
                continue;
            }
            let lo = xyz(|a| 2.0 * m.position[a] as f64);
            if r.metacell_cells(lo, m.cell_mask & 0xff, tmin, tmax)
                .next()
                .is_some()
            {
                return true;
            }
        }
        false
    }

    /// Bit `k` set when the ray may pass through metacell slot `k` of `cluster` (global index
    /// `cluster_index`) within the widened `t` range; empty slots are left out when the packed
    /// copy ([`AllClusterBoxes`]) answers.
    #[inline(always)]
    fn metacell_candidates<L: Lanes>(
        &self,
        lanes: L,
        faces: &BoxFaces,
        cluster: &[Metacell],
        cluster_index: u32,
        t: (f32, f32),
    ) -> u32 {
        match self.cluster_boxes.get(cluster_index as usize) {
            Some(boxes) if boxes.usable() => lanes.metacell_boxes(boxes, faces, t),
            _ => metacell_hits(faces, cluster, t),
        }
    }

    /// Where the box record of global cluster `c` lies (dangling past the end; for prefetching).
    #[inline(always)]
    pub(super) fn cluster_record_ptr(&self, c: usize) -> *const i8 {
        self.cluster_boxes.record_ptr(c)
    }

    /// Hints the CPU to load what the search of global cluster `c` reads first.
    #[inline(always)]
    pub(super) fn prefetch_cluster(&self, c: usize) {
        if let Some(boxes) = self.cluster_boxes.get(c) {
            prefetch_slice(std::slice::from_ref(boxes));
        }
    }

    #[inline(always)]
    fn corners(&self, index: u32) -> [f32; 8] {
        let n = self.cell_bytes;
        let start = index as usize * n;
        read_corners(&self.cells[start..start + n], self.precision)
    }
}

type Found = (f64, u32, [u32; 3], (u32, u32), Trilinear, [f64; 3]);

/// A closest-hit search in progress: the best `t` so far (the search window's end until something
/// is found) and what was found there.
pub(super) struct Best {
    pub t: f64,
    found: Option<Found>,
}

impl Best {
    pub(super) fn new(tmax: f64) -> Self {
        Best {
            t: tmax,
            found: None,
        }
    }
}

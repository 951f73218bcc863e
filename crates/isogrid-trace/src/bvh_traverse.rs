//! Closest-hit and any-hit traversal of a [`ClusterBvh`] (the paper's future work, §3.6): ordered,
//! nearest child first, one slab test per 8-wide node (`node_ray.rs`; AVX2, or two SSE2 halves,
//! `lanes.rs`), and in each leaf cluster the search the block walk runs in its clusters
//! (`cluster_search.rs`), so hits are those of the block walk.
//!
//! Units: as [`crate::cluster_bvh`]: node boxes in cell units grown by [`node_margin`], the ray
//! re-based to where it enters the grid's box so that f32 `t` values stay small.

use crate::cell_ray::{cell_units, CellUnits};
use crate::cluster_bvh::{node_margin, ClusterBvh, LEAF, STACK, WIDTH};
use crate::cluster_search::{Best, ClusterSearch, Hit, Occlusion};
use crate::crossing::Crossing;
#[cfg(target_arch = "x86_64")]
use crate::lanes::Avx2;
use crate::lanes::{Baseline, Lanes};
use crate::node_ray::NodeRay;
use crate::root_gate::RootGate;
use isogrid::camera::Ray;
use isogrid::grid::CellGrid;
use isogrid::layout::{Metacell, CLUSTER_SLOTS};
use std::mem::MaybeUninit;

/// A tracer that finds candidate metacells with a [`ClusterBvh`] (leaf clusters of regrouped
/// metacells) instead of walking blocks ([`Tracer`](crate::Tracer)). Same hits (it runs the same
/// search inside each cluster); `Sync`.
#[derive(Debug, Clone)]
pub struct BvhTracer<'g> {
    /// The search inside a cluster, over the hierarchy's leaf clusters.
    search: ClusterSearch<'g>,
    cell_dims: [f64; 3],
    margin: f64,
    /// `1 / spacing` per axis, once per tracer.
    to_cells: [f64; 3],
    bvh: ClusterBvh,
    gate: RootGate,
}

impl<'g> BvhTracer<'g> {
    pub fn new(grid: &'g CellGrid, crossing: Crossing) -> Self {
        Self::with_bvh(grid, crossing, ClusterBvh::new(grid))
    }

    /// With a given hierarchy (which should be [`ClusterBvh::new`] of `grid`).
    pub fn with_bvh(grid: &'g CellGrid, crossing: Crossing, bvh: ClusterBvh) -> Self {
        let spacing = grid.info().spacing;
        let cell_dims = grid.info().cell_dims().map(|c| c as f64);
        let margin = node_margin(grid.info().cell_dims());
        let to_cells = spacing.map(|s| 1.0 / s);
        BvhTracer {
            search: ClusterSearch::new(grid, crossing, bvh.leaf_slots()),
            cell_dims,
            margin,
            to_cells,
            bvh,
            gate: RootGate::new(spacing, to_cells, cell_dims, margin),
        }
    }

    pub fn bvh(&self) -> &ClusterBvh {
        &self.bvh
    }

    /// Bytes the tracer adds to the grid's own buffers: the hierarchy ([`ClusterBvh::bytes`]) and
    /// the per-leaf metacell records its leaf searches read.
    pub fn extra_bytes(&self) -> usize {
        self.bvh.bytes() + self.search.extra_bytes()
    }

    /// The 16 slots of leaf cluster `c` (empty when out of range).
    #[inline(always)]
    fn cluster(&self, c: usize) -> &[Metacell] {
        self.bvh.leaf(c)
    }

    /// The closest crossing of the isosurface with `t ∈ [tmin, tmax]`, or `None`; as
    /// [`Tracer::closest_hit`](crate::Tracer::closest_hit).
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
    unsafe fn closest_hit_avx2(&self, avx2: Avx2, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let root = self.bvh.nodes.first()?;
        // SAFETY: as this function's (`Avx2` includes AVX2 and FMA).
        if !unsafe { self.gate.passes_avx2(ray, root, tmin, tmax) } {
            return None;
        }
        // SAFETY: as this function's.
        unsafe { self.traverse_avx2(avx2, ray, tmin, tmax) }
    }

    /// The traversal for rays the root gate lets through, out of line so that the rays it stops
    /// never run the traversal's setup.
    ///
    /// # Safety
    /// As [`Self::closest_hit_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    #[inline(never)]
    unsafe fn traverse_avx2(&self, avx2: Avx2, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        self.closest_hit_with(avx2, ray, tmin, tmax)
    }

    /// The SIMD set of the box tests: "avx2" where the CPU runs AVX2, FMA and the bit
    /// instructions, else "baseline" (SSE2 on x86-64); `ISOGRID_NO_AVX2=1` forces the baseline.
    pub fn simd(&self) -> &'static str {
        self.search.lanes().name()
    }

    /// The ray's [`cell_units`] and its [`NodeRay`] for the window `[tmin, tmax]`.
    #[inline(always)]
    fn node_ray(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<(CellUnits, NodeRay)> {
        let units = cell_units(ray, self.search.spacing(), self.to_cells);
        let cell_ray = || self.search.cell_ray(ray);
        let nr = NodeRay::new(cell_ray, units, self.cell_dims, self.margin, tmin, tmax)?;
        Some((units, nr))
    }

    #[inline(always)]
    fn closest_hit_with<L: Lanes>(&self, lanes: L, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let (units, nr) = self.node_ray(ray, tmin, tmax)?;
        // Built at the first leaf, from the units computed above: most rays that miss never reach
        // one (on the dragon 7 % of them do), and those that do need no divisions again.
        let mut cell_ray = None;
        let nodes = &self.bvh.nodes[..];
        if nodes.is_empty() {
            return None;
        }
        let mut best = Best::new(tmax);
        // Only entries below `sp` are ever read, and each was written first.
        let mut stack = [const { MaybeUninit::<(u32, f32)>::uninit() }; STACK + 1];
        let mut sp = 0;
        let mut window = nr.window(tmin, best.t);
        let mut next = Some(0u32);
        loop {
            // The nearest child of the last node goes next without a trip through the stack.
            let id = match next.take() {
                Some(id) => id,
                None => {
                    if sp == 0 {
                        break;
                    }
                    sp -= 1;
                    // SAFETY: entries below `sp` were written (see above).
                    let (id, entry) = unsafe { stack[sp].assume_init() };
                    if entry > window.1 {
                        continue;
                    }
                    id
                }
            };
            if id & LEAF != 0 {
                let c = (id & !LEAF) as usize;
                let cluster = self.cluster(c);
                if cluster.len() == CLUSTER_SLOTS {
                    let r = cell_ray.get_or_insert_with(|| self.search.cell_ray_of_units(units));
                    let c = c as u32;
                    let faces = &nr.faces;
                    self.search.closest_in_cluster_by(
                        lanes, faces, window, r, cluster, c, tmin, &mut best,
                    );
                    window = nr.window(tmin, best.t);
                }
                continue;
            }
            let Some(node) = nodes.get(id as usize) else {
                continue;
            };
            let (mask, near) = lanes.node_test(&nr, node, window);
            let prefetch = |child: u32| self.prefetch_child(child);
            if mask == 0 {
                continue;
            }
            let k0 = mask.trailing_zeros() as usize;
            let rest = mask & (mask - 1);
            // One or two children (most nodes a ray enters) in one path without a branch on
            // which: the second is the first again when there is none, and the stack pointer
            // moves past it only when it exists. Separate paths for one and for two children
            // branched on the count, the traversal's most mispredicted branch (cachegrind); one
            // path took 4 % off the dragon's and MNI's rays.
            if rest & (rest.wrapping_sub(1)) == 0 {
                let two = rest != 0;
                // The highest child: the second of two, or the only one again.
                let k1 = (31 - mask.leading_zeros()) as usize;
                let (c0, c1) = (node.child[k0], node.child[k1]);
                prefetch(c0);
                prefetch(c1);
                let swap = near[k1] < near[k0];
                let near_child = if swap { c1 } else { c0 };
                let far_child = if swap { c0 } else { c1 };
                let far_t = if swap { near[k0] } else { near[k1] };
                next = Some(near_child);
                // `stack` has one spare entry, so this write is in bounds even when full.
                stack[sp].write((far_child, far_t));
                sp += (two & (sp < STACK)) as usize;
                continue;
            }
            // Three or more: children far to near, so that the nearest is taken first.
            let mut mask = mask;
            let mut order = [(0f32, 0u32); WIDTH];
            let mut count = 0;
            while mask != 0 {
                let k = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let child = node.child[k];
                prefetch(child);
                let mut j = count;
                while j > 0 && order[j - 1].0 < near[k] {
                    order[j] = order[j - 1];
                    j -= 1;
                }
                order[j] = (near[k], child);
                count += 1;
            }
            next = Some(order[count - 1].1);
            for &(t, child) in &order[..count - 1] {
                if sp < STACK {
                    stack[sp].write((child, t));
                    sp += 1;
                }
            }
        }
        // The search knows the leaf and slot; the hit reports the grid's cluster, as the block walk
        // does.
        self.search
            .hit_of(ray, &best, |leaf, slot| self.bvh.grid_cluster(leaf, slot))
    }

    /// Hints the CPU to load what visiting `child` reads first: a node's two lines, or a leaf's
    /// box record and its three lines of slots. The addresses are chosen without a branch (a
    /// leaf or a node is a coin toss per child); a prefetch never faults, and the one chosen
    /// always lies inside the hierarchy's arrays.
    #[inline(always)]
    fn prefetch_child(&self, child: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let leaf = child & LEAF != 0;
            let index = (child & !LEAF) as usize;
            let node = self.bvh.nodes.as_ptr().wrapping_add(index).cast::<i8>();
            let slots = self.bvh.leaves.as_ptr().wrapping_add(index).cast::<i8>();
            let record = self.search.cluster_record_ptr(index);
            // A mask, not an `if`: LLVM compiled the `if` to a branch.
            let leaf_mask = (leaf as usize).wrapping_neg();
            let pick = |a: *const i8, b: *const i8| {
                ((a as usize & leaf_mask) | (b as usize & !leaf_mask)) as *const i8
            };
            // SAFETY: prefetching is a hint and never faults.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(pick(record, node));
                _mm_prefetch::<_MM_HINT_T0>(pick(slots, node.wrapping_add(64)));
                _mm_prefetch::<_MM_HINT_T0>(pick(slots.wrapping_add(64), node.wrapping_add(64)));
                _mm_prefetch::<_MM_HINT_T0>(pick(slots.wrapping_add(128), node.wrapping_add(64)));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = child;
    }

    /// Whether anything blocks the ray within `[tmin, tmax]`; as
    /// [`Tracer::any_hit`](crate::Tracer::any_hit).
    pub fn any_hit(&self, ray: &Ray, tmin: f64, tmax: f64, occlusion: Occlusion) -> bool {
        if occlusion == Occlusion::Surface {
            return self.closest_hit(ray, tmin, tmax).is_some();
        }
        let Some((units, nr)) = self.node_ray(ray, tmin, tmax) else {
            return false;
        };
        let r = self.search.cell_ray_of_units(units);
        if self.bvh.nodes.is_empty() {
            return false;
        }
        let window = nr.window(tmin, tmax);
        // Only entries below `sp` are ever read, and each was written first.
        let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK];
        stack[0].write(0);
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below `sp` were written (see above).
            let id = unsafe { stack[sp].assume_init() };
            let Some(node) = self.bvh.nodes.get(id as usize) else {
                continue;
            };
            let (mut mask, _) = Baseline.node_test(&nr, node, window);
            while mask != 0 {
                let k = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let child = node.child[k];
                if child & LEAF != 0 {
                    let c = child & !LEAF;
                    let cluster = self.cluster(c as usize);
                    if cluster.len() == CLUSTER_SLOTS
                        && self
                            .search
                            .any_box_in_cluster(Baseline, &r, cluster, c, tmin, tmax)
                    {
                        return true;
                    }
                } else if sp < STACK {
                    stack[sp].write(child);
                    sp += 1;
                }
            }
        }
        false
    }

    /// Closest hits of many rays in parallel (`t ∈ [0, ∞)`), as [`crate::closest_hits`].
    ///
    /// # Panics
    /// When `out` and `rays` differ in length.
    pub fn closest_hits(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        use rayon::prelude::*;
        assert_eq!(rays.len(), out.len(), "one output per ray");
        out.par_chunks_mut(GATE_BATCH)
            .zip(rays.par_chunks(GATE_BATCH))
            .with_min_len(4)
            .for_each(|(o, r)| self.closest_hits_batch(r, o));
    }

    /// At most [`GATE_BATCH`] rays: with AVX2, every ray's root gate first, then the traversal of
    /// those it lets through; the same hits as [`Self::closest_hit`] ray by ray.
    fn closest_hits_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.search.lanes().avx2 {
            // SAFETY: an `Avx2` exists only where the CPU runs all of its set (`Avx2::detect`).
            return unsafe { self.closest_hits_batch_avx2(avx2, rays, out) };
        }
        for (o, r) in out.iter_mut().zip(rays) {
            *o = self.closest_hit(r, 0.0, f64::INFINITY);
        }
    }

    /// # Safety
    /// As [`Self::closest_hit_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    unsafe fn closest_hits_batch_avx2(&self, avx2: Avx2, rays: &[Ray], out: &mut [Option<Hit>]) {
        const _: () = assert!(GATE_BATCH <= 64);
        out.fill(None);
        let Some(root) = self.bvh.nodes.first() else {
            return;
        };
        let mut pass = 0u64;
        for (i, r) in rays.iter().enumerate().take(GATE_BATCH) {
            // SAFETY: as this function's.
            let p = unsafe { self.gate.passes_avx2(r, root, 0.0, f64::INFINITY) };
            pass |= (p as u64) << i;
        }
        while pass != 0 {
            let i = pass.trailing_zeros() as usize;
            pass &= pass - 1;
            // SAFETY: as this function's.
            out[i] = unsafe { self.traverse_avx2(avx2, &rays[i], 0.0, f64::INFINITY) };
        }
    }
}

/// Rays whose root gates run back to back before any of them is traversed, so that their tests
/// overlap, and the branch on each one's outcome is taken on a bit known in advance instead of at
/// the end of its test (mispredicted for a mixed run of rays that miss and hit). On the ray
/// benchmark's random rays: dragon −3 %, MNI within noise.
/// Any size up to 64 (one bit per ray) amortises the loop; 64 was not tuned further.
const GATE_BATCH: usize = 64;

#[cfg(test)]
mod tests;

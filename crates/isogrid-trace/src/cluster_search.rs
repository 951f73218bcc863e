//! The search inside one cluster, shared by both traversals: the block walk
//! ([`Tracer`](crate::Tracer)) and the cluster hierarchy ([`BvhTracer`](crate::BvhTracer)). The
//! cluster's metacell boxes are slab-tested in f32 lanes (paper §3.6), then each candidate
//! metacell's active cells are walked nearest first and searched for the isosurface crossing
//! ([`crate::crossing`]), the closest kept in a [`Best`] that becomes the [`Hit`].
//!
//! A traversal hands this search a cluster (its 16 slots, as the grid stores one) and its index;
//! a [`ClusterSearch`] holds what the search reads besides: the grid's corner records, the
//! crossing mode and a 64-byte box record per cluster (`cluster_boxes.rs`). The block walk
//! builds one over the grid's clusters, the hierarchy over its own leaf clusters, so both find
//! the same crossings.
//!
//! Units: cell units (world / spacing per axis), with the world ray's parameter `t`.

use crate::cell_ray::{min, widen_f32, xyz, BoxFaces, CellRay, CellUnits};
use crate::cluster_boxes::AllClusterBoxes;
use crate::crossing::{Crossing, Trilinear};
use crate::lanes::{Chosen, Lanes};
use isogrid::camera::Ray;
use isogrid::grid::CellGrid;
use isogrid::layout::{read_corners, Metacell, Precision, CLUSTER_SLOTS};

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
    /// The surface itself, with the tracer's crossing mode: agrees with
    /// [`Tracer::closest_hit`](crate::Tracer::closest_hit).
    Surface,
}

/// What the search inside a cluster reads besides the cluster's slots: the grid's corner records
/// and isovalue, the crossing mode, the margin of the f32 metacell tests, a box record per
/// cluster of the set it searches (the grid's clusters, or a hierarchy's leaf clusters), and the
/// SIMD set chosen for this CPU. `Sync`.
#[derive(Debug, Clone)]
pub(crate) struct ClusterSearch<'g> {
    cells: &'g [u8],
    precision: Precision,
    /// [`Precision::bytes_per_cell`], read per traced cell.
    cell_bytes: usize,
    iso_code: f64,
    spacing: [f64; 3],
    crossing: Crossing,
    margin: f64,
    cluster_boxes: AllClusterBoxes,
    lanes: Chosen,
    /// In a label grid, crossings this close (world units) are one: a cell may be stored once
    /// per label, and touching labels' surfaces coincide there, so such a tie is settled by
    /// [`wins_tie`]. The search windows reach this far past the best crossing, so that the other
    /// label's crossing is found even in the neighbouring cell. 0 for other grids.
    tie_slack: f64,
}

/// [`ClusterSearch`]'s tie slack per world unit of the largest sample spacing: two labels'
/// coinciding crossings come from complementary indicators and differ only by rounding (about
/// 10⁻¹⁵ of a cell).
const TIE: f64 = 1e-6;

/// Which of two coinciding crossings (`t` within [`TIE`]) a ray sees: the surface it enters
/// (∇f along the ray: its front face) over the one it leaves; else the one found first. So a
/// shared boundary shows one label, without speckle, and the label beyond it once the label
/// before it is hidden. The GPU tracer settles ties the same way (`wins_tie` in trace.wgsl).
#[inline(never)]
fn wins_tie(found: (&Trilinear, [f64; 3]), best: (&Trilinear, [f64; 3]), delta: [f64; 3]) -> bool {
    let enters = |(tri, u): (&Trilinear, [f64; 3])| {
        let g = tri.gradient(u);
        g[0] * delta[0] + g[1] * delta[1] + g[2] * delta[2] > 0.0
    };
    enters(found) && !enters(best)
}

/// Margin (cells) by which the f32 metacell test grows each box so that rounding never culls a
/// box the ray really touches; exact f64 tests follow for the cells.
fn metacell_margin(cell_dims: [f64; 3]) -> f64 {
    let largest = cell_dims[0].max(cell_dims[1]).max(cell_dims[2]);
    (1e-3f64).max(largest * 1e-5)
}

/// Hints the CPU to load the cache lines of `data` (no-op off x86-64). Never faults.
#[inline(always)]
pub(crate) fn prefetch_slice<T>(data: &[T]) {
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

impl<'g> ClusterSearch<'g> {
    /// The search over `clusters` (16 slots each, as the grid stores them; the clusters' indices
    /// are indices into `clusters`) of `grid`'s cells.
    pub(crate) fn new(grid: &'g CellGrid, crossing: Crossing, clusters: &[Metacell]) -> Self {
        let info = grid.info();
        ClusterSearch {
            cells: grid.cells(),
            precision: info.precision,
            cell_bytes: info.precision.bytes_per_cell(),
            iso_code: info.mapping.iso_code as f64,
            spacing: info.spacing,
            crossing,
            margin: metacell_margin(info.cell_dims().map(|c| c as f64)),
            cluster_boxes: AllClusterBoxes::new(clusters),
            lanes: Chosen::detect(),
            tie_slack: match grid.labels() {
                Some(_) => TIE * info.spacing.iter().fold(0.0f64, |m, &s| m.max(s)),
                None => 0.0,
            },
        }
    }

    pub(crate) fn crossing(&self) -> Crossing {
        self.crossing
    }

    /// Bytes the search adds to the grid's own buffers: a box record per cluster.
    pub(crate) fn extra_bytes(&self) -> usize {
        self.cluster_boxes.bytes()
    }

    /// Sample spacing (world units per cell) per axis.
    pub(crate) fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    /// The SIMD set of the box tests, chosen for this CPU.
    pub(crate) fn lanes(&self) -> Chosen {
        self.lanes
    }

    /// `ray` in cell units, with the metacell tests' constants.
    pub(crate) fn cell_ray(&self, ray: &Ray) -> CellRay {
        CellRay::new(ray, self.spacing, self.margin)
    }

    /// As [`Self::cell_ray`], from the ray's [`crate::cell_ray::cell_units`].
    #[inline(always)]
    pub(crate) fn cell_ray_of_units(&self, units: CellUnits) -> CellRay {
        CellRay::from_units(units, self.margin)
    }

    /// The [`Hit`] (with its normal) of the search result `best` of `ray`; `cluster_of` maps where
    /// the hit metacell was found (index of the searched cluster, slot in it) to the grid's
    /// cluster.
    #[inline(always)]
    pub(crate) fn hit_of(
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

    /// The closest-hit search inside one cluster (`cluster`: its 16 slots, `cluster_index`: its global
    /// cluster index): its metacell boxes, then the cells of each candidate metacell nearest
    /// first, keeping the closest crossing before `best.t` in `best`.
    #[inline(always)]
    pub(crate) fn closest_in_cluster<L: Lanes>(
        &self,
        lanes: L,
        r: &CellRay,
        cluster: &[Metacell],
        cluster_index: u32,
        tmin: f64,
        best: &mut Best,
    ) {
        let t = widen_f32(tmin, best.t);
        self.closest_in_cluster_by(lanes, r.faces(), t, r, cluster, cluster_index, tmin, best);
    }

    /// As [`Self::closest_in_cluster`], with the metacell boxes tested by `faces` within `t`
    /// (widened for f32 lanes, and measured as `faces` measure it): the hierarchy tests them with
    /// the constants and the window of its node tests, which it holds already.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn closest_in_cluster_by<L: Lanes>(
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
                let u = || xyz(|a| (start_local[a] + s * delta[a]).clamp(0.0, 1.0));
                // `best.t` is the crossing found plus the tie slack (0 outside label grids).
                let wins = match &best.found {
                    None => true,
                    Some(b) if (t - b.0).abs() <= self.tie_slack => {
                        self.tie_slack > 0.0 && wins_tie((&tri, u()), (&b.4, b.5), delta)
                    }
                    Some(b) => t < b.0,
                };
                if wins {
                    best.t = t + self.tie_slack;
                    best.found = Some((t, index, pos, found_in, tri, u()));
                }
                break;
            }
        }
    }

    /// Whether the ray passes through an active cell box of `cluster` (its 16 slots, global index
    /// `cluster_index`) within `[tmin, tmax]`.
    #[inline(always)]
    pub(crate) fn any_box_in_cluster<L: Lanes>(
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
            widen_f32(tmin, tmax),
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
    pub(crate) fn cluster_record_ptr(&self, c: usize) -> *const i8 {
        self.cluster_boxes.record_ptr(c)
    }

    /// Hints the CPU to load what the search of global cluster `c` reads first.
    #[inline(always)]
    pub(crate) fn prefetch_cluster(&self, c: usize) {
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
pub(crate) struct Best {
    pub t: f64,
    found: Option<Found>,
}

impl Best {
    pub(crate) fn new(tmax: f64) -> Self {
        Best {
            t: tmax,
            found: None,
        }
    }
}

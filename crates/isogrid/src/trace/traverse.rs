//! Hierarchical ray traversal of clustered grid cells (paper §3.6): a 3D DDA (Amanatides & Woo,
//! 1987) over the dense 16³-cell block grid skips empty blocks; inside a block every cluster bound
//! (slot 15), then every metacell's 2×2×2-cell box, then every active cell is tested with the slab
//! test (Majercik et al. 2018, as §3.2), and the cells the ray passes through are searched for the
//! isosurface crossing ([`super::crossing`]).
//!
//! Units: rays are in world space (sample (i, j, k) at (i·sx, j·sy, k·sz)) with unit directions,
//! and `t` is the world distance along the ray. Internally the ray is rescaled into cell units
//! (world / spacing per axis) with the same parameter `t`, so boxes need no spacing.
//!
//! Closest hit: every cell of a block that the ray reaches before the best hit so far is tested and
//! the minimum kept; a block is finished before the DDA moves on, and traversal stops once the best
//! hit lies before the exit of the current block — all later blocks start after it.

use super::crossing::{Crossing, Trilinear};
use crate::camera::Ray;
use crate::grid::CellGrid;
use crate::layout::{
    read_corners, Block, Metacell, Precision, BLOCK_CELLS, BOUND_SLOT, CLUSTER_SLOTS,
};

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

/// Traces rays through one grid. Cheap to create; shares the grid's buffers; `Sync`.
#[derive(Debug, Clone, Copy)]
pub struct Tracer<'g> {
    blocks: &'g [Block],
    metacells: &'g [Metacell],
    cells: &'g [u8],
    precision: Precision,
    iso_code: f64,
    spacing: [f64; 3],
    cell_dims: [f64; 3],
    block_dims: [i64; 3],
    crossing: Crossing,
    margin: f32,
}

/// A ray in cell units: `origin / spacing`, `direction / spacing`, and the reciprocal direction
/// with zero components replaced by a tiny value so that slab tests never see 0·∞.
#[derive(Debug, Clone, Copy)]
struct CellRay {
    origin: [f64; 3],
    direction: [f64; 3],
    inv: [f64; 3],
    /// f32 copies for the batched metacell test, with the reciprocal kept finite.
    origin32: [f32; 3],
    inv32: [f32; 3],
}

impl CellRay {
    /// Entry and exit `t` of the box `[lo, hi]` (cell units); empty when entry > exit.
    #[inline(always)]
    fn slab(&self, lo: [f64; 3], hi: [f64; 3]) -> (f64, f64) {
        let mut near = f64::NEG_INFINITY;
        let mut far = f64::INFINITY;
        for a in 0..3 {
            let t0 = (lo[a] - self.origin[a]) * self.inv[a];
            let t1 = (hi[a] - self.origin[a]) * self.inv[a];
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        (near, far)
    }
    #[inline(always)]
    fn at(&self, t: f64) -> [f64; 3] {
        [0, 1, 2].map(|a| self.origin[a] + t * self.direction[a])
    }
}

/// Clusters a block can hold: 16³ cells = 512 metacells in clusters of 15.
const MAX_BLOCK_CLUSTERS: usize = (BLOCK_CELLS / 2).pow(3).div_ceil(CLUSTER_SLOTS - 1);

/// Margin (cells) by which the f32 metacell test grows each box so that rounding never culls a
/// box the ray really touches; exact f64 tests follow for the cells.
fn metacell_margin(cell_dims: [f64; 3]) -> f32 {
    let largest = cell_dims[0].max(cell_dims[1]).max(cell_dims[2]);
    (1e-3f64).max(largest * 1e-5) as f32
}

#[inline(always)]
fn min32(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}
#[inline(always)]
fn max32(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// Bit `i` set when the ray may pass through metacell slot `i` (0–14) of `cluster` within
/// `[tmin, tmax]`: all 15 slab tests at once in f32 lanes (vectorised by the compiler), on boxes
/// grown by `margin`. Empty slots are not excluded here.
#[inline(always)]
fn metacell_hits(r: &CellRay, cluster: &[Metacell], tmin: f64, tmax: f64, margin: f32) -> u32 {
    let mut lo = [[0f32; 16]; 3];
    for (i, m) in cluster[..BOUND_SLOT].iter().enumerate() {
        for a in 0..3 {
            lo[a][i] = 2.0 * m.position[a] as f32;
        }
    }
    let mut near = [f32::NEG_INFINITY; 16];
    let mut far = [f32::INFINITY; 16];
    for a in 0..3 {
        let (o, inv) = (r.origin32[a], r.inv32[a]);
        for i in 0..16 {
            let t0 = (lo[a][i] - margin - o) * inv;
            let t1 = (lo[a][i] + (2.0 + margin) - o) * inv;
            near[i] = max32(near[i], min32(t0, t1));
            far[i] = min32(far[i], max32(t0, t1));
        }
    }
    // Widen the t range a little too: t itself is rounded to f32.
    let lo_t = (tmin - 1e-3 - 1e-5 * tmin.abs()) as f32;
    let hi_t = (tmax + 1e-3 + 1e-5 * tmax.abs()).min(f32::MAX as f64) as f32;
    let mut mask = 0u32;
    for i in 0..16 {
        let hit = near[i] <= far[i] && far[i] >= lo_t && near[i] <= hi_t;
        mask |= (hit as u32) << i;
    }
    mask & 0x7fff
}

#[inline(always)]
fn box_of(lo: [u32; 3], size: u32) -> ([f64; 3], [f64; 3]) {
    (lo.map(|v| v as f64), lo.map(|v| (v + size) as f64))
}

impl<'g> Tracer<'g> {
    pub fn new(grid: &'g CellGrid, crossing: Crossing) -> Self {
        let info = grid.info();
        let bd = info.block_dims();
        Tracer {
            blocks: grid.blocks(),
            metacells: grid.metacells(),
            cells: grid.cells(),
            precision: info.precision,
            iso_code: info.mapping.iso_code as f64,
            spacing: info.spacing,
            cell_dims: info.cell_dims().map(|c| c as f64),
            block_dims: bd.map(|b| b as i64),
            crossing,
            margin: metacell_margin(info.cell_dims().map(|c| c as f64)),
        }
    }

    pub fn crossing(&self) -> Crossing {
        self.crossing
    }

    fn cell_ray(&self, ray: &Ray) -> CellRay {
        let direction: [f64; 3] = [0, 1, 2].map(|a| ray.direction[a] / self.spacing[a]);
        let origin = [0, 1, 2].map(|a| ray.origin[a] / self.spacing[a]);
        let inv = direction.map(|d| 1.0 / if d == 0.0 { 1e-300 } else { d });
        CellRay {
            origin,
            direction,
            inv,
            origin32: origin.map(|v| v as f32),
            inv32: inv.map(|v| v.clamp(-1e30, 1e30) as f32),
        }
    }

    /// The closest crossing of the isosurface with `t ∈ [tmin, tmax]`, or `None`.
    pub fn closest_hit(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let r = self.cell_ray(ray);
        let mut best = Best {
            t: tmax,
            found: None,
        };
        self.walk_blocks(&r, tmin, tmax, |block| {
            self.closest_in_block(&r, block, tmin, &mut best);
            best.t
        });
        let (t, cell, position, cluster, tri, u) = best.found?;
        let g = tri.gradient(u);
        let gw = [0, 1, 2].map(|a| g[a] / self.spacing[a]);
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
            cluster,
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
        self.walk_blocks(&r, tmin, tmax, |block| {
            if self.any_box_in_block(&r, block, tmin, tmax) {
                hit = true;
                f64::NEG_INFINITY
            } else {
                f64::INFINITY
            }
        });
        hit
    }

    /// Amanatides–Woo over blocks in `[tmin, tmax]`. `visit(block)` handles a non-empty block and
    /// returns the best hit `t` so far; traversal stops once it is no later than the block's exit.
    #[inline(always)]
    fn walk_blocks(&self, r: &CellRay, tmin: f64, tmax: f64, mut visit: impl FnMut(&Block) -> f64) {
        let (near, far) = r.slab([0.0; 3], self.cell_dims);
        let t_enter = near.max(tmin);
        let t_exit = far.min(tmax);
        if !(t_enter <= t_exit) || self.block_dims.contains(&0) {
            return;
        }
        let p = r.at(t_enter);
        let bc = BLOCK_CELLS as f64;
        let mut block =
            [0usize, 1, 2].map(|a| ((p[a] / bc).floor() as i64).clamp(0, self.block_dims[a] - 1));
        let mut step = [0i64; 3];
        let mut t_next = [0.0f64; 3];
        let mut t_delta = [0.0f64; 3];
        for a in 0..3 {
            let forward = r.direction[a] >= 0.0;
            step[a] = if forward { 1 } else { -1 };
            let boundary = if forward { block[a] + 1 } else { block[a] } as f64 * bc;
            t_next[a] = (boundary - r.origin[a]) * r.inv[a];
            t_delta[a] = bc * r.inv[a].abs();
        }
        let [nx, ny, _] = self.block_dims;
        loop {
            let exit = t_next[0].min(t_next[1]).min(t_next[2]);
            let index = (block[0] + nx * (block[1] + ny * block[2])) as usize;
            let b = &self.blocks[index];
            if b.metacell_count > 0 {
                let best = visit(b);
                if best <= exit {
                    return;
                }
            }
            if exit >= t_exit {
                return;
            }
            let a = if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
                0
            } else if t_next[1] <= t_next[2] {
                1
            } else {
                2
            };
            block[a] += step[a];
            if block[a] < 0 || block[a] >= self.block_dims[a] {
                return;
            }
            t_next[a] += t_delta[a];
        }
    }

    fn closest_in_block(&self, r: &CellRay, block: &Block, tmin: f64, best: &mut Best) {
        let slots = &self.metacells[block.slots()];
        let first_cluster = block.metacell_pointer as usize / CLUSTER_SLOTS;
        // Clusters whose bound the ray enters, nearest first, so that the search can stop at the
        // first cluster that starts behind the best hit. A block holds at most 512 metacells, so
        // at most 35 clusters.
        let mut order = [(0.0f64, 0u16); MAX_BLOCK_CLUSTERS];
        let mut count = 0;
        for (ci, cluster) in slots.chunks_exact(CLUSTER_SLOTS).enumerate() {
            let (lo, hi) = cluster[BOUND_SLOT].as_bound().cell_box();
            let (near, far) = r.slab(lo.map(|v| v as f64), hi.map(|v| v as f64));
            if near > far || far < tmin || near > best.t || count == MAX_BLOCK_CLUSTERS {
                continue;
            }
            let mut k = count;
            while k > 0 && order[k - 1].0 > near {
                order[k] = order[k - 1];
                k -= 1;
            }
            order[k] = (near, ci as u16);
            count += 1;
        }
        for &(near, ci) in &order[..count] {
            if near > best.t {
                break;
            }
            let ci = ci as usize;
            let cluster = &slots[ci * CLUSTER_SLOTS..(ci + 1) * CLUSTER_SLOTS];
            let mut candidates = metacell_hits(r, cluster, tmin, best.t, self.margin);
            while candidates != 0 {
                let m = &cluster[candidates.trailing_zeros() as usize];
                candidates &= candidates - 1;
                if m.cell_mask == 0 {
                    continue;
                }
                let mask = m.cell_mask & 0xff;
                let mut bits = mask;
                while bits != 0 {
                    let bit = bits.trailing_zeros();
                    bits &= bits - 1;
                    let pos = m.cell_position(bit);
                    let (lo, hi) = box_of(pos, 1);
                    let (near, far) = r.slab(lo, hi);
                    let t0 = near.max(tmin);
                    let t1 = far.min(best.t);
                    if !(t0 < t1) {
                        continue;
                    }
                    let index = m.cell_pointer + (mask & ((1u16 << bit) - 1)).count_ones();
                    let tri = Trilinear::new(&self.corners(index));
                    let start = r.at(t0);
                    let end = r.at(t1);
                    let start_local = [0, 1, 2].map(|a| start[a] - lo[a]);
                    let delta = [0, 1, 2].map(|a| end[a] - start[a]);
                    let cubic = tri.along(start_local, delta, self.iso_code);
                    if let Some(s) = cubic.first_crossing(self.crossing) {
                        let t = t0 + s * (t1 - t0);
                        if t < best.t || best.found.is_none() {
                            let u =
                                [0, 1, 2].map(|a| (start_local[a] + s * delta[a]).clamp(0.0, 1.0));
                            best.t = t;
                            best.found = Some((t, index, pos, (first_cluster + ci) as u32, tri, u));
                        }
                    }
                }
            }
        }
    }

    fn any_box_in_block(&self, r: &CellRay, block: &Block, tmin: f64, tmax: f64) -> bool {
        for cluster in self.metacells[block.slots()].chunks_exact(CLUSTER_SLOTS) {
            let (lo, hi) = cluster[BOUND_SLOT].as_bound().cell_box();
            let (near, far) = r.slab(lo.map(|v| v as f64), hi.map(|v| v as f64));
            if near > far || far < tmin || near > tmax {
                continue;
            }
            let mut candidates = metacell_hits(r, cluster, tmin, tmax, self.margin);
            while candidates != 0 {
                let m = &cluster[candidates.trailing_zeros() as usize];
                candidates &= candidates - 1;
                if m.cell_mask == 0 {
                    continue;
                }
                let mut bits = m.cell_mask & 0xff;
                while bits != 0 {
                    let bit = bits.trailing_zeros();
                    bits &= bits - 1;
                    let (lo, hi) = box_of(m.cell_position(bit), 1);
                    let (near, far) = r.slab(lo, hi);
                    if near.max(tmin) < far.min(tmax) {
                        return true;
                    }
                }
            }
        }
        false
    }

    #[inline(always)]
    fn corners(&self, index: u32) -> [f32; 8] {
        let n = self.precision.bytes_per_cell();
        let start = index as usize * n;
        read_corners(&self.cells[start..start + n], self.precision)
    }
}

type Found = (f64, u32, [u32; 3], u32, Trilinear, [f64; 3]);

struct Best {
    t: f64,
    found: Option<Found>,
}

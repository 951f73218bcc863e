//! An independent CPU reference for the cell rasteriser: marches each pixel's ray (from
//! `Camera::ray`, in f64) through the whole grid in steps of 1/32 cell, evaluating the trilinear
//! interpolant of the stored corner codes in active cells and the known side of inactive cells,
//! and bisects the first sign change to 1e-9. Normals are −∇f of the active cell at the hit.

use isogrid::layout::{read_corners, CLUSTER_SLOTS};
use isogrid::{Camera, CellGrid, Ray, Volume};
use rayon::prelude::*;

#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// World distance from the eye along the unit ray.
    pub t: f64,
    /// Unit world −∇f.
    pub normal: [f64; 3],
}

pub struct Reference {
    cells: [usize; 3],
    spacing: [f64; 3],
    iso: f64,
    /// Dense over cells: index into `corners`, or u32::MAX for an inactive cell.
    index: Vec<u32>,
    corners: Vec<[f64; 8]>,
    /// Dense over cells: the side of an inactive cell (all its corners agree).
    inactive_inside: Vec<bool>,
}

const NONE: u32 = u32::MAX;

impl Reference {
    pub fn new(volume: &Volume, grid: &CellGrid) -> Self {
        let info = grid.info();
        let dims = volume.dims();
        let cells = dims.map(|d| d - 1);
        let n = cells[0] * cells[1] * cells[2];
        let mut index = vec![NONE; n];
        let mut corners = Vec::new();
        for (slot, m) in grid.metacells().iter().enumerate() {
            if slot % CLUSTER_SLOTS == CLUSTER_SLOTS - 1 {
                continue;
            }
            let mut record = m.cell_pointer as usize;
            for bit in 0..8 {
                if m.cell_mask & (1 << bit) == 0 {
                    continue;
                }
                let c = m.cell_position(bit).map(|v| v as usize);
                let codes = read_corners(grid.cell_record(record), info.precision);
                index[c[0] + cells[0] * (c[1] + cells[1] * c[2])] = corners.len() as u32;
                corners.push(codes.map(|v| v as f64));
                record += 1;
            }
        }
        let mut inactive_inside = vec![false; n];
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    inactive_inside[i + cells[0] * (j + cells[1] * k)] =
                        volume.get(i, j, k) >= info.iso;
                }
            }
        }
        Reference {
            cells,
            spacing: info.spacing,
            iso: info.mapping.iso_code as f64,
            index,
            corners,
            inactive_inside,
        }
    }

    /// Cell containing a world point (clamped to the grid) and the point in that cell's [0,1]³.
    fn locate(&self, p: [f64; 3]) -> (usize, [f64; 3]) {
        let mut cell = [0usize; 3];
        let mut local = [0.0; 3];
        for a in 0..3 {
            let c = p[a] / self.spacing[a];
            let i = (c.floor().max(0.0) as usize).min(self.cells[a] - 1);
            cell[a] = i;
            local[a] = c - i as f64;
        }
        (
            cell[0] + self.cells[0] * (cell[1] + self.cells[1] * cell[2]),
            local,
        )
    }

    fn inside(&self, p: [f64; 3]) -> bool {
        let (cell, local) = self.locate(p);
        match self.index[cell] {
            NONE => self.inactive_inside[cell],
            i => trilinear(&self.corners[i as usize], local) >= self.iso,
        }
    }

    fn normal(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let (cell, local) = self.locate(p);
        let i = self.index[cell];
        if i == NONE {
            return None;
        }
        let g = gradient(&self.corners[i as usize], local);
        let n = [0, 1, 2].map(|a| -g[a] / self.spacing[a]);
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        (len > 0.0).then(|| n.map(|v| v / len))
    }

    // One slab per axis over three per-axis arrays: indexing reads clearer than zips here.
    #[allow(clippy::needless_range_loop)]
    pub fn trace(&self, ray: &Ray) -> Option<Hit> {
        let hi = [0, 1, 2].map(|a| self.cells[a] as f64 * self.spacing[a]);
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            let d = ray.direction[a];
            if d.abs() < 1e-300 {
                if ray.origin[a] < 0.0 || ray.origin[a] > hi[a] {
                    return None;
                }
                continue;
            }
            let (mut ta, mut tb) = ((0.0 - ray.origin[a]) / d, (hi[a] - ray.origin[a]) / d);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
        if t1 <= t0 {
            return None;
        }
        let at = |t: f64| [0, 1, 2].map(|a| ray.origin[a] + t * ray.direction[a]);
        let step = self.spacing.iter().cloned().fold(f64::INFINITY, f64::min) / 32.0;
        let start = t0 + 1e-9;
        let first = self.inside(at(start));
        let mut prev = start;
        loop {
            let t = (prev + step).min(t1 - 1e-9);
            if t <= prev {
                return None;
            }
            if self.inside(at(t)) != first {
                let (mut a, mut b) = (prev, t);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if self.inside(at(m)) == first {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let normal = self.normal(at(b)).or_else(|| self.normal(at(a)))?;
                return Some(Hit {
                    t: 0.5 * (a + b),
                    normal,
                });
            }
            prev = t;
        }
    }

    /// One hit (or miss) per pixel, row-major from the top-left.
    pub fn render(&self, camera: &Camera) -> Vec<Option<Hit>> {
        (0..camera.width * camera.height)
            .into_par_iter()
            .map(|i| self.trace(&camera.ray(i % camera.width, i / camera.width)))
            .collect()
    }
}

fn trilinear(v: &[f64; 8], p: [f64; 3]) -> f64 {
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(v[0], v[1], p[0]);
    let x10 = lerp(v[2], v[3], p[0]);
    let x01 = lerp(v[4], v[5], p[0]);
    let x11 = lerp(v[6], v[7], p[0]);
    lerp(lerp(x00, x10, p[1]), lerp(x01, x11, p[1]), p[2])
}

fn gradient(v: &[f64; 8], p: [f64; 3]) -> [f64; 3] {
    // Finite differences of the trilinear form are exact along each axis (it is linear there).
    let mut g = [0.0; 3];
    for a in 0..3 {
        let mut lo = p;
        let mut hi = p;
        lo[a] = 0.0;
        hi[a] = 1.0;
        g[a] = trilinear(v, hi) - trilinear(v, lo);
    }
    g
}

/// How a GPU frame agrees with the reference.
#[derive(Debug)]
pub struct Agreement {
    pub pixels: usize,
    pub hit_agree: usize,
    pub both_hit: usize,
    /// Pixels hit by both whose depths differ by at most the tolerance.
    pub depth_ok: usize,
    pub max_depth_error: f64,
    /// Angles (degrees) between GPU and reference normals where both hit and depth agrees, sorted.
    pub angles: Vec<f64>,
}

impl Agreement {
    pub fn hit_fraction(&self) -> f64 {
        self.hit_agree as f64 / self.pixels as f64
    }
    pub fn depth_fraction(&self) -> f64 {
        self.depth_ok as f64 / self.both_hit.max(1) as f64
    }
    pub fn angle_quantile(&self, q: f64) -> f64 {
        if self.angles.is_empty() {
            return 0.0;
        }
        self.angles[((self.angles.len() - 1) as f64 * q).round() as usize]
    }
}

pub fn compare(
    frame: &isogrid_gpu::Frame,
    reference: &[Option<Hit>],
    depth_tolerance: f64,
) -> Agreement {
    let mut a = Agreement {
        pixels: reference.len(),
        hit_agree: 0,
        both_hit: 0,
        depth_ok: 0,
        max_depth_error: 0.0,
        angles: Vec::new(),
    };
    for (i, r) in reference.iter().enumerate() {
        let gpu_hit = frame.is_hit(i);
        if gpu_hit != r.is_some() {
            continue;
        }
        a.hit_agree += 1;
        let Some(r) = r else { continue };
        a.both_hit += 1;
        let err = (frame.depth[i] as f64 - r.t).abs();
        a.max_depth_error = a.max_depth_error.max(err);
        if err <= depth_tolerance {
            a.depth_ok += 1;
            let n = frame.normal[i].map(|v| v as f64);
            let dot =
                (n[0] * r.normal[0] + n[1] * r.normal[1] + n[2] * r.normal[2]).clamp(-1.0, 1.0);
            a.angles.push(dot.acos().to_degrees());
        }
    }
    a.angles.sort_by(|x, y| x.total_cmp(y));
    a
}

//! Ray setup: a ray in cell units with everything the traversals' slab tests need precomputed
//! (the slab test of Kay & Kajiya 1986 as the paper's §3.2 uses it, with the near and far face of
//! every box chosen once per ray from the direction's signs, Williams et al. 2005).
//!
//! Cell units: world / spacing per axis, so cell `(i, j, k)` is the box `[i, i+1]×[j, j+1]×[k, k+1]`;
//! the ray parameter `t` stays the world distance along the unit-direction world ray.

use isogrid::camera::Ray;

/// See the module docs. Zero direction components get a huge finite reciprocal (as if the
/// direction were +1e−300) so that slab tests never compute 0·∞.
#[derive(Debug, Clone, Copy)]
pub(super) struct CellRay {
    pub origin: [f64; 3],
    pub direction: [f64; 3],
    pub inv: [f64; 3],
    /// Metacell boxes grown by the tracer's margin, `t` as the ray's own.
    faces: BoxFaces,
}

impl CellRay {
    /// `ray` (world space) rescaled by `spacing`; metacell boxes grown by `margin` cells.
    pub fn new(ray: &Ray, spacing: [f64; 3], margin: f64) -> Self {
        Self::from_units(cell_units(ray, spacing, spacing.map(|s| 1.0 / s)), margin)
    }

    /// As [`Self::new`], from the ray's [`cell_units`].
    #[inline(always)]
    pub fn from_units(units: CellUnits, margin: f64) -> Self {
        let (origin, direction, inv) = units;
        CellRay {
            origin,
            direction,
            inv,
            faces: BoxFaces::new(origin, inv, margin),
        }
    }

    /// Entry and exit `t` of the box `[lo, hi]` (cell units, `lo ≤ hi` on every axis); empty when
    /// entry > exit.
    #[inline(always)]
    pub fn slab(&self, lo: [f64; 3], hi: [f64; 3]) -> (f64, f64) {
        let mut near = f64::NEG_INFINITY;
        let mut far = f64::INFINITY;
        for a in 0..3 {
            // The face met first is the one with the smaller time: a minimum and a maximum
            // instead of choosing the face by the direction's sign, which compiled to a branch
            // that a random ray's sign makes unpredictable (the times are the same products).
            let t_lo = (lo[a] - self.origin[a]) * self.inv[a];
            let t_hi = (hi[a] - self.origin[a]) * self.inv[a];
            near = max(near, min(t_lo, t_hi));
            far = min(far, max(t_lo, t_hi));
        }
        (near, far)
    }

    /// The f32 slab-test constants of metacell boxes for this ray.
    #[inline(always)]
    pub fn faces(&self) -> &BoxFaces {
        &self.faces
    }

    /// Whether the ray runs towards −axis `a`.
    #[inline(always)]
    pub fn negative(&self, a: usize) -> bool {
        self.faces.negative[a]
    }

    /// The cells of the metacell whose lowest cell is `lo` (cell units) that the ray passes
    /// through within `[tmin, tmax]`, nearest first: at most four `(entry, exit, cell bit)` with
    /// bit = x + 2y + 4z inside the metacell, and only cells whose bit is set in `mask`.
    ///
    /// One slab test for the metacell and the three mid-planes replace eight cell slab tests, and
    /// the order lets the closest-hit search stop at the first crossing. Every face time is
    /// `(plane − origin)·inv` as in [`Self::slab`], so neighbouring cells and metacells agree
    /// exactly on shared faces.
    #[inline(always)]
    pub fn metacell_cells(&self, lo: [f64; 3], mask: u16, tmin: f64, tmax: f64) -> MetacellCells {
        let (near, far) = self.slab(lo, xyz(|a| lo[a] + 2.0));
        let (t_in, t_out) = (max(near, tmin), min(far, tmax));
        if !(t_in < t_out) {
            return MetacellCells {
                bounds: [0.0; 5],
                bits: 0,
                listed: 0,
            };
        }
        // Segment boundaries: entry, the mid-plane crossings clamped into [entry, exit] and
        // sorted, exit. Without branches (a sorting network, and the cells kept as a bit set):
        // which planes a random ray crosses, and in which order, is a coin toss that a branch
        // predictor keeps getting wrong. Empty segments (a plane outside the metacell's span, or
        // two planes crossed at once) are dropped.
        let mid = xyz(|a| {
            min(
                max((lo[a] + 1.0 - self.origin[a]) * self.inv[a], t_in),
                t_out,
            )
        });
        let (a, b) = (min(mid[0], mid[1]), max(mid[0], mid[1]));
        let (b, c) = (min(b, mid[2]), max(b, mid[2]));
        let (a, b) = (min(a, b), max(a, b));
        let bounds = [t_in, a, b, c, t_out];
        // Which cell a segment lies in, from the face times alone: every mid-plane time is one of
        // the bounds, so a segment lies wholly past a plane's crossing (time ≤ its start) or
        // wholly before it; past it, a ray running towards +axis is on the upper side. Per axis,
        // bit k of `upper` is segment k's side; spread to bit 8k and merged, byte k is its cell.
        let spread = |four: u32| four.wrapping_mul(0x0020_4081) & 0x0101_0101;
        let bits = (0..3).fold(0u32, |bits, a| {
            let past = (0..4).fold(0u32, |m, k| m | ((mid[a] <= bounds[k]) as u32) << k);
            let upper = past ^ (self.negative(a) as u32 * 0xf);
            bits | spread(upper) << a
        });
        let listed = (0..4).fold(0u32, |m, k| {
            let cell = bits >> (8 * k) & 7;
            let keep = (bounds[k] < bounds[k + 1]) & (mask >> cell & 1 == 1);
            m | (keep as u32) << k
        });
        MetacellCells {
            bounds,
            bits,
            listed,
        }
    }

    #[inline(always)]
    pub fn at(&self, t: f64) -> [f64; 3] {
        xyz(|a| self.origin[a] + t * self.direction[a])
    }
}

/// The cells of one metacell a ray passes through ([`CellRay::metacell_cells`]), nearest first,
/// as `(entry, exit, cell bit)`: segment `k` runs from `bounds[k]` to `bounds[k + 1]` in the cell
/// whose bit is byte `k` of `bits`, and is listed when bit `k` of `listed` is set.
#[derive(Debug, Clone, Copy)]
pub(super) struct MetacellCells {
    bounds: [f64; 5],
    bits: u32,
    listed: u32,
}

impl Iterator for MetacellCells {
    type Item = (f64, f64, u32);

    #[inline(always)]
    fn next(&mut self) -> Option<Self::Item> {
        if self.listed == 0 {
            return None;
        }
        let k = self.listed.trailing_zeros() as usize;
        self.listed &= self.listed - 1;
        Some((self.bounds[k], self.bounds[k + 1], self.bits >> (8 * k) & 7))
    }
}

/// A ray's f32 slab-test constants for boxes made of whole metacells (2×2×2 cells), in cell
/// units: on axis `a` the face met first of the metacell at position `p` (metacell units) lies at
/// `t = p·scale[a] + near[a]`, the face met last at `p·scale[a] + far[a]`, every box grown by a
/// margin, with `t` measured from the origin the constants were made for. The hierarchy's nodes,
/// the cluster bounds and the metacells inside a cluster are all such boxes.
#[derive(Debug, Clone, Copy)]
pub(super) struct BoxFaces {
    pub scale: [f32; 3],
    pub near: [f32; 3],
    pub far: [f32; 3],
    /// Per axis, whether the ray runs towards −axis (then a box's upper face is met first).
    pub negative: [bool; 3],
}

impl BoxFaces {
    /// For the ray from `origin` with reciprocal direction `inv` (cell units), boxes grown by
    /// `margin` cells.
    #[inline(always)]
    pub fn new(origin: [f64; 3], inv: [f64; 3], margin: f64) -> Self {
        // f32 keeps the reciprocal finite; the margin absorbs the rounding of these constants.
        let inv = xyz(|a| inv[a].clamp(-1e30, 1e30));
        // Offset of a box's lower face from 2·lo, and of its upper face from 2·hi; the face met
        // first has the smaller time (no branch on the sign, as in `CellRay::slab`).
        let lower = xyz(|a| ((-margin - origin[a]) * inv[a]) as f32);
        let upper = xyz(|a| ((2.0 + margin - origin[a]) * inv[a]) as f32);
        BoxFaces {
            scale: xyz(|a| (2.0 * inv[a]) as f32),
            near: xyz(|a| min(lower[a], upper[a])),
            far: xyz(|a| max(lower[a], upper[a])),
            negative: xyz(|a| inv[a] < 0.0),
        }
    }

    /// Slab tests of four boxes made of metacells, in f32 lanes, on boxes grown by the margin.
    /// Box `k` runs from metacell `lo[a][k]` to metacell `hi[a][k]` (inclusive) on axis `a`, so
    /// `lo == hi` is one metacell's 2×2×2 cells and a cluster bound is its `lo, hi`; `lo > hi`
    /// is an empty box. Returns bit `k` set when the ray passes through box `k` within
    /// `[lo_t, hi_t]`, and each box's entry `t` (≤ the true entry: the box is grown).
    #[inline(always)]
    pub fn boxes4(
        &self,
        lo: &[[f32; 4]; 3],
        hi: &[[f32; 4]; 3],
        (lo_t, hi_t): (f32, f32),
    ) -> (u32, [f32; 4]) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of the x86-64 baseline; every load and store addresses 4 lanes.
            unsafe {
                let mut near = _mm_set1_ps(lo_t);
                let mut far = _mm_set1_ps(hi_t);
                for a in 0..3 {
                    // The face met first belongs to the box's lower metacell unless the ray runs
                    // towards −axis (then `near` holds the upper face's offset).
                    let (first, last) = if self.negative[a] { (hi, lo) } else { (lo, hi) };
                    let first = _mm_loadu_ps(first[a].as_ptr());
                    let last = _mm_loadu_ps(last[a].as_ptr());
                    let scale = _mm_set1_ps(self.scale[a]);
                    let n = _mm_set1_ps(self.near[a]);
                    let f = _mm_set1_ps(self.far[a]);
                    let n = _mm_add_ps(_mm_mul_ps(first, scale), n);
                    let f = _mm_add_ps(_mm_mul_ps(last, scale), f);
                    near = _mm_max_ps(near, n);
                    far = _mm_min_ps(far, f);
                }
                let mut entry = [0f32; 4];
                _mm_storeu_ps(entry.as_mut_ptr(), near);
                (_mm_movemask_ps(_mm_cmple_ps(near, far)) as u32, entry)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut near = [lo_t; 4];
            let mut far = [hi_t; 4];
            for a in 0..3 {
                let (first, last) = if self.negative[a] { (hi, lo) } else { (lo, hi) };
                for k in 0..4 {
                    let scale = self.scale[a];
                    near[k] = max(near[k], first[a][k] * scale + self.near[a]);
                    far[k] = min(far[k], last[a][k] * scale + self.far[a]);
                }
            }
            let mask = (0..4).fold(0, |m, k| m | ((near[k] <= far[k]) as u32) << k);
            (mask, near)
        }
    }
}

/// `ray`'s origin, direction and the direction's reciprocals in cell units (world / `spacing`;
/// `to_cells` is `1 / spacing`, which callers keep per tracer), as [`CellRay`] holds them; for
/// callers that need them in registers before, or instead of, a whole `CellRay`.
#[inline(always)]
pub(super) fn cell_units(ray: &Ray, spacing: [f64; 3], to_cells: [f64; 3]) -> CellUnits {
    // One division between the ray and the reciprocals (spacing / direction, not
    // 1 / (direction / spacing)): the per-ray setup is a chain that every ray waits on.
    let direction: [f64; 3] = xyz(|a| ray.direction[a] * to_cells[a]);
    let origin = xyz(|a| ray.origin[a] * to_cells[a]);
    let inv = xyz(|a| {
        if ray.direction[a] == 0.0 {
            1e300
        } else {
            spacing[a] / ray.direction[a]
        }
    });
    (origin, direction, inv)
}

/// A ray's origin, direction and per-axis reciprocal of the direction, in cell units.
pub(super) type CellUnits = ([f64; 3], [f64; 3], [f64; 3]);

/// `min` and `max` without `f64::min`'s NaN handling (a few instructions more per call on the
/// hottest path): no NaN reaches them, since directions are finite and reciprocals are finite.
#[inline(always)]
pub(super) fn min<T: PartialOrd>(a: T, b: T) -> T {
    if a < b {
        a
    } else {
        b
    }
}
#[inline(always)]
pub(super) fn max<T: PartialOrd>(a: T, b: T) -> T {
    if a > b {
        a
    } else {
        b
    }
}

/// `[lo, hi]` in f32 for the lanes' slab tests, never narrower than in f64: each end is pushed
/// out by 10⁻³ + 10⁻⁵·|end| and clamped to the finite f32 range, which holds every box's `t`.
/// That is far more than the conversion's rounding (2⁻²⁴ relative); the slack also covers the
/// block walk's f32 box times, which are measured from the ray's origin rather than from a point
/// near the boxes. Wider only costs a box test that the exact f64 cell test then rejects. No
/// branch (directed rounding with `next_up`/`next_down` took about 100 instructions per ray):
/// this runs once per ray and once per cluster searched.
#[inline(always)]
pub(crate) fn widen_f32(lo: f64, hi: f64) -> (f32, f32) {
    const ABSOLUTE: f64 = 1e-3;
    const RELATIVE: f64 = 1e-5;
    let lo = max(lo - ABSOLUTE - RELATIVE * lo.abs(), -(f32::MAX as f64));
    let hi = min(hi + ABSOLUTE + RELATIVE * hi.abs(), f32::MAX as f64);
    (lo as f32, hi as f32)
}

/// `[f(0), f(1), f(2)]`. `<[T; 3]>::map` is not always inlined: its calls were a tenth of the
/// tracer's instructions.
#[inline(always)]
pub(super) fn xyz<T>(f: impl Fn(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::{uniform_sphere, Rng};

    /// The cells `metacell_cells` lists, in its order, are those whose own slab test the ray
    /// passes with a segment longer than rounding, nearest first, with the same times.
    #[test]
    fn metacell_cells_agree_with_eight_slab_tests() {
        let mut rng = Rng::for_sample(17, 0, 0);
        let mut listed = 0;
        for round in 0..20_000 {
            let lo = [1.0, 2.0, 1.0];
            let origin: [f64; 3] = std::array::from_fn(|_| -1.0 + 6.0 * rng.unit());
            // Most rays aimed at a point of the metacell, the rest in any direction.
            let mut direction = uniform_sphere(&mut rng);
            if round % 4 != 0 {
                let target: [f64; 3] = std::array::from_fn(|a| lo[a] + 2.0 * rng.unit());
                let d = xyz(|a| target[a] - origin[a]);
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                direction = d.map(|v| v / len);
            }
            // Some rays parallel to an axis, as camera rays through a pixel centre can be.
            if round % 10 == 0 {
                direction[round / 10 % 3] = 0.0;
            }
            let ray = Ray { origin, direction };
            let r = CellRay::new(&ray, [1.0; 3], 0.0);
            let mask = (rng.unit() * 256.0) as u16 | 1;
            let (tmin, tmax) = (0.0, 2.0 + 6.0 * rng.unit());
            let cells: Vec<_> = r.metacell_cells(lo, mask, tmin, tmax).collect();
            let mut expected: Vec<(f64, f64, u32)> = (0..8u32)
                .filter(|&bit| mask >> bit & 1 == 1)
                .filter_map(|bit| {
                    let cell = xyz(|a| lo[a] + (bit >> a & 1) as f64);
                    let (near, far) = r.slab(cell, xyz(|a| cell[a] + 1.0));
                    let (t0, t1) = (max(near, tmin), min(far, tmax));
                    (t1 - t0 > 1e-9).then_some((t0, t1, bit))
                })
                .collect();
            expected.sort_by(|a, b| a.0.total_cmp(&b.0));
            // Every listed segment is non-empty and in a cell of the mask.
            for &(t0, t1, bit) in &cells {
                assert!(t0 < t1 && mask >> bit & 1 == 1, "{ray:?}: {cells:?}");
            }
            let got: Vec<_> = cells.iter().filter(|s| s.1 - s.0 > 1e-9).copied().collect();
            assert_eq!(
                got.len(),
                expected.len(),
                "{ray:?}: {got:?} vs {expected:?}"
            );
            for (g, e) in got.iter().zip(&expected) {
                assert_eq!(g.2, e.2, "{ray:?}: {got:?} vs {expected:?}");
                assert!(
                    (g.0 - e.0).abs() < 1e-12 && (g.1 - e.1).abs() < 1e-12,
                    "{g:?} {e:?}"
                );
            }
            listed += got.len();
        }
        assert!(listed > 15_000, "{listed} cells listed");
    }
}

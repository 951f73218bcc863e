//! Where a ray crosses the isosurface inside one cell: the trilinear interpolant of the cell's
//! eight stored corner codes, restricted to the ray's segment through the cell, is a cubic in the
//! ray parameter (Parker et al. 1998, "Interactive ray tracing for isosurface rendering").
//!
//! Cell-local coordinates: `u ∈ [0, 1]³`, corner `c` at `(c&1, c>>1&1, c>>2&1)` (layout.rs order).
//! The segment is `u(s) = start + s·delta` for `s ∈ [0, 1]`, and a crossing is the first `s > 0`
//! where the side of the isovalue (inside ⇔ code ≥ iso) differs from the side at `s = 0`. Touching
//! the isovalue without changing side is not a crossing.
//!
//! Two ways to find it ([`Crossing`]):
//! * `Samples3` (the paper's §3.2, as the rasteriser does it): the trilinear field is sampled at
//!   three points of the segment — its entry `s = 0`, its middle `s = ½` and its exit `s = 1` — and
//!   the first pair of consecutive samples on different sides brackets the crossing, which is then
//!   refined. Two crossings between the same pair of samples are missed (a ray that dips into a
//!   thin sliver of the surface and leaves again within half a cell).
//! * `Exact`: the cubic's derivative splits `[0, 1]` into at most three monotonic pieces; the first
//!   piece whose end lies on the other side brackets the first crossing. No crossing is missed
//!   except one within rounding error of a tangency.

/// How the crossing inside a cell is located.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Crossing {
    /// Three samples (entry, middle, exit of the cell segment), refined between the first pair on
    /// different sides: the paper's choice, shared with the GPU rasteriser.
    #[default]
    Samples3,
    /// First root of the cubic along the ray, found robustly on monotonic pieces.
    Exact,
}

/// The trilinear interpolant of eight corner values as a polynomial
/// `k0 + kx·x + ky·y + kz·z + kxy·xy + kxz·xz + kyz·yz + kxyz·xyz`.
#[derive(Debug, Clone, Copy)]
pub struct Trilinear {
    k: [f64; 8],
}

impl Trilinear {
    /// From corner values in corner order (bit 0 = +x, bit 1 = +y, bit 2 = +z).
    #[inline]
    pub fn new(corners: &[f32; 8]) -> Self {
        let mut c = [0f64; 8];
        for (c, &v) in c.iter_mut().zip(corners) {
            *c = v as f64;
        }
        Trilinear {
            k: [
                c[0],
                c[1] - c[0],
                c[2] - c[0],
                c[4] - c[0],
                c[3] - c[2] - c[1] + c[0],
                c[5] - c[4] - c[1] + c[0],
                c[6] - c[4] - c[2] + c[0],
                c[7] - c[6] - c[5] - c[3] + c[4] + c[2] + c[1] - c[0],
            ],
        }
    }

    /// Value at local point `u`.
    pub fn value(&self, u: [f64; 3]) -> f64 {
        let [k0, kx, ky, kz, kxy, kxz, kyz, kxyz] = self.k;
        let [x, y, z] = u;
        k0 + kx * x + ky * y + kz * z + kxy * x * y + kxz * x * z + kyz * y * z + kxyz * x * y * z
    }

    /// Gradient at local point `u`, in code units per cell.
    pub fn gradient(&self, u: [f64; 3]) -> [f64; 3] {
        let [_, kx, ky, kz, kxy, kxz, kyz, kxyz] = self.k;
        let [x, y, z] = u;
        [
            kx + kxy * y + kxz * z + kxyz * y * z,
            ky + kxy * x + kyz * z + kxyz * x * z,
            kz + kxz * x + kyz * y + kxyz * x * y,
        ]
    }

    /// Coefficients `[a, b, c, d]` of `value(start + s·delta) − iso = a·s³ + b·s² + c·s + d`.
    pub fn along(&self, start: [f64; 3], delta: [f64; 3], iso: f64) -> Cubic {
        let [_, kx, ky, kz, kxy, kxz, kyz, kxyz] = self.k;
        let [ox, oy, oz] = start;
        let [dx, dy, dz] = delta;
        let a = kxyz * dx * dy * dz;
        let b = kxy * dx * dy
            + kxz * dx * dz
            + kyz * dy * dz
            + kxyz * (ox * dy * dz + oy * dx * dz + oz * dx * dy);
        let c = kx * dx
            + ky * dy
            + kz * dz
            + kxy * (ox * dy + oy * dx)
            + kxz * (ox * dz + oz * dx)
            + kyz * (oy * dz + oz * dy)
            + kxyz * (dx * oy * oz + dy * ox * oz + dz * ox * oy);
        let d = self.value(start) - iso;
        Cubic([a, b, c, d])
    }
}

/// `a·s³ + b·s² + c·s + d`.
#[derive(Debug, Clone, Copy)]
pub struct Cubic(pub [f64; 4]);

/// Bracket width (in `s`) at which refinement stops; segments are at most √3 cells long, so the
/// hit is placed within ~2e-9 cells.
const S_TOLERANCE: f64 = 1e-9;
const MAX_REFINE_STEPS: usize = 64;

impl Cubic {
    #[inline]
    pub fn eval(&self, s: f64) -> f64 {
        let [a, b, c, d] = self.0;
        ((a * s + b) * s + c) * s + d
    }

    /// First `s ∈ (0, 1]` where the side (`≥ 0` inside) differs from the side at 0, by `mode`.
    #[inline]
    pub fn first_crossing(&self, mode: Crossing) -> Option<f64> {
        let start_inside = self.eval(0.0) >= 0.0;
        match mode {
            Crossing::Samples3 => {
                let mid = self.eval(0.5);
                if (mid >= 0.0) != start_inside {
                    return Some(self.refine(0.0, 0.5, start_inside));
                }
                let end = self.eval(1.0);
                if (end >= 0.0) != start_inside {
                    return Some(self.refine(0.5, 1.0, start_inside));
                }
                None
            }
            Crossing::Exact => {
                let mut splits = [0.0, 1.0, 1.0];
                let n = self.extrema_in_unit(&mut splits);
                let mut lo = 0.0;
                for &hi in splits[..n].iter().chain(std::iter::once(&1.0)) {
                    if hi <= lo {
                        continue;
                    }
                    if (self.eval(hi) >= 0.0) != start_inside {
                        return Some(self.refine(lo, hi, start_inside));
                    }
                    lo = hi;
                }
                None
            }
        }
    }

    /// Roots of the derivative `3a·s² + 2b·s + c` strictly inside (0, 1), ascending; returns how
    /// many were written.
    fn extrema_in_unit(&self, out: &mut [f64; 3]) -> usize {
        let [a, b, c, _] = self.0;
        let (qa, qb, qc) = (3.0 * a, 2.0 * b, c);
        let mut roots = [f64::NAN; 2];
        let scale = qa.abs().max(qb.abs()).max(qc.abs());
        if scale == 0.0 {
            return 0;
        }
        if qa.abs() <= 1e-12 * scale {
            if qb != 0.0 {
                roots[0] = -qc / qb;
            }
        } else {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                // Numerically stable pair (no cancellation between −b and √disc).
                let q = -0.5 * (qb + qb.signum() * disc.sqrt());
                if q != 0.0 {
                    roots = [q / qa, qc / q];
                } else {
                    roots = [0.0, 0.0];
                }
            }
        }
        if roots[0] > roots[1] {
            roots.swap(0, 1);
        }
        let mut n = 0;
        for r in roots {
            if r > 0.0 && r < 1.0 {
                out[n] = r;
                n += 1;
            }
        }
        n
    }

    #[inline]
    fn derivative(&self, s: f64) -> f64 {
        let [a, b, c, _] = self.0;
        (3.0 * a * s + 2.0 * b) * s + c
    }

    /// Shrinks `[lo, hi]` (side at `lo` = `start_inside`, at `hi` the other) to the crossing and
    /// returns the first point known to be on the far side.
    ///
    /// Newton's method kept inside the bracket (bisection whenever a step would leave it), started
    /// from the false-position point: the cubic is smooth, so it converges in about four steps
    /// where false position took about ten. Newton iterates approach a root from one side, so once
    /// a step is shorter than half the tolerance the point half a tolerance further is past the
    /// root and closes the bracket: that point is returned without evaluating it (the evaluation
    /// was a fifth of a hit ray's refinement; on the 2M rays of `bench_rays.py` the hits moved by
    /// at most one f32 unit, on 3 rays), unless the step heads the wrong way, when it is evaluated
    /// as any other.
    fn refine(&self, mut lo: f64, mut hi: f64, start_inside: bool) -> f64 {
        let (f_lo, f_hi) = (self.eval(lo), self.eval(hi));
        let mut s = lo - f_lo * (hi - lo) / (f_hi - f_lo);
        if !(s > lo && s < hi) {
            s = 0.5 * (lo + hi);
        }
        for _ in 0..MAX_REFINE_STEPS {
            if hi - lo <= S_TOLERANCE {
                break;
            }
            let f = self.eval(s);
            if (f >= 0.0) == start_inside {
                lo = s;
            } else {
                hi = s;
            }
            let step = -f / self.derivative(s);
            if step.abs() < 0.5 * S_TOLERANCE {
                // Converged: the root lies within `step` of `s`, far closer than the tolerance.
                // Half a tolerance further along the step is past it, which is where the
                // evaluation below would close the bracket; stop without it. Only steps that
                // head towards the far side are cut short (a step against the bracket's order
                // means the iterate has not converged).
                if lo == s && step >= 0.0 {
                    let past = s + 0.5 * S_TOLERANCE;
                    return if past < hi { past } else { hi };
                }
                if hi == s && step <= 0.0 {
                    return hi;
                }
            }
            let step = if step.abs() < 0.5 * S_TOLERANCE {
                0.5 * S_TOLERANCE * if step < 0.0 { -1.0 } else { 1.0 }
            } else {
                step
            };
            s += step;
            if !(s > lo && s < hi) {
                s = 0.5 * (lo + hi);
            }
        }
        hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_matches_trilinear_along_the_segment() {
        let c = [0.0, 3.0, -2.0, 7.0, 1.5, -4.0, 2.0, 9.0];
        let tri = Trilinear::new(&c);
        let start = [0.1, 0.9, 0.3];
        let delta = [0.8, -0.7, 0.6];
        let cubic = tri.along(start, delta, 1.25);
        for i in 0..=10 {
            let s = i as f64 / 10.0;
            let u = [0, 1, 2].map(|a| start[a] + s * delta[a]);
            assert!((cubic.eval(s) - (tri.value(u) - 1.25)).abs() < 1e-12);
        }
        // Corners reproduce the stored values.
        for (i, &v) in c.iter().enumerate() {
            let u = [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64];
            assert!((tri.value(u) - v as f64).abs() < 1e-12);
        }
    }

    /// A small xorshift generator for the property tests below.
    fn unit_stream(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The refinement returns a point on the far side of the crossing, within the tolerance of
    /// the root (found here by bisection to rounding), also where it stops without evaluating.
    #[test]
    fn refinement_lands_just_past_the_root() {
        let mut unit = unit_stream(0x2545_f491_4f6c_dd1d);
        let mut refined = 0;
        for _ in 0..20_000 {
            let cubic = Cubic(std::array::from_fn(|_| 8.0 * unit() - 4.0));
            let Some(s) = cubic.first_crossing(Crossing::Samples3) else {
                continue;
            };
            let inside = cubic.eval(0.0) >= 0.0;
            let (mut lo, mut hi) = if (cubic.eval(0.5) >= 0.0) != inside {
                (0.0, 0.5)
            } else {
                (0.5, 1.0)
            };
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if (cubic.eval(mid) >= 0.0) == inside {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // Several roots may share a bracket; the refinement finds one of them.
            let near_a_root = (0..=1000).any(|k| {
                let (a, b) = (s - 2.0 * S_TOLERANCE, s);
                let x = a + (b - a) * k as f64 / 1000.0;
                (cubic.eval(x) >= 0.0) == inside
            });
            assert!((cubic.eval(s) >= 0.0) != inside, "{cubic:?} {s}");
            assert!(
                near_a_root,
                "{cubic:?}: {s} is not just past a root (bisection: {hi})"
            );
            refined += 1;
        }
        assert!(refined > 5_000, "{refined}");
    }

    #[test]
    fn exact_finds_a_double_crossing_that_three_samples_miss() {
        // (s − 0.1)(s − 0.3)·k: dips below zero on (0.1, 0.3) only.
        let cubic = Cubic([0.0, 1.0, -0.4, 0.03]);
        assert_eq!(cubic.first_crossing(Crossing::Samples3), None);
        let s = cubic.first_crossing(Crossing::Exact).unwrap();
        assert!((s - 0.1).abs() < 1e-8, "{s}");
        // A single crossing is found by both, at the same place.
        let single = Cubic([2.0, -1.0, 0.5, -0.3]);
        let a = single.first_crossing(Crossing::Samples3).unwrap();
        let b = single.first_crossing(Crossing::Exact).unwrap();
        assert!((a - b).abs() < 1e-8 && single.eval(b).abs() < 1e-7);
    }
}

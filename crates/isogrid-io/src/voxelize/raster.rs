//! Exact rasterisation of triangles onto columns of fine-voxel centres, one ray axis at a time.
//!
//! For ray axis `w` with plane axes `(u, v)`, a triangle covers the column through fine-voxel
//! centre `(fu + ½, fv + ½)` when that point lies inside its projection. Positions are snapped to
//! a fixed-point grid of 1/256 fine voxel and the inside test uses exact 64-bit edge functions, so
//! the answer never depends on rounding: a column through an edge shared by two triangles hits
//! exactly one of them, and one through a silhouette edge hits both or neither (parity unchanged).
//!
//! Ties (a centre exactly on an edge or vertex) are broken by the rule "include the edge when its
//! direction `d` has `d.v < 0`, or `d.v = 0` and `d.u > 0`" on the counter-clockwise-oriented
//! projection. This equals testing the point moved by an infinitesimal `(ε, ε²)`, the same for
//! every triangle, so the ray is effectively in general position: it crosses a closed surface an
//! even number of times whatever the mesh's winding.
//!
//! A crossing at depth `d` (fine units along `w`) is reported as a *toggle* at the first voxel
//! whose centre lies beyond it, `⌊d + ½⌋`: inside/outside along the ray is then the running parity
//! of toggles.

use std::ops::Range;

/// Fractional bits of the fixed-point positions.
pub(super) const SUB_BITS: u32 = 8;
pub(super) const ONE: i64 = 1 << SUB_BITS;
const HALF: i64 = ONE / 2;

/// A vertex in fixed-point fine-voxel coordinates (`ONE` per fine voxel; fine voxel `f` spans
/// `[f·ONE, (f+1)·ONE)`, its centre at `f·ONE + HALF`).
pub(super) type Fixed = [i64; 3];

/// The direction rays travel along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RayAxis {
    X,
    Y,
    Z,
}

impl RayAxis {
    pub(super) const ALL: [RayAxis; 3] = [RayAxis::X, RayAxis::Y, RayAxis::Z];

    /// `(u, v, w)`: the two plane axes and the ray axis.
    fn frame(self) -> (usize, usize, usize) {
        match self {
            RayAxis::X => (1, 2, 0),
            RayAxis::Y => (0, 2, 1),
            RayAxis::Z => (0, 1, 2),
        }
    }
}

/// Index of the first fine voxel whose centre is at or after `m` (fixed point).
fn first_centre_from(m: i64) -> i64 {
    (m - HALF + ONE - 1).div_euclid(ONE)
}

/// Index of the last fine voxel whose centre is at or before `m` (fixed point).
fn last_centre_until(m: i64) -> i64 {
    (m - HALF).div_euclid(ONE)
}

/// Range of toggle indices a triangle can produce along `w`, for quick rejection.
pub(super) fn toggle_span(tri: &[Fixed; 3], w: usize) -> Range<i64> {
    let lo = tri.iter().map(|p| p[w]).min().unwrap_or(0);
    let hi = tri.iter().map(|p| p[w]).max().unwrap_or(0);
    (lo + HALF).div_euclid(ONE)..(hi + HALF).div_euclid(ONE) + 1
}

/// Range of fine-voxel centres a triangle spans along axis `a`.
pub(super) fn centre_span(tri: &[Fixed; 3], a: usize) -> Range<i64> {
    let lo = tri.iter().map(|p| p[a]).min().unwrap_or(0);
    let hi = tri.iter().map(|p| p[a]).max().unwrap_or(0);
    first_centre_from(lo)..last_centre_until(hi) + 1
}

/// One directed edge's exact inside test.
struct Edge {
    p: [i64; 2],
    d: [i64; 2],
    /// 0 when points exactly on the edge count as inside, 1 when they do not.
    bias: i64,
}

impl Edge {
    fn new(p: [i64; 2], q: [i64; 2]) -> Self {
        let d = [q[0] - p[0], q[1] - p[1]];
        let includes_ties = d[1] < 0 || (d[1] == 0 && d[0] > 0);
        Edge {
            p,
            d,
            bias: (!includes_ties) as i64,
        }
    }

    /// Twice the signed area of (p, q, x): positive left of the edge. Exact: coordinates stay
    /// below 2^30, so the products stay below 2^61.
    fn value(&self, x: [i64; 2]) -> i64 {
        self.d[0] * (x[1] - self.p[1]) - self.d[1] * (x[0] - self.p[0])
    }
}

/// Reports every column of `axis` the triangle covers, as the fine voxel `[fx, fy, fz]` where the
/// ray's toggle lands. Columns are limited to `[0, fine)` on both plane axes and to `v_range` on
/// the second one; toggles outside `toggle_range` are dropped.
pub(super) fn rasterise(
    tri: &[Fixed; 3],
    axis: RayAxis,
    fine: [i64; 3],
    v_range: Range<i64>,
    toggle_range: Range<i64>,
    emit: &mut impl FnMut([i64; 3]),
) {
    let (u, v, w) = axis.frame();
    let project = |p: &Fixed| [p[u], p[v]];
    let (a, mut b, mut c) = (project(&tri[0]), project(&tri[1]), project(&tri[2]));
    let (wa, mut wb, mut wc) = (tri[0][w], tri[1][w], tri[2][w]);
    let mut area = Edge::new(a, b).value(c);
    if area == 0 {
        // Seen edge-on: a ray in general position misses it.
        return;
    }
    if area < 0 {
        std::mem::swap(&mut b, &mut c);
        std::mem::swap(&mut wb, &mut wc);
        area = -area;
    }
    // Edge opposite each vertex: its value at x, divided by the area, is that vertex's
    // barycentric weight.
    let edges = [Edge::new(b, c), Edge::new(c, a), Edge::new(a, b)];
    let span = |k: usize| {
        let lo = a[k].min(b[k]).min(c[k]);
        let hi = a[k].max(b[k]).max(c[k]);
        first_centre_from(lo)..last_centre_until(hi) + 1
    };
    let (su, sv) = (span(0), span(1));
    let u_range = su.start.max(0)..su.end.min(fine[u]);
    let v_range = sv.start.max(v_range.start).max(0)..sv.end.min(v_range.end).min(fine[v]);
    let depth_scale = 1.0 / (area as f64 * ONE as f64);
    for fv in v_range {
        let cv = fv * ONE + HALF;
        for fu in u_range.clone() {
            let x = [fu * ONE + HALF, cv];
            let e = [edges[0].value(x), edges[1].value(x), edges[2].value(x)];
            if e.iter().zip(&edges).any(|(&value, edge)| value < edge.bias) {
                continue;
            }
            let depth =
                (e[0] as f64 * wa as f64 + e[1] as f64 * wb as f64 + e[2] as f64 * wc as f64)
                    * depth_scale;
            let toggle = (depth + 0.5).floor() as i64;
            if toggle_range.contains(&toggle) {
                let mut voxel = [0i64; 3];
                voxel[u] = fu;
                voxel[v] = fv;
                voxel[w] = toggle;
                emit(voxel);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixed(p: [f64; 3]) -> Fixed {
        p.map(|c| (c * ONE as f64).round() as i64)
    }

    fn columns(tris: &[[Fixed; 3]], axis: RayAxis) -> Vec<[i64; 3]> {
        let mut out = Vec::new();
        for t in tris {
            rasterise(t, axis, [64; 3], 0..64, 0..65, &mut |p| out.push(p));
        }
        out.sort();
        out
    }

    /// A square split along its diagonal, whose corners and diagonal pass exactly through voxel
    /// centres: every centre of the closed square region must be hit exactly once across the two
    /// triangles, except those on the outer boundary, which follow the tie rule.
    #[test]
    fn shared_edges_and_vertices_are_counted_once() {
        let (p0, p1, p2, p3) = (
            fixed([1.5, 1.5, 3.0]),
            fixed([5.5, 1.5, 3.0]),
            fixed([5.5, 5.5, 3.0]),
            fixed([1.5, 5.5, 3.0]),
        );
        // Both windings, to show orientation does not matter.
        for tris in [[[p0, p1, p2], [p0, p2, p3]], [[p0, p2, p1], [p0, p3, p2]]] {
            let hits = columns(&tris, RayAxis::Z);
            let mut dedup = hits.clone();
            dedup.dedup();
            assert_eq!(hits, dedup, "a column was hit twice");
            // Interior centres 2..=4 in both axes are inside the open square: all 9 present.
            for x in 2..5 {
                for y in 2..5 {
                    assert!(hits.contains(&[x, y, 3]), "({x},{y}) missed");
                }
            }
            // On the boundary the tie rule acts like nudging the point by (ε, ε²): the covered
            // set is the half-open square [1.5, 5.5)², 4 × 4 centres.
            assert_eq!(hits.len(), 16);
        }
    }

    /// The tie rule must be the same as perturbing the query point: compare against a dense
    /// check with points nudged by (ε, ε²).
    #[test]
    fn tie_rule_matches_perturbed_point() {
        let tri = [
            fixed([2.5, 2.5, 1.0]),
            fixed([6.5, 4.5, 2.0]),
            fixed([2.5, 6.5, 9.0]),
        ];
        let hits = columns(&[tri], RayAxis::Z);
        let inside = |x: f64, y: f64| {
            let p: Vec<[f64; 2]> = tri
                .iter()
                .map(|q| [q[0] as f64 / 256.0, q[1] as f64 / 256.0])
                .collect();
            let cross = |a: [f64; 2], b: [f64; 2], x: [f64; 2]| {
                (b[0] - a[0]) * (x[1] - a[1]) - (b[1] - a[1]) * (x[0] - a[0])
            };
            let s = [
                cross(p[0], p[1], [x, y]),
                cross(p[1], p[2], [x, y]),
                cross(p[2], p[0], [x, y]),
            ];
            s.iter().all(|&v| v > 0.0) || s.iter().all(|&v| v < 0.0)
        };
        for fx in 0..10 {
            for fy in 0..10 {
                let expected = inside(fx as f64 + 0.5 + 1e-6, fy as f64 + 0.5 + 1e-12);
                let got = hits.iter().any(|h| h[0] == fx && h[1] == fy);
                assert_eq!(got, expected, "({fx},{fy})");
            }
        }
    }

    #[test]
    fn toggles_land_after_the_crossing() {
        // A plane z = 3.2 covering column (1,1) hits between centres 2.5 and 3.5: toggle at 3.
        let tri = [
            fixed([0.0, 0.0, 3.2]),
            fixed([4.0, 0.0, 3.2]),
            fixed([0.0, 4.0, 3.2]),
        ];
        assert!(columns(&[tri], RayAxis::Z).contains(&[1, 1, 3]));
        // Exactly on a centre (3.5): the voxel there is still before the crossing.
        let tri = [
            fixed([0.0, 0.0, 3.5]),
            fixed([4.0, 0.0, 3.5]),
            fixed([0.0, 4.0, 3.5]),
        ];
        assert!(columns(&[tri], RayAxis::Z).contains(&[1, 1, 4]));
        // Same plane seen along x: edge-on, no hits.
        assert!(columns(&[tri], RayAxis::X).is_empty());
        // A slanted triangle along x: plane x = y + 0.25 over (y, z); column (y=1, z=0) crosses at
        // x = 1.75, toggle at 2.
        let tri = [
            fixed([0.25, 0.0, 0.0]),
            fixed([4.25, 4.0, 0.0]),
            fixed([0.25, 0.0, 4.0]),
        ];
        assert!(columns(&[tri], RayAxis::X).contains(&[2, 1, 0]));
    }

    #[test]
    fn spans() {
        let tri = [
            fixed([0.4, 0.0, 3.2]),
            fixed([2.6, 0.0, 3.4]),
            fixed([0.0, 4.0, 3.7]),
        ];
        assert_eq!(centre_span(&tri, 0), 0..3);
        assert_eq!(toggle_span(&tri, 2), 3..5);
    }
}

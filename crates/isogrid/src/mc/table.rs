//! The Marching Cubes case table, derived at first use from the cube's geometry instead of typed in.
//!
//! For each of the 256 inside/outside patterns of a cell's corners, the isosurface is traced as
//! closed loops of crossed edges: on every cube face the crossed edges are joined pairwise by
//! segments, the segments are chained into loops, and each loop is cut into triangles.
//!
//! Conventions (shared with `extract.rs`):
//! - corner `c` sits at `(c & 1, c >> 1 & 1, c >> 2 & 1)`: bit 0 is i (x), bit 1 is j (y), bit 2 is k (z);
//! - edge `e` runs along axis `e / 4`; `e % 4` numbers the other two axes' bits, lower axis first,
//!   so edges 0–3 are the x-edges at (y, z) = (0,0), (1,0), (0,1), (1,1), edges 4–7 the y-edges at
//!   (x, z) in the same order and edges 8–11 the z-edges at (x, y).
//!
//! Ambiguous faces (two inside corners on a diagonal) always keep the inside corners apart. The rule
//! reads only the face's four corners, so the two cells sharing a face draw the same segments there
//! and the mesh has no cracks.
//!
//! Triangles wind counter-clockwise seen from the outside: their right-hand normal points from the
//! inside (value >= iso) to the outside, i.e. down the gradient.
//!
//! A loop's triangulation never adds a diagonal between two edges of the same face (every loop of
//! every case admits one; building the table checks it). Such a diagonal could be chosen by both
//! cells sharing the face, and that mesh edge would then belong to four triangles. Diagonals through
//! the cell's interior belong to that cell alone, so every mesh edge stays in exactly two triangles.

use std::sync::OnceLock;

/// The most triangles a case produces (checked when the table is built).
pub(crate) const MAX_TRIANGLES: usize = 5;

/// The triangles of one corner pattern, as cell edge numbers.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Case {
    pub(crate) triangle_count: u8,
    /// Bit `e` set when edge `e` is crossed.
    pub(crate) edge_mask: u16,
    pub(crate) triangles: [[u8; 3]; MAX_TRIANGLES],
}

/// The table indexed by the corner pattern: bit `c` of the index is set when corner `c` is inside.
pub(crate) fn cases() -> &'static [Case; 256] {
    static TABLE: OnceLock<Box<[Case; 256]>> = OnceLock::new();
    TABLE.get_or_init(|| Box::new(std::array::from_fn(|pattern| build_case(pattern as u8))))
}

/// The two corners of edge `e`, lower corner first (the corner with the edge's axis bit clear).
pub(crate) const fn edge_corners(e: u8) -> (u8, u8) {
    let axis = e / 4;
    let other = e % 4;
    let lower = match axis {
        0 => other << 1,
        1 => (other & 1) | (other >> 1) << 2,
        _ => other,
    };
    (lower, lower | 1 << axis)
}

fn edge_between(c0: u8, c1: u8) -> u8 {
    let axis = (c0 ^ c1).trailing_zeros() as u8;
    let lower = c0.min(c1);
    let other = match axis {
        0 => lower >> 1,
        1 => (lower & 1) | (lower >> 2) << 1,
        _ => lower & 3,
    };
    axis * 4 + other
}

/// The faces (axis, side) that edge `e` lies on.
fn edge_faces(e: u8) -> [(u8, u8); 2] {
    let axis = e / 4;
    let (lower, _) = edge_corners(e);
    let mut faces = [(0, 0); 2];
    let mut n = 0;
    for a in 0..3u8 {
        if a != axis {
            faces[n] = (a, lower >> a & 1);
            n += 1;
        }
    }
    faces
}

fn corner_position(c: u8) -> [f64; 3] {
    [(c & 1) as f64, (c >> 1 & 1) as f64, (c >> 2 & 1) as f64]
}

fn edge_midpoint(e: u8) -> [f64; 3] {
    let (a, b) = edge_corners(e);
    let (pa, pb) = (corner_position(a), corner_position(b));
    std::array::from_fn(|i| 0.5 * (pa[i] + pb[i]))
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Directs the segment between edges `ea` and `eb` on a face with outward normal `normal` so
/// that, seen from outside the cube, the inside lies on its right. `corners` are the face corners
/// that decide the side, with their insideness.
fn orient(ea: u8, eb: u8, normal: [f64; 3], corners: &[(u8, bool)]) -> (u8, u8) {
    let start = edge_midpoint(ea);
    let towards_outside = cross(normal, sub(edge_midpoint(eb), start));
    let side: f64 = corners
        .iter()
        .map(|&(c, inside)| {
            let d = dot(towards_outside, sub(corner_position(c), start));
            if inside {
                d
            } else {
                -d
            }
        })
        .sum();
    assert!(side != 0.0, "a face corner lies on a segment");
    if side < 0.0 {
        (ea, eb)
    } else {
        (eb, ea)
    }
}

fn build_case(pattern: u8) -> Case {
    let inside = |c: u8| pattern >> c & 1 == 1;
    // next[e] = the crossed edge that follows e along its loop.
    let mut next = [u8::MAX; 12];
    let mut incoming = [0u8; 12];
    for axis in 0..3u8 {
        let (u, v) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        for side in 0..2u8 {
            let corners: [u8; 4] =
                [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(cu, cv)| side << axis | cu << u | cv << v);
            let mut normal = [0.0; 3];
            normal[axis as usize] = if side == 1 { 1.0 } else { -1.0 };
            // edges[q] joins corners[q] and corners[q + 1].
            let edges: [u8; 4] =
                std::array::from_fn(|q| edge_between(corners[q], corners[(q + 1) % 4]));
            let crossed: Vec<usize> = (0..4)
                .filter(|&q| inside(corners[q]) != inside(corners[(q + 1) % 4]))
                .collect();
            let mut segments = Vec::new();
            match crossed.len() {
                0 => {}
                2 => {
                    let all: Vec<(u8, bool)> = corners.iter().map(|&c| (c, inside(c))).collect();
                    segments.push(orient(edges[crossed[0]], edges[crossed[1]], normal, &all));
                }
                4 => {
                    // Alternating corners: cut off each inside corner by itself.
                    for q in 0..4 {
                        if inside(corners[q]) {
                            let before = edges[(q + 3) % 4];
                            let after = edges[q];
                            segments.push(orient(before, after, normal, &[(corners[q], true)]));
                        }
                    }
                }
                n => unreachable!("a square has an even number of sign changes, got {n}"),
            }
            for (from, to) in segments {
                assert_eq!(next[from as usize], u8::MAX, "edge leaves twice");
                next[from as usize] = to;
                incoming[to as usize] += 1;
            }
        }
    }

    let mut edge_mask = 0u16;
    for e in 0..12u8 {
        let (a, b) = edge_corners(e);
        if inside(a) != inside(b) {
            edge_mask |= 1 << e;
            assert!(
                next[e as usize] != u8::MAX && incoming[e as usize] == 1,
                "pattern {pattern:#010b}: loops do not close at edge {e}"
            );
        }
    }

    let mut case = Case {
        triangle_count: 0,
        edge_mask,
        triangles: [[0; 3]; MAX_TRIANGLES],
    };
    let mut visited = 0u16;
    for start in 0..12u8 {
        if edge_mask >> start & 1 == 0 || visited >> start & 1 == 1 {
            continue;
        }
        let mut loop_edges = Vec::new();
        let mut e = start;
        while visited >> e & 1 == 0 {
            visited |= 1 << e;
            loop_edges.push(e);
            e = next[e as usize];
        }
        assert_eq!(e, start, "pattern {pattern:#010b}: a loop does not return");
        let triangles = triangulate(&loop_edges, &|a, b| !shares_face(a, b))
            .unwrap_or_else(|| panic!("pattern {pattern:#010b}: no crack-free triangulation"));
        for t in triangles {
            case.triangles[case.triangle_count as usize] = t;
            case.triangle_count += 1;
        }
    }
    case
}

/// Whether edges `a` and `b` lie on a common face.
fn shares_face(a: u8, b: u8) -> bool {
    let fb = edge_faces(b);
    edge_faces(a).iter().any(|f| fb.contains(f))
}

/// Triangulates the polygon `poly` (in loop order), using only diagonals that `allowed` accepts.
/// Triangles keep the polygon's winding.
fn triangulate(poly: &[u8], allowed: &dyn Fn(u8, u8) -> bool) -> Option<Vec<[u8; 3]>> {
    let n = poly.len();
    if n == 3 {
        return Some(vec![[poly[0], poly[1], poly[2]]]);
    }
    // The triangle on the side (poly[0], poly[n-1]) has its apex at some poly[k].
    for k in 1..n - 1 {
        if k > 1 && !allowed(poly[0], poly[k]) {
            continue;
        }
        if k < n - 2 && !allowed(poly[k], poly[n - 1]) {
            continue;
        }
        let mut out = vec![[poly[0], poly[k], poly[n - 1]]];
        if k > 1 {
            match triangulate(&poly[..=k], allowed) {
                Some(t) => out.extend(t),
                None => continue,
            }
        }
        if k < n - 2 {
            match triangulate(&poly[k..], allowed) {
                Some(t) => out.extend(t),
                None => continue,
            }
        }
        return Some(out);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_round_trip() {
        for e in 0..12u8 {
            let (a, b) = edge_corners(e);
            assert_eq!((a ^ b).count_ones(), 1);
            assert!(a < b);
            assert_eq!(edge_between(a, b), e);
            assert_eq!(edge_between(b, a), e);
        }
    }

    #[test]
    fn every_case_covers_its_crossed_edges() {
        let table = cases();
        for (pattern, case) in table.iter().enumerate() {
            let crossed = (0..12u8)
                .filter(|&e| {
                    let (a, b) = edge_corners(e);
                    (pattern >> a & 1) != (pattern >> b & 1)
                })
                .fold(0u16, |m, e| m | 1 << e);
            assert_eq!(case.edge_mask, crossed);
            let mut used = 0u16;
            for t in &case.triangles[..case.triangle_count as usize] {
                assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
                for e in t {
                    used |= 1 << e;
                }
            }
            assert_eq!(used, case.edge_mask, "pattern {pattern:#010b}");
        }
        assert_eq!(table[0].triangle_count, 0);
        assert_eq!(table[255].triangle_count, 0);
    }

    #[test]
    fn single_corner_triangle_faces_away_from_the_inside_corner() {
        for c in 0..8u8 {
            for (pattern, sign) in [(1u8 << c, 1.0), (!(1u8 << c), -1.0)] {
                let case = &cases()[pattern as usize];
                assert_eq!(case.triangle_count, 1);
                let [a, b, d] = case.triangles[0].map(edge_midpoint);
                let normal = cross(sub(b, a), sub(d, a));
                let away = sub(a, corner_position(c));
                assert!(sign * dot(normal, away) > 0.0, "pattern {pattern:#010b}");
            }
        }
    }
}

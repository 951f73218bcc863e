//! Small helpers that turn a format's spatial metadata into a valid [`Geometry`].
//!
//! Formats allow things a [`Geometry`] does not: zero or NaN spacing (unknown), negative spacing
//! (a flipped axis). Unknown spacing becomes 1; a negative one keeps its magnitude and flips the
//! axis's direction row, so positions `origin + i·spacing·direction` stay the same.

use isogrid::Geometry;

pub(crate) type Vec3 = [f64; 3];

pub(crate) fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|`, or `None` for a zero or non-finite vector.
pub(crate) fn normalized(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n.is_finite() && n > 0.0).then(|| a.map(|x| x / n))
}

/// A geometry from possibly odd file values: see the module doc for the rules.
pub(crate) fn geometry(
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: Option<[Vec3; 3]>,
) -> Geometry {
    let mut g = Geometry::new(dims);
    if let Some(direction) = direction {
        if direction.iter().flatten().all(|x| x.is_finite()) {
            g.direction = direction;
        }
    }
    for (axis, &s) in spacing.iter().enumerate() {
        if s.is_finite() && s != 0.0 {
            g.spacing[axis] = s.abs();
            if s < 0.0 {
                g.direction[axis] = g.direction[axis].map(|x| -x);
            }
        }
    }
    if origin.iter().all(|x| x.is_finite()) {
        g.origin = origin;
    }
    g
}

//! Small helpers that turn a format's spatial metadata into a valid [`Geometry`].
//!
//! Formats allow things a [`Geometry`] does not. The rule, the same for every format:
//! - NaN spacing means "unknown" (NRRD's spec says so for `spacings`; a reader maps its format's
//!   own "unset" marker to NaN) and becomes 1;
//! - a negative spacing keeps its magnitude and flips the axis's direction row, so positions
//!   `origin + i·spacing·direction` stay the same;
//! - zero or infinite spacing is an error: no voxel has that size, and 1 would be a guess.

use isogrid::{Error, Geometry, Result};

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

/// `|a|`; finite for every finite `a`: a file's axis of length 1e200 (whose square overflows) or
/// 1e-200 (whose square underflows) is that length, not ∞ or 0.
pub(crate) fn norm(a: Vec3) -> f64 {
    let squared = dot(a, a);
    if squared.is_finite() && squared >= f64::MIN_POSITIVE {
        squared.sqrt()
    } else {
        a[0].hypot(a[1]).hypot(a[2])
    }
}

/// `a / |a|`, or `None` for a zero or non-finite vector.
pub(crate) fn normalized(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n.is_finite() && n > 0.0).then(|| a.map(|x| x / n))
}

/// A geometry from possibly odd file values, its world coordinates in `frame`: see the module
/// doc for the rules.
pub(crate) fn geometry(
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: Option<[Vec3; 3]>,
    frame: isogrid::WorldFrame,
) -> Result<Geometry> {
    if let Some(axis) = (0..3).find(|&a| spacing[a] == 0.0 || spacing[a].is_infinite()) {
        return Err(Error::corrupt(format!(
            "spacing {} along axis {axis} is not a voxel size (it must be finite and non-zero)",
            spacing[axis]
        )));
    }
    let mut g = Geometry::new(dims);
    g.frame = frame;
    if let Some(direction) = direction {
        if direction.iter().flatten().all(|x| x.is_finite()) {
            g.direction = direction;
        }
    }
    for (axis, &s) in spacing.iter().enumerate() {
        if !s.is_nan() {
            g.spacing[axis] = s.abs();
            if s < 0.0 {
                g.direction[axis] = g.direction[axis].map(|x| -x);
            }
        }
    }
    if origin.iter().all(|x| x.is_finite()) {
        g.origin = origin;
    }
    Ok(g)
}

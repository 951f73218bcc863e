//! Analytic fields sampled at voxel positions: sphere, torus, gyroid and Marschner–Lobb.
//!
//! Shapes with a geometric meaning (sphere, torus, gyroid) are encoded as a signed distance in
//! voxels through a linear ramp (see [`super::distance_to_u8`]) so the 0.5 isosurface is the exact
//! shape; the Marschner–Lobb signal is already defined on `[0, 1]` with its classic isovalue 0.5
//! (Marschner & Lobb, *An evaluation of reconstruction filters for volume rendering*, 1994).

use super::{distance_to_u8, unit_to_u8, PointField};
use std::f64::consts::PI;

/// Centre of the cube `[0, size-1]³` and its edge length `size - 1` (at least 1 to stay finite).
fn centre_and_extent(size: usize) -> (f64, f64) {
    let extent = (size.max(2) - 1) as f64;
    ((size as f64 - 1.0) / 2.0, extent)
}

pub(super) struct Sphere {
    centre: f64,
    radius: f64,
}

impl Sphere {
    pub(super) fn new(size: usize) -> Self {
        let (centre, extent) = centre_and_extent(size);
        Sphere {
            centre,
            radius: 0.4 * extent,
        }
    }
}

impl PointField for Sphere {
    fn value(&self, p: [f64; 3]) -> u8 {
        let d = p.map(|x| x - self.centre);
        distance_to_u8(self.radius - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
    }
}

/// A torus around the z axis through the centre.
pub(super) struct Torus {
    centre: f64,
    major: f64,
    minor: f64,
}

impl Torus {
    pub(super) fn new(size: usize) -> Self {
        let (centre, extent) = centre_and_extent(size);
        Torus {
            centre,
            major: 0.28 * extent,
            minor: 0.1 * extent,
        }
    }
}

impl PointField for Torus {
    fn value(&self, p: [f64; 3]) -> u8 {
        let d = p.map(|x| x - self.centre);
        let from_core_circle = (d[0] * d[0] + d[1] * d[1]).sqrt() - self.major;
        let dist = (from_core_circle * from_core_circle + d[2] * d[2]).sqrt();
        distance_to_u8(self.minor - dist)
    }
}

/// `sin x cos y + sin y cos z + sin z cos x > 0`, three periods across the cube.
pub(super) struct Gyroid {
    /// Radians per voxel.
    omega: f64,
}

const GYROID_PERIODS: f64 = 3.0;

impl Gyroid {
    pub(super) fn new(size: usize) -> Self {
        let (_, extent) = centre_and_extent(size);
        Gyroid {
            omega: 2.0 * PI * GYROID_PERIODS / extent,
        }
    }
}

impl PointField for Gyroid {
    fn value(&self, p: [f64; 3]) -> u8 {
        let [x, y, z] = p.map(|c| c * self.omega);
        let g = x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos();
        // The gradient of g has magnitude ≈ ω near the surface, so g/ω approximates the signed
        // distance in voxels well enough for a smooth ramp.
        distance_to_u8(g / self.omega)
    }
}

/// ρ(x,y,z) = (1 − sin(πz/2) + α(1 + cos(2π f_M cos(π r/2)))) / (2(1 + α)), r = √(x²+y²),
/// over `[-1, 1]³`.
pub(super) struct MarschnerLobb {
    /// Voxel → [-1, 1] scale.
    scale: f64,
}

const ML_FREQUENCY: f64 = 6.0;
const ML_ALPHA: f64 = 0.25;

impl MarschnerLobb {
    pub(super) fn new(size: usize) -> Self {
        let (_, extent) = centre_and_extent(size);
        MarschnerLobb {
            scale: 2.0 / extent,
        }
    }
}

impl PointField for MarschnerLobb {
    fn value(&self, p: [f64; 3]) -> u8 {
        let [x, y, z] = p.map(|c| c * self.scale - 1.0);
        let r = (x * x + y * y).sqrt();
        let radial = (2.0 * PI * ML_FREQUENCY * (PI * r / 2.0).cos()).cos();
        let rho =
            (1.0 - (PI * z / 2.0).sin() + ML_ALPHA * (1.0 + radial)) / (2.0 * (1.0 + ML_ALPHA));
        unit_to_u8(rho)
    }
}

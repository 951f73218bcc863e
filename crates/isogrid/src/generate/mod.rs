//! Procedural test volumes: analytic fields and a synthetic "hairball".
//!
//! The paper (§4, Table 2) evaluates on CT scans and on voxelised meshes, all rendered at the
//! normalised isovalue 0.5. These generators give reproducible stand-ins of any size without data
//! files: every field is scaled so that **its interesting surface is the 0.5 isosurface**, i.e. the
//! u8 value 127.5. A sample is inside when its value is ≥ 127.5, which for u8 means ≥ 128.
//!
//! Coordinates: sample `(i, j, k)` of a `size³` volume sits at `(i, j, k)` in voxel units (unit
//! spacing, zero origin); shapes are defined relative to the cube `[0, size-1]³` so that the same
//! field at another size is the same shape, scaled.
//!
//! All generators are parallel (rayon, one task per row of samples) and deterministic: each sample
//! depends only on its position, the size and the seed, never on the thread count.

mod analytic;
mod hairball;
mod rng;

use crate::volume::{Volume, VolumeData, MAX_DIM};
use rayon::prelude::*;
use std::fmt;
use std::str::FromStr;

/// Which procedural field [`generate`] produces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Field {
    /// A solid ball of radius `0.4·(size-1)` in the middle; closed, away from the border.
    Sphere,
    /// A solid torus around the z axis (major radius `0.28·(size-1)`, minor `0.1·(size-1)`); closed.
    Torus,
    /// The solid side of a gyroid with three periods across the volume; open, fills the cube.
    Gyroid,
    /// The Marschner–Lobb test signal (f_M = 6, α = 0.25) over `[-1, 1]³`, whose classic 0.5
    /// isosurface is a stack of rippled rings: a hard case for reconstruction filters.
    MarschnerLobb,
    /// A few hundred random thick tubes inside a ball: high depth complexity, like the paper's
    /// Hairball dataset. The only field that uses the seed.
    Hairball,
}

impl Field {
    /// Every field, in a stable order (for CLI help and tests).
    pub const ALL: [Field; 5] = [
        Field::Sphere,
        Field::Torus,
        Field::Gyroid,
        Field::MarschnerLobb,
        Field::Hairball,
    ];

    /// The name used on the command line and by `FromStr`/`Display`.
    pub fn name(self) -> &'static str {
        match self {
            Field::Sphere => "sphere",
            Field::Torus => "torus",
            Field::Gyroid => "gyroid",
            Field::MarschnerLobb => "marschner-lobb",
            Field::Hairball => "hairball",
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Field {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        Field::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                let names: Vec<_> = Field::ALL.iter().map(|f| f.name()).collect();
                crate::Error::invalid(format!(
                    "unknown field '{s}' (expected one of: {})",
                    names.join(", ")
                ))
            })
    }
}

/// A `size³` u8 volume of `field` with unit spacing and zero origin; the surface of interest is
/// the 0.5 isosurface (u8 127.5). `seed` only matters for [`Field::Hairball`].
///
/// # Panics
/// When `size` is 0 or larger than [`MAX_DIM`] (a programming error, not a data error).
pub fn generate(field: Field, size: usize, seed: u64) -> Volume {
    assert!(
        (1..=MAX_DIM).contains(&size),
        "generate: size {size} is outside 1..={MAX_DIM}"
    );
    let data = match field {
        Field::Sphere => fill_samples(size, analytic::Sphere::new(size)),
        Field::Torus => fill_samples(size, analytic::Torus::new(size)),
        Field::Gyroid => fill_samples(size, analytic::Gyroid::new(size)),
        Field::MarschnerLobb => fill_samples(size, analytic::MarschnerLobb::new(size)),
        Field::Hairball => hairball::generate(size, seed),
    };
    Volume::new([size; 3], VolumeData::U8(data)).expect("size³ samples for a size³ volume")
}

/// A field evaluated independently at each sample position.
trait PointField: Sync {
    /// The u8 value at sample `(i, j, k)` (voxel units).
    fn value(&self, p: [f64; 3]) -> u8;
}

/// Evaluates `field` at every sample, one rayon task per row.
fn fill_samples(size: usize, field: impl PointField) -> Vec<u8> {
    let mut data = vec![0u8; size * size * size];
    data.par_chunks_mut(size)
        .enumerate()
        .for_each(|(row, out)| {
            let (j, k) = (row % size, row / size);
            for (i, v) in out.iter_mut().enumerate() {
                *v = field.value([i as f64, j as f64, k as f64]);
            }
        });
    data
}

/// Half-width, in voxels, of the linear ramp that turns a signed distance into u8: wide enough
/// for trilinear interpolation to place the surface with sub-voxel accuracy, narrow enough to look
/// like a sharp object.
const RAMP_HALF_WIDTH: f64 = 2.0;

/// Maps a signed distance in voxels (positive inside) to u8 so that distance 0 lands on 127.5.
fn distance_to_u8(signed_distance: f64) -> u8 {
    unit_to_u8(0.5 + 0.5 * signed_distance / RAMP_HALF_WIDTH)
}

/// Maps `[0, 1]` to `[0, 255]`, clamping; 0.5 maps to 127.5, which rounds up to 128 (inside).
fn unit_to_u8(x: f64) -> u8 {
    (x * 255.0).round().clamp(0.0, 255.0) as u8
}

/// A `size`³ u16 label volume of 3³ cubes in 11 labels (cube `c` has label
/// `(cx + 7·cy + 13·cz) mod 11 + 1`): every cube touches others on every side and a 16³ block
/// holds all 11 labels, so a label grid of it holds more clusters per block than an isosurface
/// can (tests of the tracers' label handling).
pub fn labelled_cubes(size: usize) -> Volume {
    let labels: Vec<u16> = (0..size * size * size)
        .map(|i| {
            let c = [i % size, i / size % size, i / (size * size)].map(|v| v / 3);
            ((c[0] + 7 * c[1] + 13 * c[2]) % 11 + 1) as u16
        })
        .collect();
    Volume::new([size; 3], crate::VolumeData::U16(labels)).expect("a cube of u16 labels")
}

/// A label volume (u8) of `size`³ samples: a ball of radius `0.375·size` in the middle cut into
/// three labels 1, 2, 3 side by side along x (thirds of its diameter), background 0; every label
/// touches the next. For tests and demos of label grids.
pub fn labelled_ball(size: usize) -> Volume {
    let centre = (size as f64 - 1.0) / 2.0;
    let radius = 0.375 * size as f64;
    let labels: Vec<u8> = (0..size * size * size)
        .map(|i| {
            let p = [i % size, i / size % size, i / (size * size)].map(|c| c as f64 - centre);
            if p.iter().map(|c| c * c).sum::<f64>() < radius * radius {
                1 + ((p[0] + radius) / (2.0 * radius / 3.0)).clamp(0.0, 2.0) as u8
            } else {
                0
            }
        })
        .collect();
    Volume::new([size; 3], crate::VolumeData::U8(labels)).expect("a cube of u8 labels")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u8_data(v: &Volume) -> &[u8] {
        match v.data() {
            VolumeData::U8(d) => d,
            _ => panic!("generators make u8 volumes"),
        }
    }

    fn inside_count(v: &Volume) -> usize {
        u8_data(v).iter().filter(|&&x| x >= 128).count()
    }

    #[test]
    fn names_round_trip() {
        for f in Field::ALL {
            assert_eq!(f.to_string().parse::<Field>().unwrap(), f);
        }
        assert_eq!(
            "Marschner-Lobb".parse::<Field>().unwrap(),
            Field::MarschnerLobb
        );
        let err = "cube".parse::<Field>().unwrap_err();
        assert!(err.to_string().contains("hairball"), "{err}");
    }

    #[test]
    fn sizes_and_geometry() {
        for f in Field::ALL {
            for size in [1, 2, 17] {
                let v = generate(f, size, 1);
                assert_eq!(v.dims(), [size; 3]);
                assert_eq!(v.spacing(), [1.0; 3]);
                assert_eq!(v.origin(), [0.0; 3]);
            }
        }
    }

    #[test]
    fn every_field_has_a_surface() {
        for f in Field::ALL {
            let v = generate(f, 48, 3);
            let n = inside_count(&v);
            assert!(n > 0 && n < 48 * 48 * 48, "{f}: {n} inside samples");
        }
    }

    #[test]
    fn deterministic_across_thread_counts() {
        let run = |threads: usize, f: Field| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| generate(f, 40, 7))
        };
        for f in Field::ALL {
            assert_eq!(run(1, f), run(3, f), "{f}");
        }
    }

    #[test]
    fn sphere_volume_matches_analytic_ball() {
        let size = 64;
        let v = generate(Field::Sphere, size, 0);
        let r = 0.4 * (size - 1) as f64;
        let expected = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        let got = inside_count(&v) as f64;
        assert!(
            (got - expected).abs() / expected < 0.02,
            "{got} vs {expected}"
        );
    }

    /// Closed shapes must leave the whole border outside so their isosurface is closed.
    #[test]
    fn closed_fields_stay_off_the_border() {
        for f in [Field::Sphere, Field::Torus, Field::Hairball] {
            for size in [8, 33] {
                let v = generate(f, size, 5);
                let n = size - 1;
                for k in 0..size {
                    for j in 0..size {
                        for i in 0..size {
                            let border = [i, j, k].iter().any(|&c| c == 0 || c == n);
                            if border {
                                assert!(v.get(i, j, k) < 127.5, "{f} {size}: ({i},{j},{k})");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn torus_has_a_hole_and_a_ring() {
        let size = 101;
        let v = generate(Field::Torus, size, 0);
        let c = 50;
        assert!(v.get(c, c, c) < 127.5, "centre of the hole is outside");
        let ring = (50.0 + 0.28 * 100.0f64).round() as usize;
        assert!(
            v.get(ring, c, c) >= 127.5,
            "a point on the core circle is inside"
        );
        // Volume of a torus: 2π²Rr².
        let (big, small) = (0.28 * 100.0, 0.1 * 100.0);
        let expected = 2.0 * std::f64::consts::PI.powi(2) * big * small * small;
        let got = inside_count(&v) as f64;
        assert!(
            (got - expected).abs() / expected < 0.03,
            "{got} vs {expected}"
        );
    }

    /// The solid gyroid splits space into two congruent halves: about half the samples are inside.
    #[test]
    fn gyroid_splits_space_in_half() {
        let v = generate(Field::Gyroid, 60, 0);
        let frac = inside_count(&v) as f64 / (60.0f64).powi(3);
        assert!((frac - 0.5).abs() < 0.03, "{frac}");
    }

    /// Marschner–Lobb at known points: ρ(0,0,0) = (1 + 0.25(1 + cos 12π)) / 2.5 = 0.6 and at
    /// z = 1 the term 1 − sin(π/2) vanishes.
    #[test]
    fn marschner_lobb_known_values() {
        let v = generate(Field::MarschnerLobb, 41, 0);
        assert_eq!(v.get(20, 20, 20), (0.6f64 * 255.0).round());
        // (x, y, z) = (0, 0, 1): (0 + 0.25·2) / 2.5 = 0.2.
        assert_eq!(v.get(20, 20, 40), (0.2f64 * 255.0).round());
    }

    #[test]
    fn hairball_is_deep_and_partial() {
        let size = 96;
        let v = generate(Field::Hairball, size, 42);
        let d = u8_data(&v);
        let inside = inside_count(&v) as f64 / d.len() as f64;
        assert!(inside > 0.02 && inside < 0.5, "inside fraction {inside}");
        assert!(d.iter().any(|&x| x > 0 && x < 255), "has partial coverage");
        // Depth complexity: rays through the middle along x, y and z cross the surface many times.
        let mid = size / 2;
        for axis in 0..3 {
            let mut crossings = 0;
            let mut was_inside = false;
            for t in 0..size {
                let mut p = [mid; 3];
                p[axis] = t;
                let inside = v.get(p[0], p[1], p[2]) >= 127.5;
                crossings += (inside != was_inside) as usize;
                was_inside = inside;
            }
            assert!(crossings >= 8, "axis {axis}: {crossings} crossings");
        }
        assert_ne!(v, generate(Field::Hairball, size, 43), "seed changes it");
    }
}

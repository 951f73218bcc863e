//! The path tracers' environment (paper §3.6): an equirectangular (latitude–longitude) radiance
//! map and the built-in sky used without one. Both path tracers read these: the CPU tracer
//! (`isogrid-trace`) calls [`EnvMap::radiance`] and [`sky`] directly, the GPU tracer
//! (`isogrid-gpu`) uploads the map's texels and evaluates WGSL twins of the same two functions
//! (`environment` and `sky` in `crates/isogrid-gpu/shaders/pathtrace.wgsl`).
//!
//! Equirectangular maps are the format of Radiance `.hdr` light probes (Debevec's panoramas);
//! the lookup interpolates bilinearly between texel centres, as a texture unit would.

use crate::error::{Error, Result};
use std::f32::consts::PI;

/// A linear-RGB equirectangular radiance map: `width × height` texels, row-major from the top.
///
/// **Orientation.** World +y is up (the camera presets' up). The map is the sphere of directions
/// seen from its centre, not mirrored:
/// - the **centre column faces −z**, what camera view 1 (from +z towards −z, +y up) sees straight
///   ahead;
/// - **row 0 faces +y** (straight up), the last row −y (straight down);
/// - **longitude increases to the right**: a quarter of the width right of the centre faces +x,
///   a quarter left faces −x, and the left and right edges meet facing +z.
///
/// So texel (x, y) is centred on the direction `(sin θ sin φ, cos θ, −sin θ cos φ)` with
/// φ = 2π(x + ½)/width − π and θ = π(y + ½)/height ([`EnvMap::texel_direction`]), and direction
/// `d` sits at φ = atan2(dₓ, −d_z), θ = acos(d_y).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvMap {
    width: u32,
    height: u32,
    texels: Vec<[f32; 3]>,
}

impl EnvMap {
    /// `texels` row by row from the top; errors unless there are `width·height ≥ 1` of them and
    /// all are finite and non-negative.
    pub fn new(width: u32, height: u32, texels: Vec<[f32; 3]>) -> Result<EnvMap> {
        let count = width as u64 * height as u64;
        if count == 0 || texels.len() as u64 != count {
            return Err(Error::invalid(format!(
                "environment map of {width}x{height} needs {count} texels, got {}",
                texels.len()
            )));
        }
        if let Some(bad) = texels
            .iter()
            .flatten()
            .find(|v| !(v.is_finite() && **v >= 0.0))
        {
            return Err(Error::invalid(format!(
                "environment radiance must be finite and non-negative, found {bad}"
            )));
        }
        Ok(EnvMap {
            width,
            height,
            texels,
        })
    }

    /// The same radiance from every direction (a 1×1 map).
    pub fn constant(rgb: [f32; 3]) -> Result<EnvMap> {
        EnvMap::new(1, 1, vec![rgb])
    }

    /// A map whose texels hold `radiance(direction)` at their centre directions.
    pub fn from_fn(
        width: u32,
        height: u32,
        radiance: impl Fn([f32; 3]) -> [f32; 3],
    ) -> Result<EnvMap> {
        let texels = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| radiance(Self::texel_direction(width, height, x, y)))
            .collect();
        EnvMap::new(width, height, texels)
    }

    /// Unit world direction at the centre of texel (x, y) of a `width × height` map.
    pub fn texel_direction(width: u32, height: u32, x: u32, y: u32) -> [f32; 3] {
        let phi = std::f64::consts::TAU * (x as f64 + 0.5) / width as f64 - std::f64::consts::PI;
        let theta = std::f64::consts::PI * (y as f64 + 0.5) / height as f64;
        [
            theta.sin() * phi.sin(),
            theta.cos(),
            -theta.sin() * phi.cos(),
        ]
        .map(|v| v as f32)
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Texels row by row from the top.
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.texels
    }

    /// Radiance arriving from unit world direction `d`: bilinear between texel centres, wrapping
    /// in longitude and clamping at the poles. Keep in sync with `environment` in
    /// `crates/isogrid-gpu/shaders/pathtrace.wgsl`.
    pub fn radiance(&self, d: [f32; 3]) -> [f32; 3] {
        let (w, h) = (self.width as i64, self.height as i64);
        let phi = d[0].atan2(-d[2]);
        let theta = d[1].clamp(-1.0, 1.0).acos();
        let u = (phi + PI) / (2.0 * PI) * w as f32 - 0.5;
        let v = theta / PI * h as f32 - 0.5;
        let (bx, by) = (u.floor(), v.floor());
        let (fx, fy) = (u - bx, v - by);
        let x0 = (bx as i64).rem_euclid(w);
        let x1 = (x0 + 1) % w;
        let y0 = (by as i64).clamp(0, h - 1);
        let y1 = (by as i64 + 1).clamp(0, h - 1);
        let at = |x: i64, y: i64| self.texels[(x + w * y) as usize];
        let mix = |a: [f32; 3], b: [f32; 3], t: f32| -> [f32; 3] {
            std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t)
        };
        let top = mix(at(x0, y0), at(x1, y0), fx);
        let bottom = mix(at(x0, y1), at(x1, y1), fx);
        mix(top, bottom, fy)
    }
}

// The built-in sky. Keep in sync with `sky` in crates/isogrid-gpu/shaders/pathtrace.wgsl.
const SKY_ZENITH: [f32; 3] = [0.20, 0.40, 0.90];
const SKY_HORIZON: [f32; 3] = [0.85, 0.90, 1.00];
const SKY_GROUND: [f32; 3] = [0.30, 0.27, 0.24];
/// Towards the built-in sky's sun (not normalised): high, from the upper left front of view 1.
pub const SUN_DIRECTION: [f32; 3] = [-0.35, 0.80, 0.50];
const SUN_RADIANCE: [f32; 3] = [12.0, 11.0, 9.5];
const SUN_EXPONENT: f32 = 64.0;

/// Linear RGB radiance of the built-in sky (used when no [`EnvMap`] is given) from unit world
/// direction `d`: with `y = d[1]` (world +y is up), `mix(HORIZON, ZENITH, √y)` above the horizon,
/// `mix(HORIZON, GROUND, √−y)` below, plus a smooth sun lobe `SUN · max(d·s, 0)^64` around
/// `s` = normalised [`SUN_DIRECTION`], where ZENITH = (0.20, 0.40, 0.90), HORIZON = (0.85, 0.90,
/// 1.00), GROUND = (0.30, 0.27, 0.24) and SUN = (12.0, 11.0, 9.5). Keep in sync with `sky` in
/// `crates/isogrid-gpu/shaders/pathtrace.wgsl`.
pub fn sky(d: [f32; 3]) -> [f32; 3] {
    let (far, t) = if d[1] >= 0.0 {
        (SKY_ZENITH, d[1].sqrt())
    } else {
        (SKY_GROUND, (-d[1]).sqrt())
    };
    let len = SUN_DIRECTION.iter().map(|v| v * v).sum::<f32>().sqrt();
    let cos = (0..3)
        .map(|a| d[a] * SUN_DIRECTION[a] / len)
        .sum::<f32>()
        .max(0.0);
    let sun = cos.powf(SUN_EXPONENT);
    std::array::from_fn(|a| SKY_HORIZON[a] + (far[a] - SKY_HORIZON[a]) * t + SUN_RADIANCE[a] * sun)
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: [f32; 3] = [1.0, 0.0, 0.0];
    const GREEN: [f32; 3] = [0.0, 1.0, 0.0];
    const BLUE: [f32; 3] = [0.0, 0.0, 1.0];
    const YELLOW: [f32; 3] = [1.0, 1.0, 0.0];
    const WHITE: [f32; 3] = [1.0, 1.0, 1.0];
    const BLACK: [f32; 3] = [0.0, 0.0, 0.0];

    /// A 64×32 map painted by hand in the documented orientation: a white top row, a black bottom
    /// row, and between them four bands of longitude, each a quarter of the width centred on one
    /// axis. The centre column faces −z, so columns 24..40 are blue; a quarter of the width to the
    /// right, +x, columns 40..56 are yellow; a quarter to the left, −x, columns 8..24 green; +z
    /// at both edges, columns 56..64 and 0..8, red.
    fn axis_bands_map() -> EnvMap {
        let (w, h) = (64u32, 32u32);
        let texels = (0..h)
            .flat_map(|y| {
                (0..w).map(move |x| match (y, x) {
                    (0, _) => WHITE,
                    (31, _) => BLACK,
                    (_, 8..24) => GREEN,
                    (_, 24..40) => BLUE,
                    (_, 40..56) => YELLOW,
                    _ => RED,
                })
            })
            .collect();
        EnvMap::new(w, h, texels).unwrap()
    }

    fn normalise(d: [f32; 3]) -> [f32; 3] {
        let n = d.iter().map(|v| v * v).sum::<f32>().sqrt();
        d.map(|v| v / n)
    }

    #[test]
    fn lookups_follow_the_documented_orientation() {
        let map = axis_bands_map();
        // Directions away from the bands' edges (45° either side of each axis) and the poles.
        let cases = [
            ([0.0, -0.2, -1.0], BLUE),  // −z: the centre column
            ([1.0, 0.1, 0.0], YELLOW),  // +x: a quarter right of the centre
            ([-1.0, 0.1, 0.0], GREEN),  // −x: a quarter left
            ([0.0, 0.0, 1.0], RED),     // +z: the edges, where the map wraps
            ([0.8, 0.0, -1.0], BLUE),   // 39° from −z towards +x: still −z's band
            ([1.0, 0.3, -0.8], YELLOW), // 51° from −z towards +x: +x's band
            ([-0.8, -0.3, -1.0], BLUE), // 39° from −z towards −x
            ([-1.0, 0.0, -0.8], GREEN), // 51° from −z towards −x
            ([0.8, 0.0, 1.0], RED),     // 39° from +z towards +x, right of the seam
            ([-0.8, 0.0, 1.0], RED),    // 39° from +z towards −x, left of the seam
        ];
        for (d, want) in cases {
            let got = map.radiance(normalise(d));
            assert!(
                (0..3).all(|c| (got[c] - want[c]).abs() < 1e-5),
                "direction {d:?}: {got:?}, expected {want:?}"
            );
        }
        // Straight up is the top row, straight down the bottom row, whatever the longitude.
        for d in [[0.0, 1.0, 0.0], normalise([0.01, 1.0, -0.01])] {
            assert_eq!(map.radiance(d), WHITE, "{d:?}");
        }
        assert_eq!(map.radiance([0.0, -1.0, 0.0]), BLACK);
        // A texel's centre direction reads back that texel.
        for (x, y) in [(0, 5), (17, 1), (40, 20), (63, 30)] {
            let d = EnvMap::texel_direction(64, 32, x, y);
            let want = map.texels()[(x + 64 * y) as usize];
            let got = map.radiance(d);
            assert!((0..3).all(|c| (got[c] - want[c]).abs() < 1e-4), "{x},{y}");
        }
    }

    #[test]
    fn lookups_interpolate_between_texel_centres_and_wrap_in_longitude() {
        // 4×1: the seam between the last and the first column (+z) mixes the two equally.
        let map = EnvMap::new(4, 1, vec![[0.0; 3], [1.0; 3], [2.0; 3], [4.0; 3]]).unwrap();
        let seam = map.radiance([0.0, 0.0, 1.0]);
        assert!((seam[0] - 2.0).abs() < 1e-5, "{seam:?}");
        // The centre column's direction (−z) lies half way between texels 1 and 2.
        assert!((map.radiance([0.0, 0.0, -1.0])[0] - 1.5).abs() < 1e-5);
        assert_eq!(
            EnvMap::constant([0.5; 3])
                .unwrap()
                .radiance([0.0, 0.0, 1.0]),
            [0.5; 3]
        );
    }

    #[test]
    fn bad_maps_are_rejected() {
        assert!(EnvMap::new(2, 2, vec![[0.0; 3]; 3]).is_err());
        assert!(EnvMap::new(0, 0, Vec::new()).is_err());
        let nan = EnvMap::new(1, 1, vec![[1.0, f32::NAN, 0.0]]).unwrap_err();
        assert_eq!(nan.kind(), crate::ErrorKind::InvalidInput);
        assert!(EnvMap::constant([-1.0, 0.0, 0.0]).is_err());
    }

    #[test]
    fn the_sky_is_bright_at_the_sun_blue_above_and_dark_below() {
        let sun = sky(normalise(SUN_DIRECTION));
        assert!(sun.iter().all(|&v| v > 9.0), "{sun:?}");
        let (up, down) = (sky([0.0, 1.0, 0.0]), sky([0.0, -1.0, 0.0]));
        assert!(up[2] > up[0] && up[2] > down[2], "{up:?} {down:?}");
        let horizon = sky(normalise([0.35, 0.0, -0.5])); // opposite the sun's azimuth
        assert!((0..3).all(|c| (horizon[c] - SKY_HORIZON[c]).abs() < 1e-3));
    }
}

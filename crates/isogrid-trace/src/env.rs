//! Environment lighting for the path tracer: a constant colour, an analytic sky with a sun, or an
//! equirectangular (latitude–longitude) radiance map.
//!
//! Directions are world-space unit vectors with **+y up** (the camera presets' up). An
//! equirectangular map of `width × height` texels covers longitude across its width and latitude
//! down its height: row 0 looks straight up (+y), the last row straight down; the centre column
//! looks along −z, a quarter of the width to the right along +x. Radiance is linear RGB.

use isogrid::error::{Error, Result};

/// A linear-RGB equirectangular radiance map (see the module docs for its orientation).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvMap {
    width: u32,
    height: u32,
    texels: Vec<[f32; 3]>,
}

impl EnvMap {
    /// `texels` row by row from the top; errors unless there are `width·height ≥ 1` of them and
    /// all are finite and non-negative.
    pub fn new(width: u32, height: u32, texels: Vec<[f32; 3]>) -> Result<Self> {
        if width == 0 || height == 0 || texels.len() as u64 != width as u64 * height as u64 {
            return Err(Error::invalid(format!(
                "environment map needs {width}x{height} texels, got {}",
                texels.len()
            )));
        }
        if texels
            .iter()
            .flatten()
            .any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(Error::invalid(
                "environment map has negative or non-finite radiance",
            ));
        }
        Ok(EnvMap {
            width,
            height,
            texels,
        })
    }
    /// Texels row by row from the top (+y up, equirectangular).
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.texels
    }
    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Nearest texel in direction `d` (unit, world).
    pub fn lookup(&self, d: [f64; 3]) -> [f32; 3] {
        let phi = d[0].atan2(-d[2]); // 0 along −z, +π/2 along +x
        let theta = d[1].clamp(-1.0, 1.0).acos(); // 0 up
        let u = phi / std::f64::consts::TAU + 0.5;
        let v = theta / std::f64::consts::PI;
        let x = ((u * self.width as f64) as i64).clamp(0, self.width as i64 - 1) as usize;
        let y = ((v * self.height as f64) as i64).clamp(0, self.height as i64 - 1) as usize;
        self.texels[x + self.width as usize * y]
    }
}

/// Where escaping path-tracer rays get their radiance.
#[derive(Debug, Clone, PartialEq)]
pub enum Environment {
    /// Gradient sky (blue zenith, pale horizon, grey ground) and a small bright sun.
    Sky,
    /// The same radiance in every direction (a white furnace with `[1.0; 3]`).
    Uniform([f32; 3]),
    Map(EnvMap),
}

/// Towards the sun of [`Environment::Sky`]: high, from the upper right front.
pub const SUN_DIR: [f64; 3] = [0.40, 0.80, 0.45];
/// Cosine of the sun's angular radius (4°).
const SUN_COS_RADIUS: f64 = 0.997_564;
const SUN_RADIANCE: [f32; 3] = [30.0, 28.0, 24.0];

impl Environment {
    /// Radiance arriving from direction `d` (unit, world, pointing away from the scene).
    pub fn radiance(&self, d: [f64; 3]) -> [f32; 3] {
        match self {
            Environment::Uniform(c) => *c,
            Environment::Map(map) => map.lookup(d),
            Environment::Sky => sky(d),
        }
    }
}

fn sky(d: [f64; 3]) -> [f32; 3] {
    let n = (SUN_DIR[0] * SUN_DIR[0] + SUN_DIR[1] * SUN_DIR[1] + SUN_DIR[2] * SUN_DIR[2]).sqrt();
    let cos_sun = (d[0] * SUN_DIR[0] + d[1] * SUN_DIR[1] + d[2] * SUN_DIR[2]) / n;
    if cos_sun >= SUN_COS_RADIUS {
        return SUN_RADIANCE;
    }
    let zenith = [0.18f32, 0.34, 0.75];
    let horizon = [0.85f32, 0.88, 0.95];
    let ground = [0.22f32, 0.20, 0.18];
    let y = d[1] as f32;
    if y >= 0.0 {
        let t = y.sqrt();
        std::array::from_fn(|c| horizon[c] * (1.0 - t) + zenith[c] * t)
    } else {
        // A soft transition just below the horizon avoids a hard seam.
        let t = (-y * 8.0).min(1.0);
        std::array::from_fn(|c| horizon[c] * (1.0 - t) + ground[c] * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equirect_orientation_and_sky_sun() {
        // 4×2 map: distinct texels, check up/down and the −z / +x columns.
        let texels = (0..8).map(|i| [i as f32, 0.0, 0.0]).collect();
        let map = EnvMap::new(4, 2, texels).unwrap();
        assert_eq!(map.lookup([0.0, 0.3, -0.95])[0], 2.0); // top row, centre column (u = 0.5)
        assert_eq!(map.lookup([0.99, -0.1, 0.0])[0], 7.0); // bottom row, +x is u = 0.75
        assert!(EnvMap::new(2, 2, vec![[0.0; 3]; 3]).is_err());
        let s = Environment::Sky;
        let sun = SUN_DIR.map(|v| v / (0.4f64 * 0.4 + 0.64 + 0.45 * 0.45).sqrt());
        assert!(s.radiance(sun)[0] > 10.0);
        assert!(s.radiance([0.0, 1.0, 0.0])[2] > s.radiance([0.0, -1.0, 0.0])[2]);
    }
}

//! The path tracer's environment (paper §3.6, Figure 6): HDR maps given by the caller, the
//! built-in sky used without one, and their upload as a float texture.

use crate::error::GpuError;
use crate::wgpu_util::Gpu;
use std::sync::atomic::{AtomicU64, Ordering};

/// An equirectangular HDR environment: linear RGB radiance, `width × height` texels, row-major
/// from the top. Texel (x, y) is centred on the direction with φ = 2π(x + ½)/width − π and
/// θ = π(y + ½)/height: `(sin θ cos φ, cos θ, sin θ sin φ)`, so row 0 is world +y (up) and the
/// middle of the image looks along −x. Lookups interpolate bilinearly between texel centres,
/// wrapping in φ.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvMap {
    width: u32,
    height: u32,
    rgb: Vec<f32>,
}

impl EnvMap {
    /// `rgb` holds `width · height · 3` finite, non-negative values.
    pub fn new(width: u32, height: u32, rgb: Vec<f32>) -> Result<EnvMap, GpuError> {
        let texels = width as u64 * height as u64;
        if texels == 0 || rgb.len() as u64 != 3 * texels {
            return Err(GpuError::invalid(format!(
                "environment map of {width}x{height} texels needs {} floats, got {}",
                3 * texels,
                rgb.len()
            )));
        }
        if let Some(bad) = rgb.iter().find(|v| !v.is_finite() || **v < 0.0) {
            return Err(GpuError::invalid(format!(
                "environment radiance must be finite and non-negative, found {bad}"
            )));
        }
        Ok(EnvMap { width, height, rgb })
    }

    /// The same radiance from every direction (a 1×1 map).
    pub fn constant(rgb: [f32; 3]) -> Result<EnvMap, GpuError> {
        EnvMap::new(1, 1, rgb.to_vec())
    }

    /// A map whose texels hold `radiance(direction)` at their centre directions.
    pub fn from_fn(
        width: u32,
        height: u32,
        radiance: impl Fn([f32; 3]) -> [f32; 3],
    ) -> Result<EnvMap, GpuError> {
        let mut rgb = Vec::with_capacity(3 * width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                rgb.extend_from_slice(&radiance(Self::texel_direction(width, height, x, y)));
            }
        }
        EnvMap::new(width, height, rgb)
    }

    /// Unit world direction at the centre of texel (x, y).
    pub fn texel_direction(width: u32, height: u32, x: u32, y: u32) -> [f32; 3] {
        let phi = std::f64::consts::TAU * (x as f64 + 0.5) / width as f64 - std::f64::consts::PI;
        let theta = std::f64::consts::PI * (y as f64 + 0.5) / height as f64;
        [
            (theta.sin() * phi.cos()) as f32,
            theta.cos() as f32,
            (theta.sin() * phi.sin()) as f32,
        ]
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    pub fn rgb(&self) -> &[f32] {
        &self.rgb
    }
}

/// An [`EnvMap`] resident on the GPU (`Rgba32Float` texture).
#[derive(Debug)]
pub struct GpuEnvMap {
    pub(crate) view: wgpu::TextureView,
    /// Identifies the map in the accumulation key: another map restarts accumulation.
    pub(crate) id: u64,
}

// The built-in sky; keep in sync with `sky` in shaders/pathtrace.wgsl.
const SKY_ZENITH: [f32; 3] = [0.20, 0.40, 0.90];
const SKY_HORIZON: [f32; 3] = [0.85, 0.90, 1.00];
const SKY_GROUND: [f32; 3] = [0.30, 0.27, 0.24];
const SUN_DIR: [f32; 3] = [-0.35, 0.80, 0.50];
const SUN_RADIANCE: [f32; 3] = [12.0, 11.0, 9.5];
const SUN_EXPONENT: f32 = 64.0;

/// Linear RGB radiance of the built-in sky (used when no [`EnvMap`] is given) from unit world
/// direction `d`: with `y = d[1]` (world +y is up), `mix(HORIZON, ZENITH, √y)` above the horizon,
/// `mix(HORIZON, GROUND, √−y)` below, plus a sun lobe `SUN · max(d·s, 0)^64` around
/// `s = normalize(−0.35, 0.80, 0.50)`, where ZENITH = (0.20, 0.40, 0.90), HORIZON = (0.85, 0.90,
/// 1.00), GROUND = (0.30, 0.27, 0.24) and SUN = (12.0, 11.0, 9.5).
pub fn sky_radiance(d: [f32; 3]) -> [f32; 3] {
    let (far, t) = if d[1] >= 0.0 {
        (SKY_ZENITH, d[1].sqrt())
    } else {
        (SKY_GROUND, (-d[1]).sqrt())
    };
    let len = SUN_DIR.iter().map(|v| v * v).sum::<f32>().sqrt();
    let cos = (0..3)
        .map(|a| d[a] * SUN_DIR[a] / len)
        .sum::<f32>()
        .max(0.0);
    let sun = cos.powf(SUN_EXPONENT);
    std::array::from_fn(|a| SKY_HORIZON[a] + (far[a] - SKY_HORIZON[a]) * t + SUN_RADIANCE[a] * sun)
}

static NEXT_ENV_ID: AtomicU64 = AtomicU64::new(1);

/// Uploads an environment map for [`crate::PathTraceOptions::env`].
pub(crate) fn upload_env(gpu: &Gpu, env: &EnvMap) -> Result<GpuEnvMap, GpuError> {
    let max = gpu.limits.max_texture_dimension_2d;
    if env.width > max || env.height > max {
        return Err(GpuError::too_large(format!(
            "environment map {}x{} exceeds the device's largest texture ({max} per side)",
            env.width, env.height
        )));
    }
    gpu.scoped("uploading the environment map", || {
        let rgba: Vec<f32> = env
            .rgb
            .chunks_exact(3)
            .flat_map(|c| [c[0], c[1], c[2], 0.0])
            .collect();
        Ok(GpuEnvMap {
            view: gpu.float_texture("environment map", env.width, env.height, &rgba),
            id: NEXT_ENV_ID.fetch_add(1, Ordering::Relaxed),
        })
    })
}

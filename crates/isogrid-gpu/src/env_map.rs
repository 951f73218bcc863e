//! The path tracer's environment map on the GPU (paper §3.6, Figure 6): the core's [`EnvMap`]
//! uploaded as a float texture. The map's orientation and the built-in sky used without one are
//! the core's ([`isogrid::env_map`]); `environment` and `sky` in `shaders/pathtrace.wgsl` are
//! their twins.

use crate::error::GpuError;
use crate::wgpu_util::Gpu;
use isogrid::EnvMap;
use std::sync::atomic::{AtomicU64, Ordering};

/// An [`EnvMap`] resident on the GPU (`Rgba32Float` texture).
#[derive(Debug)]
pub struct GpuEnvMap {
    pub(crate) view: wgpu::TextureView,
    /// Identifies the map in the accumulation key: another map restarts accumulation.
    pub(crate) id: u64,
}

static NEXT_ENV_ID: AtomicU64 = AtomicU64::new(1);

/// Uploads an environment map for [`crate::PathTraceOptions::env`].
pub(crate) fn upload_env(gpu: &Gpu, env: &EnvMap) -> Result<GpuEnvMap, GpuError> {
    let max = gpu.limits.max_texture_dimension_2d;
    let (width, height) = (env.width(), env.height());
    if width > max || height > max {
        return Err(GpuError::too_large(format!(
            "environment map {width}x{height} exceeds the device's largest texture ({max} per side)"
        )));
    }
    gpu.scoped("uploading the environment map", || {
        let rgba: Vec<f32> = env
            .texels()
            .iter()
            .flat_map(|&[r, g, b]| [r, g, b, 0.0])
            .collect();
        Ok(GpuEnvMap {
            view: gpu.float_texture("environment map", width, height, &rgba),
            id: NEXT_ENV_ID.fetch_add(1, Ordering::Relaxed),
        })
    })
}

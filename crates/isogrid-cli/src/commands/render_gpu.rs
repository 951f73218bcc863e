//! The GPU side of `isogrid render`: the wgpu renderer (cell rasterisation, visibility buffer,
//! EWA, deferred shading, and the MC and CR baselines of paper Table 4).

use anyhow::Result;
use isogrid::mc::marching_cubes;
use isogrid::{Camera, CellGrid, Volume};
use isogrid_gpu::{Frame, GpuErrorKind, Mode, RenderOptions, Renderer, Scene};
use serde::Serialize;

/// Per-pass GPU milliseconds (median over frames after the first), `null` where unmeasured.
#[derive(Serialize, Default)]
pub struct GpuTimes {
    /// Depth + G-buffer: cell raster (both visibility passes) plus EWA, or the MC mesh (Table 4).
    pub raster_ms: Option<f64>,
    /// Raster without the EWA pass.
    pub raster_no_ewa_ms: Option<f64>,
    pub ewa_ms: Option<f64>,
    pub shade_ms: Option<f64>,
    pub cull_ms: Option<f64>,
    pub frame_ms: Option<f64>,
    /// Path tracing: the compute pass tracing secondary rays (and primary ones when traced).
    pub trace_ms: Option<f64>,
}

impl From<isogrid_gpu::PassTimings> for GpuTimes {
    fn from(t: isogrid_gpu::PassTimings) -> Self {
        GpuTimes {
            raster_ms: t.raster_ms,
            raster_no_ewa_ms: t.raster_ms.map(|r| r - t.ewa_ms.unwrap_or(0.0)),
            ewa_ms: t.ewa_ms,
            shade_ms: t.shade_ms,
            cull_ms: t.cull_ms,
            frame_ms: t.frame_ms,
            trace_ms: t.trace_ms,
        }
    }
}

pub struct GpuRender {
    pub adapter: String,
    pub frame: Frame,
    pub times: GpuTimes,
}

impl GpuRender {
    fn new(renderer: &Renderer, frame: Frame) -> Self {
        GpuRender {
            adapter: renderer.adapter_info(),
            times: GpuTimes::from(frame.timings),
            frame,
        }
    }
}

/// The renderer, or `None` when the machine has no adapter at all (callers may fall back).
pub fn renderer() -> Result<Option<Renderer>> {
    match Renderer::new() {
        Ok(r) => Ok(Some(r)),
        Err(e) if e.kind() == GpuErrorKind::NoAdapter => Ok(None),
        Err(e) => Err(isogrid::Error::from(e).into()),
    }
}

/// Path tracing (§3.6): raster (hybrid) or traced primaries, traced secondaries; `frames`
/// samples per pixel.
pub fn path_trace(
    renderer: &Renderer,
    grid: &CellGrid,
    camera: &Camera,
    frames: u32,
    bounces: u32,
    env: Option<&isogrid_trace::EnvMap>,
    primary: isogrid_gpu::PrimaryRays,
) -> Result<GpuRender> {
    let gpu_grid = renderer.upload_grid(grid).map_err(isogrid::Error::from)?;
    let gpu_env = match env {
        Some(map) => {
            let rgb = map.texels().iter().flatten().copied().collect();
            let env = isogrid_gpu::EnvMap::new(map.width(), map.height(), rgb)
                .map_err(isogrid::Error::from)?;
            Some(renderer.upload_env(&env).map_err(isogrid::Error::from)?)
        }
        None => None,
    };
    let options = isogrid_gpu::PathTraceOptions {
        frames,
        bounces,
        env: gpu_env.as_ref(),
        primary,
        ..Default::default()
    };
    let frame = renderer
        .path_trace(&gpu_grid, camera, &options)
        .map_err(isogrid::Error::from)?;
    Ok(GpuRender::new(renderer, frame))
}

/// Renders `mode` of `grid` (with `volume` for `mc` and `cr`) with `options`.
pub fn render(
    renderer: &Renderer,
    grid: &CellGrid,
    volume: Option<&Volume>,
    camera: &Camera,
    mode: Mode,
    options: &RenderOptions,
) -> Result<GpuRender> {
    let need_volume = |what: &str| {
        anyhow::anyhow!("mode {what} needs the volume: give a volume file, not a .cgc file")
    };
    let frame = match mode {
        Mode::Mc => {
            let volume = volume.ok_or_else(|| need_volume("mc"))?;
            let mesh = marching_cubes(&volume.view(), grid.info().iso);
            let gpu_mesh = renderer.upload_mesh(&mesh).map_err(isogrid::Error::from)?;
            renderer.render_with(Scene::Mesh(&gpu_mesh), camera, mode, options)
        }
        Mode::Cr => {
            let volume = volume.ok_or_else(|| need_volume("cr"))?;
            let gpu_grid = renderer.upload_grid(grid).map_err(isogrid::Error::from)?;
            let gpu_volume = renderer
                .upload_volume(&volume.view(), &gpu_grid)
                .map_err(isogrid::Error::from)?;
            renderer.render_with(
                Scene::Volume {
                    grid: &gpu_grid,
                    volume: &gpu_volume,
                },
                camera,
                mode,
                options,
            )
        }
        _ => {
            let gpu_grid = renderer.upload_grid(grid).map_err(isogrid::Error::from)?;
            renderer.render_with(Scene::Grid(&gpu_grid), camera, mode, options)
        }
    }
    .map_err(isogrid::Error::from)?;
    Ok(GpuRender::new(renderer, frame))
}

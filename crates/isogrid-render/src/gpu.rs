//! A request on the GPU renderer (isogrid-gpu): cell rasterisation (paper §3.2–3.4), the MC and
//! CR baselines of Table 4, or path tracing (§3.6) with one sample per pixel per frame.

use crate::mode::Mode;
use crate::output::{GpuStats, Rendered};
use crate::policy::Placement;
use crate::request::RenderRequest;
use isogrid::mc::marching_cubes;
use isogrid::{Camera, CellGrid, Error, Progress, Result, Volume};
use isogrid_gpu::{Frame, Renderer, Scene};
use std::time::Instant;

pub(crate) fn render(
    renderer: &Renderer,
    request: &RenderRequest,
    grid: &CellGrid,
    volume: Option<&Volume>,
    camera: &Camera,
    progress: &Progress,
) -> Result<Rendered> {
    let parts = request.parts();
    let mode = parts.mode;
    let volume = match (mode.needs_volume(), volume) {
        (true, None) => {
            return Err(Error::invalid(format!(
                "mode {mode} needs the original volume, and a .cgc file has none"
            )))
        }
        (_, v) => v,
    };
    progress.check()?;
    let start = Instant::now();
    let (frame, frames) = if mode == Mode::PathTrace {
        let gpu_grid = renderer.upload_grid(grid)?;
        let env = request.env.upload(renderer)?;
        let options = isogrid_gpu::PathTraceOptions {
            frames: parts.samples,
            bounces: parts.bounces,
            env: env.as_ref(),
            primary: parts.primary.unwrap_or_default().gpu(),
            occlusion_culling: parts.occlusion_culling,
            progress: Some(progress),
            ..Default::default()
        };
        let frame = renderer.path_trace(&gpu_grid, camera, &options)?;
        (frame, parts.samples)
    } else {
        // One step: raster frames are too quick to count one by one.
        progress.start(1);
        let options = isogrid_gpu::RenderOptions {
            frames: parts.frames,
            occlusion_culling: parts.occlusion_culling,
            cell_raster: parts.cell_raster,
            ..Default::default()
        };
        let gpu_mode = mode;
        let frame = match (mode, volume) {
            (Mode::Mc, Some(volume)) => {
                let mesh = marching_cubes(&volume.view(), grid.info().iso);
                let gpu_mesh = renderer.upload_mesh(&mesh)?;
                renderer.render_with(Scene::Mesh(&gpu_mesh), camera, gpu_mode, &options)?
            }
            (Mode::Cr, Some(volume)) => {
                let gpu_grid = renderer.upload_grid(grid)?;
                let gpu_volume = renderer.upload_volume(&volume.view(), &gpu_grid)?;
                let scene = Scene::Volume {
                    grid: &gpu_grid,
                    volume: &gpu_volume,
                };
                renderer.render_with(scene, camera, gpu_mode, &options)?
            }
            _ => {
                let gpu_grid = renderer.upload_grid(grid)?;
                renderer.render_with(Scene::Grid(&gpu_grid), camera, gpu_mode, &options)?
            }
        };
        progress.advance(1);
        (frame, parts.frames)
    };
    let seconds = start.elapsed().as_secs_f64();
    Ok(rendered(renderer, frame, frames, seconds, mode))
}

fn rendered(renderer: &Renderer, f: Frame, frames: u32, seconds: f64, mode: Mode) -> Rendered {
    let rgb8 = f
        .rgba8
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    Rendered {
        width: f.width,
        height: f.height,
        rgb8,
        placement: Placement::Gpu,
        adapter: renderer.adapter_info(),
        seconds,
        samples: (mode == Mode::PathTrace).then_some(f.samples),
        cpu: None,
        gpu: Some(GpuStats {
            frames,
            timings: f.timings,
            drawn_cells: f.drawn_cells,
            probed_cells: f.probed_cells,
            cell_raster: f.cell_raster,
        }),
        depth: f.depth,
        normal: f.normal,
        cluster: f.cluster,
    }
}

//! [`render`]: runs a placed request on its renderer, reporting progress and stopping on cancel.

use crate::context::RenderContext;
use crate::output::Rendered;
use crate::policy::Placement;
use crate::request::RenderRequest;
use isogrid::{CellGrid, Progress, Result, Volume};

/// Renders `grid` (with its `volume` for the modes that need it) as `request` asks, on
/// `placement` (from [`RenderContext::decide`]). `progress` counts finished work (image rows on
/// the CPU, frames of GPU path tracing) and stops the render within a tile or a frame of
/// [`Progress::cancel`], with an error of kind [`isogrid::ErrorKind::Cancelled`].
pub fn render(
    ctx: &RenderContext,
    request: &RenderRequest,
    placement: Placement,
    grid: &CellGrid,
    volume: Option<&Volume>,
    progress: &Progress,
) -> Result<Rendered> {
    // Checked before anything is uploaded or traced.
    let (lo, hi) = grid.info().world_bounds();
    let camera = request.camera(lo, hi)?;
    match placement {
        Placement::Cpu => crate::cpu::render(request, grid, &camera, progress),
        Placement::Gpu => {
            let renderer = ctx.renderer()?;
            crate::gpu::render(renderer, request, grid, volume, progress)
        }
    }
}

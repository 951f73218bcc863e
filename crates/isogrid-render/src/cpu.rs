//! A request on the CPU tracer (isogrid-trace): Blinn–Phong ray tracing or path tracing.

use crate::mode::Mode;
use crate::output::{CpuStats, Rendered};
use crate::policy::Placement;
use crate::request::RenderRequest;
use isogrid::{Camera, CellGrid, Error, Progress, Result};
use isogrid_trace::{render_with_progress, Crossing, PathTraceOptions, RenderOptions, Shading};
use std::time::Instant;

pub(crate) fn render(
    request: &RenderRequest,
    grid: &CellGrid,
    camera: &Camera,
    progress: &Progress,
) -> Result<Rendered> {
    let parts = request.parts();
    let path_trace = parts.mode == Mode::PathTrace;
    let shading = if path_trace {
        Shading::PathTrace(PathTraceOptions {
            samples_per_pixel: parts.samples,
            bounces: parts.bounces,
            environment: request.env.for_cpu(),
            seed: parts.seed,
            ..PathTraceOptions::default()
        })
    } else {
        Shading::Phong
    };
    let coloring = match &parts.color {
        None => None,
        Some(spec) => {
            let attribute = grid.attribute().ok_or_else(|| {
                Error::invalid("colouring asks for the grid's attribute, and the grid has none")
            })?;
            Some(spec.coloring(attribute.info())?)
        }
    };
    let options = RenderOptions {
        crossing: parts.crossing,
        traversal: parts.traversal,
        shading,
        coloring,
    };
    let start = Instant::now();
    let image = render_with_progress(grid, camera, &options, progress)?;
    let seconds = start.elapsed().as_secs_f64();
    Ok(Rendered {
        width: image.width,
        height: image.height,
        cpu: Some(CpuStats {
            crossing: match parts.crossing {
                Crossing::Exact => "exact",
                _ => "samples3",
            },
            traversal: parts.traversal.name(),
            build_seconds: image.build_seconds,
            rays: image.rays_traced,
        }),
        rgb8: image.rgb8,
        depth: image.depth,
        normal: image.normal,
        cluster: image.cluster,
        value: image.value,
        label: None,
        placement: Placement::Cpu,
        adapter: "CPU ray tracer".into(),
        seconds,
        samples: path_trace.then_some(parts.samples),
        gpu: None,
    })
}

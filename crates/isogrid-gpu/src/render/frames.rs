//! Runs one render call: checks the request, finds or resets the view's visibility bits, sets up
//! the call's targets, bind groups and queries, records and submits each frame, and reads back
//! the last one.

use super::bindings::FrameBindings;
use super::frame_passes::FramePasses;
use super::plan::FramePlan;
use super::readback::Readbacks;
use super::timings::{read_timings, PassClock, Timestamps, TS_TRACE};
use super::uniforms::frame_uniforms;
use crate::error::{GpuError, GpuErrorKind};
use crate::options::{Mode, PathTraceOptions, RenderOptions};
use crate::output::Frame;
use crate::passes::RasterPasses;
use crate::pathtrace::{PathTracePass, TracePipelines};
use crate::upload::Scene;
use crate::view::ViewState;
use crate::wgpu_util::Gpu;
use isogrid::Camera;

/// The device and the passes a render call records.
pub(crate) struct FrameContext<'a> {
    pub gpu: &'a Gpu,
    pub passes: &'a RasterPasses,
    pub tracer: &'a TracePipelines,
}

/// Renders `options.frames` frames of `camera`'s view of `scene` in `mode` with `view`'s state,
/// path tracing with `path_trace` where given, and reads back the last frame.
pub(crate) fn render(
    ctx: &FrameContext<'_>,
    view: &mut ViewState,
    scene: Scene<'_>,
    camera: &Camera,
    mode: Mode,
    options: &RenderOptions,
    path_trace: Option<&PathTraceOptions>,
) -> Result<Frame, GpuError> {
    camera
        .validate()
        .map_err(|e| GpuError::invalid(e.to_string()))?;
    let max = ctx.gpu.limits.max_texture_dimension_2d;
    if camera.width > max || camera.height > max {
        return Err(GpuError::too_large(format!(
            "image {}x{} exceeds the device's largest texture ({max} per side)",
            camera.width, camera.height
        )));
    }
    let (grid, volume, mesh) = match (mode, scene) {
        (
            Mode::Cgc | Mode::CgcNoEwa | Mode::PathTrace,
            Scene::Grid(g) | Scene::Volume { grid: g, .. },
        ) => (Some(g), None, None),
        (Mode::Cr, Scene::Volume { grid, volume }) => (Some(grid), Some(volume), None),
        (Mode::Mc, Scene::Mesh(m)) => (None, None, Some(m)),
        _ => {
            return Err(GpuError::invalid(format!(
                "mode {mode:?} needs {}",
                match mode {
                    Mode::Mc => "an uploaded mesh (Scene::Mesh)",
                    Mode::Cr => "a grid and its volume (Scene::Volume)",
                    _ => "an uploaded grid (Scene::Grid)",
                }
            )))
        }
    };
    if options.coloring.is_some() {
        let missing = match (mode, grid, mesh) {
            (_, Some(g), _) if g.attribute.is_none() => {
                Some("the grid has no attribute to colour by".to_string())
            }
            (_, None, Some(m)) if !m.has_values => {
                Some("the mesh was uploaded without vertex values to colour by".into())
            }
            _ => None,
        };
        if let Some(why) = missing {
            return Err(GpuError::invalid(why));
        }
    }
    let plan = FramePlan::new((grid, volume, mesh), camera, mode, options, path_trace);
    ctx.gpu.scoped("rendering", || {
        render_unscoped(ctx, view, &plan, camera, mode, path_trace)
    })
}

fn render_unscoped(
    ctx: &FrameContext<'_>,
    view: &mut ViewState,
    plan: &FramePlan<'_>,
    camera: &Camera,
    mode: Mode,
    path_trace: Option<&PathTraceOptions>,
) -> Result<Frame, GpuError> {
    let gpu = ctx.gpu;
    let frames = plan.frames;
    // Visibility state belongs to one view; a new view starts with every cluster visible.
    let visibility = match plan.grid {
        Some(g) => {
            let key = format!("{camera:?} {mode:?} {}", plan.flags);
            Some(view.visibility_for(gpu, g, key)?)
        }
        None => None,
    };
    let bindings = FrameBindings::new(gpu, ctx.passes, camera, plan, visibility.as_ref());
    let timestamps = Timestamps::new(gpu, frames);
    let page_count = plan.grid.map_or(0, |g| g.pages.len()) as u64;
    // Traced primaries run no shading pass, which writes the values.
    let values = plan.coloring.is_some() && !plan.traced;
    let readbacks = Readbacks::new(gpu, &bindings.targets, page_count, values);
    let t = &bindings.targets;
    let path_pass = match (path_trace, plan.grid) {
        (Some(o), Some(g)) => Some(PathTracePass::prepare(
            gpu,
            ctx.tracer,
            view,
            g,
            camera,
            o,
            [&t.final_normal, &t.color, &t.ids],
            &t.value_view,
            &bindings.uniforms,
        )?),
        _ => None,
    };
    let first_frame = match plan.grid {
        Some(_) => view.take_frames(frames),
        None => 0,
    };
    let clock = PassClock::new(timestamps.as_ref());
    let passes = FramePasses {
        passes: ctx.passes,
        plan,
        bindings: &bindings,
        clock: &clock,
        visibility: visibility.as_ref(),
        size: (camera.width, camera.height),
    };
    // With a progress to report to, the CPU waits for frame f − 1 after submitting frame f: the
    // GPU stays busy, finished frames are counted, and a cancel is seen within a frame.
    let progress = path_trace.and_then(|o| o.progress);
    if let Some(p) = progress {
        p.start(frames as u64);
    }
    let mut in_flight = None;
    for f in 0..frames {
        if let Some(p) = progress.filter(|p| p.is_cancelled()) {
            gpu.device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| GpuError::device(format!("waiting for the GPU: {e}")))?;
            let (done, total) = p.counts();
            return Err(GpuError::new(
                GpuErrorKind::Cancelled,
                format!("interrupted after {done} of {total} frames"),
            ));
        }
        let uniforms = frame_uniforms(
            camera,
            plan.grid,
            plan.volume.is_some(),
            plan.bounds,
            plan.flags,
            first_frame.wrapping_add(f),
        );
        gpu.queue
            .write_buffer(&bindings.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        clock.start_frame(f);
        if let Some(m) = plan.mesh {
            passes.mesh(&mut encoder, m);
        }
        if let Some(g) = plan.raster_grid {
            passes.cull_and_raster(&mut encoder, g);
            passes.ewa(&mut encoder, g);
            if plan.occlusion {
                passes.visibility(&mut encoder);
            }
        }
        if plan.grid.is_none() {
            passes.clear_ewa(&mut encoder);
        }
        passes.shade(&mut encoder);
        if let Some(pt) = &path_pass {
            pt.encode(
                gpu,
                &mut encoder,
                f,
                clock.compute(TS_TRACE),
                f + 1 == frames,
            );
        }
        if f + 1 == frames {
            if let Some(t) = &timestamps {
                t.resolve(&mut encoder);
            }
            let pages = plan.raster_grid.map_or(&[][..], |g| &g.pages[..]);
            readbacks.record(&mut encoder, pages);
        }
        let submitted = gpu.queue.submit([encoder.finish()]);
        if let Some(p) = progress {
            if let Some(previous) = in_flight.replace(submitted) {
                gpu.device
                    .poll(wgpu::PollType::Wait {
                        submission_index: Some(previous),
                        timeout: None,
                    })
                    .map_err(|e| GpuError::device(format!("waiting for the GPU: {e}")))?;
                p.advance(1);
            }
        }
    }

    let timings = read_timings(gpu, timestamps.as_ref(), &clock)?;
    let mut frame = readbacks.frame(gpu, timings, plan.occlusion, plan.cell_raster)?;
    if let Some(pt) = path_pass {
        pt.finish(gpu, &mut frame, view, frames)?;
    }
    if let Some(p) = progress {
        p.advance(1);
    }
    Ok(frame)
}

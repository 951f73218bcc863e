//! Runs one render call: resets visibility on a new view, sets up the call's targets, bind
//! groups and queries, records and submits each frame, and reads back the last one.

use super::frame_passes::FramePasses;
use super::plan::FramePlan;
use super::timings::{PassClock, TS_TRACE};
use super::{Frame, Mode};
use crate::error::GpuError;
use crate::pathtrace::PathTraceOptions;
use crate::Renderer;
use isogrid::Camera;
use std::sync::atomic::Ordering;

impl Renderer {
    /// Visibility state belongs to one view; a new view starts with every cluster visible.
    fn reset_visibility_for_view(
        &self,
        plan: &FramePlan<'_>,
        camera: &Camera,
        mode: Mode,
    ) -> Result<(), GpuError> {
        if let Some(g) = plan.grid {
            let key = format!("{camera:?} {mode:?} {}", plan.flags);
            let mut last = g
                .last_view
                .lock()
                .map_err(|_| GpuError::device("visibility state poisoned"))?;
            if last.as_deref() != Some(key.as_str()) {
                let all = vec![0xffu8; g.visibility_bytes as usize];
                self.queue.write_buffer(&g.visible_last_frame, 0, &all);
                let none = vec![0u8; g.visibility_bytes as usize];
                self.queue.write_buffer(&g.visible_new, 0, &none);
                *last = Some(key);
            }
        }
        Ok(())
    }

    pub(super) fn render_unscoped(
        &self,
        plan: &FramePlan<'_>,
        camera: &Camera,
        mode: Mode,
        path_trace: Option<&PathTraceOptions>,
    ) -> Result<Frame, GpuError> {
        let frames = plan.frames;
        let bindings = self.frame_bindings(camera, plan);
        self.reset_visibility_for_view(plan, camera, mode)?;
        let timestamps = self.timestamps(frames);
        let page_count = plan.grid.map_or(0, |g| g.pages.len()) as u64;
        let readbacks = self.readbacks(&bindings.targets, page_count);
        let t = &bindings.targets;
        let path_pass = match (path_trace, plan.grid) {
            (Some(o), Some(g)) => Some(self.prepare_path_trace(
                g,
                camera,
                o,
                [&t.final_normal, &t.color, &t.ids],
                &bindings.uniforms,
            )?),
            _ => None,
        };
        let clock = PassClock::new(timestamps.as_ref());
        let passes = FramePasses {
            pipelines: &self.pipelines,
            plan,
            bindings: &bindings,
            clock: &clock,
            size: (camera.width, camera.height),
        };
        for f in 0..frames {
            let frame_index = plan
                .grid
                .map_or(0, |g| g.frame_index.fetch_add(1, Ordering::Relaxed));
            let uniforms = self.frame_uniforms(
                camera,
                plan.grid,
                plan.volume.is_some(),
                plan.bounds,
                plan.flags,
                frame_index,
            );
            self.queue
                .write_buffer(&bindings.uniforms, 0, bytemuck::bytes_of(&uniforms));
            let mut encoder = self
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
                    passes.visibility(&mut encoder, g);
                }
            }
            if plan.grid.is_none() {
                passes.clear_ewa(&mut encoder);
            }
            passes.shade(&mut encoder);
            if let Some(pt) = &path_pass {
                pt.encode(
                    self,
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
            self.queue.submit([encoder.finish()]);
        }

        let timings = self.read_timings(timestamps.as_ref(), &clock)?;
        let mut frame = readbacks.frame(self, timings, plan.occlusion, plan.cell_raster)?;
        if let (Some(pt), Some(g)) = (path_pass, plan.grid) {
            pt.finish(self, &mut frame, g, frames)?;
        }
        Ok(frame)
    }
}

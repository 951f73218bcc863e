//! Records one frame's passes in order (the sequence in the crate docs): cluster expansion and
//! cell raster, hardware or compute, with probes and the newly visible clusters; EWA splats; the
//! visibility update; deferred shading; or the MC mesh in place of the cells.

use super::bindings::FrameBindings;
use super::plan::FramePlan;
use super::timings::{
    PassClock, TS_EWA, TS_EXPAND, TS_EXPAND_NEW, TS_PROBE, TS_RASTER, TS_RASTER_NEW, TS_SHADE,
    TS_VISIBILITY,
};
use crate::gpu_types::{LIST_FULL, LIST_NEW, LIST_PROBE};
use crate::passes::{ComputeRasterCall, RasterPasses, RasterStep};
use crate::upload::{GpuGrid, GpuMesh};
use crate::view::Visibility;
use crate::wgpu_util::color_attachment;

/// What the passes of every frame of one render call bind and time.
pub(super) struct FramePasses<'a> {
    pub passes: &'a RasterPasses,
    pub plan: &'a FramePlan<'a>,
    pub bindings: &'a FrameBindings,
    pub clock: &'a PassClock<'a>,
    /// The view's cluster visibility bits (with a grid).
    pub visibility: Option<&'a Visibility>,
    /// Image size in pixels.
    pub size: (u32, u32),
}

impl FramePasses<'_> {
    /// Begins a render pass that clears the G-buffer, the cluster ids (to "no hit") and the
    /// reversed-Z depth.
    fn clear_targets<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> wgpu::RenderPass<'e> {
        let t = &self.bindings.targets;
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[
                color_attachment(&t.surface_view, Some(wgpu::Color::TRANSPARENT)),
                color_attachment(
                    &t.ids_view,
                    Some(wgpu::Color {
                        r: u32::MAX as f64,
                        g: u32::MAX as f64,
                        b: 0.0,
                        a: 0.0,
                    }),
                ),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &t.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// The MC baseline: the mesh in place of the cell raster.
    pub fn mesh(&self, encoder: &mut wgpu::CommandEncoder, m: &GpuMesh) {
        let mut pass = self.clear_targets(encoder, "mc mesh raster", self.clock.render(TS_RASTER));
        self.passes
            .mesh
            .draw(&mut pass, &self.bindings.scene.render, m);
    }

    fn compute_raster<'g>(&'g self, g: &'g GpuGrid) -> ComputeRasterCall<'g> {
        let b = self.bindings;
        ComputeRasterCall {
            raster: &self.passes.compute,
            scene: &b.scene.compute,
            groups: &b.compute_raster,
            pages: &g.pages,
            size: self.size,
        }
    }

    /// Expansion and raster of the clusters visible last frame, then with occlusion culling the
    /// probes, expansion of the newly visible clusters and their raster into the same targets.
    pub fn cull_and_raster(&self, encoder: &mut wgpu::CommandEncoder, g: &GpuGrid) {
        let b = self.bindings;
        for page in &g.pages {
            encoder.copy_buffer_to_buffer(
                &b.args_template,
                0,
                &page.args,
                0,
                b.args_template.size(),
            );
        }
        let expansion = &self.passes.expansion;
        let scene = &b.scene.compute;
        expansion.expand(
            encoder,
            false,
            scene,
            &g.pages,
            self.clock.compute(TS_EXPAND),
        );
        let compute = self.compute_raster(g);
        self.raster_visible(encoder, g, &compute);
        if self.plan.occlusion {
            self.probe(encoder, g, &compute);
            let ts = self.clock.compute(TS_EXPAND_NEW);
            expansion.expand(encoder, true, scene, &g.pages, ts);
            self.raster_new(encoder, g, &compute);
        }
    }

    fn raster_visible(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        g: &GpuGrid,
        compute: &ComputeRasterCall<'_>,
    ) {
        let b = self.bindings;
        if self.plan.compute_raster {
            self.passes
                .expansion
                .size_dispatches(encoder, &b.scene.compute, &g.pages);
            // The clear is part of the timed raster, as the hardware path's load op is. A grid
            // without pages has nothing to bind for the compute clear, nor any cell to draw.
            let clear: &[RasterStep] = if g.pages.is_empty() {
                drop(self.clear_targets(encoder, "clear cell raster targets", None));
                &[]
            } else {
                &[RasterStep::Clear]
            };
            let draw: &[RasterStep] = if self.plan.occlusion {
                &[RasterStep::DepthFull]
            } else {
                &[RasterStep::DepthFull, RasterStep::ResolveFull]
            };
            let steps = [clear, draw].concat();
            let ts = self.clock.compute(TS_RASTER);
            compute.pass(encoder, "compute cell raster", ts, &steps);
        } else {
            let mut pass = self.clear_targets(encoder, "cell raster", self.clock.render(TS_RASTER));
            self.passes
                .hardware
                .draw_cells(&mut pass, &b.scene.render, &g.pages, LIST_FULL);
        }
    }

    fn probe(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        g: &GpuGrid,
        compute: &ComputeRasterCall<'_>,
    ) {
        if self.plan.compute_raster {
            let probes = [RasterStep::Probe];
            let ts = self.clock.compute(TS_PROBE);
            compute.pass(encoder, "compute probes", ts, &probes);
        } else {
            let b = self.bindings;
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visibility probes"),
                color_attachments: &[color_attachment(&b.targets.ids_view, None)],
                depth_stencil_attachment: None,
                timestamp_writes: self.clock.render(TS_PROBE),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.passes.hardware.draw_probes(
                &mut pass,
                &b.scene.render,
                &b.depth_input,
                &g.pages,
                LIST_PROBE,
            );
        }
    }

    fn raster_new(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        g: &GpuGrid,
        compute: &ComputeRasterCall<'_>,
    ) {
        let b = self.bindings;
        if self.plan.compute_raster {
            self.passes
                .expansion
                .size_dispatches(encoder, &b.scene.compute, &g.pages);
            let steps = [
                RasterStep::DepthNew,
                RasterStep::ResolveFull,
                RasterStep::ResolveNew,
            ];
            let label = "compute cell raster (newly visible) and resolve";
            compute.pass(encoder, label, self.clock.compute(TS_RASTER_NEW), &steps);
        } else {
            let t = &b.targets;
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cell raster (newly visible)"),
                color_attachments: &[
                    color_attachment(&t.surface_view, None),
                    color_attachment(&t.ids_view, None),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &t.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: self.clock.render(TS_RASTER_NEW),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.passes
                .hardware
                .draw_cells(&mut pass, &b.scene.render, &g.pages, LIST_NEW);
        }
    }

    /// EWA normal splats of the drawn cells (§3.4); without EWA the target is only cleared.
    pub fn ewa(&self, encoder: &mut wgpu::CommandEncoder, g: &GpuGrid) {
        let (plan, b) = (self.plan, self.bindings);
        if plan.ewa && plan.compute_raster && !g.pages.is_empty() {
            encoder.clear_buffer(&b.ewa_sum, 0, None);
            let steps: &[RasterStep] = if plan.occlusion {
                &[
                    RasterStep::SplatFull,
                    RasterStep::SplatNew,
                    RasterStep::ResolveSplats,
                ]
            } else {
                &[RasterStep::SplatFull, RasterStep::ResolveSplats]
            };
            let ts = self.clock.compute(TS_EWA);
            self.compute_raster(g)
                .pass(encoder, "compute ewa splats", ts, steps);
            return;
        }
        // Cleared in every mode so that the shading pass can always read it.
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("ewa normal splats"),
            color_attachments: &[color_attachment(
                &b.targets.ewa_view,
                Some(wgpu::Color::TRANSPARENT),
            )],
            depth_stencil_attachment: None,
            timestamp_writes: if plan.ewa {
                self.clock.render(TS_EWA)
            } else {
                None
            },
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if plan.ewa {
            let lists: &[u64] = if plan.occlusion {
                &[LIST_FULL, LIST_NEW]
            } else {
                &[LIST_FULL]
            };
            self.passes.ewa.draw(
                &mut pass,
                &b.scene.render,
                &b.surface_input,
                &g.pages,
                lists,
            );
        }
    }

    /// The mesh path never touches the EWA target; clears it for the shading pass.
    pub fn clear_ewa(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("clear ewa target"),
            color_attachments: &[color_attachment(
                &self.bindings.targets.ewa_view,
                Some(wgpu::Color::TRANSPARENT),
            )],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    }

    /// Rebuilds the view's cluster visibility bits from the cluster id target (occlusion culling).
    pub fn visibility(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(visibility) = self.visibility else {
            return;
        };
        let b = self.bindings;
        self.passes.visibility.record(
            encoder,
            visibility,
            &b.scene.compute,
            &b.ids_input,
            self.size,
            self.clock.compute(TS_VISIBILITY),
        );
    }

    /// Deferred shading into the colour and final normal targets: in a compute pass after the
    /// compute raster, else in a full-screen fragment pass; none with traced primaries.
    pub fn shade(&self, encoder: &mut wgpu::CommandEncoder) {
        let b = self.bindings;
        let shading = &self.passes.shading;
        if let Some(outputs) = &b.shade_outputs {
            shading.record_compute(
                encoder,
                &b.scene.compute,
                &b.shade_inputs,
                outputs,
                self.size,
                self.clock.compute(TS_SHADE),
            );
        } else if !self.plan.traced {
            let t = &b.targets;
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("deferred shading"),
                color_attachments: &[
                    color_attachment(&t.color_view, Some(wgpu::Color::BLACK)),
                    color_attachment(&t.final_view, Some(wgpu::Color::TRANSPARENT)),
                    color_attachment(&t.value_view, Some(wgpu::Color::TRANSPARENT)),
                ],
                depth_stencil_attachment: None,
                timestamp_writes: self.clock.render(TS_SHADE),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            shading.draw(&mut pass, &b.scene.render, &b.shade_inputs);
        }
    }
}

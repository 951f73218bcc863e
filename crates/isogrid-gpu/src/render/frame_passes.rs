//! Records one frame's passes (the sequence in the crate docs): cluster expansion and cell raster,
//! hardware or compute, with probes and the newly visible clusters; EWA splats; the visibility
//! update; deferred shading; or the MC mesh in place of the cells.

use super::bindings::{color_attachment, dispatch_size};
use super::plan::FramePlan;
use super::targets::FrameBindings;
use super::timings::{
    PassClock, TS_EWA, TS_EXPAND, TS_EXPAND_NEW, TS_PROBE, TS_RASTER, TS_RASTER_NEW, TS_SHADE,
    TS_VISIBILITY,
};
use crate::compute_raster::{ComputeRaster, RasterStep};
use crate::gpu_types::{PageDrawArgs, LIST_FULL, LIST_NEW, LIST_PROBE};
use crate::pipelines::Pipelines;
use crate::upload::{GpuGrid, GpuMesh};

/// What the passes of every frame of one render call bind and time.
pub(super) struct FramePasses<'a> {
    pub pipelines: &'a Pipelines,
    pub plan: &'a FramePlan<'a>,
    pub bindings: &'a FrameBindings,
    pub clock: &'a PassClock<'a>,
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
        let b = self.bindings;
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[
                color_attachment(&b.surface_view, Some(wgpu::Color::TRANSPARENT)),
                color_attachment(
                    &b.ids_view,
                    Some(wgpu::Color {
                        r: u32::MAX as f64,
                        g: u32::MAX as f64,
                        b: 0.0,
                        a: 0.0,
                    }),
                ),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &b.depth_view,
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
        if m.index_count > 0 {
            pass.set_pipeline(&self.pipelines.mesh_pipeline);
            pass.set_bind_group(0, &self.bindings.scene_render, &[]);
            pass.set_bind_group(1, &m.bind_group, &[]);
            pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..m.index_count, 0, 0..1);
        }
    }

    fn compute_raster<'g>(&'g self, g: &'g GpuGrid) -> ComputeRaster<'g> {
        let b = self.bindings;
        ComputeRaster {
            pipelines: self.pipelines,
            scene: &b.scene_compute,
            targets: &b.raster_targets,
            ewa_targets: &b.ewa_targets,
            pages: &g.pages,
            size: self.size,
        }
    }

    /// Cell lists of every page from the clusters' visibility bits (`expand.wgsl`).
    fn expand(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        slot: u32,
        g: &GpuGrid,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: self.clock.compute(slot),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.bindings.scene_compute, &[]);
        for page in &g.pages {
            pass.set_bind_group(1, &page.compute_group, &[]);
            let (x, y) = dispatch_size(page.slot_count);
            pass.dispatch_workgroups(x, y, 1);
        }
    }

    /// Expansion and raster of the clusters visible last frame, then with occlusion culling the
    /// probes, expansion of the newly visible clusters and their raster into the same targets.
    pub fn cull_and_raster(&self, encoder: &mut wgpu::CommandEncoder, g: &GpuGrid) {
        let (p, b) = (self.pipelines, self.bindings);
        for page in &g.pages {
            encoder.copy_buffer_to_buffer(
                &b.args_template,
                0,
                &page.args,
                0,
                b.args_template.size(),
            );
        }
        self.expand(
            encoder,
            "expand visible clusters",
            &p.expand_visible,
            TS_EXPAND,
            g,
        );
        let compute = self.compute_raster(g);
        self.raster_visible(encoder, g, &compute);
        if self.plan.occlusion {
            self.probe(encoder, g, &compute);
            let label = "expand newly visible clusters";
            self.expand(encoder, label, &p.expand_new, TS_EXPAND_NEW, g);
            self.raster_new(encoder, g, &compute);
        }
    }

    fn raster_visible(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        g: &GpuGrid,
        compute: &ComputeRaster<'_>,
    ) {
        let b = self.bindings;
        if self.plan.compute_raster {
            compute.size_dispatches(encoder);
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
            pass.set_pipeline(&self.pipelines.cells);
            pass.set_bind_group(0, &b.scene_render, &[]);
            for page in &g.pages {
                pass.set_bind_group(1, &page.render_groups[LIST_FULL as usize], &[]);
                pass.draw_indirect(&page.args, PageDrawArgs::offset(LIST_FULL));
            }
        }
    }

    fn probe(&self, encoder: &mut wgpu::CommandEncoder, g: &GpuGrid, compute: &ComputeRaster<'_>) {
        if self.plan.compute_raster {
            let probes = [RasterStep::Probe];
            let ts = self.clock.compute(TS_PROBE);
            compute.pass(encoder, "compute probes", ts, &probes);
        } else {
            let b = self.bindings;
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visibility probes"),
                color_attachments: &[color_attachment(&b.ids_view, None)],
                depth_stencil_attachment: None,
                timestamp_writes: self.clock.render(TS_PROBE),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipelines.probe);
            pass.set_bind_group(0, &b.scene_render, &[]);
            pass.set_bind_group(2, &b.depth_input, &[]);
            for page in &g.pages {
                pass.set_bind_group(1, &page.render_groups[LIST_PROBE as usize], &[]);
                pass.draw_indirect(&page.args, PageDrawArgs::offset(LIST_PROBE));
            }
        }
    }

    fn raster_new(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        g: &GpuGrid,
        compute: &ComputeRaster<'_>,
    ) {
        if self.plan.compute_raster {
            compute.size_dispatches(encoder);
            let steps = [
                RasterStep::DepthNew,
                RasterStep::ResolveFull,
                RasterStep::ResolveNew,
            ];
            let label = "compute cell raster (newly visible) and resolve";
            compute.pass(encoder, label, self.clock.compute(TS_RASTER_NEW), &steps);
        } else {
            let b = self.bindings;
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cell raster (newly visible)"),
                color_attachments: &[
                    color_attachment(&b.surface_view, None),
                    color_attachment(&b.ids_view, None),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &b.depth_view,
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
            pass.set_pipeline(&self.pipelines.cells);
            pass.set_bind_group(0, &b.scene_render, &[]);
            for page in &g.pages {
                pass.set_bind_group(1, &page.render_groups[LIST_NEW as usize], &[]);
                pass.draw_indirect(&page.args, PageDrawArgs::offset(LIST_NEW));
            }
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
                &b.ewa_view,
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
            pass.set_pipeline(&self.pipelines.ewa);
            pass.set_bind_group(0, &b.scene_render, &[]);
            pass.set_bind_group(2, &b.surface_input, &[]);
            let lists: &[u64] = if plan.occlusion {
                &[LIST_FULL, LIST_NEW]
            } else {
                &[LIST_FULL]
            };
            for page in &g.pages {
                for &list in lists {
                    pass.set_bind_group(1, &page.render_groups[list as usize], &[]);
                    pass.draw_indirect(&page.args, PageDrawArgs::offset(list));
                }
            }
        }
    }

    /// The mesh path never touches the EWA target; clears it for the shading pass.
    pub fn clear_ewa(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("clear ewa target"),
            color_attachments: &[color_attachment(
                &self.bindings.ewa_view,
                Some(wgpu::Color::TRANSPARENT),
            )],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    }

    /// Rebuilds the clusters' visibility bits from the cluster id target (occlusion culling).
    pub fn visibility(&self, encoder: &mut wgpu::CommandEncoder, g: &GpuGrid) {
        let b = self.bindings;
        encoder.clear_buffer(&g.visible_last_frame, 0, None);
        encoder.clear_buffer(&g.visible_new, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("visibility update"),
            timestamp_writes: self.clock.compute(TS_VISIBILITY),
        });
        pass.set_pipeline(&self.pipelines.visibility);
        pass.set_bind_group(0, &b.scene_compute, &[]);
        pass.set_bind_group(1, &b.ids_input, &[]);
        pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
    }

    /// Deferred shading into the colour and final normal targets: in a compute pass after the
    /// compute raster, else in a full-screen fragment pass; none with traced primaries.
    pub fn shade(&self, encoder: &mut wgpu::CommandEncoder) {
        let (p, b) = (self.pipelines, self.bindings);
        if let Some(outputs) = &b.shade_outputs {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("deferred shading (compute)"),
                timestamp_writes: self.clock.compute(TS_SHADE),
            });
            pass.set_pipeline(&p.shade_compute);
            pass.set_bind_group(0, &b.scene_compute, &[]);
            pass.set_bind_group(1, &b.shade_inputs, &[]);
            pass.set_bind_group(2, outputs, &[]);
            pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
        } else if !self.plan.traced {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("deferred shading"),
                color_attachments: &[
                    color_attachment(&b.color_view, Some(wgpu::Color::BLACK)),
                    color_attachment(&b.final_view, Some(wgpu::Color::TRANSPARENT)),
                ],
                depth_stencil_attachment: None,
                timestamp_writes: self.clock.render(TS_SHADE),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&p.shade);
            pass.set_bind_group(0, &b.scene_render, &[]);
            pass.set_bind_group(1, &b.shade_inputs, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

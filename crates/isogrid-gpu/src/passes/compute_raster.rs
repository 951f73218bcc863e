//! The compute cell raster (paper §3.2, the probes of §3.3 and the EWA splats of §3.4, as compute
//! passes: `shaders/cells_compute.wgsl`, `shaders/ewa_compute.wgsl`): one thread per cell walks
//! its pixels, visibility is an atomic maximum of the reversed-Z depth, the G-buffer is written
//! in a resolve step, and EWA splats sum in integers. See [`crate::CellRaster`] for when it is
//! used instead of the hardware raster.

use super::scene::SceneLayouts;
use crate::gpu_types::{PageDispatchArgs, LIST_FULL, LIST_NEW, LIST_PROBE};
use crate::shaders::{CELLS_COMPUTE, EWA_COMPUTE};
use crate::targets::{Targets, EWA_FORMAT, IDS_FORMAT, SURFACE_FORMAT};
use crate::upload::{GridLayouts, Page};
use crate::wgpu_util::{
    buffer_entry, compute, layout, module, pipeline_layout, specialised_compute, storage, texture,
    texture_entry, written_texture, Gpu, D2, FLOAT,
};
use wgpu::{BindGroupLayout, ComputePipeline, ShaderStages};

/// The compute raster's layouts and pipelines.
pub(crate) struct ComputeRaster {
    /// Group 2 of `cells_compute.wgsl`: the depth words and the G-buffer storage views.
    targets: BindGroupLayout,
    /// Group 2 of `ewa_compute.wgsl`: the splat sums, the G-buffer and the EWA target.
    ewa_targets: BindGroupLayout,
    depth_full: ComputePipeline,
    depth_new: ComputePipeline,
    resolve_full: ComputePipeline,
    resolve_new: ComputePipeline,
    probe: ComputePipeline,
    clear: ComputePipeline,
    splat_full: ComputePipeline,
    splat_new: ComputePipeline,
    resolve_splats: ComputePipeline,
}

/// One compute raster pass over one list of every page.
#[derive(Clone, Copy)]
pub(crate) enum RasterStep {
    DepthFull,
    DepthNew,
    ResolveFull,
    ResolveNew,
    Probe,
    SplatFull,
    SplatNew,
    /// Per pixel, not per list: the splat sums into the EWA target.
    ResolveSplats,
    /// Per pixel, not per list: empty depth words, G-buffer and IDs.
    Clear,
}

/// Group 2 of the compute raster's passes in one render call.
pub(crate) struct ComputeRasterGroups {
    targets: wgpu::BindGroup,
    ewa_targets: wgpu::BindGroup,
}

impl ComputeRaster {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts, grid: &GridLayouts) -> Self {
        let c = ShaderStages::COMPUTE;
        let targets = layout(
            device,
            "compute raster targets",
            &[
                storage(0, c, false),
                written_texture(1, SURFACE_FORMAT),
                written_texture(2, IDS_FORMAT),
            ],
        );
        let ewa_targets = layout(
            device,
            "compute ewa targets",
            &[
                storage(0, c, false),
                texture(1, c, FLOAT, D2),
                written_texture(2, EWA_FORMAT),
            ],
        );
        let raster_module = module(device, "cells_compute.wgsl", CELLS_COMPUTE);
        let raster_layout = pipeline_layout(
            device,
            "compute raster",
            &[&scene.compute, &grid.page_compute, &targets],
        );
        let ewa_module = module(device, "ewa_compute.wgsl", EWA_COMPUTE);
        let ewa_layout = pipeline_layout(
            device,
            "compute ewa",
            &[&scene.compute, &grid.page_compute, &ewa_targets],
        );
        let raster = |label: &str, list: u64, resolve: bool| {
            let constants = [
                ("RASTER_LIST", list as f64),
                ("RASTER_RESOLVE", resolve as u8 as f64),
            ];
            specialised_compute(
                device,
                label,
                &raster_layout,
                &raster_module,
                "raster_cells",
                &constants,
            )
        };
        let splat = |label: &str, list: u64| {
            specialised_compute(
                device,
                label,
                &ewa_layout,
                &ewa_module,
                "splat_cells",
                &[("EWA_LIST", list as f64)],
            )
        };
        ComputeRaster {
            depth_full: raster("compute raster depth (full list)", LIST_FULL, false),
            depth_new: raster("compute raster depth (new list)", LIST_NEW, false),
            resolve_full: raster("compute raster resolve (full list)", LIST_FULL, true),
            resolve_new: raster("compute raster resolve (new list)", LIST_NEW, true),
            probe: compute(
                device,
                "compute raster probes",
                &raster_layout,
                &raster_module,
                "probe_cells",
            ),
            clear: compute(
                device,
                "compute raster clear",
                &raster_layout,
                &raster_module,
                "clear_targets",
            ),
            splat_full: splat("compute ewa splats (full list)", LIST_FULL),
            splat_new: splat("compute ewa splats (new list)", LIST_NEW),
            resolve_splats: compute(
                device,
                "compute ewa resolve",
                &ewa_layout,
                &ewa_module,
                "resolve_splats",
            ),
            targets,
            ewa_targets,
        }
    }

    /// Group 2 over `targets`, the per-pixel reversed-Z depth words and the splats' sums.
    pub fn bind(
        &self,
        gpu: &Gpu,
        targets: &Targets,
        depth_words: &wgpu::Buffer,
        ewa_sum: &wgpu::Buffer,
    ) -> ComputeRasterGroups {
        ComputeRasterGroups {
            targets: gpu.bind_group(
                "compute raster targets",
                &self.targets,
                &[
                    buffer_entry(0, depth_words),
                    texture_entry(1, &targets.surface_view),
                    texture_entry(2, &targets.ids_view),
                ],
            ),
            ewa_targets: gpu.bind_group(
                "compute ewa targets",
                &self.ewa_targets,
                &[
                    buffer_entry(0, ewa_sum),
                    texture_entry(1, &targets.surface_view),
                    texture_entry(2, &targets.ewa_view),
                ],
            ),
        }
    }
}

/// The bind groups and pipelines one frame's compute raster passes use.
pub(crate) struct ComputeRasterCall<'a> {
    pub raster: &'a ComputeRaster,
    pub scene: &'a wgpu::BindGroup,
    pub groups: &'a ComputeRasterGroups,
    pub pages: &'a [Page],
    /// Image size in pixels.
    pub size: (u32, u32),
}

impl ComputeRasterCall<'_> {
    /// Records `steps` in order, each over every page, in one timed compute pass.
    pub fn pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
        steps: &[RasterStep],
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timestamps,
        });
        let p = self.raster;
        pass.set_bind_group(0, self.scene, &[]);
        for step in steps {
            let (pipeline, list) = match step {
                RasterStep::DepthFull => (&p.depth_full, LIST_FULL),
                RasterStep::DepthNew => (&p.depth_new, LIST_NEW),
                RasterStep::ResolveFull => (&p.resolve_full, LIST_FULL),
                RasterStep::ResolveNew => (&p.resolve_new, LIST_NEW),
                RasterStep::Probe => (&p.probe, LIST_PROBE),
                RasterStep::SplatFull => (&p.splat_full, LIST_FULL),
                RasterStep::SplatNew => (&p.splat_new, LIST_NEW),
                RasterStep::ResolveSplats | RasterStep::Clear => {
                    let (pipeline, targets) = match step {
                        RasterStep::Clear => (&p.clear, &self.groups.targets),
                        _ => (&p.resolve_splats, &self.groups.ewa_targets),
                    };
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(2, targets, &[]);
                    // Group 1 is in the layout, unused by these per-pixel entry points.
                    if let Some(page) = self.pages.first() {
                        pass.set_bind_group(1, &page.compute_group, &[]);
                    }
                    pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
                    continue;
                }
            };
            let splats = matches!(step, RasterStep::SplatFull | RasterStep::SplatNew);
            pass.set_bind_group(
                2,
                if splats {
                    &self.groups.ewa_targets
                } else {
                    &self.groups.targets
                },
                &[],
            );
            pass.set_pipeline(pipeline);
            for page in self.pages {
                pass.set_bind_group(1, &page.compute_group, &[]);
                pass.dispatch_workgroups_indirect(
                    &page.dispatch_args,
                    PageDispatchArgs::offset(list),
                );
            }
        }
    }
}

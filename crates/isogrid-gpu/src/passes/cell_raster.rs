//! The paper's cell raster through the graphics pipeline (§3.2–3.3, `shaders/cells.wgsl`,
//! `shaders/probe.wgsl`): each cell a screen rectangle whose fragments find the isosurface
//! crossing, writing the G-buffer, cluster ids and depth; and the probe splats that mark clusters
//! that became visible.

use super::scene::SceneLayouts;
use crate::gpu_types::PageDrawArgs;
use crate::shaders::{CELLS, PROBE};
use crate::targets::{Targets, DEPTH_FORMAT, IDS_FORMAT, SURFACE_FORMAT};
use crate::upload::{GridLayouts, Page};
use crate::wgpu_util::{
    layout, module, pipeline_layout, render_pipeline, target, texture, texture_entry, Gpu,
    RenderSpec, D2,
};
use wgpu::ShaderStages;

/// The hardware cell raster's and the probes' pipelines, and the probes' depth input layout.
pub(crate) struct HardwareRaster {
    cells: wgpu::RenderPipeline,
    probe: wgpu::RenderPipeline,
    depth_input: wgpu::BindGroupLayout,
}

impl HardwareRaster {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts, grid: &GridLayouts) -> Self {
        let depth_input = layout(
            device,
            "raster depth input",
            &[texture(
                0,
                ShaderStages::FRAGMENT,
                wgpu::TextureSampleType::Depth,
                D2,
            )],
        );
        // The fragment shader writes the crossing's depth, which is never nearer than the
        // rectangle's (the box's nearest corner): declaring that (conservative depth) keeps the
        // early depth test, which rejects cells behind what is already drawn before any sampling.
        // Only here, and only for devices that offer it: `@early_depth_test` is a wgpu extension,
        // not WebGPU WGSL, so the shared files (and the web viewer) never contain it.
        let cells_source = CELLS.concat();
        let cells_source = if device
            .features()
            .contains(wgpu::Features::SHADER_EARLY_DEPTH_TEST)
        {
            cells_source.replace(
                "@fragment\nfn fs_cell",
                "@fragment @early_depth_test(less_equal)\nfn fs_cell",
            )
        } else {
            cells_source
        };
        let cells_module = module(device, "cells.wgsl", &[&cells_source]);
        let cells_layout = pipeline_layout(device, "cells", &[&scene.render, &grid.page_render]);
        let cells = render_pipeline(
            device,
            RenderSpec {
                label: "cell raster",
                layout: &cells_layout,
                module: &cells_module,
                vertex: "vs_cell",
                fragment: "fs_cell",
                targets: &[target(SURFACE_FORMAT), target(IDS_FORMAT)],
                depth: Some(DEPTH_FORMAT),
            },
        );
        let probe_module = module(device, "probe.wgsl", PROBE);
        let probe_layout = pipeline_layout(
            device,
            "probe",
            &[&scene.render, &grid.page_render, &depth_input],
        );
        let probe = render_pipeline(
            device,
            RenderSpec {
                label: "visibility probes",
                layout: &probe_layout,
                module: &probe_module,
                vertex: "vs_probe",
                fragment: "fs_probe",
                // The pass needs an attachment for its size; probes only write visibility bits.
                targets: &[Some(wgpu::ColorTargetState {
                    format: IDS_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::empty(),
                })],
                depth: None,
            },
        );
        HardwareRaster {
            cells,
            probe,
            depth_input,
        }
    }

    /// The probes' group 2: the raster depth of `targets`.
    pub fn bind_depth(&self, gpu: &Gpu, targets: &Targets) -> wgpu::BindGroup {
        gpu.bind_group(
            "raster depth input",
            &self.depth_input,
            &[texture_entry(0, &targets.depth_view)],
        )
    }

    /// Draws instance list `list` of every page as cell rectangles.
    pub fn draw_cells(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        scene: &wgpu::BindGroup,
        pages: &[Page],
        list: u64,
    ) {
        pass.set_pipeline(&self.cells);
        pass.set_bind_group(0, scene, &[]);
        for page in pages {
            pass.set_bind_group(1, &page.render_groups[list as usize], &[]);
            pass.draw_indirect(&page.args, PageDrawArgs::offset(list));
        }
    }

    /// Draws the probe list of every page against the raster depth (`depth`, [`Self::bind_depth`]).
    pub fn draw_probes(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        scene: &wgpu::BindGroup,
        depth: &wgpu::BindGroup,
        pages: &[Page],
        list: u64,
    ) {
        pass.set_pipeline(&self.probe);
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(2, depth, &[]);
        for page in pages {
            pass.set_bind_group(1, &page.render_groups[list as usize], &[]);
            pass.draw_indirect(&page.args, PageDrawArgs::offset(list));
        }
    }
}

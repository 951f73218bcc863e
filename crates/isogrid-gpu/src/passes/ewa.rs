//! EWA normal splatting through the graphics pipeline (paper §3.4, `shaders/ewa.wgsl`): each drawn
//! cell adds a Gaussian-weighted normal to the pixels around its hit, blended additively into a
//! float target that shading normalises.

use super::scene::SceneLayouts;
use crate::gpu_types::PageDrawArgs;
use crate::shaders::EWA;
use crate::targets::{Targets, EWA_FORMAT};
use crate::upload::{GridLayouts, Page};
use crate::wgpu_util::{
    layout, module, pipeline_layout, render_pipeline, texture, texture_entry, Gpu, RenderSpec, D2,
    FLOAT,
};

/// The splats' pipeline and the layout of their G-buffer input.
pub(crate) struct EwaSplats {
    pipeline: wgpu::RenderPipeline,
    surface_input: wgpu::BindGroupLayout,
}

impl EwaSplats {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts, grid: &GridLayouts) -> Self {
        let surface_input = layout(
            device,
            "raster surface input",
            &[texture(0, wgpu::ShaderStages::FRAGMENT, FLOAT, D2)],
        );
        let ewa_module = module(device, "ewa.wgsl", EWA);
        let ewa_layout = pipeline_layout(
            device,
            "ewa",
            &[&scene.render, &grid.page_render, &surface_input],
        );
        let additive = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let pipeline = render_pipeline(
            device,
            RenderSpec {
                label: "ewa normal splats",
                layout: &ewa_layout,
                module: &ewa_module,
                vertex: "vs_splat",
                fragment: "fs_splat",
                targets: &[Some(wgpu::ColorTargetState {
                    format: EWA_FORMAT,
                    blend: Some(wgpu::BlendState {
                        color: additive,
                        alpha: additive,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: None,
            },
        );
        EwaSplats {
            pipeline,
            surface_input,
        }
    }

    /// Group 2: the raster G-buffer of `targets`.
    pub fn bind(&self, gpu: &Gpu, targets: &Targets) -> wgpu::BindGroup {
        gpu.bind_group(
            "raster surface input",
            &self.surface_input,
            &[texture_entry(0, &targets.surface_view)],
        )
    }

    /// Splats the cells of `lists` of every page.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        scene: &wgpu::BindGroup,
        surface: &wgpu::BindGroup,
        pages: &[Page],
        lists: &[u64],
    ) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(2, surface, &[]);
        for page in pages {
            for &list in lists {
                pass.set_bind_group(1, &page.render_groups[list as usize], &[]);
                pass.draw_indirect(&page.args, PageDrawArgs::offset(list));
            }
        }
    }
}

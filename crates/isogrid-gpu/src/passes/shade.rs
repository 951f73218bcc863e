//! Deferred shading (`shaders/shade.wgsl`): normalised Blinn–Phong (`isogrid::shading`) of the
//! G-buffer, with EWA normals where the splats covered the pixel, into the sRGB colour and the
//! final normal + distance targets, coloured by a colour map over the surface's attribute where
//! the render asks for it (the value each pixel shows goes to the value target); as a full-screen fragment pass, or per pixel in a compute
//! pass after the compute raster.

use super::scene::SceneLayouts;
use crate::shaders::SHADE;
use crate::targets::{Targets, COLOR_FORMAT, FINAL_FORMAT, VALUE_FORMAT};
use crate::wgpu_util::{
    buffer_entry, compute, layout, module, pipeline_layout, render_pipeline, storage, target,
    texture, texture_entry, uniform, written_texture, Gpu, RenderSpec, D2, FLOAT,
};
use wgpu::ShaderStages;

/// The shading pipelines (fragment and compute) and the layouts of their inputs and outputs.
pub(crate) struct Shading {
    fragment: wgpu::RenderPipeline,
    compute: wgpu::ComputePipeline,
    inputs: wgpu::BindGroupLayout,
    outputs: wgpu::BindGroupLayout,
}

impl Shading {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts) -> Self {
        let fc = ShaderStages::FRAGMENT | ShaderStages::COMPUTE;
        let inputs = layout(
            device,
            "shading inputs",
            &[
                texture(0, fc, FLOAT, D2),
                texture(1, fc, FLOAT, D2),
                texture(2, fc, wgpu::TextureSampleType::Uint, D2),
                uniform(3, fc),
                storage(4, fc, true),
            ],
        );
        let outputs = layout(
            device,
            "compute shading outputs",
            &[
                written_texture(0, COLOR_FORMAT),
                written_texture(1, FINAL_FORMAT),
                written_texture(2, VALUE_FORMAT),
            ],
        );
        let shade_module = module(device, "shade.wgsl", SHADE);
        let shade_layout = pipeline_layout(device, "shade", &[&scene.render, &inputs]);
        let fragment = render_pipeline(
            device,
            RenderSpec {
                label: "deferred shading",
                layout: &shade_layout,
                module: &shade_module,
                vertex: "vs_fullscreen",
                fragment: "fs_shade",
                targets: &[
                    target(COLOR_FORMAT),
                    target(FINAL_FORMAT),
                    target(VALUE_FORMAT),
                ],
                depth: None,
            },
        );
        let compute = compute(
            device,
            "deferred shading (compute)",
            &pipeline_layout(
                device,
                "shade (compute)",
                &[&scene.compute, &inputs, &outputs],
            ),
            &shade_module,
            "shade_pixels",
        );
        Shading {
            fragment,
            compute,
            inputs,
            outputs,
        }
    }

    /// Group 1: the raster G-buffer, the EWA sums and the cluster ids of `targets`, the colouring
    /// (`ColorUniforms`) and the colour data: a label grid's cluster albedos, else a dummy (the
    /// cell raster writes the hit cell's attribute code into the ID target).
    pub fn bind_inputs(
        &self,
        gpu: &Gpu,
        targets: &Targets,
        coloring: &wgpu::Buffer,
        color_data: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        gpu.bind_group(
            "shading inputs",
            &self.inputs,
            &[
                texture_entry(0, &targets.surface_view),
                texture_entry(1, &targets.ewa_view),
                texture_entry(2, &targets.ids_view),
                buffer_entry(3, coloring),
                buffer_entry(4, color_data),
            ],
        )
    }

    /// Group 2 of the compute pass: the colour and final normal targets as storage.
    pub fn bind_outputs(&self, gpu: &Gpu, targets: &Targets) -> wgpu::BindGroup {
        gpu.bind_group(
            "compute shading outputs",
            &self.outputs,
            &[
                texture_entry(0, &targets.color_view),
                texture_entry(1, &targets.final_view),
                texture_entry(2, &targets.value_view),
            ],
        )
    }

    /// Shades every pixel in a compute pass.
    pub fn record_compute(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        inputs: &wgpu::BindGroup,
        outputs: &wgpu::BindGroup,
        size: (u32, u32),
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("deferred shading (compute)"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.compute);
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(1, inputs, &[]);
        pass.set_bind_group(2, outputs, &[]);
        pass.dispatch_workgroups(size.0.div_ceil(8), size.1.div_ceil(8), 1);
    }

    /// Shades every pixel with one full-screen triangle, in a pass whose attachments are the
    /// colour and final normal targets.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        scene: &wgpu::BindGroup,
        inputs: &wgpu::BindGroup,
    ) {
        pass.set_pipeline(&self.fragment);
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(1, inputs, &[]);
        pass.draw(0..3, 0..1);
    }
}

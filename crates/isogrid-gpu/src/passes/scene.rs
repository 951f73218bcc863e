//! Group 0 of every cell, mesh and shading pass, shared as re_renderer shares its global
//! bindings: the frame uniforms, the view's cluster visibility bits and the original volume (CR).

use crate::wgpu_util::{
    buffer_entry, layout, storage, texture, texture_entry, uniform, Gpu, FLOAT,
};
use wgpu::{BindGroupLayout, ShaderStages};

/// The layouts of group 0, for compute and for render pipelines.
pub(crate) struct SceneLayouts {
    pub compute: BindGroupLayout,
    pub render: BindGroupLayout,
}

/// Group 0 of one render call, for compute and for render passes.
pub(crate) struct SceneGroups {
    pub compute: wgpu::BindGroup,
    pub render: wgpu::BindGroup,
}

/// What group 0 binds: the frame uniforms, the visibility bits (last frame, new this frame) and
/// the original volume.
pub(crate) struct SceneInputs<'a> {
    pub uniforms: &'a wgpu::Buffer,
    pub visible_last_frame: &'a wgpu::Buffer,
    pub visible_new: &'a wgpu::Buffer,
    pub volume: &'a wgpu::TextureView,
}

impl SceneLayouts {
    pub fn new(device: &wgpu::Device) -> Self {
        let vf = ShaderStages::VERTEX | ShaderStages::FRAGMENT;
        let c = ShaderStages::COMPUTE;
        let f = ShaderStages::FRAGMENT;
        let d3 = wgpu::TextureViewDimension::D3;
        // Group 0: frame uniforms, visibility bits (last frame, new this frame), original volume.
        let compute = layout(
            device,
            "scene (compute)",
            &[
                uniform(0, c),
                storage(1, c, false),
                texture(2, c, FLOAT, d3),
                storage(3, c, false),
            ],
        );
        let render = layout(
            device,
            "scene (render)",
            &[
                uniform(0, vf),
                texture(2, vf, FLOAT, d3),
                storage(3, f, false),
            ],
        );
        SceneLayouts { compute, render }
    }

    pub fn bind(&self, gpu: &Gpu, inputs: &SceneInputs<'_>) -> SceneGroups {
        SceneGroups {
            compute: gpu.bind_group(
                "scene (compute)",
                &self.compute,
                &[
                    buffer_entry(0, inputs.uniforms),
                    buffer_entry(1, inputs.visible_last_frame),
                    texture_entry(2, inputs.volume),
                    buffer_entry(3, inputs.visible_new),
                ],
            ),
            render: gpu.bind_group(
                "scene (render)",
                &self.render,
                &[
                    buffer_entry(0, inputs.uniforms),
                    texture_entry(2, inputs.volume),
                    buffer_entry(3, inputs.visible_new),
                ],
            ),
        }
    }
}

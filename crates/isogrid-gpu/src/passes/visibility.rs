//! The visibility update (paper §3.3, `shaders/visibility.wgsl`): rebuilds the view's
//! per-cluster visibility bits from the cluster id target, for the next frame's expansion.

use super::scene::SceneLayouts;
use crate::shaders::VISIBILITY;
use crate::targets::Targets;
use crate::view::Visibility;
use crate::wgpu_util::{compute, layout, module, pipeline_layout, texture, texture_entry, Gpu, D2};

/// The update's pipeline and the layout of its cluster id input.
pub(crate) struct VisibilityUpdate {
    pipeline: wgpu::ComputePipeline,
    ids_input: wgpu::BindGroupLayout,
}

impl VisibilityUpdate {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts) -> Self {
        let ids_input = layout(
            device,
            "cluster id input",
            &[texture(
                0,
                wgpu::ShaderStages::COMPUTE,
                wgpu::TextureSampleType::Uint,
                D2,
            )],
        );
        let visibility_module = module(device, "visibility.wgsl", VISIBILITY);
        let visibility_layout =
            pipeline_layout(device, "visibility", &[&scene.compute, &ids_input]);
        let pipeline = compute(
            device,
            "visibility update",
            &visibility_layout,
            &visibility_module,
            "update_visibility",
        );
        VisibilityUpdate {
            pipeline,
            ids_input,
        }
    }

    /// Group 1: the cluster ids of `targets`.
    pub fn bind(&self, gpu: &Gpu, targets: &Targets) -> wgpu::BindGroup {
        gpu.bind_group(
            "cluster id input",
            &self.ids_input,
            &[texture_entry(0, &targets.ids_view)],
        )
    }

    /// Clears `visibility` and sets the bit of every cluster with a pixel in the id target.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        visibility: &Visibility,
        scene: &wgpu::BindGroup,
        ids: &wgpu::BindGroup,
        size: (u32, u32),
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        encoder.clear_buffer(&visibility.last_frame, 0, None);
        encoder.clear_buffer(&visibility.new, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("visibility update"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(1, ids, &[]);
        pass.dispatch_workgroups(size.0.div_ceil(8), size.1.div_ceil(8), 1);
    }
}

//! The Marching Cubes baseline's raster (`shaders/mesh.wgsl`): the snorm16 mesh into the same
//! G-buffer and depth targets as the cells, so that shading and read-back are shared.

use super::scene::SceneLayouts;
use crate::shaders::MESH;
use crate::targets::{DEPTH_FORMAT, IDS_FORMAT, SURFACE_FORMAT};
use crate::upload::{GpuMesh, GridLayouts};
use crate::wgpu_util::{module, pipeline_layout, render_pipeline, target, RenderSpec};

/// The mesh raster's pipeline.
pub(crate) struct MeshRaster {
    pipeline: wgpu::RenderPipeline,
}

impl MeshRaster {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts, grid: &GridLayouts) -> Self {
        let mesh_module = module(device, "mesh.wgsl", MESH);
        let mesh_layout = pipeline_layout(device, "mesh", &[&scene.render, &grid.mesh]);
        let pipeline = render_pipeline(
            device,
            RenderSpec {
                label: "mc mesh raster",
                layout: &mesh_layout,
                module: &mesh_module,
                vertex: "vs_mesh",
                fragment: "fs_mesh",
                targets: &[target(SURFACE_FORMAT), target(IDS_FORMAT)],
                depth: Some(DEPTH_FORMAT),
            },
        );
        MeshRaster { pipeline }
    }

    /// Draws the whole mesh.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, scene: &wgpu::BindGroup, m: &GpuMesh) {
        if m.index_count > 0 {
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, scene, &[]);
            pass.set_bind_group(1, &m.bind_group, &[]);
            pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..m.index_count, 0, 0..1);
        }
    }
}

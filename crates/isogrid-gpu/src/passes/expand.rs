//! Cluster expansion (paper §3.3, `shaders/expand.wgsl`): from the view's cluster visibility bits,
//! each page's instance lists — cells of visible clusters that survive back-face and frustum
//! culling, one probe cell per metacell of the other clusters, and later the cells of clusters the
//! probes found — with their indirect draw and dispatch arguments.

use super::scene::SceneLayouts;
use crate::shaders::EXPAND;
use crate::upload::{GridLayouts, Page};
use crate::wgpu_util::{compute, dispatch_size, module, pipeline_layout};

/// The expansion's pipelines.
pub(crate) struct ClusterExpansion {
    visible: wgpu::ComputePipeline,
    newly_visible: wgpu::ComputePipeline,
    size_dispatches: wgpu::ComputePipeline,
}

impl ClusterExpansion {
    pub fn new(device: &wgpu::Device, scene: &SceneLayouts, grid: &GridLayouts) -> Self {
        let expand_module = module(device, "expand.wgsl", EXPAND);
        let expand_layout =
            pipeline_layout(device, "expand", &[&scene.compute, &grid.page_compute]);
        let visible = compute(
            device,
            "expand visible clusters",
            &expand_layout,
            &expand_module,
            "expand_visible",
        );
        let newly_visible = compute(
            device,
            "expand newly visible clusters",
            &expand_layout,
            &expand_module,
            "expand_new",
        );
        let size_dispatches = compute(
            device,
            "size compute raster dispatches",
            &pipeline_layout(
                device,
                "size dispatches",
                &[&scene.compute, &grid.page_compute, &grid.dispatch_args],
            ),
            &expand_module,
            "size_dispatches",
        );
        ClusterExpansion {
            visible,
            newly_visible,
            size_dispatches,
        }
    }

    /// Cell lists of every page from the clusters' visibility bits: those of clusters visible
    /// last frame and the probes (`newly_visible` false), or those of clusters the probes found.
    pub fn expand(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        newly_visible: bool,
        scene: &wgpu::BindGroup,
        pages: &[Page],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let (label, pipeline) = if newly_visible {
            ("expand newly visible clusters", &self.newly_visible)
        } else {
            ("expand visible clusters", &self.visible)
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene, &[]);
        for page in pages {
            pass.set_bind_group(1, &page.compute_group, &[]);
            let (x, y) = dispatch_size(page.slot_count);
            pass.dispatch_workgroups(x, y, 1);
        }
    }

    /// Turns the lists' instance counts into the compute raster's indirect dispatch sizes; after
    /// each expansion.
    pub fn size_dispatches(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        pages: &[Page],
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("size compute raster dispatches"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.size_dispatches);
        pass.set_bind_group(0, scene, &[]);
        for page in pages {
            pass.set_bind_group(1, &page.compute_group, &[]);
            pass.set_bind_group(2, &page.dispatch_group, &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
    }
}

//! The raster passes of a frame, one struct per pass owning its pipelines and bind-group layouts
//! (as in rerun's `re_renderer`), all built once per [`crate::Renderer`]: group 0 shared by all
//! ([`scene`]), cluster expansion, the hardware and the compute cell raster, EWA splats, the
//! visibility update, deferred shading and the MC mesh. The path tracer's pipelines are in
//! `crate::pathtrace`; the order in which a frame runs these passes is in `crate::render`.

mod cell_raster;
mod compute_raster;
mod ewa;
mod expand;
mod mesh;
mod scene;
mod shade;
mod visibility;

pub(crate) use cell_raster::HardwareRaster;
pub(crate) use compute_raster::{
    ComputeRaster, ComputeRasterCall, ComputeRasterGroups, RasterStep,
};
pub(crate) use ewa::EwaSplats;
pub(crate) use expand::ClusterExpansion;
pub(crate) use mesh::MeshRaster;
pub(crate) use scene::{SceneGroups, SceneInputs, SceneLayouts};
pub(crate) use shade::Shading;
pub(crate) use visibility::VisibilityUpdate;

use crate::upload::GridLayouts;

/// Every raster pass of a frame.
pub(crate) struct RasterPasses {
    pub scene: SceneLayouts,
    pub expansion: ClusterExpansion,
    pub hardware: HardwareRaster,
    pub compute: ComputeRaster,
    pub ewa: EwaSplats,
    pub visibility: VisibilityUpdate,
    pub shading: Shading,
    pub mesh: MeshRaster,
}

impl RasterPasses {
    pub fn new(device: &wgpu::Device, grid: &GridLayouts) -> Self {
        let scene = SceneLayouts::new(device);
        RasterPasses {
            expansion: ClusterExpansion::new(device, &scene, grid),
            compute: ComputeRaster::new(device, &scene, grid),
            visibility: VisibilityUpdate::new(device, &scene),
            hardware: HardwareRaster::new(device, &scene, grid),
            ewa: EwaSplats::new(device, &scene, grid),
            shading: Shading::new(device, &scene),
            mesh: MeshRaster::new(device, &scene, grid),
            scene,
        }
    }
}

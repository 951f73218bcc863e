//! Which passes a render call's frames run, decided once from the mode, the options, the scene
//! and where the eye is.

use crate::gpu_types::{
    COLOR_LABELS, COLOR_MESH, COLOR_NONE, COLOR_RECORDS, FLAG_BACKFACE, FLAG_EWA, FLAG_OCCLUSION,
};
use crate::options::{CellRaster, Mode, PathTraceOptions, PrimaryRays, RenderOptions};
use crate::upload::{GpuGrid, GpuMesh, GpuVolume};
use isogrid::Camera;

/// The scene and the pass choices of one render call; every frame follows it.
pub(super) struct FramePlan<'a> {
    /// Frames to render, at least 1.
    pub frames: u32,
    pub grid: Option<&'a GpuGrid>,
    /// The original samples ([`Mode::Cr`]).
    pub volume: Option<&'a GpuVolume>,
    pub mesh: Option<&'a GpuMesh>,
    /// The grid the raster passes draw; `None` where the path tracer traces the primary rays.
    pub raster_grid: Option<&'a GpuGrid>,
    pub ewa: bool,
    /// Traced primaries: the path-trace pass alone fills the image and the G-buffer.
    pub traced: bool,
    pub occlusion: bool,
    /// The raster that draws the cells ([`CellRaster::Auto`] resolved); `None` without one.
    pub cell_raster: Option<CellRaster>,
    pub compute_raster: bool,
    /// World bounds of the grid or mesh.
    pub bounds: ([f64; 3], [f64; 3]),
    /// `FLAG_*` bits of the frame uniforms.
    pub flags: u32,
    /// Where the shading pass finds each pixel's attribute value (`COLOR_*`).
    pub color_source: u32,
    pub coloring: Option<&'a isogrid::colormap::Coloring>,
}

impl<'a> FramePlan<'a> {
    pub fn new(
        (grid, volume, mesh): (
            Option<&'a GpuGrid>,
            Option<&'a GpuVolume>,
            Option<&'a GpuMesh>,
        ),
        camera: &Camera,
        mode: Mode,
        options: &'a RenderOptions,
        path_trace: Option<&PathTraceOptions>,
    ) -> Self {
        let frames = options.frames.max(1);
        let ewa = matches!(mode, Mode::Cgc | Mode::PathTrace);
        let traced = path_trace.is_some_and(|o| o.primary == PrimaryRays::Traced);
        let raster_grid = grid.filter(|_| !traced);
        let bounds = match (grid, mesh) {
            (Some(g), _) => g.info.world_bounds(),
            (None, Some(m)) => m.bounds,
            _ => ([0.0; 3], [1.0; 3]),
        };
        let eye_outside =
            (0..3).any(|a| camera.eye[a] < bounds.0[a] || camera.eye[a] > bounds.1[a]);
        let occlusion = options.occlusion_culling && grid.is_some();
        let cell_raster = raster_grid.map(|g| options.cell_raster.resolve(camera, &g.info));
        let compute_raster = cell_raster == Some(CellRaster::Compute);
        let backface =
            options.backface_culling && grid.is_some_and(|g| g.border_outside) && eye_outside;
        let mut flags = 0;
        if occlusion {
            flags |= FLAG_OCCLUSION;
        }
        if backface {
            flags |= FLAG_BACKFACE;
        }
        if ewa {
            flags |= FLAG_EWA;
        }
        let color_source = match (&options.coloring, grid, mesh) {
            (None, Some(g), _) if g.label_albedo.is_some() => COLOR_LABELS,
            (None, None, Some(m)) if m.label_albedo.is_some() => COLOR_LABELS,
            (None, _, _) => COLOR_NONE,
            (Some(_), Some(_), _) => COLOR_RECORDS,
            (Some(_), None, _) => COLOR_MESH,
        };
        FramePlan {
            color_source,
            coloring: options.coloring.as_ref(),
            frames,
            grid,
            volume,
            mesh,
            raster_grid,
            ewa,
            traced,
            occlusion,
            cell_raster,
            compute_raster,
            bounds,
            flags,
        }
    }
}

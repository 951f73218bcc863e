//! One rendered image: what to draw ([`Mode`], [`Scene`]), how ([`RenderOptions`]), what comes
//! back ([`Frame`]), and the [`Renderer::render`] entry points that check their inputs.
//!
//! A render call plans its passes (`plan.rs`), builds its targets and bind groups
//! (`targets.rs`), records each frame (`frame_passes.rs`, driven by `frames.rs`) with timestamp
//! queries around each pass (`timings.rs`), and reads back colour, depth, normal and cluster AOVs
//! (`readback.rs`).

mod bindings;
mod frame_passes;
mod frames;
mod plan;
mod readback;
mod targets;
mod timings;
mod uniforms;

pub(crate) use bindings::{buffer_entry, dispatch_size, texture_entry};
pub use timings::PassTimings;

use crate::compute_raster::CellRaster;
use crate::error::GpuError;
use crate::pathtrace::PathTraceOptions;
use crate::upload::{GpuGrid, GpuMesh, GpuVolume};
use crate::Renderer;
use isogrid::Camera;
use plan::FramePlan;

/// What to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Cell rasterisation of the clustered grid cells with EWA normal splatting (§3.2–3.4).
    Cgc,
    /// Cell rasterisation with per-pixel trilinear-gradient normals, no EWA pass.
    CgcNoEwa,
    /// The Marching Cubes mesh baseline.
    Mc,
    /// Cell rasterisation sampling the original volume (the paper's CR \[13\] baseline), with the
    /// same clusters and visibility buffer.
    Cr,
    /// Hybrid path tracing (§3.6): the [`Mode::Cgc`] G-buffer gives primary hits, secondary rays
    /// are traced through the blocks, clusters, metacells and cells in a compute pass, and the
    /// samples accumulate while the view rests. See [`Renderer::path_trace`] for the options,
    /// among them tracing the primary rays too ([`crate::PrimaryRays::Traced`]).
    PathTrace,
}

/// The uploaded data a mode draws: [`Mode::Cgc`] and [`Mode::CgcNoEwa`] need a grid,
/// [`Mode::Cr`] a grid and its volume, [`Mode::Mc`] a mesh.
#[derive(Clone, Copy)]
pub enum Scene<'a> {
    Grid(&'a GpuGrid),
    Volume {
        grid: &'a GpuGrid,
        volume: &'a GpuVolume,
    },
    Mesh(&'a GpuMesh),
}

/// How to render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderOptions {
    /// Renders the same view this many times (at least 1); the visibility buffer converges over
    /// frames and timings are the median over frames after the first.
    pub frames: u32,
    /// Draws only clusters visible last frame (or found visible by probes this frame).
    pub occlusion_culling: bool,
    /// Skips cells whose surface faces away from the eye, where that cannot change the image (the
    /// grid's border is outside the surface and the eye is outside the grid box).
    pub backface_culling: bool,
    /// Which raster draws the cells; see [`CellRaster`].
    pub cell_raster: CellRaster,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            frames: 1,
            occlusion_culling: true,
            backface_culling: true,
            cell_raster: CellRaster::Auto,
        }
    }
}

/// A rendered image with per-pixel AOVs, row-major from the top-left.
#[derive(Debug, Clone)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// sRGB colour, 4 bytes per pixel (alpha 255).
    pub rgba8: Vec<u8>,
    /// World distance from the eye to the hit along the pixel's ray; `+inf` on a miss.
    pub depth: Vec<f32>,
    /// Unit world normal −∇f (pointing out of the solid, to values below the isovalue) as shaded;
    /// NaN on a miss.
    pub normal: Vec<[f32; 3]>,
    /// Cluster index of the hit (global, slot / 16); `u32::MAX` on a miss, 0 for MC hits.
    pub cluster: Vec<u32>,
    pub timings: PassTimings,
    /// Cells fully rasterised in the last frame (both visibility passes; 0 for MC).
    pub drawn_cells: u64,
    /// Probe splats drawn in the last frame.
    pub probed_cells: u64,
    /// [`Mode::PathTrace`]: mean linear RGB radiance per pixel over all accumulated samples (what
    /// `rgba8` encodes as sRGB); empty in other modes.
    pub linear: Vec<[f32; 3]>,
    /// [`Mode::PathTrace`]: samples per pixel accumulated so far for this view; 0 in other modes.
    pub samples: u32,
    /// The raster that drew the cells ([`CellRaster::Auto`] resolved); `None` for the MC mesh.
    pub cell_raster: Option<CellRaster>,
}

impl Frame {
    pub fn is_hit(&self, pixel: usize) -> bool {
        self.cluster[pixel] != u32::MAX
    }
}

impl Renderer {
    /// Renders `frames` frames of one view with default culling; see [`Renderer::render_with`].
    pub fn render(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        frames: u32,
    ) -> Result<Frame, GpuError> {
        self.render_with(
            scene,
            camera,
            mode,
            &RenderOptions {
                frames,
                ..Default::default()
            },
        )
    }

    /// Renders `options.frames` frames of one view and reads back the last one.
    ///
    /// Visibility persists in the [`GpuGrid`] between calls with the same camera, mode and
    /// options; any other view starts from "every cluster visible", so the first frame is complete.
    ///
    /// [`Mode::PathTrace`] uses [`PathTraceOptions::default`] with these frames and culling
    /// options; [`Renderer::path_trace`] takes the others.
    pub fn render_with(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
    ) -> Result<Frame, GpuError> {
        let path_trace = (mode == Mode::PathTrace).then(|| PathTraceOptions {
            frames: options.frames,
            occlusion_culling: options.occlusion_culling,
            backface_culling: options.backface_culling,
            ..Default::default()
        });
        self.render_checked(scene, camera, mode, options, path_trace.as_ref())
    }

    pub(crate) fn render_checked(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
        path_trace: Option<&PathTraceOptions>,
    ) -> Result<Frame, GpuError> {
        camera
            .validate()
            .map_err(|e| GpuError::invalid(e.to_string()))?;
        let max = self.limits.max_texture_dimension_2d;
        if camera.width > max || camera.height > max {
            return Err(GpuError::too_large(format!(
                "image {}x{} exceeds the device's largest texture ({max} per side)",
                camera.width, camera.height
            )));
        }
        let (grid, volume, mesh) = match (mode, scene) {
            (
                Mode::Cgc | Mode::CgcNoEwa | Mode::PathTrace,
                Scene::Grid(g) | Scene::Volume { grid: g, .. },
            ) => (Some(g), None, None),
            (Mode::Cr, Scene::Volume { grid, volume }) => (Some(grid), Some(volume), None),
            (Mode::Mc, Scene::Mesh(m)) => (None, None, Some(m)),
            _ => {
                return Err(GpuError::invalid(format!(
                    "mode {mode:?} needs {}",
                    match mode {
                        Mode::Mc => "an uploaded mesh (Scene::Mesh)",
                        Mode::Cr => "a grid and its volume (Scene::Volume)",
                        _ => "an uploaded grid (Scene::Grid)",
                    }
                )))
            }
        };
        let plan = FramePlan::new((grid, volume, mesh), camera, mode, options, path_trace);
        self.scoped("rendering", || {
            self.render_unscoped(&plan, camera, mode, path_trace)
        })
    }
}

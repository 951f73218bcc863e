//! What a render call is asked for: the [`Mode`], the [`RenderOptions`] with the [`CellRaster`]
//! that draws the cells, and the path tracer's [`PathTraceOptions`] with its [`PrimaryRays`].

use crate::env_map::GpuEnvMap;
use isogrid::{Camera, GridInfo, Progress};

/// What to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
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
    /// samples accumulate while the view rests. See [`crate::Renderer::path_trace`] for the
    /// options, among them tracing the primary rays too ([`PrimaryRays::Traced`]).
    PathTrace,
}

impl Mode {
    /// Every mode, in the order front ends list them.
    pub const ALL: [Mode; 5] = [
        Mode::Cgc,
        Mode::CgcNoEwa,
        Mode::Mc,
        Mode::Cr,
        Mode::PathTrace,
    ];

    /// The name every front end spells it with: `cgc`, `cgc-noewa`, `mc`, `cr` or `pathtrace`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Cgc => "cgc",
            Mode::CgcNoEwa => "cgc-noewa",
            Mode::Mc => "mc",
            Mode::Cr => "cr",
            Mode::PathTrace => "pathtrace",
        }
    }

    /// Needs the original volume (the MC mesh or the CR samples), so a `.cgc` file cannot show it.
    pub fn needs_volume(self) -> bool {
        matches!(self, Mode::Mc | Mode::Cr)
    }
}

impl std::str::FromStr for Mode {
    type Err = isogrid::Error;
    /// [`Mode::name`], any case.
    fn from_str(s: &str) -> isogrid::Result<Self> {
        Mode::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                isogrid::Error::invalid(format!(
                    "mode must be cgc, cgc-noewa, mc, cr or pathtrace, not {s:?}"
                ))
            })
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How to render.
#[derive(Debug, Clone, PartialEq)]
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
    /// Colours the surface by its attribute through this map and range: the grid's cell attribute
    /// ([`crate::GpuGrid::has_attribute`]) or the mesh's vertex values
    /// ([`crate::Renderer::upload_colored_mesh`]); `None` draws the one fixed albedo. The value
    /// each pixel shows is read back as [`crate::Frame::value`]. Not for path tracing.
    pub coloring: Option<isogrid::colormap::Coloring>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            frames: 1,
            occlusion_culling: true,
            backface_culling: true,
            cell_raster: CellRaster::Auto,
            coloring: None,
        }
    }
}

/// Which raster draws the cells of [`Mode::Cgc`], [`Mode::CgcNoEwa`], [`Mode::Cr`] and the
/// primary rays of [`Mode::PathTrace`].
///
/// Both rasters run the same per-pixel test (`shaders/cell_hit.wgsl`) on the same instance lists,
/// so they find the same crossings; they differ in who walks a cell's pixels. The hardware raster
/// draws each cell as a rectangle and lets fragments do it, which is the paper's design (§3.2).
/// The compute raster gives each cell one thread that loops over its rectangle, resolves
/// visibility with an atomic maximum of the reversed-Z depth, and writes the G-buffer in a second
/// pass. The compute raster wins where cells cover few pixels and where the graphics pipeline is
/// weak next to the compute units (datacenter GPUs such as the H100), and loses where cells grow
/// large on screen: one thread then walks many pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum CellRaster {
    /// [`CellRaster::Compute`] unless a cell can cover more than [`MAX_COMPUTE_CELL_PIXELS`]
    /// pixels across in this view (the eye close to or inside the grid), then the hardware one.
    #[default]
    Auto,
    /// Screen rectangles through the graphics pipeline, one fragment per covered pixel (§3.2).
    Hardware,
    /// One compute thread per cell looping over its covered pixels.
    Compute,
}

/// Widest projected cell, in pixels, that [`CellRaster::Auto`] leaves to the compute raster: the
/// thread of such a cell tests up to about this many squared pixels while its neighbours in the
/// warp test a few. A bound, not a tuned optimum: standard views of 128³–512³ grids at 1080p
/// project cells to 1–8 pixels.
pub const MAX_COMPUTE_CELL_PIXELS: f64 = 32.0;

impl CellRaster {
    /// The raster `self` stands for with this camera and grid ([`CellRaster::Auto`] resolved).
    pub fn resolve(self, camera: &Camera, info: &GridInfo) -> CellRaster {
        if self != CellRaster::Auto {
            return self;
        }
        if widest_cell_pixels(camera, info) <= MAX_COMPUTE_CELL_PIXELS {
            CellRaster::Compute
        } else {
            CellRaster::Hardware
        }
    }
}

/// An upper estimate of a cell's projected width in pixels: the cell diagonal seen at the grid
/// box's nearest point, times 2 for the perspective stretch towards the image corners (at most
/// 1 / cos² of the half diagonal field of view, under 2 for fields of view up to 70°).
fn widest_cell_pixels(camera: &Camera, info: &GridInfo) -> f64 {
    let (lo, hi) = info.world_bounds();
    let distance = (0..3)
        .map(|a| (lo[a] - camera.eye[a]).max(camera.eye[a] - hi[a]).max(0.0))
        .map(|d| d * d)
        .sum::<f64>()
        .sqrt();
    let diagonal = info.spacing.iter().map(|s| s * s).sum::<f64>().sqrt();
    let focal_pixels =
        camera.height as f64 / (2.0 * (camera.fovy_degrees.to_radians() * 0.5).tan());
    if distance <= 0.0 {
        return f64::INFINITY;
    }
    2.0 * diagonal * focal_pixels / distance
}

/// Bounces of [`PathTraceOptions::default`] (the paper's Figure 6).
pub const DEFAULT_BOUNCES: u32 = 3;
/// Most bounces a path may take.
pub const MAX_BOUNCES: u32 = 64;

/// Where the path tracer's primary hits come from ([`PathTraceOptions::primary`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum PrimaryRays {
    /// The paper's hybrid (§3.6): the [`Mode::Cgc`] raster passes (cell raster with the
    /// visibility buffer, EWA normals, deferred shading) give the primary hits.
    #[default]
    Raster,
    /// Primary rays from the eye through each pixel centre are traced through the hierarchy like
    /// the secondaries, in the same compute pass, and no raster pass runs: for GPUs whose
    /// graphics pipeline is weak next to their compute (an H100 shades a 1080p full-screen
    /// fragment pass in 1.47 ms but traces 3 bounces of a 512³ grid in about 2 ms), or to path
    /// trace with compute only. Normals are the trilinear gradient's (no EWA smoothing); culling
    /// options do not apply.
    Traced,
}

/// How to path trace ([`crate::Renderer::path_trace`]).
#[derive(Debug, Clone, Copy)]
pub struct PathTraceOptions<'a> {
    /// Frames rendered by this call, each adding one sample per pixel (at least 1).
    pub frames: u32,
    /// Diffuse reflections per path (secondary rays traced); a path that has not escaped to the
    /// environment after them contributes nothing. 0 shows only the directly visible environment.
    pub bounces: u32,
    /// The environment; `None` uses the built-in sky ([`isogrid::env_map::sky`]).
    pub env: Option<&'a GpuEnvMap>,
    /// Lambertian albedo, each component in [0, 1].
    pub albedo: [f32; 3],
    /// Culling of the primary raster passes ([`RenderOptions`]); does not change the image.
    pub occlusion_culling: bool,
    pub backface_culling: bool,
    /// Rasterised (the paper's hybrid, the default) or traced primary rays.
    pub primary: PrimaryRays,
    /// Counts finished frames and is checked before each frame: with it, at most two frames are
    /// in flight and a cancel ends the call within a frame ([`crate::GpuErrorKind::Cancelled`]).
    pub progress: Option<&'a Progress>,
    /// Colours every surface by the grid's attribute through this map and range: the colour is
    /// the albedo at every bounce (`albedo` is then unused), as the CPU path tracer does.
    pub coloring: Option<&'a isogrid::colormap::Coloring>,
}

impl Default for PathTraceOptions<'_> {
    fn default() -> Self {
        PathTraceOptions {
            frames: 1,
            bounces: DEFAULT_BOUNCES,
            env: None,
            albedo: isogrid::shading::ALBEDO,
            occlusion_culling: true,
            backface_culling: true,
            primary: PrimaryRays::Raster,
            progress: None,
            coloring: None,
        }
    }
}

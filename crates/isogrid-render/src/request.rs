//! [`RenderRequest`]: everything a render needs to know, checked from its parts
//! ([`RequestParts`]) before any data is read or any device opened. The CLI, the Python package
//! and the viewer fill the parts from their flags, keywords and widgets.

use crate::environment::{EnvSource, LoadedEnv};
use crate::mode::{cpu_draws, Aov, Backend, Mode, Primary};
use isogrid::LabelSelection;
use isogrid::{Camera, Error, Result};
use isogrid_trace::{Crossing, Traversal};

/// Most pixels an image may have (the CPU tracer's limit, a 16K × 16K image).
pub const MAX_PIXELS: u64 = isogrid_trace::render::MAX_PIXELS;
/// Most frames a GPU render may repeat a view, and most samples per pixel of path tracing.
pub const MAX_FRAMES: u32 = 1 << 20;
/// Most scatterings per path (the GPU path tracer's limit; the CPU one follows it).
pub const MAX_BOUNCES: u32 = isogrid_gpu::MAX_BOUNCES;

/// Host memory per pixel of a render, bytes: the CPU tracer keeps each pixel's primary hit
/// (64), radiance (12), path-tracing sum (24), sRGB (3), depth (4), normal (12) and cluster (4),
/// and a PNG encoder a row-filtered copy (4); the GPU read-back holds RGBA, depth, normal and
/// cluster (24) and their staging copies.
const BYTES_PER_PIXEL: u64 = 128;

/// Where the camera looks from.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraSpec {
    /// A standard view of the grid's box ([`Camera::preset`]): 1 (front) or 2 (oblique).
    View(u8),
    /// The same standard view of the surface's box ([`isogrid::CellGrid::surface_bounds`]: the active
    /// cells', the shown labels' where labels are hidden), so that a small structure fills the
    /// image; the grid's box when the surface is empty.
    SurfaceView(u8),
    /// Eye, target and up as world points, and the vertical field of view in degrees.
    LookAt {
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        fovy_degrees: f64,
    },
}

/// The parts of a request, as front ends collect them; [`RenderRequest::new`] checks them.
#[derive(Debug, Clone)]
pub struct RequestParts {
    pub mode: Mode,
    pub backend: Backend,
    pub camera: CameraSpec,
    /// Width and height in pixels.
    pub size: (u32, u32),
    /// Path tracing only.
    pub environment: EnvSource,
    /// Path tracing: samples per pixel (on the GPU one per frame).
    pub samples: u32,
    /// GPU raster modes: how many times the view is rendered (the visibility buffer converges;
    /// timings are the median over frames after the first).
    pub frames: u32,
    /// Path tracing: scatterings per path.
    pub bounces: u32,
    /// GPU path tracing: where primary hits come from; `None` is the default (raster), and naming
    /// one asks for the GPU.
    pub primary: Option<Primary>,
    /// CPU: how rays find candidate metacells (the same image either way).
    pub traversal: Traversal,
    /// CPU: the crossing solver.
    pub crossing: Crossing,
    /// CPU path tracing: the random seed.
    pub seed: u64,
    /// Per-pixel outputs wanted besides the image (each once).
    pub aovs: Vec<Aov>,
    /// GPU: draw only clusters visible last frame (the visibility buffer of §3.3).
    pub occlusion_culling: bool,
    /// GPU: which raster draws the cells.
    pub cell_raster: isogrid_gpu::CellRaster,
    /// Colour the surface by the grid's attribute; `None`: one colour. Every mode of both
    /// renderers draws it (path tracing with the colour as albedo).
    pub color: Option<ColorSpec>,
    /// A label grid: draw only these labels (`None`: all)...
    pub show: Option<LabelSelection>,
    /// ...except these (`None`: none). Values or ranges naming no label of the grid are refused.
    pub hide: Option<LabelSelection>,
}

/// How a surface is coloured by its grid's attribute.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColorSpec {
    pub map: isogrid::colormap::ColorMap,
    /// The values the map spans; `None`: the attribute's range on the surface.
    pub clim: Option<[f64; 2]>,
}

impl ColorSpec {
    /// How the values of the attribute `info` describes become colours: the map over `clim`, or
    /// over the attribute's range on the surface.
    pub fn coloring(&self, info: &isogrid::AttributeInfo) -> Result<isogrid::colormap::Coloring> {
        let clim = self
            .clim
            .unwrap_or_else(|| isogrid::colormap::Coloring::default_clim(info.range));
        isogrid::colormap::Coloring::new(self.map, clim)
    }
}

impl Default for RequestParts {
    fn default() -> Self {
        RequestParts {
            mode: Mode::Cgc,
            backend: Backend::Auto,
            camera: CameraSpec::View(1),
            size: (1280, 720),
            environment: EnvSource::Sky,
            samples: 16,
            frames: 1,
            bounces: isogrid_gpu::DEFAULT_BOUNCES,
            primary: None,
            traversal: Traversal::default(),
            crossing: Crossing::Samples3,
            seed: 0,
            aovs: Vec::new(),
            occlusion_culling: true,
            cell_raster: isogrid_gpu::CellRaster::Auto,
            color: None,
            show: None,
            hide: None,
        }
    }
}

/// A checked render request: its parts are consistent, the image fits in memory and the
/// environment map (if any) is read. Build with [`RenderRequest::new`]; run with
/// [`crate::render`].
#[derive(Debug, Clone)]
pub struct RenderRequest {
    parts: RequestParts,
    pub(crate) env: LoadedEnv,
}

impl RenderRequest {
    /// Checks `parts` and reads the environment map. Errors are [`isogrid::ErrorKind::InvalidInput`]
    /// (inconsistent parts), `TooLarge` (the image) or the map file's own.
    pub fn new(parts: RequestParts) -> Result<RenderRequest> {
        let (w, h) = parts.size;
        if w == 0 || h == 0 || w as u64 * h as u64 > MAX_PIXELS {
            return Err(Error::invalid(format!(
                "image size {w}x{h} must be positive with at most {MAX_PIXELS} pixels"
            )));
        }
        isogrid::memory::ensure_fits(
            &format!("a {w}x{h} render"),
            w as u64 * h as u64 * BYTES_PER_PIXEL,
        )?;
        match &parts.camera {
            CameraSpec::View(v) | CameraSpec::SurfaceView(v) if !(1..=2).contains(v) => {
                return Err(Error::invalid(format!(
                    "view {v} does not exist: the standard views are 1 (front) and 2 (oblique)"
                )))
            }
            CameraSpec::View(_) | CameraSpec::SurfaceView(_) => {}
            // A look-at camera does not depend on the grid: check it now.
            CameraSpec::LookAt { .. } => {
                parts.camera.resolve(([0.0; 3], [1.0; 3]), None, w, h)?;
            }
        }
        let path_trace = parts.mode == Mode::PathTrace;
        if !(1..=MAX_FRAMES).contains(&parts.frames) {
            return Err(Error::invalid(format!(
                "frames must be 1 to {MAX_FRAMES}, not {}",
                parts.frames
            )));
        }
        if !(1..=MAX_FRAMES).contains(&parts.samples) {
            return Err(Error::invalid(format!(
                "samples per pixel must be 1 to {MAX_FRAMES}, not {}",
                parts.samples
            )));
        }
        if parts.bounces > MAX_BOUNCES {
            return Err(Error::invalid(format!(
                "bounces must be at most {MAX_BOUNCES}, not {}",
                parts.bounces
            )));
        }
        if !path_trace && parts.environment != EnvSource::Sky {
            return Err(Error::invalid(format!(
                "an environment map lights path tracing only, not mode {}",
                parts.mode
            )));
        }
        if let Some(p) = parts.primary {
            if !path_trace {
                return Err(Error::invalid(format!(
                    "primary rays ({}) apply to GPU path tracing only, not to mode {}",
                    p.name(),
                    parts.mode
                )));
            }
            if parts.backend == Backend::Cpu {
                return Err(Error::invalid(format!(
                    "primary rays ({}) apply to GPU path tracing only, not to the CPU backend",
                    p.name()
                )));
            }
        }
        if parts.backend == Backend::Cpu && !cpu_draws(parts.mode) {
            return Err(Error::invalid(format!(
                "mode {} needs the GPU renderer; on the CPU use mode cgc or pathtrace",
                parts.mode
            )));
        }
        if let Some(clim) = parts.color.as_ref().and_then(|c| c.clim) {
            isogrid::colormap::check_clim(clim)?;
        }
        if parts.aovs.contains(&Aov::Value) && parts.primary == Some(Primary::Traced) {
            return Err(Error::invalid(
                "the value AOV of path tracing is read from the raster primaries; drop --primary traced",
            ));
        }
        for (i, aov) in parts.aovs.iter().enumerate() {
            if parts.aovs[..i].contains(aov) {
                return Err(Error::invalid(format!("AOV {} given twice", aov.name())));
            }
        }
        let env = LoadedEnv::load(&parts.environment)?;
        Ok(RenderRequest { parts, env })
    }

    pub fn parts(&self) -> &RequestParts {
        &self.parts
    }
    pub fn mode(&self) -> Mode {
        self.parts.mode
    }
    pub fn backend(&self) -> Backend {
        self.parts.backend
    }
    pub fn width(&self) -> u32 {
        self.parts.size.0
    }
    pub fn height(&self) -> u32 {
        self.parts.size.1
    }

    /// The camera for a grid whose box is `grid_box` and whose surface's is `surface_box` (in
    /// the renderers' frame, index × spacing; `None` for an empty surface): standard views frame
    /// one of the two. `mirrored`: the grid's axes mirror its world
    /// ([`isogrid::GridInfo::mirrors_world`]), and the camera is mirrored so that its image shows
    /// the world as it lies.
    pub fn camera(
        &self,
        grid_box: Box3,
        surface_box: Option<Box3>,
        mirrored: bool,
    ) -> Result<Camera> {
        let (w, h) = self.parts.size;
        let camera = self.parts.camera.resolve(grid_box, surface_box, w, h)?;
        Ok(camera.with_mirror(mirrored))
    }
}

/// A box `(lo, hi)` in the renderers' frame (index × spacing).
pub type Box3 = ([f64; 3], [f64; 3]);

impl CameraSpec {
    /// The camera of a `width × height` image of a grid of box `grid_box` and surface box
    /// `surface_box` ([`RenderRequest::camera`]), checked.
    pub fn resolve(
        &self,
        grid_box: Box3,
        surface_box: Option<Box3>,
        width: u32,
        height: u32,
    ) -> Result<Camera> {
        match *self {
            CameraSpec::View(v) => Camera::preset(v, grid_box.0, grid_box.1, width, height),
            CameraSpec::SurfaceView(v) => {
                let (lo, hi) = surface_box.unwrap_or(grid_box);
                Camera::preset(v, lo, hi, width, height)
            }
            CameraSpec::LookAt {
                eye,
                target,
                up,
                fovy_degrees,
            } => {
                let camera = Camera {
                    eye,
                    target,
                    up,
                    fovy_degrees,
                    width,
                    height,
                    mirrored: false,
                };
                camera.validate()?;
                Ok(camera)
            }
        }
    }
}

//! [`Renderer`]: a headless wgpu device with every pass's pipelines, built once, and the crate's
//! entry points — uploads, one-off and per-view renders, path tracing and ray queries — which hand
//! the work to the modules that do it.

use crate::backends::request_adapter;
use crate::env_map::{upload_env, GpuEnvMap};
use crate::error::{GpuError, GpuErrorKind};
use crate::options::{Mode, PathTraceOptions, RenderOptions};
use crate::output::Frame;
use crate::passes::RasterPasses;
use crate::pathtrace::{trace_ray_batch, RayHit, TracePipelines};
use crate::render::{render, FrameContext};
use crate::targets::{EWA_FORMAT, IDS_FORMAT, SURFACE_FORMAT};
use crate::upload::{GpuGrid, GpuMesh, GpuVolume, GridLayouts, MeshColor, Scene, Uploader};
use crate::view::ViewState;
use crate::wgpu_util::Gpu;
use isogrid::EnvMap;
use isogrid::{Camera, CellGrid, Ray};
use std::sync::{Arc, Mutex};

/// A headless wgpu device with the renderer's pipelines, built once. Uploaded grids, meshes,
/// volumes and environment maps belong to the renderer that uploaded them; what a view keeps
/// between frames is in a [`ViewState`].
pub struct Renderer {
    gpu: Gpu,
    grid_layouts: GridLayouts,
    passes: RasterPasses,
    tracer: TracePipelines,
    /// Bytes of the largest storage buffer binding pages may use.
    page_bytes: u64,
}

impl Renderer {
    /// Opens the default adapter of [`crate::preferred_backends`] headlessly (`WGPU_BACKEND=vulkan|gl|...`
    /// picks the backend) with the adapter's own limits, and builds all pipelines.
    ///
    /// Fails with [`GpuErrorKind::NoAdapter`] when there is no adapter or it cannot run compute
    /// and fragment-storage shaders; callers may fall back to a CPU renderer then.
    pub fn new() -> Result<Renderer, GpuError> {
        let adapter = request_adapter()
            .map_err(|e| GpuError::new(GpuErrorKind::NoAdapter, format!("no GPU adapter: {e}")))?;
        let info = adapter.get_info();
        let needed = wgpu::DownlevelFlags::COMPUTE_SHADERS
            | wgpu::DownlevelFlags::FRAGMENT_WRITABLE_STORAGE
            | wgpu::DownlevelFlags::INDIRECT_EXECUTION;
        if !adapter.get_downlevel_capabilities().flags.contains(needed) {
            return Err(GpuError::new(
                GpuErrorKind::NoAdapter,
                format!(
                    "adapter {} ({:?}) lacks compute shaders, fragment storage writes or indirect draws",
                    info.name, info.backend
                ),
            ));
        }
        for format in [SURFACE_FORMAT, IDS_FORMAT, EWA_FORMAT] {
            let usages = adapter.get_texture_format_features(format).allowed_usages;
            if !usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT) {
                return Err(GpuError::new(
                    GpuErrorKind::NoAdapter,
                    format!(
                        "adapter {} ({:?}) cannot render to {format:?} targets",
                        info.name, info.backend
                    ),
                ));
            }
        }
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        // Optional: timestamps for pass timings; early depth tests in spite of the cell raster's
        // depth writes (conservative depth, see `passes/cell_raster.rs`).
        let features = adapter.features()
            & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SHADER_EARLY_DEPTH_TEST);
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("isogrid-gpu device"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::device(format!("cannot open {}: {e}", info.name)))?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let grid_layouts = GridLayouts::new(&device);
        let passes = RasterPasses::new(&device, &grid_layouts);
        let tracer = TracePipelines::new(&device);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::device(format!("building pipelines: {e}")));
        }
        let gpu = Gpu {
            device,
            queue,
            info,
            limits,
            timestamps,
            uncaptured,
        };
        Ok(Renderer {
            page_bytes: gpu.binding_limit(),
            gpu,
            grid_layouts,
            passes,
            tracer,
        })
    }

    /// Adapter name and backend, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub fn adapter_info(&self) -> String {
        format!("{} ({:?})", self.gpu.info.name, self.gpu.info.backend)
    }

    /// Whether pass timings are measured (the adapter supports timestamp queries).
    pub fn has_timestamps(&self) -> bool {
        self.gpu.timestamps
    }

    /// Caps the bytes per storage binding below the device limit, so that tests can exercise
    /// paging with small structures. Only affects later uploads.
    #[doc(hidden)]
    pub fn set_page_bytes(&mut self, bytes: u64) {
        self.page_bytes = bytes.clamp(256, self.gpu.binding_limit());
    }

    fn uploader(&self) -> Uploader<'_> {
        Uploader {
            gpu: &self.gpu,
            layouts: &self.grid_layouts,
            page_bytes: self.page_bytes,
        }
    }

    /// Uploads blocks, metacell slots and corner records, split into pages when they exceed one
    /// storage binding, with the cell attribute when the grid has one (2 bytes per active cell,
    /// after the records of each page, so an attribute is paged like the cells).
    pub fn upload_grid(&self, grid: &CellGrid) -> Result<GpuGrid, GpuError> {
        self.uploader().upload_grid(grid)
    }

    /// Uploads an MC mesh as snorm16 positions scaled by its bounds and u32 indices (paper Table 3).
    pub fn upload_mesh(&self, mesh: &isogrid::mc::McMesh) -> Result<GpuMesh, GpuError> {
        self.uploader().upload_mesh(mesh, MeshColor::None)
    }

    /// Uploads an MC mesh with one attribute value per vertex (4 bytes each), which renders with
    /// [`crate::RenderOptions::coloring`] draw through a colour map, interpolated across triangles.
    pub fn upload_colored_mesh(
        &self,
        mesh: &isogrid::mc::McMesh,
        values: &[f32],
    ) -> Result<GpuMesh, GpuError> {
        self.uploader().upload_mesh(mesh, MeshColor::Values(values))
    }

    /// Uploads a label mesh of a grid of `spacing` (positions index × spacing): `vertex_labels`
    /// gives each vertex's label as an index in `table` (all three of a triangle the same), and
    /// `values`, where given, an attribute value per vertex (4 more bytes each). Renders draw
    /// each label in its colour, or with [`crate::RenderOptions::coloring`] its values through
    /// the colour map, and their cluster AOV gives the label's index under each pixel.
    pub fn upload_label_mesh(
        &self,
        mesh: &isogrid::mc::McMesh,
        vertex_labels: &[u32],
        table: &[isogrid::labels::Label],
        spacing: [f64; 3],
        values: Option<&[f32]>,
    ) -> Result<GpuMesh, GpuError> {
        self.uploader().upload_mesh(
            mesh,
            MeshColor::Labels {
                vertex_labels,
                table,
                spacing,
                values,
            },
        )
    }

    /// Uploads the original samples (as f32 data values) for the CR baseline; `grid` must have
    /// been extracted from this volume.
    pub fn upload_volume(
        &self,
        volume: &isogrid::VolumeView,
        grid: &GpuGrid,
    ) -> Result<GpuVolume, GpuError> {
        self.uploader().upload_volume(volume, grid)
    }

    /// Uploads an environment map for [`PathTraceOptions::env`].
    pub fn upload_env(&self, env: &EnvMap) -> Result<GpuEnvMap, GpuError> {
        upload_env(&self.gpu, env)
    }

    fn frame_context(&self) -> FrameContext<'_> {
        FrameContext {
            gpu: &self.gpu,
            passes: &self.passes,
            tracer: &self.tracer,
        }
    }

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

    /// Renders `options.frames` frames of one view, starting afresh (every cluster visible in
    /// the first frame, no accumulated samples), and reads back the last one. To keep the
    /// visibility buffer and path-traced samples from one call to the next, as an interactive
    /// view does, use [`Renderer::render_view`].
    pub fn render_with(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
    ) -> Result<Frame, GpuError> {
        self.render_view(&mut ViewState::new(), scene, camera, mode, options)
    }

    /// Renders `options.frames` frames of one view with `view`'s state and reads back the last
    /// one.
    ///
    /// Visibility persists in `view` between calls with the same grid, camera, mode and options;
    /// any other starts from "every cluster visible", so the first frame is complete. One
    /// uploaded grid may be drawn by any number of views, each with its own [`ViewState`].
    ///
    /// [`Mode::PathTrace`] uses [`PathTraceOptions::default`] with these frames and culling
    /// options; [`Renderer::path_trace_view`] takes the others.
    pub fn render_view(
        &self,
        view: &mut ViewState,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
    ) -> Result<Frame, GpuError> {
        let path_trace = (mode == Mode::PathTrace).then(|| PathTraceOptions {
            frames: options.frames,
            occlusion_culling: options.occlusion_culling,
            backface_culling: options.backface_culling,
            coloring: options.coloring.as_ref(),
            ..Default::default()
        });
        let ctx = self.frame_context();
        render(
            &ctx,
            view,
            scene,
            camera,
            mode,
            options,
            path_trace.as_ref(),
        )
    }

    /// Path traces `options.frames` frames of one view, starting afresh, and reads back the mean
    /// of their samples; see [`Renderer::path_trace_view`], which keeps accumulating over calls.
    pub fn path_trace(
        &self,
        grid: &GpuGrid,
        camera: &Camera,
        options: &PathTraceOptions<'_>,
    ) -> Result<Frame, GpuError> {
        self.path_trace_view(&mut ViewState::new(), grid, camera, options)
    }

    /// Path traces `options.frames` frames of one view (hybrid: raster primaries, traced
    /// secondaries; or everything traced with [`crate::PrimaryRays::Traced`], which records only
    /// the trace pass) and reads back the accumulated image: `rgba8` is the sRGB mean, `linear`
    /// the linear mean and `samples` the samples per pixel so far. The depth, normal and cluster
    /// AOVs are the primary hits. Calls with the same `view`, grid, camera, bounces, albedo,
    /// environment and primary rays keep accumulating; anything else starts afresh.
    ///
    /// Grids split into several pages (larger than one storage binding) are traced with up to
    /// six pages bound at once, and grids of more pages in passes over groups of six (see
    /// [`Renderer::trace_rays`]).
    pub fn path_trace_view(
        &self,
        view: &mut ViewState,
        grid: &GpuGrid,
        camera: &Camera,
        options: &PathTraceOptions<'_>,
    ) -> Result<Frame, GpuError> {
        // The raster primaries are shaded in colour too: their value is where paths start.
        let raster = RenderOptions {
            frames: options.frames,
            occlusion_culling: options.occlusion_culling,
            backface_culling: options.backface_culling,
            coloring: options.coloring.cloned(),
            ..Default::default()
        };
        let ctx = self.frame_context();
        render(
            &ctx,
            view,
            Scene::Grid(grid),
            camera,
            Mode::PathTrace,
            &raster,
            Some(options),
        )
    }

    /// Traces world-space rays (any non-zero direction length; t is measured along the unit
    /// direction from t = 0) through the grid's hierarchy on the GPU and returns the nearest
    /// isosurface crossing of each, as the path tracer's secondary rays find them.
    ///
    /// A grid split into pages (larger than one storage binding) is traced with groups of up to
    /// six pages bound at once, one pass per group, each keeping the nearer crossing: any number
    /// of pages gives the hits of a one-page trace. Paged grids need at least 15 storage buffers
    /// per shader stage; a device with fewer makes this and [`Renderer::path_trace`] fail with
    /// [`GpuErrorKind::TooLarge`] naming the numbers.
    pub fn trace_rays(
        &self,
        grid: &GpuGrid,
        rays: &[Ray],
    ) -> Result<Vec<Option<RayHit>>, GpuError> {
        trace_ray_batch(&self.gpu, &self.tracer, grid, rays)
    }
}

//! Hybrid path tracing of clustered grid cells (paper §3.6, Figure 6): primary hits come from the
//! cell raster's G-buffer ([`crate::Mode::Cgc`] passes, EWA normals), secondary rays are traced in
//! a compute pass through blocks → occupied metacells → cells (`shaders/trace.wgsl`), with
//! Lambertian bounces, cosine-weighted sampling and an HDR environment (`shaders/pathtrace.wgsl`).
//!
//! # Traced primary rays
//!
//! [`PrimaryRays::Traced`] traces the primary rays too, from the eye through each pixel centre,
//! with the same `trace_ray` as the secondaries, in the same compute pass
//! (`path_trace_traced_primary`): no raster, EWA, culling or shading pass runs. It exists because
//! some GPUs' graphics pipelines are slow next to their compute: on an NVIDIA H100 a full-screen
//! fragment pass at 1080p took 1.47 ms and the raster passes of a 512³ grid about 12 ms, while
//! the 3 traced bounces took about 2 ms (docs/benchmarks-gpu.md). It also makes a path tracer
//! that needs compute only. The pass writes the primary hit (normal, eye distance, cluster) into
//! the G-buffer targets as storage textures, so the frame's AOVs read back as in the hybrid.
//! Primary normals are then the trilinear gradient, not the EWA-smoothed ones, so the two modes
//! converge to slightly different images and each keeps its own accumulation.
//!
//! One sample per pixel per frame; samples accumulate in a per-pixel `vec4<f32>` sum (the
//! Rgba32Float texel layout) kept with the [`GpuGrid`] and reset whenever the view, bounces,
//! albedo or environment change. World space and rays are `isogrid::camera`'s; the environment's
//! up is world +y (the camera presets' up).
//!
//! # Grids larger than one storage binding
//!
//! Uploads split a grid into pages of whole clusters, each with its own metacell-slot and
//! corner-record buffers (`upload.rs`). The raster passes draw page by page, but a traced ray may
//! need any cluster, so the tracer binds all pages of the grid at once: up to [`TRACE_PAGES`] (6)
//! pairs of bindings plus a small page table (first global slot and record of each page,
//! `TracePages`), read through `slot_word` / `record_word` in `shaders/trace_pages.wgsl`, which
//! switch on the page index because WGSL cannot index an array of bindings without binding
//! arrays (not available on every backend). A 16³ block's clusters may straddle a page boundary,
//! so the page is looked up per cluster (a scan of at most six table entries, cheap next to the
//! cluster's 15 metacells), and hits remember their page.
//!
//! Why this rather than several dispatches, one per group of pages: the path tracer follows each
//! path through several bounces inside one dispatch, so splitting the grid over dispatches would
//! need a wavefront tracer (ray state in buffers, one dispatch per bounce and page group). Six
//! pages keep 15 storage buffers per shader stage (12 for pages, blocks, and the rays and hits or
//! the accumulation), within the 16 that GL and most devices offer; six bindings of 128 MiB
//! (lavapipe; 2–4 GiB on discrete GPUs) hold grids of several hundred MB and more. A grid of
//! more pages, or a device with fewer storage buffers per stage, gets a `TooLarge` error naming
//! the numbers and can still be rasterised.
//!
//! One-page grids (the common case) keep their own pipelines compiled over `cell_data.wgsl`,
//! where the page lookup is the constant 0 and every read is a plain array access, exactly the
//! code before paging; the several-pages pipelines are compiled on first use. Measured on
//! lavapipe (100k random rays in a 96³ gyroid, old and new renderer interleaved in one process):
//! one page traces as fast as before paging (1.96 s vs 1.95 s best of 12); the same grid in six
//! pages gives bit-identical hits but takes about 5× as long, because a CPU SIMD driver runs
//! every case of the per-read `switch` under a lane mask. On a GPU only the lanes of a warp that
//! read different pages diverge. Binding arrays (`metacells[page][i]`, a native-only wgpu
//! feature) would remove the switch where available; not done.

use crate::error::GpuError;
use crate::gpu_types::{FrameUniforms, TracePages, TraceUniforms, SOURCE_RECORDS, TRACE_PAGES};
use crate::pipelines::{
    compute, layout, module, pipeline_layout, storage, texture, uniform, CELL_DATA, COLOR_FORMAT,
    COMMON, D2, FINAL_FORMAT, FLOAT, IDS_FORMAT, TRACE_PAGES_DATA,
};
use crate::render::{buffer_entry, dispatch_size, texture_entry, Frame};
use crate::upload::GpuGrid;
use crate::Renderer;
use isogrid::{Camera, Ray};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use wgpu::util::DeviceExt;

/// Bounces of [`PathTraceOptions::default`] (the paper's Figure 6).
pub const DEFAULT_BOUNCES: u32 = 3;
/// Most bounces a path may take.
pub const MAX_BOUNCES: u32 = 64;
/// Secondary rays start this far (in cells of the smallest spacing) off the surface along the
/// normal, well above the raster's and the tracer's crossing error (≈ 1e-4 cell after bisection).
const RAY_OFFSET_CELLS: f64 = 2e-3;

/// An equirectangular HDR environment: linear RGB radiance, `width × height` texels, row-major
/// from the top. Texel (x, y) is centred on the direction with φ = 2π(x + ½)/width − π and
/// θ = π(y + ½)/height: `(sin θ cos φ, cos θ, sin θ sin φ)`, so row 0 is world +y (up) and the
/// middle of the image looks along −x. Lookups interpolate bilinearly between texel centres,
/// wrapping in φ.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvMap {
    width: u32,
    height: u32,
    rgb: Vec<f32>,
}

impl EnvMap {
    /// `rgb` holds `width · height · 3` finite, non-negative values.
    pub fn new(width: u32, height: u32, rgb: Vec<f32>) -> Result<EnvMap, GpuError> {
        let texels = width as u64 * height as u64;
        if texels == 0 || rgb.len() as u64 != 3 * texels {
            return Err(GpuError::invalid(format!(
                "environment map of {width}x{height} texels needs {} floats, got {}",
                3 * texels,
                rgb.len()
            )));
        }
        if let Some(bad) = rgb.iter().find(|v| !v.is_finite() || **v < 0.0) {
            return Err(GpuError::invalid(format!(
                "environment radiance must be finite and non-negative, found {bad}"
            )));
        }
        Ok(EnvMap { width, height, rgb })
    }

    /// The same radiance from every direction (a 1×1 map).
    pub fn constant(rgb: [f32; 3]) -> Result<EnvMap, GpuError> {
        EnvMap::new(1, 1, rgb.to_vec())
    }

    /// A map whose texels hold `radiance(direction)` at their centre directions.
    pub fn from_fn(
        width: u32,
        height: u32,
        radiance: impl Fn([f32; 3]) -> [f32; 3],
    ) -> Result<EnvMap, GpuError> {
        let mut rgb = Vec::with_capacity(3 * width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                rgb.extend_from_slice(&radiance(Self::texel_direction(width, height, x, y)));
            }
        }
        EnvMap::new(width, height, rgb)
    }

    /// Unit world direction at the centre of texel (x, y).
    pub fn texel_direction(width: u32, height: u32, x: u32, y: u32) -> [f32; 3] {
        let phi = std::f64::consts::TAU * (x as f64 + 0.5) / width as f64 - std::f64::consts::PI;
        let theta = std::f64::consts::PI * (y as f64 + 0.5) / height as f64;
        [
            (theta.sin() * phi.cos()) as f32,
            theta.cos() as f32,
            (theta.sin() * phi.sin()) as f32,
        ]
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    pub fn rgb(&self) -> &[f32] {
        &self.rgb
    }
}

/// An [`EnvMap`] resident on the GPU (`Rgba32Float` texture).
#[derive(Debug)]
pub struct GpuEnvMap {
    view: wgpu::TextureView,
    /// Identifies the map in the accumulation key: another map restarts accumulation.
    id: u64,
}

// The built-in sky; keep in sync with `sky` in shaders/pathtrace.wgsl.
const SKY_ZENITH: [f32; 3] = [0.20, 0.40, 0.90];
const SKY_HORIZON: [f32; 3] = [0.85, 0.90, 1.00];
const SKY_GROUND: [f32; 3] = [0.30, 0.27, 0.24];
const SUN_DIR: [f32; 3] = [-0.35, 0.80, 0.50];
const SUN_RADIANCE: [f32; 3] = [12.0, 11.0, 9.5];
const SUN_EXPONENT: f32 = 64.0;

/// Linear RGB radiance of the built-in sky (used when no [`EnvMap`] is given) from unit world
/// direction `d`: with `y = d[1]` (world +y is up), `mix(HORIZON, ZENITH, √y)` above the horizon,
/// `mix(HORIZON, GROUND, √−y)` below, plus a sun lobe `SUN · max(d·s, 0)^64` around
/// `s = normalize(−0.35, 0.80, 0.50)`, where ZENITH = (0.20, 0.40, 0.90), HORIZON = (0.85, 0.90,
/// 1.00), GROUND = (0.30, 0.27, 0.24) and SUN = (12.0, 11.0, 9.5).
pub fn sky_radiance(d: [f32; 3]) -> [f32; 3] {
    let (far, t) = if d[1] >= 0.0 {
        (SKY_ZENITH, d[1].sqrt())
    } else {
        (SKY_GROUND, (-d[1]).sqrt())
    };
    let len = SUN_DIR.iter().map(|v| v * v).sum::<f32>().sqrt();
    let cos = (0..3)
        .map(|a| d[a] * SUN_DIR[a] / len)
        .sum::<f32>()
        .max(0.0);
    let sun = cos.powf(SUN_EXPONENT);
    std::array::from_fn(|a| SKY_HORIZON[a] + (far[a] - SKY_HORIZON[a]) * t + SUN_RADIANCE[a] * sun)
}

/// Where the path tracer's primary hits come from ([`PathTraceOptions::primary`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum PrimaryRays {
    /// The paper's hybrid (§3.6): the [`crate::Mode::Cgc`] raster passes (cell raster with the
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

/// How to path trace ([`Renderer::path_trace`]).
#[derive(Debug, Clone, Copy)]
pub struct PathTraceOptions<'a> {
    /// Frames rendered by this call, each adding one sample per pixel (at least 1).
    pub frames: u32,
    /// Diffuse reflections per path (secondary rays traced); a path that has not escaped to the
    /// environment after them contributes nothing. 0 shows only the directly visible environment.
    pub bounces: u32,
    /// The environment; `None` uses the built-in sky ([`sky_radiance`]).
    pub env: Option<&'a GpuEnvMap>,
    /// Lambertian albedo, each component in [0, 1].
    pub albedo: [f32; 3],
    /// Culling of the primary raster passes ([`crate::RenderOptions`]); does not change the image.
    pub occlusion_culling: bool,
    pub backface_culling: bool,
    /// Rasterised (the paper's hybrid, the default) or traced primary rays.
    pub primary: PrimaryRays,
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
        }
    }
}

/// The nearest crossing of a ray with the isosurface ([`Renderer::trace_rays`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// World distance along the unit ray direction.
    pub t: f32,
    /// Unit world normal −∇f of the stored trilinear field (out of the solid).
    pub normal: [f32; 3],
}

/// The trace entry points compiled against one way of binding the grid's cells.
#[derive(Clone)]
pub(crate) struct TraceEntryPoints {
    path_trace: wgpu::ComputePipeline,
    trace_rays: wgpu::ComputePipeline,
    /// `path_trace_traced_primary`, compiled on first use: most renderers never trace primary
    /// rays, and each compile of the tracer slows the renderer's start.
    traced_primary: Arc<OnceLock<wgpu::ComputePipeline>>,
    shader: wgpu::ShaderModule,
    traced_primary_layout: wgpu::PipelineLayout,
}

impl TraceEntryPoints {
    fn traced_primary(&self, device: &wgpu::Device) -> wgpu::ComputePipeline {
        self.traced_primary
            .get_or_init(|| {
                compute(
                    device,
                    "path trace, traced primaries",
                    &self.traced_primary_layout,
                    &self.shader,
                    "path_trace_traced_primary",
                )
            })
            .clone()
    }
}

/// The several-pages variant: its group 1 layout (page table, then [`TRACE_PAGES`] metacell and
/// [`TRACE_PAGES`] record bindings) and pipelines.
struct PagedTrace {
    pages: wgpu::BindGroupLayout,
    entry: TraceEntryPoints,
}

/// Layouts and pipelines of the trace passes: the one-page variant built with the renderer, the
/// several-pages one on the first trace of a paged grid (most grids fit one page, and compiling
/// the tracer again would slow every renderer's start).
pub(crate) struct TracePipelines {
    grid: wgpu::BindGroupLayout,
    page: wgpu::BindGroupLayout,
    path_io: wgpu::BindGroupLayout,
    traced_primary_io: wgpu::BindGroupLayout,
    ray_io: wgpu::BindGroupLayout,
    one_page: TraceEntryPoints,
    paged: OnceLock<PagedTrace>,
}

impl TracePipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let c = wgpu::ShaderStages::COMPUTE;
        // Group 0: frame uniforms, trace uniforms, blocks.
        let grid = layout(
            device,
            "trace grid",
            &[uniform(0, c), uniform(1, c), storage(3, c, true)],
        );
        // Group 1: the (single) page's uniforms, metacell slots and corner records.
        let page = layout(
            device,
            "trace page",
            &[uniform(0, c), storage(1, c, true), storage(2, c, true)],
        );
        // The G-buffer (read, raster primaries; or written, traced primaries), accumulation,
        // output and environment.
        let path_io = layout(
            device,
            "path trace io",
            &[
                texture(0, c, FLOAT, D2),
                storage(1, c, false),
                written_texture(2, COLOR_FORMAT),
                texture(3, c, FLOAT, D2),
            ],
        );
        let traced_primary_io = layout(
            device,
            "path trace io (traced primaries)",
            &[
                storage(1, c, false),
                written_texture(2, COLOR_FORMAT),
                texture(3, c, FLOAT, D2),
                written_texture(6, FINAL_FORMAT),
                written_texture(7, IDS_FORMAT),
            ],
        );
        let ray_io = layout(
            device,
            "trace rays io",
            &[storage(4, c, true), storage(5, c, false)],
        );
        let one_page = entry_points(
            device,
            "one page",
            CELL_DATA,
            [&grid, &page, &path_io, &traced_primary_io, &ray_io],
        );
        TracePipelines {
            one_page,
            grid,
            page,
            path_io,
            traced_primary_io,
            ray_io,
            paged: OnceLock::new(),
        }
    }

    /// The several-pages variant, compiled on first use.
    fn paged(&self, device: &wgpu::Device) -> &PagedTrace {
        self.paged.get_or_init(|| {
            let c = wgpu::ShaderStages::COMPUTE;
            // Binding 0: the page table; 1 + p: page p's metacell slots; 1 + TRACE_PAGES + p: its
            // corner records (as trace_pages.wgsl declares them).
            let mut entries = vec![uniform(0, c)];
            entries.extend((1..=2 * TRACE_PAGES as u32).map(|b| storage(b, c, true)));
            let pages = layout(device, "trace pages", &entries);
            let entry = entry_points(
                device,
                "several pages",
                TRACE_PAGES_DATA,
                [
                    &self.grid,
                    &pages,
                    &self.path_io,
                    &self.traced_primary_io,
                    &self.ray_io,
                ],
            );
            PagedTrace { pages, entry }
        })
    }
}

/// A write-only storage texture of the compute stage.
fn written_texture(binding: u32, format: wgpu::TextureFormat) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format,
            view_dimension: D2,
        },
        count: None,
    }
}

/// Compiles trace.wgsl + pathtrace.wgsl over `cell_storage` (the cell decoding and the page
/// bindings it reads) with layouts [grid, pages, path trace io, traced primaries io, trace rays
/// io]; the traced-primaries entry point only on first use.
fn entry_points(
    device: &wgpu::Device,
    variant: &str,
    cell_storage: &str,
    [grid, pages, path_io, traced_primary_io, ray_io]: [&wgpu::BindGroupLayout; 5],
) -> TraceEntryPoints {
    let shader = module(
        device,
        &format!("trace.wgsl + pathtrace.wgsl ({variant})"),
        &[
            COMMON,
            cell_storage,
            include_str!("../shaders/trace.wgsl"),
            include_str!("../shaders/pathtrace.wgsl"),
        ],
    );
    let path_layout = pipeline_layout(
        device,
        &format!("path trace ({variant})"),
        &[grid, pages, path_io],
    );
    let rays_layout = pipeline_layout(
        device,
        &format!("trace rays ({variant})"),
        &[grid, pages, ray_io],
    );
    TraceEntryPoints {
        path_trace: compute(
            device,
            &format!("path trace ({variant})"),
            &path_layout,
            &shader,
            "path_trace",
        ),
        trace_rays: compute(
            device,
            &format!("trace rays ({variant})"),
            &rays_layout,
            &shader,
            "trace_rays",
        ),
        traced_primary: Arc::default(),
        traced_primary_layout: pipeline_layout(
            device,
            &format!("path trace, traced primaries ({variant})"),
            &[grid, pages, traced_primary_io],
        ),
        shader,
    }
}

/// How one trace call binds the grid: groups 0 (uniforms, blocks) and 1 (the pages), and the
/// pipelines compiled for that binding.
struct TraceBinding {
    groups: [wgpu::BindGroup; 2],
    entry: TraceEntryPoints,
}

/// Running per-pixel sums of one view.
pub(crate) struct Accumulation {
    key: String,
    sum: wgpu::Buffer,
    samples: u32,
}

/// Everything one path-traced render call needs, prepared before its frames.
pub(crate) struct PathTracePass {
    uniforms: wgpu::Buffer,
    base: TraceUniforms,
    groups: [wgpu::BindGroup; 3],
    pipeline: wgpu::ComputePipeline,
    sum: wgpu::Buffer,
    readback: wgpu::Buffer,
    first_sample: u32,
    size: (u32, u32),
}

static NEXT_ENV_ID: AtomicU64 = AtomicU64::new(1);

impl Renderer {
    /// Uploads an environment map for [`PathTraceOptions::env`].
    pub fn upload_env(&self, env: &EnvMap) -> Result<GpuEnvMap, GpuError> {
        let max = self.limits.max_texture_dimension_2d;
        if env.width > max || env.height > max {
            return Err(GpuError::too_large(format!(
                "environment map {}x{} exceeds the device's largest texture ({max} per side)",
                env.width, env.height
            )));
        }
        self.scoped("uploading the environment map", || {
            let rgba: Vec<f32> = env
                .rgb
                .chunks_exact(3)
                .flat_map(|c| [c[0], c[1], c[2], 0.0])
                .collect();
            Ok(GpuEnvMap {
                view: self.float_texture("environment map", env.width, env.height, &rgba),
                id: NEXT_ENV_ID.fetch_add(1, Ordering::Relaxed),
            })
        })
    }

    fn float_texture(
        &self,
        label: &str,
        width: u32,
        height: u32,
        rgba: &[f32],
    ) -> wgpu::TextureView {
        self.device
            .create_texture_with_data(
                &self.queue,
                &wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(rgba),
            )
            .create_view(&wgpu::TextureViewDescriptor::default())
    }

    /// Path traces `options.frames` frames of one view (hybrid: raster primaries, traced
    /// secondaries; or everything traced with [`PrimaryRays::Traced`], which records only the
    /// trace pass) and reads back the accumulated image: `rgba8` is the sRGB mean, `linear` the
    /// linear mean and `samples` the samples per pixel so far. The depth, normal and cluster AOVs
    /// are the primary hits. Calls with the same camera, bounces, albedo, environment and
    /// primary rays keep accumulating; anything else starts afresh.
    ///
    /// Grids split into several pages (larger than one storage binding) are traced with up to
    /// six pages bound at once; a grid of more pages fails with
    /// [`crate::GpuErrorKind::TooLarge`] (see [`Renderer::trace_rays`]).
    pub fn path_trace(
        &self,
        grid: &GpuGrid,
        camera: &Camera,
        options: &PathTraceOptions<'_>,
    ) -> Result<Frame, GpuError> {
        let raster = crate::RenderOptions {
            frames: options.frames,
            occlusion_culling: options.occlusion_culling,
            backface_culling: options.backface_culling,
            ..Default::default()
        };
        self.render_checked(
            crate::Scene::Grid(grid),
            camera,
            crate::Mode::PathTrace,
            &raster,
            Some(options),
        )
    }

    /// Traces world-space rays (any non-zero direction length; t is measured along the unit
    /// direction from t = 0) through the grid's hierarchy on the GPU and returns the nearest
    /// isosurface crossing of each, as the path tracer's secondary rays find them.
    ///
    /// A grid split into pages (larger than one storage binding) is traced with all its pages
    /// bound at once, which works for up to six pages and on devices with at least 15 storage
    /// buffers per shader stage; otherwise this and [`Renderer::path_trace`] fail with
    /// [`crate::GpuErrorKind::TooLarge`] naming the numbers.
    pub fn trace_rays(
        &self,
        grid: &GpuGrid,
        rays: &[Ray],
    ) -> Result<Vec<Option<RayHit>>, GpuError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let mut packed = Vec::with_capacity(rays.len() * 8);
        for (i, ray) in rays.iter().enumerate() {
            let len = ray.direction.iter().map(|v| v * v).sum::<f64>().sqrt();
            let finite = ray
                .origin
                .iter()
                .chain(&ray.direction)
                .all(|v| v.is_finite());
            if !finite || !len.is_finite() || len == 0.0 {
                return Err(GpuError::invalid(format!(
                    "ray {i} has a non-finite origin or a zero or non-finite direction"
                )));
            }
            packed.extend(ray.origin.map(|v| v as f32));
            packed.push(0.0);
            packed.extend(ray.direction.map(|v| (v / len) as f32));
            packed.push(f32::MAX);
        }
        let ray_bytes = packed.len() as u64 * 4;
        if ray_bytes > self.binding_limit() {
            return Err(GpuError::too_large(format!(
                "{} rays need {ray_bytes} bytes, more than one storage binding holds ({} bytes)",
                rays.len(),
                self.binding_limit()
            )));
        }
        self.scoped("tracing rays", || {
            let frame = FrameUniforms {
                eye: [0.0; 4],
                right: [1.0, 0.0, 0.0, 1.0],
                up: [0.0, 1.0, 0.0, 1.0],
                forward: [0.0, 0.0, -1.0, 0.0],
                viewport: [1.0; 4],
                cell_to_world: spacing_and_iso(grid),
                params: [grid.info.precision.bits(), SOURCE_RECORDS, 0, 0],
            };
            let frame = self.uniform_buffer("trace frame uniforms", bytemuck::bytes_of(&frame));
            let mut uniforms = self.trace_uniforms(grid, 0, [0.0; 3]);
            uniforms.sample[2] = rays.len() as u32;
            let uniforms = self.uniform_buffer("trace uniforms", bytemuck::bytes_of(&uniforms));
            let binding = self.trace_binding(grid, &frame, &uniforms)?;
            let storage = wgpu::BufferUsages::STORAGE;
            let ray_buffer = self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("rays"),
                    contents: bytemuck::cast_slice(&packed),
                    usage: storage,
                });
            let hit_bytes = ray_bytes / 2;
            let hits = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ray hits"),
                size: hit_bytes,
                usage: storage | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let readback = self.readback_buffer("ray hits readback", hit_bytes);
            let io = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("trace rays io"),
                layout: &self.pipelines.trace.ray_io,
                entries: &[buffer_entry(4, &ray_buffer), buffer_entry(5, &hits)],
            });
            let mut encoder = self
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("trace rays"),
                });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("trace rays"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&binding.entry.trace_rays);
                pass.set_bind_group(0, &binding.groups[0], &[]);
                pass.set_bind_group(1, &binding.groups[1], &[]);
                pass.set_bind_group(2, &io, &[]);
                let (x, y) = dispatch_size(rays.len() as u32);
                pass.dispatch_workgroups(x, y, 1);
            }
            encoder.copy_buffer_to_buffer(&hits, 0, &readback, 0, hit_bytes);
            self.queue.submit([encoder.finish()]);
            let hits: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&self.read_buffer(&readback)?);
            Ok(hits
                .iter()
                .map(|h| {
                    (h[3] < 1e38).then_some(RayHit {
                        t: h[3],
                        normal: [h[0], h[1], h[2]],
                    })
                })
                .collect())
        })
    }

    fn uniform_buffer(&self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
    }

    fn readback_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn trace_uniforms(&self, grid: &GpuGrid, bounces: u32, albedo: [f32; 3]) -> TraceUniforms {
        let info = &grid.info;
        let blocks = if grid.blocks.is_some() {
            info.block_dims()
        } else {
            [0; 3]
        };
        let cells = info.cell_dims();
        let offset = RAY_OFFSET_CELLS * info.spacing.iter().cloned().fold(f64::INFINITY, f64::min);
        TraceUniforms {
            block_dims: [blocks[0], blocks[1], blocks[2], bounces],
            cell_dims: [
                cells[0] as f32,
                cells[1] as f32,
                cells[2] as f32,
                offset as f32,
            ],
            albedo: [albedo[0], albedo[1], albedo[2], 0.0],
            sample: [0; 4],
        }
    }

    /// The device's largest storage binding: the limit for buffers that are not grid pages (the
    /// test hook `set_page_bytes` shrinks only pages).
    fn binding_limit(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Bind groups 0 (uniforms, blocks) and 1 (the pages) of the trace passes and the pipelines
    /// for them: a grid of one page (or none) binds it as the raster passes do; a paged grid binds
    /// all its pages at once with a page table (`shaders/trace_pages.wgsl`). A grid without
    /// blocks or pages binds small dummies that the shader never reads (it sees no blocks).
    fn trace_binding(
        &self,
        grid: &GpuGrid,
        frame: &wgpu::Buffer,
        uniforms: &wgpu::Buffer,
    ) -> Result<TraceBinding, GpuError> {
        let dummy = || {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("unused trace data"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::UNIFORM,
                mapped_at_creation: false,
            })
        };
        let t = &self.pipelines.trace;
        let blocks = grid.blocks.clone().unwrap_or_else(dummy);
        let group0 = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace grid"),
            layout: &t.grid,
            entries: &[
                buffer_entry(0, frame),
                buffer_entry(1, uniforms),
                buffer_entry(3, &blocks),
            ],
        });
        if grid.pages.len() <= 1 {
            let (page_uniforms, metacells, cells) = match grid.pages.first() {
                Some(p) => (p.uniforms.clone(), p.metacells.clone(), p.cells.clone()),
                None => (dummy(), dummy(), dummy()),
            };
            let group1 = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("trace page"),
                layout: &t.page,
                entries: &[
                    buffer_entry(0, &page_uniforms),
                    buffer_entry(1, &metacells),
                    buffer_entry(2, &cells),
                ],
            });
            return Ok(TraceBinding {
                groups: [group0, group1],
                entry: t.one_page.clone(),
            });
        }
        let largest = grid
            .pages
            .iter()
            .map(|p| p.metacells.size().max(p.cells.size()))
            .max()
            .unwrap_or(0);
        if grid.pages.len() > TRACE_PAGES {
            return Err(GpuError::too_large(format!(
                "ray tracing binds at most {TRACE_PAGES} pages of a grid at once, but this one was \
                 split into {} pages (storage bindings of up to {largest} bytes, {} active cells); \
                 it can only be rasterised",
                grid.pages.len(),
                grid.active_cells()
            )));
        }
        let needed = 2 * TRACE_PAGES as u32 + 3;
        let allowed = self.limits.max_storage_buffers_per_shader_stage;
        if allowed < needed {
            return Err(GpuError::too_large(format!(
                "ray tracing a grid of {} pages binds {needed} storage buffers per shader stage, \
                 but the device allows {allowed}; it can only be rasterised",
                grid.pages.len()
            )));
        }
        let mut table = TracePages {
            count: [grid.pages.len() as u32, 0, 0, 0],
            first_slot: [[0; 4]; 2],
            first_cell: [[0; 4]; 2],
        };
        for (i, page) in grid.pages.iter().enumerate() {
            table.first_slot[i / 4][i % 4] = page.first_slot;
            table.first_cell[i / 4][i % 4] = page.first_cell;
        }
        let table = self.uniform_buffer("trace page table", bytemuck::bytes_of(&table));
        let unused = dummy();
        let page_buffer = |i: usize, pick: fn(&crate::upload::Page) -> &wgpu::Buffer| {
            grid.pages.get(i).map_or(&unused, pick)
        };
        let mut entries = vec![buffer_entry(0, &table)];
        for i in 0..TRACE_PAGES {
            entries.push(buffer_entry(1 + i as u32, page_buffer(i, |p| &p.metacells)));
            entries.push(buffer_entry(
                1 + (TRACE_PAGES + i) as u32,
                page_buffer(i, |p| &p.cells),
            ));
        }
        let paged = t.paged(&self.device);
        let group1 = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace pages"),
            layout: &paged.pages,
            entries: &entries,
        });
        Ok(TraceBinding {
            groups: [group0, group1],
            entry: paged.entry.clone(),
        })
    }

    /// Validates the options, finds or restarts the grid's accumulation for this view, and binds
    /// the G-buffer (`targets[0]`, final normal + distance; `targets[2]`, cluster ids), read for
    /// raster primaries and written for traced ones, and the output (`targets[1]`, colour).
    pub(crate) fn prepare_path_trace(
        &self,
        grid: &GpuGrid,
        camera: &Camera,
        options: &PathTraceOptions<'_>,
        targets: [&wgpu::Texture; 3],
        frame_uniforms: &wgpu::Buffer,
    ) -> Result<PathTracePass, GpuError> {
        if options.bounces > MAX_BOUNCES {
            return Err(GpuError::invalid(format!(
                "{} bounces requested, at most {MAX_BOUNCES} are supported",
                options.bounces
            )));
        }
        if options.albedo.iter().any(|a| !(0.0..=1.0).contains(a)) {
            return Err(GpuError::invalid(format!(
                "albedo {:?} is outside [0, 1]",
                options.albedo
            )));
        }
        let base = {
            let mut u = self.trace_uniforms(grid, options.bounces, options.albedo);
            u.sample[1] = options.env.is_some() as u32;
            u
        };
        let uniforms = self.uniform_buffer("trace uniforms", bytemuck::bytes_of(&base));
        let binding = self.trace_binding(grid, frame_uniforms, &uniforms)?;
        let pixels = camera.width as u64 * camera.height as u64;
        let sum_bytes = 16 * pixels;
        if sum_bytes > self.binding_limit() {
            return Err(GpuError::too_large(format!(
                "a {}x{} accumulation buffer exceeds one storage binding",
                camera.width, camera.height
            )));
        }
        let key = format!(
            "{camera:?} bounces {} albedo {:?} env {} primary {:?}",
            options.bounces,
            options.albedo,
            options.env.map_or(0, |e| e.id),
            options.primary
        );
        let (sum, first_sample) = {
            let mut acc = grid
                .accumulation
                .lock()
                .map_err(|_| GpuError::device("accumulation state poisoned"))?;
            match acc.as_ref() {
                Some(a) if a.key == key => (a.sum.clone(), a.samples),
                _ => {
                    // New buffers are zero-initialised: an empty sum.
                    let sum = self.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("path trace accumulation"),
                        size: sum_bytes,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    });
                    *acc = Some(Accumulation {
                        key,
                        sum: sum.clone(),
                        samples: 0,
                    });
                    (sum, 0)
                }
            }
        };
        let dummy_env;
        let env_view = match options.env {
            Some(e) => &e.view,
            None => {
                dummy_env = self.float_texture("no environment map", 1, 1, &[0.0; 4]);
                &dummy_env
            }
        };
        let [gbuffer, output, ids] =
            targets.map(|t| t.create_view(&wgpu::TextureViewDescriptor::default()));
        let mut entries = vec![
            buffer_entry(1, &sum),
            texture_entry(2, &output),
            texture_entry(3, env_view),
        ];
        let t = &self.pipelines.trace;
        let (io_layout, pipeline) = match options.primary {
            PrimaryRays::Raster => {
                entries.push(texture_entry(0, &gbuffer));
                (&t.path_io, binding.entry.path_trace.clone())
            }
            PrimaryRays::Traced => {
                entries.extend([texture_entry(6, &gbuffer), texture_entry(7, &ids)]);
                (
                    &t.traced_primary_io,
                    binding.entry.traced_primary(&self.device),
                )
            }
        };
        let io = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("path trace io"),
            layout: io_layout,
            entries: &entries,
        });
        let [group0, group1] = binding.groups;
        Ok(PathTracePass {
            uniforms,
            base,
            groups: [group0, group1, io],
            pipeline,
            readback: self.readback_buffer("accumulation readback", sum_bytes),
            sum,
            first_sample,
            size: (camera.width, camera.height),
        })
    }
}

impl PathTracePass {
    /// Records frame `f` of this call's trace pass; the last frame also copies the sums out.
    pub(crate) fn encode(
        &self,
        renderer: &Renderer,
        encoder: &mut wgpu::CommandEncoder,
        f: u32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
        last: bool,
    ) {
        let mut u = self.base;
        u.sample[0] = self.first_sample.wrapping_add(f);
        renderer
            .queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("path trace"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&self.pipeline);
            for (i, group) in self.groups.iter().enumerate() {
                pass.set_bind_group(i as u32, group, &[]);
            }
            pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
        }
        if last {
            encoder.copy_buffer_to_buffer(&self.sum, 0, &self.readback, 0, self.readback.size());
        }
    }

    /// Reads the sums back into `frame.linear` and records the samples taken.
    pub(crate) fn finish(
        self,
        renderer: &Renderer,
        frame: &mut Frame,
        grid: &GpuGrid,
        frames: u32,
    ) -> Result<(), GpuError> {
        let sums: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(&renderer.read_buffer(&self.readback)?);
        frame.linear = sums
            .iter()
            .map(|s| {
                let n = s[3].max(1.0);
                [s[0] / n, s[1] / n, s[2] / n]
            })
            .collect();
        frame.samples = self.first_sample + frames;
        let mut acc = grid
            .accumulation
            .lock()
            .map_err(|_| GpuError::device("accumulation state poisoned"))?;
        if let Some(a) = acc.as_mut() {
            a.samples = frame.samples;
        }
        Ok(())
    }
}

fn spacing_and_iso(grid: &GpuGrid) -> [f32; 4] {
    let s = grid.info.spacing;
    [
        s[0] as f32,
        s[1] as f32,
        s[2] as f32,
        grid.info.mapping.iso_code,
    ]
}

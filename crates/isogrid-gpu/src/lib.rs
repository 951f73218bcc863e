//! GPU renderer for clustered grid cells (paper §3.2–3.4), built on wgpu; headless, one image per
//! [`Renderer::render`] call, read back with per-pixel depth, normal and cluster AOVs.
//!
//! Passes of one CGC frame ([`Mode::Cgc`]), each in its own shader file under `shaders/`:
//!
//! 1. `expand.wgsl` (compute): clusters visible last frame → instance list of cells that survive
//!    back-face and frustum culling; other clusters → one probe cell per metacell (§3.3).
//! 2. `cells.wgsl`: cell rasterisation by billboard splatting (§3.2) into a G-buffer (world normal
//!    and eye distance), a cluster-ID target (`Rg32Uint`) and a reversed-Z depth buffer.
//! 3. `probe.wgsl`: probes mark clusters that became visible; `expand.wgsl` lists their cells and
//!    a second raster pass draws them in the same frame (the paper's second visibility buffer).
//! 4. `ewa.wgsl`: Gaussian normal splats accumulated into a float target (§3.4).
//! 5. `visibility.wgsl` (compute): rebuilds the per-cluster visibility bits from the ID target.
//! 6. `shade.wgsl`: deferred normalised Blinn–Phong (`isogrid::shading`), sRGB output.
//!
//! Steps 2–4 and 6 have two implementations with the same per-pixel code ([`CellRaster`]): the
//! paper's, through the graphics pipeline (rectangles and fragments), and compute passes in which
//! one thread per cell walks its pixels (`cells_compute.wgsl`, `ewa_compute.wgsl`, atomics for
//! depth and splat sums) and shading runs per pixel. The default picks the compute one unless cells
//! can grow large on screen; on an H100 it is 30× faster (`docs/gpu-performance.md`).
//!
//! [`Mode::PathTrace`] (§3.6, `pathtrace/`) runs the [`Mode::Cgc`] passes for primary hits, then
//! `trace.wgsl` + `pathtrace.wgsl` (compute) trace secondary rays through blocks, clusters,
//! metacells and cells and accumulate diffuse path-traced samples over frames. With
//! [`PrimaryRays::Traced`] the primary rays are traced in that compute pass too and no raster pass
//! runs (for GPUs whose graphics pipeline is slow next to their compute).
//!
//! Baselines: [`Mode::Mc`] draws a Marching Cubes mesh (`mesh.wgsl`), [`Mode::Cr`] runs the same
//! cell passes with corner values read from a 3D texture of the original samples.
//!
//! World space is `isogrid::camera`'s: sample (i, j, k) at (i·sx, j·sy, k·sz); pixel (0, 0) is the
//! top-left and every pixel's ray passes through its centre, as `Camera::ray`.
//!
//! Structures larger than one storage binding (`max_storage_buffer_binding_size`) are split into
//! pages of whole clusters, each with its own buffers and draws; the path tracer binds up to six
//! pages at once (see `pathtrace/mod.rs`).

mod backends;
mod compute_raster;
mod error;
mod gpu_types;
mod pathtrace;
mod pipelines;
mod render;
mod upload;

pub use backends::preferred_backends;
pub use compute_raster::{CellRaster, MAX_COMPUTE_CELL_PIXELS};
pub use error::{GpuError, GpuErrorKind};
pub use pathtrace::{
    sky_radiance, EnvMap, GpuEnvMap, PathTraceOptions, PrimaryRays, RayHit, DEFAULT_BOUNCES,
    MAX_BOUNCES,
};
pub use render::{Frame, Mode, PassTimings, RenderOptions, Scene};
pub use upload::{GpuGrid, GpuMesh, GpuVolume};

use pipelines::Pipelines;
use std::sync::{Arc, Mutex};

/// A headless wgpu device with the renderer's pipelines, built once.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    timestamps: bool,
    pipelines: Pipelines,
    /// Bytes of the largest storage buffer binding pages may use.
    page_bytes: u64,
    /// Validation errors outside an error scope land here instead of panicking.
    uncaptured: Arc<Mutex<Vec<String>>>,
}

impl Renderer {
    /// Opens the default adapter of [`preferred_backends`] headlessly (`WGPU_BACKEND=vulkan|gl|...`
    /// picks the backend) with the adapter's own limits, and builds all pipelines.
    ///
    /// Fails with [`GpuErrorKind::NoAdapter`] when there is no adapter or it cannot run compute
    /// and fragment-storage shaders; callers may fall back to a CPU renderer then.
    pub fn new() -> Result<Renderer, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: preferred_backends(),
            ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            // The real limits, so that big structures need as few pages as possible.
            apply_limit_buckets: false,
        }))
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
        for format in [
            pipelines::SURFACE_FORMAT,
            pipelines::IDS_FORMAT,
            pipelines::EWA_FORMAT,
        ] {
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
        // depth writes (conservative depth, see `pipelines.rs`).
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
        let pipelines = Pipelines::new(&device);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::device(format!("building pipelines: {e}")));
        }
        let page_bytes = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        Ok(Renderer {
            device,
            queue,
            info,
            limits,
            timestamps,
            pipelines,
            page_bytes,
            uncaptured,
        })
    }

    /// Adapter name and backend, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub fn adapter_info(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    /// Whether pass timings are measured (the adapter supports timestamp queries).
    pub fn has_timestamps(&self) -> bool {
        self.timestamps
    }

    /// Caps the bytes per storage binding below the device limit, so that tests can exercise
    /// paging with small structures. Only affects later uploads.
    #[doc(hidden)]
    pub fn set_page_bytes(&mut self, bytes: u64) {
        self.page_bytes = bytes.clamp(
            256,
            self.limits
                .max_storage_buffer_binding_size
                .min(self.limits.max_buffer_size),
        );
    }

    /// Runs `f` inside validation and out-of-memory error scopes, turning what they catch into a
    /// [`GpuError`] (`what` names the operation).
    fn scoped<T>(
        &self,
        what: &str,
        f: impl FnOnce() -> Result<T, GpuError>,
    ) -> Result<T, GpuError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let validation = pollster::block_on(validation.pop());
        let oom = pollster::block_on(oom.pop());
        if let Some(e) = oom {
            return Err(GpuError::too_large(format!(
                "{what}: out of GPU memory: {e}"
            )));
        }
        if let Some(e) = validation {
            return Err(GpuError::device(format!("{what}: {e}")));
        }
        if let Some(e) = self.uncaptured.lock().ok().and_then(|mut v| v.pop()) {
            return Err(GpuError::device(format!("{what}: {e}")));
        }
        out
    }
}

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
//! can grow large on screen; on an H100 it is 30× faster (`docs/design/gpu-frame.md`).
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
//! pages at once and traces grids of more in passes over groups of six (see `pathtrace/mod.rs`),
//! so any grid that fits the device's memory renders in every mode.
//!
//! A grid is uploaded once ([`GpuGrid`], only uploaded data) and drawn by any number of views,
//! each with its own [`ViewState`] (visibility bits, frame counter, accumulated samples).
//!
//! Modules, lowest first (none imports one above it; `scripts/check_module_cycles.py` checks):
//! `error`, `backends`, `gpu_types` and `shaders`; `wgpu_util` (the device and wgpu helpers);
//! `env_map`, `options` and `targets`; `upload` (uploaded data) and `view` (per-view state);
//! `output` (what a call returns); `passes` (one struct per raster pass, owning its pipelines)
//! and `pathtrace` (the tracer's pipelines and passes); `render` (one render call); `renderer`
//! (the [`Renderer`] and its entry points). The design is described in `docs/design/gpu-frame.md`.

mod backends;
mod env_map;
mod error;
mod gpu_types;
mod options;
mod output;
mod passes;
mod pathtrace;
mod render;
mod renderer;
mod shaders;
mod targets;
mod upload;
mod view;
mod wgpu_util;

pub use backends::{default_adapter, preferred_backends, AdapterSummary};
pub use env_map::GpuEnvMap;
pub use error::{GpuError, GpuErrorKind};
pub use options::{
    CellRaster, Mode, PathTraceOptions, PrimaryRays, RenderOptions, DEFAULT_BOUNCES, MAX_BOUNCES,
    MAX_COMPUTE_CELL_PIXELS,
};
pub use output::{Frame, PassTimings};
pub use pathtrace::RayHit;
pub use renderer::Renderer;
pub use upload::{GpuGrid, GpuMesh, GpuVolume, MeshColor, Scene};
pub use view::ViewState;

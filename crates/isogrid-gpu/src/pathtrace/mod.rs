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
//! Rgba32Float texel layout) kept with the [`crate::ViewState`] and reset whenever the view, bounces,
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

mod binding;
mod path_pass;
mod trace_pipelines;
mod trace_rays;

pub(crate) use path_pass::PathTracePass;
pub(crate) use trace_pipelines::TracePipelines;
pub(crate) use trace_rays::trace_ray_batch;
pub use trace_rays::RayHit;

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
//! corner-record buffers (the records followed by their attribute codes, `upload.rs`), no larger than the device's largest storage binding
//! (`max_storage_buffer_binding_size`, capped by `max_buffer_size`; the renderer asks for the
//! adapter's own limits: 128 MiB on lavapipe, 2–4 GiB on discrete GPUs). The raster passes draw
//! page by page, but a traced ray may need any cluster, so a trace pass binds a group of up to
//! [`TRACE_PAGES`] (6) consecutive pages at once: pairs of bindings plus a small page table
//! (first global slot and record of each page, and the end of the group's slots, `TracePages`),
//! read through `slot_word` / `record_word` in `shaders/trace_pages.wgsl`, which switch on the
//! page index because WGSL cannot index an array of bindings without binding arrays (not
//! available on every backend). A 16³ block's clusters may straddle a page boundary, so the page
//! is looked up per cluster (a scan of at most six table entries, cheap next to the cluster's 15
//! metacells), and hits remember their page. Six pages keep 15 storage buffers per shader stage
//! (12 for pages, blocks, and the rays and hits or the accumulation), within the 16 that GL and
//! most devices offer; a device with fewer gets a `TooLarge` error naming the numbers (such a
//! grid can still be rasterised).
//!
//! A grid of up to six pages is traced as one page is, in one dispatch. A grid of more pages is
//! traced in passes, one per group of six, and any grid that fits the device's memory traces:
//!
//! - Each pass sees only the clusters of its bound group; the traversal treats the others as
//!   empty space (`trace_slot_is_bound`). Its nearest crossing is the nearest among the group's
//!   cells, and the nearest of the per-group nearest crossings is the nearest in the grid. Each
//!   pass keeps the nearer of its crossing and the earlier groups' (ties keep the earlier group),
//!   and visits no block beyond that earlier crossing (`trace_ray_until`), which bounds the
//!   extra work of later groups by the distance already known. Cells are clipped to the ray's
//!   own interval only, so the winning crossing is computed from the same cell with the same
//!   arithmetic as with every page bound: the hits are bit-identical to a one-page trace (tested
//!   for 7, 13 and 20 pages).
//! - [`crate::Renderer::trace_rays`] starts every hit at "none" and dispatches its kernel once
//!   per group.
//! - The path tracer follows each path through several bounces inside one dispatch, so for
//!   grids of several groups it runs as a wavefront instead (`wavefront.rs`,
//!   `shaders/wavefront.wgsl`): per pixel, the path's state (ray, nearest crossing so far,
//!   throughput, random stream; 64 bytes) lives in a buffer; per frame, a start kernel sets up
//!   each path's first ray (from the raster G-buffer, or the eye ray for traced primaries), and
//!   per bounce (and for traced primaries) one trace dispatch per group is followed by a resolve
//!   kernel that adds the sample of a path that escaped or ran out of bounces, or draws its next
//!   ray. The steps are `follow_path`'s with its arithmetic, so the images equal the one-page
//!   ones (tested bit for bit with traced primaries). The path state limits an image to one
//!   storage binding's worth of pixels at 64 bytes each (2 M on lavapipe, 1080p fits); larger
//!   images get a `TooLarge` error.
//!
//! Cost: with `b` bounces and `g` groups a frame runs `1 + b·(g + 1)` dispatches (`g + 1` more
//! with traced primaries) instead of one, and a ray's traversal is repeated per group up to its
//! nearest crossing. On a big GPU pages are 2–4 GiB, so grids need more than one group only beyond
//! 12–24 GB of cells. Measured on lavapipe (96³ gyroid, forced page sizes, best of 3, shared
//! 2-core AMD EPYC under load from parallel builds): 100k random rays took 1.04 s in one page,
//! 7.97 s in 9 pages (2 groups) and 11.98 s in 15 pages (3 groups); a 256² path trace (4 spp,
//! 3 bounces, traced primaries) 3.22, 28.8 and 40.6 s. Most of that is the per-read page
//! `switch` of the several-pages shader, which a CPU SIMD driver runs in every case (see below),
//! times the repeated traversal per group.
//!
//! One-page grids (the common case) keep their own pipelines compiled over `cell_data.wgsl`,
//! where the page lookup is the constant 0 and every read is a plain array access; the several-pages pipelines are compiled on first use. Measured on
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
mod wavefront;

pub(crate) use path_pass::PathTracePass;
pub(crate) use trace_pipelines::TracePipelines;
pub(crate) use trace_rays::trace_ray_batch;
pub use trace_rays::RayHit;

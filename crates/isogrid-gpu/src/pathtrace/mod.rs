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

mod binding;
mod env_map;
mod trace_pipelines;
mod trace_rays;

pub use env_map::{sky_radiance, EnvMap, GpuEnvMap};
pub(crate) use trace_pipelines::TracePipelines;
pub use trace_rays::RayHit;

use crate::error::GpuError;
use crate::gpu_types::TraceUniforms;
use crate::render::{buffer_entry, texture_entry, Frame};
use crate::upload::GpuGrid;
use crate::Renderer;
use isogrid::Camera;

/// Bounces of [`PathTraceOptions::default`] (the paper's Figure 6).
pub const DEFAULT_BOUNCES: u32 = 3;
/// Most bounces a path may take.
pub const MAX_BOUNCES: u32 = 64;

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

impl Renderer {
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

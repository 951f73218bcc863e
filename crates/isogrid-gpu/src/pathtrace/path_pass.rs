//! One path-traced render call (paper §3.6): the trace pass's bindings and uniforms, prepared
//! before the frames with the view's accumulation, recorded once per frame after the primary
//! passes (one dispatch, or a [`Wavefront`] for grids of several page groups), and the
//! accumulated sums read back into the [`Frame`].

use super::binding::{trace_binding, trace_uniforms, TraceColoring};
use super::trace_pipelines::TracePipelines;
use super::wavefront::Wavefront;
use crate::error::GpuError;
use crate::gpu_types::TraceUniforms;
use crate::options::{PathTraceOptions, PrimaryRays, MAX_BOUNCES};
use crate::output::Frame;
use crate::upload::GpuGrid;
use crate::view::{Accumulation, ViewState};
use crate::wgpu_util::{buffer_entry, texture_entry, Gpu};
use isogrid::Camera;

/// Everything one path-traced render call needs, prepared before its frames.
pub(crate) struct PathTracePass {
    uniforms: wgpu::Buffer,
    base: TraceUniforms,
    work: TraceWork,
    sum: wgpu::Buffer,
    readback: wgpu::Buffer,
    first_sample: u32,
    size: (u32, u32),
}

/// How a frame's paths are traced: whole in one dispatch where one pass binds every page the
/// grid has, or bounce by bounce over groups of pages ([`Wavefront`]).
enum TraceWork {
    OnePass {
        groups: [wgpu::BindGroup; 3],
        pipeline: wgpu::ComputePipeline,
    },
    Wavefront(Wavefront),
}

impl PathTracePass {
    /// Validates the options, finds or restarts the view's accumulation for this grid and camera,
    /// and binds the G-buffer (`targets[0]`, final normal + distance; `targets[2]`, cluster ids),
    /// read for raster primaries and written for traced ones, and the output (`targets[1]`,
    /// colour).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn prepare(
        gpu: &Gpu,
        pipelines: &TracePipelines,
        view: &mut ViewState,
        grid: &GpuGrid,
        camera: &Camera,
        options: &PathTraceOptions<'_>,
        targets: [&wgpu::Texture; 3],
        values: &wgpu::TextureView,
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
            let mut u = trace_uniforms(grid, options.bounces, options.albedo);
            u.sample[1] = options.env.is_some() as u32;
            u
        };
        let uniforms = gpu.uniform_buffer("trace uniforms", bytemuck::bytes_of(&base));
        let coloring = TraceColoring::new(gpu, grid, options.coloring, Some(values))?;
        let binding = trace_binding(gpu, pipelines, grid, frame_uniforms, &uniforms, &coloring)?;
        let pixels = camera.width as u64 * camera.height as u64;
        let sum_bytes = 16 * pixels;
        if sum_bytes > gpu.binding_limit() {
            return Err(GpuError::too_large(format!(
                "a {}x{} accumulation buffer exceeds one storage binding",
                camera.width, camera.height
            )));
        }
        let key = format!(
            "grid {} {camera:?} bounces {} albedo {:?} env {} primary {:?} colour {:?}",
            grid.id,
            options.bounces,
            options.albedo,
            options.env.map_or(0, |e| e.id),
            options.primary,
            options.coloring.map(|c| (c.map, c.clim)),
        );
        let (sum, first_sample) = {
            let acc = &mut view.accumulation;
            match acc.as_ref() {
                Some(a) if a.key == key => (a.sum.clone(), a.samples),
                _ => {
                    // New buffers are zero-initialised: an empty sum.
                    let sum = gpu.device.create_buffer(&wgpu::BufferDescriptor {
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
                dummy_env = gpu.float_texture("no environment map", 1, 1, &[0.0; 4]);
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
        match options.primary {
            PrimaryRays::Raster => entries.push(texture_entry(0, &gbuffer)),
            PrimaryRays::Traced => {
                entries.extend([texture_entry(6, &gbuffer), texture_entry(7, &ids)])
            }
        }
        let size = (camera.width, camera.height);
        let work = if binding.page_groups.len() > 1 {
            let wave = pipelines
                .paged(&gpu.device)
                .wavefront(&gpu.device, &pipelines.grid);
            let kernels = match options.primary {
                PrimaryRays::Raster => &wave.raster,
                PrimaryRays::Traced => &wave.traced,
            };
            TraceWork::Wavefront(Wavefront::new(
                gpu,
                wave,
                kernels,
                binding,
                entries,
                options.bounces,
                size,
            )?)
        } else {
            let t = pipelines;
            let (io_layout, pipeline) = match options.primary {
                PrimaryRays::Raster => (&t.path_io, binding.entry.path_trace.clone()),
                PrimaryRays::Traced => (
                    &t.traced_primary_io,
                    binding.entry.traced_primary(&gpu.device),
                ),
            };
            let io = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("path trace io"),
                layout: io_layout,
                entries: &entries,
            });
            let [pages] = <[wgpu::BindGroup; 1]>::try_from(binding.page_groups)
                .map_err(|_| GpuError::device("a one-pass trace binds one page group"))?;
            TraceWork::OnePass {
                groups: [binding.grid, pages, io],
                pipeline,
            }
        };
        Ok(PathTracePass {
            uniforms,
            base,
            work,
            readback: gpu.readback_buffer("accumulation readback", sum_bytes),
            sum,
            first_sample,
            size: (camera.width, camera.height),
        })
    }

    /// Records frame `f` of this call's trace pass; the last frame also copies the sums out.
    pub(crate) fn encode(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        f: u32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
        last: bool,
    ) {
        let mut u = self.base;
        u.sample[0] = self.first_sample.wrapping_add(f);
        gpu.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("path trace"),
                timestamp_writes: timestamps,
            });
            match &self.work {
                TraceWork::OnePass { groups, pipeline } => {
                    pass.set_pipeline(pipeline);
                    for (i, group) in groups.iter().enumerate() {
                        pass.set_bind_group(i as u32, group, &[]);
                    }
                    pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
                }
                TraceWork::Wavefront(wave) => wave.encode(&mut pass),
            }
        }
        if last {
            encoder.copy_buffer_to_buffer(&self.sum, 0, &self.readback, 0, self.readback.size());
        }
    }

    /// Reads the sums back into `frame.linear` and records the samples taken.
    pub(crate) fn finish(
        self,
        gpu: &Gpu,
        frame: &mut Frame,
        view: &mut ViewState,
        frames: u32,
    ) -> Result<(), GpuError> {
        let sums: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(&self.readback)?);
        frame.linear = sums
            .iter()
            .map(|s| {
                let n = s[3].max(1.0);
                [s[0] / n, s[1] / n, s[2] / n]
            })
            .collect();
        frame.samples = self.first_sample + frames;
        if let Some(a) = view.accumulation.as_mut() {
            a.samples = frame.samples;
        }
        Ok(())
    }
}

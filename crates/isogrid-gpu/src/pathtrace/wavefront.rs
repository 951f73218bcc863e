//! Path tracing of grids in more pages than one trace pass binds (paper §3.6): the frame's paths
//! advance bounce by bounce, each bounce's rays traced in one pass per group of pages, each pass
//! keeping the nearer crossing (`shaders/wavefront.wgsl`). The nearest crossing over the groups
//! is the nearest in the grid, so the samples are those of a trace with every page bound.

use super::binding::TraceBinding;
use super::trace_pipelines::{WavefrontKernels, WavefrontPipelines};
use crate::error::GpuError;
use crate::wgpu_util::{buffer_entry, Gpu};

/// Bytes of one pixel's `PathState` in `shaders/wavefront.wgsl`.
const PATH_STATE_BYTES: u64 = 80;

/// One render call's wavefront: its bindings and kernels.
pub(super) struct Wavefront {
    grid: wgpu::BindGroup,
    page_groups: Vec<wgpu::BindGroup>,
    /// Group 2 of the trace passes (the path states) and of the start and resolve kernels.
    paths: wgpu::BindGroup,
    io: wgpu::BindGroup,
    trace: wgpu::ComputePipeline,
    start: wgpu::ComputePipeline,
    resolve_primary: Option<wgpu::ComputePipeline>,
    resolve: wgpu::ComputePipeline,
    bounces: u32,
    size: (u32, u32),
}

impl Wavefront {
    /// Binds the path states of a `size` image with `io` (the path tracer's group 2 entries for
    /// these primaries, without the path states) for `kernels`.
    pub(super) fn new(
        gpu: &Gpu,
        pipelines: &WavefrontPipelines,
        kernels: &WavefrontKernels,
        binding: TraceBinding,
        io: Vec<wgpu::BindGroupEntry<'_>>,
        bounces: u32,
        size: (u32, u32),
    ) -> Result<Wavefront, GpuError> {
        let bytes = PATH_STATE_BYTES * size.0 as u64 * size.1 as u64;
        if bytes > gpu.binding_limit() {
            return Err(GpuError::too_large(format!(
                "path tracing a grid of {} page groups keeps {PATH_STATE_BYTES} bytes per pixel, \
                 and a {}x{} image's {bytes} bytes exceed one storage binding ({} bytes)",
                binding.page_groups.len(),
                size.0,
                size.1,
                gpu.binding_limit()
            )));
        }
        // Every kernel writes a pixel's state before any reads it: no initial contents needed.
        let states = gpu.buffer("wavefront path states", bytes, wgpu::BufferUsages::STORAGE)?;
        let paths = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wavefront paths"),
            layout: &pipelines.paths,
            entries: &[buffer_entry(8, &states)],
        });
        let mut entries = io;
        entries.push(buffer_entry(8, &states));
        let io = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wavefront io"),
            layout: &kernels.io,
            entries: &entries,
        });
        Ok(Wavefront {
            grid: binding.grid,
            page_groups: binding.page_groups,
            paths,
            io,
            trace: pipelines.trace.clone(),
            start: kernels.start.clone(),
            resolve_primary: kernels.resolve_primary.clone(),
            resolve: kernels.resolve.clone(),
            bounces,
            size,
        })
    }

    /// Records one sample per pixel: start, then for the traced primaries (if any) and each
    /// bounce, one trace per page group and a resolve.
    pub(super) fn encode(&self, pass: &mut wgpu::ComputePass<'_>) {
        let groups = (self.size.0.div_ceil(8), self.size.1.div_ceil(8));
        pass.set_bind_group(0, &self.grid, &[]);
        let run = |pass: &mut wgpu::ComputePass<'_>, pipeline: &wgpu::ComputePipeline| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(2, &self.io, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        };
        let trace = |pass: &mut wgpu::ComputePass<'_>| {
            pass.set_pipeline(&self.trace);
            pass.set_bind_group(2, &self.paths, &[]);
            for pages in &self.page_groups {
                pass.set_bind_group(1, pages, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
        };
        run(pass, &self.start);
        if let Some(resolve_primary) = &self.resolve_primary {
            trace(pass);
            run(pass, resolve_primary);
        }
        for _ in 0..self.bounces {
            trace(pass);
            run(pass, &self.resolve);
        }
    }
}

//! Tracing caller-given rays on the GPU (paper §3.6): the path tracer's secondary-ray traversal
//! run on a list of world-space rays, returning each one's nearest isosurface crossing; one
//! dispatch per group of bound pages, each keeping the nearer crossing.

use super::binding::{trace_binding, trace_uniforms, TraceColoring};
use super::trace_pipelines::TracePipelines;
use crate::error::GpuError;
use crate::gpu_types::{FrameUniforms, SOURCE_RECORDS};
use crate::upload::GpuGrid;
use crate::wgpu_util::{buffer_entry, dispatch_size, Gpu};
use isogrid::Ray;
use wgpu::util::DeviceExt;

/// The nearest crossing of a ray with the isosurface ([`crate::Renderer::trace_rays`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// World distance along the unit ray direction.
    pub t: f32,
    /// Unit world normal −∇f of the stored trilinear field (out of the solid).
    pub normal: [f32; 3],
    /// The grid's cluster holding the hit cell (its label in a label grid).
    pub cluster: u32,
}

/// Traces world-space rays through the grid's hierarchy (see [`crate::Renderer::trace_rays`]).
pub(crate) fn trace_ray_batch(
    gpu: &Gpu,
    t: &TracePipelines,
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
    if ray_bytes > gpu.binding_limit() {
        return Err(GpuError::too_large(format!(
            "{} rays need {ray_bytes} bytes, more than one storage binding holds ({} bytes)",
            rays.len(),
            gpu.binding_limit()
        )));
    }
    gpu.scoped("tracing rays", || {
        let frame = FrameUniforms {
            eye: [0.0; 4],
            right: [1.0, 0.0, 0.0, 1.0],
            up: [0.0, 1.0, 0.0, 1.0],
            forward: [0.0, 0.0, -1.0, 0.0],
            viewport: [1.0; 4],
            cell_to_world: spacing_and_iso(grid),
            params: [grid.info.precision.bits(), SOURCE_RECORDS, 0, 0],
            clip: [0.0; 4],
        };
        let frame = gpu.uniform_buffer("trace frame uniforms", bytemuck::bytes_of(&frame));
        let mut uniforms = trace_uniforms(grid, 0, [0.0; 3]);
        uniforms.sample[2] = rays.len() as u32;
        let uniforms = gpu.uniform_buffer("trace uniforms", bytemuck::bytes_of(&uniforms));
        let coloring = TraceColoring::new(gpu, grid, None, None)?;
        let binding = trace_binding(gpu, t, grid, &frame, &uniforms, &coloring)?;
        let storage = wgpu::BufferUsages::STORAGE;
        let ray_buffer = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("rays"),
                contents: bytemuck::cast_slice(&packed),
                usage: storage,
            });
        // Two vec4 per ray: normal and t, then cluster and record.
        let hit_bytes = ray_bytes;
        // No crossing yet: each group's pass keeps the nearer of the hit so far and its own.
        let no_hits = vec![[0.0, 0.0, 0.0, NO_HIT]; 2 * rays.len()];
        let hits = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("ray hits"),
                contents: bytemuck::cast_slice(&no_hits),
                usage: storage | wgpu::BufferUsages::COPY_SRC,
            });
        let readback = gpu.readback_buffer("ray hits readback", hit_bytes);
        let io = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace rays io"),
            layout: &t.ray_io,
            entries: &[buffer_entry(4, &ray_buffer), buffer_entry(5, &hits)],
        });
        let mut encoder = gpu
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
            pass.set_bind_group(0, &binding.grid, &[]);
            pass.set_bind_group(2, &io, &[]);
            let (x, y) = dispatch_size(rays.len() as u32);
            for pages in &binding.page_groups {
                pass.set_bind_group(1, pages, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        encoder.copy_buffer_to_buffer(&hits, 0, &readback, 0, hit_bytes);
        gpu.queue.submit([encoder.finish()]);
        let hits: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(&readback)?);
        Ok(hits
            .chunks_exact(2)
            .map(|h| {
                (h[0][3] < NO_HIT).then_some(RayHit {
                    t: h[0][3],
                    normal: [h[0][0], h[0][1], h[0][2]],
                    cluster: h[1][0].to_bits(),
                })
            })
            .collect())
    })
}

/// `NO_HIT` of `shaders/trace.wgsl`: the t of a ray without a crossing.
const NO_HIT: f32 = 3.0e38;

fn spacing_and_iso(grid: &GpuGrid) -> [f32; 4] {
    let s = grid.info.spacing;
    [
        s[0] as f32,
        s[1] as f32,
        s[2] as f32,
        grid.info.mapping.iso_code,
    ]
}

//! Layouts and compute pipelines of the trace passes (paper §3.6): `trace.wgsl` +
//! `pathtrace.wgsl`, compiled once over a grid bound as one page and, on first use, over a grid
//! bound as a group of several pages (with `wavefront.wgsl`'s passes for grids of several groups).

use crate::gpu_types::TRACE_PAGES;
use crate::shaders::{TRACE_ONE_PAGE, TRACE_PAGED};
use crate::targets::{COLOR_FORMAT, FINAL_FORMAT, IDS_FORMAT};
use crate::wgpu_util::{
    compute, layout, module, pipeline_layout, storage, texture, uniform, written_texture, D2, FLOAT,
};
use std::sync::{Arc, OnceLock};

/// The trace entry points compiled against one way of binding the grid's cells.
#[derive(Clone)]
pub(crate) struct TraceEntryPoints {
    pub(super) path_trace: wgpu::ComputePipeline,
    pub(super) trace_rays: wgpu::ComputePipeline,
    /// `path_trace_traced_primary`, compiled on first use: most renderers never trace primary
    /// rays, and each compile of the tracer slows the renderer's start.
    pub(super) traced_primary: Arc<OnceLock<wgpu::ComputePipeline>>,
    pub(super) shader: wgpu::ShaderModule,
    pub(super) traced_primary_layout: wgpu::PipelineLayout,
}

impl TraceEntryPoints {
    pub(super) fn traced_primary(&self, device: &wgpu::Device) -> wgpu::ComputePipeline {
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
pub(super) struct PagedTrace {
    pub(super) pages: wgpu::BindGroupLayout,
    pub(super) entry: TraceEntryPoints,
    wavefront: OnceLock<WavefrontPipelines>,
}

/// The wavefront path tracer's kernels (`shaders/wavefront.wgsl`) for grids of more pages than
/// one pass binds: `trace` binds the grid, a group of pages and the path states; the others
/// no pages, so that they stay within the storage buffers per stage of every device.
pub(super) struct WavefrontPipelines {
    /// Group 2 of `trace`: the path states.
    pub(super) paths: wgpu::BindGroupLayout,
    pub(super) trace: wgpu::ComputePipeline,
    pub(super) raster: WavefrontKernels,
    pub(super) traced: WavefrontKernels,
}

/// The start and resolve kernels for one kind of primary rays, and their group 2 layout.
pub(super) struct WavefrontKernels {
    /// Raster primaries: G-buffer (read), accumulation, output, environment, path states.
    /// Traced primaries: accumulation, output, environment, G-buffer (written), path states.
    pub(super) io: wgpu::BindGroupLayout,
    pub(super) start: wgpu::ComputePipeline,
    /// `wave_resolve_primary`, for traced primaries only.
    pub(super) resolve_primary: Option<wgpu::ComputePipeline>,
    pub(super) resolve: wgpu::ComputePipeline,
}

impl PagedTrace {
    /// The wavefront kernels, compiled on the first trace of a grid of several page groups.
    pub(super) fn wavefront(
        &self,
        device: &wgpu::Device,
        grid: &wgpu::BindGroupLayout,
    ) -> &WavefrontPipelines {
        self.wavefront.get_or_init(|| {
            let c = wgpu::ShaderStages::COMPUTE;
            let shader = &self.entry.shader;
            let paths = layout(device, "wavefront paths", &[storage(8, c, false)]);
            let trace_layout =
                pipeline_layout(device, "wavefront trace", &[grid, &self.pages, &paths]);
            let trace = compute(
                device,
                "wavefront trace",
                &trace_layout,
                shader,
                "wave_trace",
            );
            let kernels = |label: &str, io: wgpu::BindGroupLayout, start: &str, traced: bool| {
                // No group 1: these kernels read no pages.
                let pipeline_layout =
                    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some(label),
                        bind_group_layouts: &[Some(grid), None, Some(&io)],
                        immediate_size: 0,
                    });
                let kernel = |entry: &str| {
                    compute(
                        device,
                        &format!("{label}: {entry}"),
                        &pipeline_layout,
                        shader,
                        entry,
                    )
                };
                WavefrontKernels {
                    start: kernel(start),
                    resolve_primary: traced.then(|| kernel("wave_resolve_primary")),
                    resolve: kernel("wave_resolve"),
                    io,
                }
            };
            let with_paths = |mut entries: Vec<wgpu::BindGroupLayoutEntry>| {
                entries.push(storage(8, c, false));
                entries
            };
            let raster_io = layout(
                device,
                "wavefront io (raster primaries)",
                &with_paths(path_io_entries()),
            );
            let traced_io = layout(
                device,
                "wavefront io (traced primaries)",
                &with_paths(traced_primary_io_entries()),
            );
            WavefrontPipelines {
                raster: kernels(
                    "wavefront (raster primaries)",
                    raster_io,
                    "wave_start",
                    false,
                ),
                traced: kernels(
                    "wavefront (traced primaries)",
                    traced_io,
                    "wave_start_traced",
                    true,
                ),
                trace,
                paths,
            }
        })
    }
}

/// Layouts and pipelines of the trace passes: the one-page variant built with the renderer, the
/// several-pages one on the first trace of a paged grid (most grids fit one page, and compiling
/// the tracer again would slow every renderer's start).
pub(crate) struct TracePipelines {
    pub(super) grid: wgpu::BindGroupLayout,
    pub(super) page: wgpu::BindGroupLayout,
    pub(super) path_io: wgpu::BindGroupLayout,
    pub(super) traced_primary_io: wgpu::BindGroupLayout,
    pub(super) ray_io: wgpu::BindGroupLayout,
    pub(super) one_page: TraceEntryPoints,
    pub(super) paged: OnceLock<PagedTrace>,
}

impl TracePipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let c = wgpu::ShaderStages::COMPUTE;
        // Group 0: frame uniforms, trace uniforms, blocks; the colouring, a label grid's cluster
        // albedos and the value of each raster primary (pathtrace.wgsl).
        let grid = layout(
            device,
            "trace grid",
            &[
                uniform(0, c),
                uniform(1, c),
                storage(3, c, true),
                uniform(4, c),
                storage(5, c, true),
                texture(6, c, FLOAT, D2),
            ],
        );
        // Group 1: the (single) page's uniforms, metacell slots and corner records.
        let page = layout(
            device,
            "trace page",
            &[uniform(0, c), storage(1, c, true), storage(2, c, true)],
        );
        // The G-buffer (read, raster primaries; or written, traced primaries), accumulation,
        // output and environment.
        let path_io = layout(device, "path trace io", &path_io_entries());
        let traced_primary_io = layout(
            device,
            "path trace io (traced primaries)",
            &traced_primary_io_entries(),
        );
        let ray_io = layout(
            device,
            "trace rays io",
            &[storage(4, c, true), storage(5, c, false)],
        );
        let one_page = entry_points(
            device,
            "one page",
            TRACE_ONE_PAGE,
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
    pub(super) fn paged(&self, device: &wgpu::Device) -> &PagedTrace {
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
                TRACE_PAGED,
                [
                    &self.grid,
                    &pages,
                    &self.path_io,
                    &self.traced_primary_io,
                    &self.ray_io,
                ],
            );
            PagedTrace {
                pages,
                entry,
                wavefront: OnceLock::new(),
            }
        })
    }
}

/// Compiles `sources` (trace.wgsl + pathtrace.wgsl over the cell decoding and page bindings of
/// one variant, `shaders/modules.txt`), with layouts [grid, pages, path trace io, traced
/// primaries io, trace rays io]; the traced-primaries entry point only on first use.
fn entry_points(
    device: &wgpu::Device,
    variant: &str,
    sources: &[&str],
    [grid, pages, path_io, traced_primary_io, ray_io]: [&wgpu::BindGroupLayout; 5],
) -> TraceEntryPoints {
    let shader = module(
        device,
        &format!("trace.wgsl + pathtrace.wgsl ({variant})"),
        sources,
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

/// Group 2 of the path tracer with raster primaries: the G-buffer (read), accumulation, output
/// and environment.
fn path_io_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let c = wgpu::ShaderStages::COMPUTE;
    vec![
        texture(0, c, FLOAT, D2),
        storage(1, c, false),
        written_texture(2, COLOR_FORMAT),
        texture(3, c, FLOAT, D2),
    ]
}

/// Group 2 of the path tracer with traced primaries: accumulation, output, environment and the
/// G-buffer (written).
fn traced_primary_io_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let c = wgpu::ShaderStages::COMPUTE;
    vec![
        storage(1, c, false),
        written_texture(2, COLOR_FORMAT),
        texture(3, c, FLOAT, D2),
        written_texture(6, FINAL_FORMAT),
        written_texture(7, IDS_FORMAT),
    ]
}

//! How a trace pass binds a grid (paper §3.6): its uniforms, its blocks and its pages, one page
//! as the raster passes bind it or groups of up to six behind a page table each.

use super::trace_pipelines::{TraceEntryPoints, TracePipelines};
use crate::error::GpuError;
use crate::gpu_types::{
    ColorUniforms, TracePages, TraceUniforms, COLOR_LABELS, COLOR_NONE, COLOR_RECORDS, TRACE_PAGES,
};
use crate::targets::VALUE_FORMAT;
use crate::upload::{GpuGrid, Page};
use crate::wgpu_util::{buffer_entry, texture_entry, view, Gpu};

/// Secondary rays start this far (in cells of the smallest spacing) off the surface along the
/// normal, well above the raster's and the tracer's crossing error (≈ 1e-4 cell after bisection).
const RAY_OFFSET_CELLS: f64 = 2e-3;

/// How one trace call binds the grid: group 0 (uniforms, blocks), one group 1 per group of pages
/// (traced one pass each, nearest crossing kept), and the pipelines compiled for that binding.
pub(super) struct TraceBinding {
    pub(super) grid: wgpu::BindGroup,
    /// One bind group for a grid of up to [`TRACE_PAGES`] pages; more pages get one per run of
    /// [`TRACE_PAGES`] consecutive pages, and are traced in passes ([`super::wavefront`]).
    pub(super) page_groups: Vec<wgpu::BindGroup>,
    pub(super) entry: TraceEntryPoints,
}

/// Group 0's colouring (pathtrace.wgsl bindings 4–6): the `ColorUniforms`, a label grid's
/// cluster albedos and the value target the shading pass wrote for raster primaries. Attribute
/// codes are read from the hit cell's page (`RecordLayout`).
pub(super) struct TraceColoring {
    uniforms: wgpu::Buffer,
    label_albedo: Option<wgpu::Buffer>,
    values: wgpu::TextureView,
}

impl TraceColoring {
    /// `coloring` of `grid`'s attribute (one albedo without it), raster primaries' values in
    /// `values` (a 1×1 dummy where there are none). Fails when colouring asks for an attribute
    /// the grid does not have uploaded.
    pub(super) fn new(
        gpu: &Gpu,
        grid: &GpuGrid,
        coloring: Option<&isogrid::colormap::Coloring>,
        values: Option<&wgpu::TextureView>,
    ) -> Result<TraceColoring, GpuError> {
        let attribute = match (coloring, grid.attribute) {
            (None, _) => None,
            (Some(_), Some(a)) => Some(a),
            (Some(_), None) => {
                return Err(GpuError::invalid("the grid has no attribute to colour by"))
            }
        };
        let source = match (attribute, &grid.label_albedo) {
            (Some(_), _) => COLOR_RECORDS,
            (None, Some(_)) => COLOR_LABELS,
            (None, None) => COLOR_NONE,
        };
        let u = ColorUniforms::new(coloring, source, attribute);
        let values = match values {
            Some(v) => v.clone(),
            None => view(&gpu.texture_2d(
                "no primary values",
                (1, 1),
                VALUE_FORMAT,
                wgpu::TextureUsages::TEXTURE_BINDING,
            )),
        };
        Ok(TraceColoring {
            uniforms: gpu.uniform_buffer("trace colouring", bytemuck::bytes_of(&u)),
            label_albedo: match source {
                COLOR_LABELS => grid.label_albedo.clone(),
                _ => None,
            },
            values,
        })
    }
}

/// The trace uniforms of `grid` with `bounces` and `albedo`; sample 0, the built-in sky.
pub(super) fn trace_uniforms(grid: &GpuGrid, bounces: u32, albedo: [f32; 3]) -> TraceUniforms {
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

/// Bind groups 0 (uniforms, blocks) and 1 (the pages) of the trace passes and the pipelines
/// for them: a grid of one page (or none) binds it as the raster passes do; a paged grid binds
/// its pages in groups of up to [`TRACE_PAGES`] with a page table each
/// (`shaders/trace_pages.wgsl`). A grid without blocks or pages binds small dummies that the
/// shader never reads (it sees no blocks).
pub(super) fn trace_binding(
    gpu: &Gpu,
    t: &TracePipelines,
    grid: &GpuGrid,
    frame: &wgpu::Buffer,
    uniforms: &wgpu::Buffer,
    coloring: &TraceColoring,
) -> Result<TraceBinding, GpuError> {
    let dummy = || {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("unused trace data"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::UNIFORM,
            mapped_at_creation: false,
        })
    };
    let blocks = grid.blocks.clone().unwrap_or_else(dummy);
    let label_albedo = coloring.label_albedo.clone().unwrap_or_else(dummy);
    let group0 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("trace grid"),
        layout: &t.grid,
        entries: &[
            buffer_entry(0, frame),
            buffer_entry(1, uniforms),
            buffer_entry(3, &blocks),
            buffer_entry(4, &coloring.uniforms),
            buffer_entry(5, &label_albedo),
            texture_entry(6, &coloring.values),
        ],
    });
    if grid.pages.len() <= 1 {
        let (page_uniforms, metacells, cells) = match grid.pages.first() {
            Some(p) => (p.uniforms.clone(), p.metacells.clone(), p.cells.clone()),
            None => (dummy(), dummy(), dummy()),
        };
        let group1 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace page"),
            layout: &t.page,
            entries: &[
                buffer_entry(0, &page_uniforms),
                buffer_entry(1, &metacells),
                buffer_entry(2, &cells),
            ],
        });
        return Ok(TraceBinding {
            grid: group0,
            page_groups: vec![group1],
            entry: t.one_page.clone(),
        });
    }
    // Pages, then blocks, the label albedos, the accumulation and the path states.
    let needed = 2 * TRACE_PAGES as u32 + 4;
    let allowed = gpu.limits.max_storage_buffers_per_shader_stage;
    if allowed < needed {
        return Err(GpuError::too_large(format!(
            "ray tracing a grid of {} pages binds {needed} storage buffers per shader stage, \
                 but the device allows {allowed}; it can only be rasterised",
            grid.pages.len()
        )));
    }
    let paged = t.paged(&gpu.device);
    let unused = dummy();
    let page_groups = grid
        .pages
        .chunks(TRACE_PAGES)
        .enumerate()
        .map(|(g, group)| {
            let last = &group[group.len() - 1];
            let mut table = TracePages {
                count: [group.len() as u32, last.first_slot + last.slot_count, 0, 0],
                first_slot: [[0; 4]; 2],
                first_cell: [[0; 4]; 2],
                codes_word: [[0; 4]; 2],
            };
            for (i, page) in group.iter().enumerate() {
                table.first_slot[i / 4][i % 4] = page.first_slot;
                table.first_cell[i / 4][i % 4] = page.first_cell;
                table.codes_word[i / 4][i % 4] = page.codes_word;
            }
            let table = gpu.uniform_buffer("trace page table", bytemuck::bytes_of(&table));
            let page_buffer =
                |i: usize, pick: fn(&Page) -> &wgpu::Buffer| group.get(i).map_or(&unused, pick);
            let mut entries = vec![buffer_entry(0, &table)];
            for i in 0..TRACE_PAGES {
                entries.push(buffer_entry(1 + i as u32, page_buffer(i, |p| &p.metacells)));
                entries.push(buffer_entry(
                    1 + (TRACE_PAGES + i) as u32,
                    page_buffer(i, |p| &p.cells),
                ));
            }
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(&format!("trace pages, group {g}")),
                layout: &paged.pages,
                entries: &entries,
            })
        })
        .collect();
    Ok(TraceBinding {
        grid: group0,
        page_groups,
        entry: paged.entry.clone(),
    })
}

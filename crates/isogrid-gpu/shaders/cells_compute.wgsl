// Cell rasterisation in compute passes (paper §3.2 and the probes of §3.3), the alternative to the
// hardware billboards of cells.wgsl and probe.wgsl for GPUs whose graphics pipeline is slow next to
// their compute units (on an H100 a full-screen fragment pass costs as much as a 1080p path-traced
// bounce) and for cells of a few pixels, where fixed-function setup per tiny rectangle dominates.
// One thread per listed cell loops over the pixels of the cell's projected rectangle and runs the
// same per-pixel test as the fragment shader (`cell_pixel_hit`, cell_hit.wgsl):
//
// - `raster_cells`, depth pass: atomicMax of the hit's reversed-Z depth bits into a per-pixel depth
//   word (positive floats order like their bit patterns; 0 = nothing yet);
// - `raster_cells`, resolve pass (after every depth pass): the cell whose depth equals the pixel's
//   word writes the G-buffer (normal + distance) and the IDs. The depth is recomputed by the same
//   code from the same inputs, so equality is exact; of cells that tie to the bit, any one wins;
// - `clear_targets`: per pixel, the depth word, the G-buffer and the IDs start empty (a compute
//   pass: on GPUs with a weak graphics pipeline, render-pass clears of these targets cost more
//   than the whole raster);
// - `probe_cells`: a probe marks its cluster newly visible where the box's nearest depth is not
//   behind the first depth pass, as probe.wgsl does with fragments.
//
// Prepended: common.wgsl, cell_decode.wgsl, cell_data.wgsl, compute_lists.wgsl, cell_hit.wgsl.

@group(0) @binding(3) var<storage, read_write> visible_new: array<atomic<u32>>;

// Reversed-Z depth bits per pixel, row-major.
@group(2) @binding(0) var<storage, read_write> raster_depth: array<atomic<u32>>;
@group(2) @binding(1) var raster_surface: texture_storage_2d<rgba32float, write>;
@group(2) @binding(2) var raster_ids: texture_storage_2d<rg32uint, write>;

struct ListedCell {
    c: CellInstance,
    k: Corners,
    span: vec4<i32>,
}

fn listed_cell(instance: u32) -> ListedCell {
    let c = cell_instance(instance);
    let box = cell_box_world(c.cell);
    return ListedCell(c, cell_corners(c.cell, c.record), pixel_span(project_box(box[0], box[1])));
}

// The list a raster pipeline walks (LIST_FULL or LIST_NEW), and whether it is the depth pass
// (false) or the resolve pass (true); set when the pipeline is created.
override RASTER_LIST: u32 = LIST_FULL;
override RASTER_RESOLVE: bool = false;

@compute @workgroup_size(64)
fn raster_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let entry = list_instance(RASTER_LIST, gid, groups);
    if entry.x == 0u {
        return;
    }
    let cell = listed_cell(entry.y);
    let width = i32(frame.viewport.x);
    for (var y = cell.span.y; y <= cell.span.w; y++) {
        for (var x = cell.span.x; x <= cell.span.z; x++) {
            let hit = cell_pixel_hit(cell.k.lo, cell.k.hi, vec3<f32>(cell.c.cell), vec2<f32>(f32(x), f32(y)) + 0.5);
            if !hit.found {
                continue;
            }
            let depth = &raster_depth[x + y * width];
            if !RASTER_RESOLVE {
                atomicMax(depth, bitcast<u32>(hit.depth));
            } else if bitcast<u32>(hit.depth) == atomicLoad(depth) {
                textureStore(raster_surface, vec2<i32>(x, y), vec4<f32>(hit.normal, hit.t));
                textureStore(raster_ids, vec2<i32>(x, y), vec4<u32>(cell.c.cluster, cell_code(cell.c.record), 0u, 0u));
            }
        }
    }
}

@compute @workgroup_size(64)
fn probe_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let entry = list_instance(LIST_PROBE, gid, groups);
    if entry.x == 0u {
        return;
    }
    let c = cell_instance(entry.y);
    let box = cell_box_world(c.cell);
    let rect = project_box(box[0], box[1]);
    let span = pixel_span(rect);
    let width = i32(frame.viewport.x);
    for (var y = span.y; y <= span.w; y++) {
        for (var x = span.x; x <= span.z; x++) {
            if rect.depth >= bitcast<f32>(atomicLoad(&raster_depth[x + y * width])) {
                atomicOr(&visible_new[c.cluster >> 5u], 1u << (c.cluster & 31u));
                return;
            }
        }
    }
}

@compute @workgroup_size(8, 8)
fn clear_targets(@builtin(global_invocation_id) gid: vec3<u32>) {
    let width = u32(frame.viewport.x);
    if gid.x >= width || gid.y >= u32(frame.viewport.y) {
        return;
    }
    atomicStore(&raster_depth[gid.x + gid.y * width], 0u);
    textureStore(raster_surface, vec2<i32>(gid.xy), vec4<f32>(0.0));
    textureStore(raster_ids, vec2<i32>(gid.xy), vec4<u32>(NO_CLUSTER, NO_CLUSTER, 0u, 0u));
}

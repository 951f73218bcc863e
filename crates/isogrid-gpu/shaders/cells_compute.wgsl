// Cell rasterisation in compute passes (paper §3.2 and the probes of §3.3), the alternative to the
// hardware billboards of cells.wgsl and probe.wgsl for GPUs whose graphics pipeline is slow next to
// their compute units (on an H100 a full-screen fragment pass costs as much as a 1080p path-traced
// bounce) and for cells of a few pixels, where fixed-function setup per tiny rectangle dominates.
// One thread per listed cell loops over the pixels of the cell's projected rectangle and runs the
// same per-pixel test as the fragment shader (`cell_pixel_hit`, cell_hit.wgsl):
//
// - `depth_*`: atomicMax of the hit's reversed-Z depth bits into a per-pixel depth word (positive
//   floats order like their bit patterns; 0 = nothing yet);
// - `resolve_*`: after every depth pass, the cell whose depth equals the pixel's word writes the
//   G-buffer (normal + distance) and the IDs. The depth is recomputed by the same code from the
//   same inputs, so equality is exact; of cells that tie to the bit, any one wins;
// - `probe_cells`: a probe marks its cluster newly visible where the box's nearest depth is not
//   behind the first depth pass, as probe.wgsl does with fragments.
//
// Dispatches are indirect, sized from each list's instance count by `size_dispatches`
// (expand.wgsl).
//
// Prepended: common.wgsl, cell_decode.wgsl, cell_data.wgsl, cell_hit.wgsl.

@group(0) @binding(3) var<storage, read_write> visible_new: array<atomic<u32>>;

@group(1) @binding(3) var<storage, read_write> full_list: array<u32>;
@group(1) @binding(4) var<storage, read_write> probe_list: array<u32>;
@group(1) @binding(5) var<storage, read_write> new_list: array<u32>;
// Three DrawIndirectArgs (full, probe, new): the instance counts.
@group(1) @binding(6) var<storage, read_write> draw_args: array<u32, 12>;

// Reversed-Z depth bits per pixel, row-major.
@group(2) @binding(0) var<storage, read_write> raster_depth: array<atomic<u32>>;
@group(2) @binding(1) var raster_surface: texture_storage_2d<rgba32float, write>;
@group(2) @binding(2) var raster_ids: texture_storage_2d<rg32uint, write>;

const LIST_FULL: u32 = 0u;
const LIST_PROBE: u32 = 1u;
const LIST_NEW: u32 = 2u;
const GROUP_SIZE: u32 = 64u;

// The list entry of this thread, or none past the list's end.
fn list_instance(list: u32, gid: vec3<u32>, groups: vec3<u32>) -> vec2<u32> {
    let i = gid.x + gid.y * groups.x * GROUP_SIZE;
    if i >= draw_args[4u * list + 1u] {
        return vec2<u32>(0u, 0u);
    }
    switch list {
        case 0u: { return vec2<u32>(1u, full_list[i]); }
        case 1u: { return vec2<u32>(1u, probe_list[i]); }
        default: { return vec2<u32>(1u, new_list[i]); }
    }
}

// Pixels whose centres lie in a screen rectangle (NDC), clipped to the viewport: x0, y0, x1, y1
// inclusive; empty when x0 > x1 or y0 > y1.
fn pixel_span(r: ScreenRect) -> vec4<i32> {
    let size = frame.viewport.xy;
    // Pixel centre x + ½ ↔ NDC (2(x + ½)/w − 1); rows run downwards from NDC y = 1.
    let x0 = ceil((r.lo.x + 1.0) * 0.5 * size.x - 0.5);
    let x1 = floor((r.hi.x + 1.0) * 0.5 * size.x - 0.5);
    let y0 = ceil((1.0 - r.hi.y) * 0.5 * size.y - 0.5);
    let y1 = floor((1.0 - r.lo.y) * 0.5 * size.y - 0.5);
    let top = size - vec2<f32>(1.0);
    return vec4<i32>(
        i32(max(x0, 0.0)), i32(max(y0, 0.0)),
        i32(min(x1, top.x)), i32(min(y1, top.y)),
    );
}

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

// The list a depth or resolve pipeline walks (LIST_FULL or LIST_NEW), set when it is created.
override RASTER_LIST: u32 = LIST_FULL;

@compute @workgroup_size(64)
fn depth_pass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let entry = list_instance(RASTER_LIST, gid, groups);
    if entry.x == 0u {
        return;
    }
    let cell = listed_cell(entry.y);
    let width = i32(frame.viewport.x);
    for (var y = cell.span.y; y <= cell.span.w; y++) {
        for (var x = cell.span.x; x <= cell.span.z; x++) {
            let hit = cell_pixel_hit(cell.k.lo, cell.k.hi, vec3<f32>(cell.c.cell), vec2<f32>(f32(x), f32(y)) + 0.5);
            if hit.found {
                atomicMax(&raster_depth[x + y * width], bitcast<u32>(hit.depth));
            }
        }
    }
}

@compute @workgroup_size(64)
fn resolve_pass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let entry = list_instance(RASTER_LIST, gid, groups);
    if entry.x == 0u {
        return;
    }
    let cell = listed_cell(entry.y);
    let width = i32(frame.viewport.x);
    for (var y = cell.span.y; y <= cell.span.w; y++) {
        for (var x = cell.span.x; x <= cell.span.z; x++) {
            let hit = cell_pixel_hit(cell.k.lo, cell.k.hi, vec3<f32>(cell.c.cell), vec2<f32>(f32(x), f32(y)) + 0.5);
            if hit.found && bitcast<u32>(hit.depth) == atomicLoad(&raster_depth[x + y * width]) {
                textureStore(raster_surface, vec2<i32>(x, y), vec4<f32>(hit.normal, hit.t));
                textureStore(raster_ids, vec2<i32>(x, y), vec4<u32>(cell.c.cluster, cell.c.record, 0u, 0u));
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

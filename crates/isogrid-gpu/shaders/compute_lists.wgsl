// What the compute passes over instance lists share (cells_compute.wgsl, ewa_compute.wgsl): the
// lists of one page, the thread → list entry mapping of their indirect dispatches (sized by
// `size_dispatches` in expand.wgsl) and the pixels a screen rectangle covers.
//
// Prepended after common.wgsl and cell_decode.wgsl + cell_data.wgsl.

@group(1) @binding(3) var<storage, read_write> full_list: array<u32>;
@group(1) @binding(4) var<storage, read_write> probe_list: array<u32>;
@group(1) @binding(5) var<storage, read_write> new_list: array<u32>;
// Three DrawIndirectArgs (full, probe, new): the instance counts.
@group(1) @binding(6) var<storage, read_write> draw_args: array<u32, 12>;

const LIST_FULL: u32 = 0u;
const LIST_PROBE: u32 = 1u;
const LIST_NEW: u32 = 2u;
// Threads per workgroup of every list pass; keep in sync with RASTER_GROUP_SIZE in expand.wgsl.
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


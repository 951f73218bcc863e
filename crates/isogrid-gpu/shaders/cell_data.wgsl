// The cells of one page per bind group: the storage behind cell_decode.wgsl for the raster
// passes (expand, cells, probe, ewa), which draw page by page, and for the path tracer when the
// whole grid is one page. trace_pages.wgsl is the several-pages twin of the `trace_page_*`
// functions and of `slot_word` / `record_word`; keep their signatures in sync.
//
// Prepended after common.wgsl and cell_decode.wgsl.

// The original samples (data units) for the CR baseline; a 1×1×1 dummy otherwise.
@group(0) @binding(2) var volume: texture_3d<f32>;

@group(1) @binding(0) var<uniform> page: PageUniforms;
@group(1) @binding(1) var<storage, read> metacells: array<u32>;
@group(1) @binding(2) var<storage, read> cells: array<u32>;

// Word i of the bound page's metacell slots / corner records; there is only page 0.
fn slot_word(page_index: u32, i: u32) -> u32 {
    return metacells[i];
}

fn record_word(page_index: u32, i: u32) -> u32 {
    return cells[i];
}

// The tracer's view of the pages (see trace_pages.wgsl): one page, holding every cluster.
fn trace_page_of_slot(global_slot: u32) -> u32 {
    return 0u;
}

fn trace_page_first_slot(page_index: u32) -> u32 {
    return page.first_slot;
}

fn trace_page_first_cell(page_index: u32) -> u32 {
    return page.first_cell;
}

fn trace_page_codes_word(page_index: u32) -> u32 {
    return page.codes_word;
}

// The one page holds every slot.
fn trace_slot_is_bound(global_slot: u32) -> bool {
    return true;
}

fn trace_slots_are_bound(first_global_slot: u32, count: u32) -> bool {
    return true;
}

fn read_metacell(local_slot: u32) -> Metacell {
    return metacell_in(0u, local_slot);
}

fn cell_corners(cell: vec3<u32>, global_record: u32) -> Corners {
    if frame.params.y == SOURCE_VOLUME {
        var v: array<f32, 8>;
        for (var c = 0u; c < 8u; c++) {
            v[c] = textureLoad(volume, vec3<i32>(cell + cell_offset(c)), 0).r;
        }
        return Corners(vec4<f32>(v[0], v[1], v[2], v[3]), vec4<f32>(v[4], v[5], v[6], v[7]));
    }
    return record_corners_in(0u, global_record - page.first_cell);
}

// The attribute code of the bound page's record `global_record` (0 without an attribute), which
// the cell raster writes into the ID target's record channel for the shading pass.
fn cell_code(global_record: u32) -> u32 {
    return record_code_in(0u, page.codes_word, global_record - page.first_cell);
}

// One drawn cell: an instance is `local_slot * 8 + bit`.
struct CellInstance {
    cell: vec3<u32>,
    record: u32,  // global record index
    cluster: u32, // global cluster index (global slot / 16)
}

fn cell_instance(instance: u32) -> CellInstance {
    let local_slot = instance >> 3u;
    let bit = instance & 7u;
    let m = read_metacell(local_slot);
    let record = m.cell_pointer + countOneBits(m.mask & ((1u << bit) - 1u));
    return CellInstance(m.origin + cell_offset(bit), record, (page.first_slot + local_slot) / 16u);
}

// Screen rectangle (NDC xy min, xy max) of a world-space box and the reversed-Z depth of its nearest
// corner. A box reaching behind the near plane covers the whole screen at depth 1; one entirely
// behind it gets an empty rectangle.
struct ScreenRect {
    lo: vec2<f32>,
    hi: vec2<f32>,
    depth: f32,
}

fn project_box(lo: vec3<f32>, hi: vec3<f32>) -> ScreenRect {
    var r = ScreenRect(vec2<f32>(1e30), vec2<f32>(-1e30), 0.0);
    var behind = 0u;
    let near = frame.eye.w;
    for (var c = 0u; c < 8u; c++) {
        let p = select(lo, hi, vec3<bool>((c & 1u) != 0u, (c & 2u) != 0u, (c & 4u) != 0u));
        let clip = clip_from_world(frame, p);
        if clip.w <= near {
            behind++;
        } else {
            let ndc = clip.xy / clip.w;
            r.lo = min(r.lo, ndc);
            r.hi = max(r.hi, ndc);
            r.depth = max(r.depth, near / clip.w);
        }
    }
    if behind == 8u {
        return ScreenRect(vec2<f32>(1.0), vec2<f32>(-1.0), 0.0);
    }
    if behind > 0u {
        return ScreenRect(vec2<f32>(-1.0), vec2<f32>(1.0), 1.0);
    }
    // Half a pixel of margin so float rounding never loses a pixel centre on the rectangle's edge.
    let margin = frame.viewport.zw;
    return ScreenRect(r.lo - margin, r.hi + margin, r.depth);
}

// Corner v (0..6, two triangles) of a rectangle as a clip position at `depth`.
fn rect_vertex(r: ScreenRect, v: u32) -> vec4<f32> {
    // Triangles (0,1,2) and (2,1,3) of the corners 0 = lo, 1 = (hi.x, lo.y), 2 = (lo.x, hi.y), 3 = hi.
    var corners = array<u32, 6>(0u, 1u, 2u, 2u, 1u, 3u);
    let corner = corners[v];
    let xy = select(r.lo, r.hi, vec2<bool>((corner & 1u) != 0u, (corner & 2u) != 0u));
    return vec4<f32>(xy, r.depth, 1.0);
}

fn cell_box_world(cell: vec3<u32>) -> array<vec3<f32>, 2> {
    let s = frame.cell_to_world.xyz;
    return array<vec3<f32>, 2>(vec3<f32>(cell) * s, vec3<f32>(cell + vec3<u32>(1u)) * s);
}

// Access to the clustered grid cells of one page (paper §3.1, Table 1), byte for byte the core's
// packed layout (`isogrid::layout`): metacell slot = 3 words (x | y << 16, z | mask << 16,
// cell_pointer), corner records at the grid's precision. Prepended after common.wgsl to the
// shaders that read cells (expand, cells, probe, ewa).

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
// The original samples (data units) for the CR baseline; a 1×1×1 dummy otherwise.
@group(0) @binding(2) var volume: texture_3d<f32>;

@group(1) @binding(0) var<uniform> page: PageUniforms;
@group(1) @binding(1) var<storage, read> metacells: array<u32>;
@group(1) @binding(2) var<storage, read> cells: array<u32>;

struct Metacell {
    origin: vec3<u32>, // cell index of its cell 0 (cell units)
    mask: u32,         // active cells, bit b = cell (b&1, b>>1&1, b>>2&1)
    cell_pointer: u32, // global index of the record of its first active cell
}

fn read_metacell(local_slot: u32) -> Metacell {
    let w0 = metacells[3u * local_slot];
    let w1 = metacells[3u * local_slot + 1u];
    let w2 = metacells[3u * local_slot + 2u];
    let position = vec3<u32>(w0 & 0xffffu, w0 >> 16u, w1 & 0xffffu);
    return Metacell(2u * position, (w1 >> 16u) & 0xffu, w2);
}

fn cell_offset(bit: u32) -> vec3<u32> {
    return vec3<u32>(bit & 1u, (bit >> 1u) & 1u, (bit >> 2u) & 1u);
}

// Corner c of a packed record, exactly `isogrid::layout::read_corner`.
fn record_corner(local_record: u32, c: u32) -> f32 {
    switch frame.params.x {
        case 4u: {
            return f32((cells[local_record] >> (4u * c)) & 0xfu);
        }
        case 8u: {
            return f32((cells[2u * local_record + c / 4u] >> (8u * (c % 4u))) & 0xffu);
        }
        case 16u: {
            return f32((cells[4u * local_record + c / 2u] >> (16u * (c % 2u))) & 0xffffu);
        }
        default: {
            return bitcast<f32>(cells[8u * local_record + c]);
        }
    }
}

// The 8 corner values of a cell as two vec4 (corners 0-3, 4-7), in the units of `frame.cell_to_world.w`.
struct Corners {
    lo: vec4<f32>,
    hi: vec4<f32>,
}

fn cell_corners(cell: vec3<u32>, global_record: u32) -> Corners {
    var v: array<f32, 8>;
    if frame.params.y == SOURCE_VOLUME {
        for (var c = 0u; c < 8u; c++) {
            v[c] = textureLoad(volume, vec3<i32>(cell + cell_offset(c)), 0).r;
        }
    } else {
        let local = global_record - page.first_cell;
        for (var c = 0u; c < 8u; c++) {
            v[c] = record_corner(local, c);
        }
    }
    return Corners(vec4<f32>(v[0], v[1], v[2], v[3]), vec4<f32>(v[4], v[5], v[6], v[7]));
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

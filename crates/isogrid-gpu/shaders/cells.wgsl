// Cell rasterisation by billboard splatting (paper §3.2, Figure 3): every listed cell is drawn as a
// screen rectangle covering its projected box; each fragment intersects its pixel's ray with the
// cell (slab test), takes three samples of the trilinear interpolant of the 8 corner values along
// the segment inside the cell, refines the first sign change relative to the isovalue
// (`cell_pixel_hit`, cell_hit.wgsl), and writes the exact depth, the normal −∇f and the IDs into
// the G-buffer and the cluster-ID target. cells_compute.wgsl does the same work in compute passes.

@group(1) @binding(3) var<storage, read> instances: array<u32>;

struct CellVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) corners_lo: vec4<f32>,
    @location(1) @interpolate(flat) corners_hi: vec4<f32>,
    @location(2) @interpolate(flat) cell: vec3<f32>,
    @location(3) @interpolate(flat) ids: vec2<u32>, // cluster, attribute code (cell_code)
}

@vertex
fn vs_cell(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> CellVarying {
    let c = cell_instance(instances[instance]);
    let box = cell_box_world(c.cell);
    let k = cell_corners(c.cell, c.record);
    var out: CellVarying;
    out.position = rect_vertex(project_box(box[0], box[1]), vertex);
    out.corners_lo = k.lo;
    out.corners_hi = k.hi;
    out.cell = vec3<f32>(c.cell);
    out.ids = vec2<u32>(c.cluster, cell_code(c.record));
    return out;
}

struct GBufferOut {
    @location(0) surface: vec4<f32>, // world normal −∇f (unit), eye distance along the ray
    @location(1) ids: vec2<u32>,     // cluster, attribute code
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_cell(in: CellVarying) -> GBufferOut {
    let hit = cell_pixel_hit(in.corners_lo, in.corners_hi, in.cell, in.position.xy);
    if !hit.found {
        discard;
    }
    var out: GBufferOut;
    out.surface = vec4<f32>(hit.normal, hit.t);
    out.ids = in.ids;
    out.depth = hit.depth;
    return out;
}

// Cell rasterisation by billboard splatting (paper §3.2, Figure 3): every listed cell is drawn as a
// screen rectangle covering its projected box; each fragment intersects its pixel's ray with the
// cell (slab test), takes three samples of the trilinear interpolant of the 8 corner values along
// the segment inside the cell, refines the first sign change relative to the isovalue, and writes
// the exact depth, the normal −∇f and the IDs into the G-buffer and the cluster-ID target.

@group(1) @binding(3) var<storage, read> instances: array<u32>;

struct CellVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) corners_lo: vec4<f32>,
    @location(1) @interpolate(flat) corners_hi: vec4<f32>,
    @location(2) @interpolate(flat) cell: vec3<f32>,
    @location(3) @interpolate(flat) ids: vec2<u32>, // cluster, record
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
    out.ids = vec2<u32>(c.cluster, c.record);
    return out;
}

// Samples along the ray segment inside the cell (the paper found three sufficient).
const RAY_SAMPLES: u32 = 3u;

// −∇ of the original volume for the CR baseline: central differences at the 8 corners (one-sided
// at the border), trilinearly interpolated, in world units.
fn volume_normal(cell: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    let dims = vec3<i32>(textureDimensions(volume));
    var g: array<vec3<f32>, 8>;
    for (var c = 0u; c < 8u; c++) {
        let s = vec3<i32>(cell) + vec3<i32>(cell_offset(c));
        var grad = vec3<f32>(0.0);
        for (var a = 0; a < 3; a++) {
            var e = vec3<i32>(0);
            e[a] = 1;
            let lo = max(s - e, vec3<i32>(0));
            let hi = min(s + e, dims - vec3<i32>(1));
            let span = f32(hi[a] - lo[a]);
            if span > 0.0 {
                grad[a] = (textureLoad(volume, hi, 0).r - textureLoad(volume, lo, 0).r) / span;
            }
        }
        g[c] = grad;
    }
    let x00 = mix(g[0], g[1], p.x);
    let x10 = mix(g[2], g[3], p.x);
    let x01 = mix(g[4], g[5], p.x);
    let x11 = mix(g[6], g[7], p.x);
    let grad = mix(mix(x00, x10, p.y), mix(x01, x11, p.y), p.z);
    return -grad / frame.cell_to_world.xyz;
}

struct GBufferOut {
    @location(0) surface: vec4<f32>, // world normal −∇f (unit), eye distance along the ray
    @location(1) ids: vec2<u32>,     // cluster, record
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_cell(in: CellVarying) -> GBufferOut {
    let dir = ray_direction(frame, in.position.xy);
    let s = frame.cell_to_world.xyz;
    // Cell-local coordinates: the ray parameter t stays the world distance from the eye.
    let origin = frame.eye.xyz / s - in.cell;
    let dir_local = dir / s;
    let iso = frame.cell_to_world.w;
    let span = slab_unit_box(origin, dir_local);
    let cos_view = dot(dir, frame.forward.xyz);
    let t_enter = max(span.x, frame.eye.w / cos_view);
    let t_exit = span.y;
    if !(t_exit > t_enter) {
        discard;
    }
    let inside_at_entry = trilinear(in.corners_lo, in.corners_hi, origin + t_enter * dir_local) >= iso;
    var ta = t_enter;
    var tb = t_enter;
    var found = false;
    for (var k = 1u; k <= RAY_SAMPLES; k++) {
        ta = tb;
        tb = mix(t_enter, t_exit, f32(k) / f32(RAY_SAMPLES));
        if (trilinear(in.corners_lo, in.corners_hi, origin + tb * dir_local) >= iso) != inside_at_entry {
            found = true;
            break;
        }
    }
    if !found {
        discard;
    }
    let t = refine_crossing(in.corners_lo, in.corners_hi, origin, dir_local, ta, tb, iso, inside_at_entry);
    let p = clamp(origin + t * dir_local, vec3<f32>(0.0), vec3<f32>(1.0));
    var normal: vec3<f32>;
    if frame.params.y == SOURCE_VOLUME {
        normal = volume_normal(in.cell, p);
    } else {
        normal = -trilinear_gradient(in.corners_lo, in.corners_hi, p) / s;
    }
    let len = length(normal);
    normal = select(-dir, normal / len, len > 0.0);
    var out: GBufferOut;
    out.surface = vec4<f32>(normal, t);
    out.ids = in.ids;
    out.depth = clamp(frame.eye.w / (t * cos_view), 0.0, 1.0);
    return out;
}

// The per-pixel work of cell rasterisation (paper §3.2, Figure 3), shared by the hardware raster
// (cells.wgsl, one fragment per pixel) and the compute raster (cells_compute.wgsl, one thread per
// cell looping over its pixels), so both find bit-identical crossings: the pixel's ray is clipped
// to the cell (slab test) and to the kept side of the clip plane, three samples of the trilinear interpolant of the 8 corner values along
// the segment find the first sign change relative to the isovalue, and the crossing is refined
// between the bracketing samples.
//
// Prepended after common.wgsl and cell_decode.wgsl + cell_data.wgsl.

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

struct PixelHit {
    found: bool,
    t: f32,              // eye distance along the pixel's ray (world units)
    normal: vec3<f32>,   // world, unit, −∇f
    depth: f32,          // reversed-Z depth of the crossing
}

// The crossing of the ray through `pixel` (pixels from the top-left, at a pixel centre) with the
// surface inside `cell` (corner values `lo`, `hi`), if the three samples find one.
fn cell_pixel_hit(lo: vec4<f32>, hi: vec4<f32>, cell: vec3<f32>, pixel: vec2<f32>) -> PixelHit {
    var hit: PixelHit;
    hit.found = false;
    let dir = ray_direction(frame, pixel);
    let s = frame.cell_to_world.xyz;
    // Cell-local coordinates: the ray parameter t stays the world distance from the eye.
    let origin = frame.eye.xyz / s - cell;
    let dir_local = dir / s;
    let iso = frame.cell_to_world.w;
    let span = slab_unit_box(origin, dir_local);
    let cos_view = dot(dir, frame.forward.xyz);
    let kept = clip_segment(frame, dir, vec2<f32>(max(span.x, frame.eye.w / cos_view), span.y));
    let t_enter = kept.x;
    let t_exit = kept.y;
    if !(t_exit > t_enter) {
        return hit;
    }
    let inside_at_entry = trilinear(lo, hi, origin + t_enter * dir_local) >= iso;
    var ta = t_enter;
    var tb = t_enter;
    for (var k = 1u; k <= RAY_SAMPLES; k++) {
        ta = tb;
        tb = mix(t_enter, t_exit, f32(k) / f32(RAY_SAMPLES));
        if (trilinear(lo, hi, origin + tb * dir_local) >= iso) != inside_at_entry {
            hit.found = true;
            break;
        }
    }
    if !hit.found {
        return hit;
    }
    let t = refine_crossing(lo, hi, origin, dir_local, ta, tb, iso, inside_at_entry);
    let p = clamp(origin + t * dir_local, vec3<f32>(0.0), vec3<f32>(1.0));
    var normal: vec3<f32>;
    if frame.params.y == SOURCE_VOLUME {
        normal = volume_normal(cell, p);
    } else {
        normal = -trilinear_gradient(lo, hi, p) / s;
    }
    let len = length(normal);
    hit.normal = select(-dir, normal / len, len > 0.0);
    hit.t = t;
    hit.depth = clamp(frame.eye.w / (t * cos_view), 0.0, 1.0);
    if (frame.params.z & FLAG_LABELS) != 0u && inside_at_entry {
        // A label grid draws touching labels' coinciding surfaces once each: the one the ray
        // leaves loses at equal depth.
        hit.depth = label_back_face_depth(hit.depth);
    }
    return hit;
}

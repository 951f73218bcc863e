// EWA-style attribute splatting (paper §3.4): every rasterised cell is splatted as a round
// Gaussian that adds its weighted cell normal to a per-pixel sum; the shading pass divides by the
// summed weight. The splat is centred on the cell's surface point estimate (one Newton step from
// the cell centre along the corner-value gradient) and weighted by a Gaussian of the cell-space
// distance from the surface point that the raster pass found at the pixel, which also acts as the
// depth test with a tolerance: splats more than two sigma away from the visible surface point, more
// than one sigma off its tangent plane, or facing the other way, add nothing.
//
// Shared by the hardware splats (ewa.wgsl: rectangles, additive blending) and the compute splats
// (ewa_compute.wgsl: one thread per cell, integer atomics). Prepended after common.wgsl and
// cell_decode.wgsl + cell_data.wgsl.

struct Splat {
    center: vec3<f32>, // cell space
    normal: vec3<f32>, // world, unit (zero where the gradient vanishes)
    rect: ScreenRect,
}

fn cell_splat(instance: u32) -> Splat {
    let c = cell_instance(instance);
    let k = cell_corners(c.cell, c.record);
    let mid = vec3<f32>(0.5);
    let g = trilinear_gradient(k.lo, k.hi, mid);
    let f = trilinear(k.lo, k.hi, mid) - frame.cell_to_world.w;
    let gg = dot(g, g);
    var local = mid;
    if gg > 0.0 {
        local = clamp(mid - f * g / gg, vec3<f32>(0.0), vec3<f32>(1.0));
    }
    let center = vec3<f32>(c.cell) + local;
    let radius = 2.0 * frame.forward.w;
    let s = frame.cell_to_world.xyz;
    let n = -g / s;
    return Splat(center, select(vec3<f32>(0.0), normalize(n), dot(n, n) > 0.0), project_box((center - radius) * s, (center + radius) * s));
}

// The splat's weight at `pixel` (pixels from the top-left, at a pixel centre) over the raster
// surface texel there (normal, eye distance; w = 0 where nothing was hit); 0 adds nothing.
fn splat_weight(center: vec3<f32>, normal: vec3<f32>, pixel: vec2<f32>, surface: vec4<f32>) -> f32 {
    // A splat cut away by the clip plane adds nothing (its cell draws nothing there either).
    if surface.w <= 0.0 || dot(surface.xyz, normal) <= 0.0 || !clip_keeps(frame, center * frame.cell_to_world.xyz) {
        return 0.0;
    }
    let dir = ray_direction(frame, pixel);
    let p = (frame.eye.xyz + surface.w * dir) / frame.cell_to_world.xyz;
    let d = p - center;
    let sigma = frame.forward.w;
    let r2 = dot(d, d) / (sigma * sigma);
    // Depth tolerance: a splat whose surface point is off the visible surface's tangent plane by
    // more than sigma belongs to another sheet (thin or close layers), not to this one.
    let s = frame.cell_to_world.xyz;
    let off_plane = abs(dot(d * s, surface.xyz)) / min(min(s.x, s.y), s.z);
    if r2 > 4.0 || off_plane > sigma {
        return 0.0;
    }
    return exp(-0.5 * r2);
}

// EWA-style attribute splatting (paper §3.4): a second pass draws every rasterised cell as a round
// Gaussian splat that adds its weighted cell normal to a float accumulation target (additive
// blending); the shading pass divides by the summed weight. The splat is centred on the cell's
// surface point estimate (one Newton step from the cell centre along the corner-value gradient)
// and weighted by a Gaussian of the cell-space distance from the surface point that the raster
// pass found at the pixel, which also acts as the depth test with a tolerance: splats more than
// two sigma away from the visible surface point, more than one sigma off its tangent plane, or
// facing the other way, add nothing.

@group(1) @binding(3) var<storage, read> instances: array<u32>;
@group(2) @binding(0) var raster_surface: texture_2d<f32>;

struct SplatVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) center: vec3<f32>, // cell space
    @location(1) @interpolate(flat) normal: vec3<f32>,  // world, unit
}

@vertex
fn vs_splat(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> SplatVarying {
    let c = cell_instance(instances[instance]);
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
    var out: SplatVarying;
    out.position = rect_vertex(project_box((center - radius) * s, (center + radius) * s), vertex);
    out.center = center;
    let n = -g / s;
    out.normal = select(vec3<f32>(0.0), normalize(n), dot(n, n) > 0.0);
    return out;
}

@fragment
fn fs_splat(in: SplatVarying) -> @location(0) vec4<f32> {
    let surface = textureLoad(raster_surface, vec2<i32>(in.position.xy), 0);
    if surface.w <= 0.0 || dot(surface.xyz, in.normal) <= 0.0 {
        discard;
    }
    let dir = ray_direction(frame, in.position.xy);
    let p = (frame.eye.xyz + surface.w * dir) / frame.cell_to_world.xyz;
    let d = p - in.center;
    let sigma = frame.forward.w;
    let r2 = dot(d, d) / (sigma * sigma);
    // Depth tolerance: a splat whose surface point is off the visible surface's tangent plane by
    // more than sigma belongs to another sheet (thin or close layers), not to this one.
    let s = frame.cell_to_world.xyz;
    let off_plane = abs(dot(d * s, surface.xyz)) / min(min(s.x, s.y), s.z);
    if r2 > 4.0 || off_plane > sigma {
        discard;
    }
    let w = exp(-0.5 * r2);
    return vec4<f32>(w * in.normal, w);
}

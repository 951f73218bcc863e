// EWA normal splatting through the graphics pipeline (paper §3.4, see ewa_splat.wgsl): each cell's
// splat is a screen rectangle whose fragments add the weighted normal to a float target by
// additive blending. ewa_compute.wgsl does the same in compute passes.

@group(1) @binding(3) var<storage, read> instances: array<u32>;
@group(2) @binding(0) var raster_surface: texture_2d<f32>;

struct SplatVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) center: vec3<f32>, // cell space
    @location(1) @interpolate(flat) normal: vec3<f32>,  // world, unit
}

@vertex
fn vs_splat(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> SplatVarying {
    let splat = cell_splat(instances[instance]);
    var out: SplatVarying;
    out.position = rect_vertex(splat.rect, vertex);
    out.center = splat.center;
    out.normal = splat.normal;
    return out;
}

@fragment
fn fs_splat(in: SplatVarying) -> @location(0) vec4<f32> {
    let surface = textureLoad(raster_surface, vec2<i32>(in.position.xy), 0);
    let w = splat_weight(in.center, in.normal, in.position.xy, surface);
    if w <= 0.0 {
        discard;
    }
    return vec4<f32>(w * in.normal, w);
}

// Deferred normalised Blinn–Phong shading (paper §3.2) of the G-buffer, with the EWA-accumulated
// normals (§3.4) when present, and the albedo of a colour map (color.wgsl) over the hit cell's
// attribute value or the MC mesh's interpolated vertex value: a full-screen fragment pass after
// the hardware raster, a compute pass after the compute raster (the same `shade_pixel`; on GPUs
// with a weak graphics pipeline the fragment pass alone costs more than the whole compute
// raster). Keep the constants and the formula in sync with `crates/isogrid/src/shading.rs`
// (`shade_albedo`, `to_srgb8`, `BACKGROUND_SRGB`).

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(1) @binding(0) var raster_surface: texture_2d<f32>;
@group(1) @binding(1) var ewa_normals: texture_2d<f32>;
@group(1) @binding(2) var cluster_ids: texture_2d<u32>;

@group(1) @binding(3) var<uniform> coloring: ColorUniforms;
// The colour data of color.wgsl (label albedos); a dummy otherwise.
@group(1) @binding(4) var<storage, read> color_data: array<u32>;
// The compute pass's outputs (the fragment pass writes the same as render targets).
@group(2) @binding(0) var shaded_color: texture_storage_2d<rgba8unorm, write>;
@group(2) @binding(1) var shaded_normal: texture_storage_2d<rgba32float, write>;
@group(2) @binding(2) var shaded_value: texture_storage_2d<r32float, write>;

const KEY_LIGHT_DIR: vec3<f32> = vec3<f32>(-0.40, 0.55, 0.73);
const KEY_LIGHT_RADIANCE: f32 = 2.6;
const FILL_LIGHT_DIR: vec3<f32> = vec3<f32>(0.70, -0.10, 0.70);
const FILL_LIGHT_RADIANCE: f32 = 0.6;
const AMBIENT: f32 = 0.06;
const ALBEDO: vec3<f32> = vec3<f32>(0.80, 0.74, 0.66);
const SPECULAR: f32 = 0.25;
const SHININESS: f32 = 48.0;
const BACKGROUND_SRGB: vec3<f32> = vec3<f32>(28.0, 30.0, 36.0);
const PI: f32 = 3.14159265358979;

fn blinn_phong(n_in: vec3<f32>, view: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let n = select(n_in, -n_in, dot(n_in, view) < 0.0);
    var rgb = albedo * AMBIENT;
    var dirs = array<vec3<f32>, 2>(KEY_LIGHT_DIR, FILL_LIGHT_DIR);
    var radiance = array<f32, 2>(KEY_LIGHT_RADIANCE, FILL_LIGHT_RADIANCE);
    for (var i = 0; i < 2; i++) {
        let l = normalize(dirs[i]);
        let ndl = max(dot(n, l), 0.0);
        if ndl <= 0.0 {
            continue;
        }
        let h = normalize(l + view);
        let spec = SPECULAR * (SHININESS + 8.0) / (8.0 * PI) * pow(max(dot(n, h), 0.0), SHININESS);
        rgb += radiance[i] * ndl * (albedo / PI + vec3<f32>(spec));
    }
    return rgb;
}

struct ShadeOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>, // final world normal (EWA or raster), eye distance
    @location(2) value: vec4<f32>,  // x: the attribute value the colour shows; NaN on a miss or uncoloured
}

// The attribute value under a hit pixel with IDs `ids` (cluster, then the cell's attribute code
// from the cell raster or the value's bits from the mesh pass).
fn surface_value(ids: vec2<u32>) -> f32 {
    if coloring.params.x == COLOR_MESH {
        return bitcast<f32>(ids.y);
    }
    return code_value(ids.y);
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((vertex << 1u) & 2u), f32(vertex & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn shade_pixel(position: vec2<f32>) -> ShadeOut {
    let pixel = vec2<i32>(position);
    var out: ShadeOut;
    let nan = bitcast<f32>(coloring.params.z);
    let ids = textureLoad(cluster_ids, pixel, 0).rg;
    if ids.x == NO_CLUSTER {
        out.color = vec4<f32>(BACKGROUND_SRGB / 255.0, 1.0);
        out.normal = vec4<f32>(0.0);
        out.value = vec4<f32>(nan);
        return out;
    }
    var albedo = ALBEDO;
    out.value = vec4<f32>(nan);
    if coloring.params.x == COLOR_LABELS {
        albedo = cluster_albedo(ids.x);
        // The path tracer's raster primaries find their cluster here (no value AOV for labels).
        out.value = vec4<f32>(bitcast<f32>(ids.x));
    } else if coloring.params.x != COLOR_NONE {
        let value = surface_value(ids);
        albedo = albedo_of(value);
        out.value = vec4<f32>(value);
    }
    let surface = textureLoad(raster_surface, pixel, 0);
    var n = surface.xyz;
    if (frame.params.z & FLAG_EWA) != 0u {
        let acc = textureLoad(ewa_normals, pixel, 0);
        let len = length(acc.xyz);
        if acc.w > 0.0 && len > 0.0 {
            n = acc.xyz / len;
        }
    }
    let dir = ray_direction(frame, position);
    // Camera space: x right, y up, z towards the viewer.
    let n_cam = vec3<f32>(dot(n, frame.right.xyz), dot(n, frame.up.xyz), -dot(n, frame.forward.xyz));
    let view = -vec3<f32>(dot(dir, frame.right.xyz), dot(dir, frame.up.xyz), -dot(dir, frame.forward.xyz));
    let rgb = blinn_phong(n_cam, normalize(view), albedo);
    out.color = vec4<f32>(to_srgb8(rgb.x), to_srgb8(rgb.y), to_srgb8(rgb.z), 1.0);
    out.normal = vec4<f32>(n, surface.w);
    return out;
}

@fragment
fn fs_shade(@builtin(position) position: vec4<f32>) -> ShadeOut {
    return shade_pixel(position.xy);
}

@compute @workgroup_size(8, 8)
fn shade_pixels(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= u32(frame.viewport.x) || gid.y >= u32(frame.viewport.y) {
        return;
    }
    let out = shade_pixel(vec2<f32>(gid.xy) + 0.5);
    textureStore(shaded_color, vec2<i32>(gid.xy), out.color);
    textureStore(shaded_normal, vec2<i32>(gid.xy), out.normal);
    textureStore(shaded_value, vec2<i32>(gid.xy), out.value);
}

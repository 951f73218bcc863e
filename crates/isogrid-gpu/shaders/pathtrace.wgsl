// Hybrid path tracing (paper §3.6, Figure 6): primary hits come from the raster G-buffer (final
// normal and eye distance of the deferred shading pass); from there, one path per pixel and frame
// bounces off Lambertian surfaces with cosine-weighted directions, traced through the clustered
// grid cells by `trace_ray` (trace.wgsl), until it escapes to the environment or runs out of
// bounces (then it contributes nothing). Each frame adds its sample to a per-pixel sum; the mean
// is written as sRGB 8-bit. `sky` and `environment` are twins of the core's
// `isogrid::env_map::sky` and `EnvMap::radiance` (crates/isogrid/src/env_map.rs): keep them in
// sync; `to_srgb8` is shared, in common.wgsl.
//
// `path_trace_traced_primary` (`PrimaryRays::Traced`) is the same path tracer with the primary
// ray from the eye through the pixel centre traced by `trace_ray` too, for devices whose graphics
// pipeline is slow next to their compute (no raster pass runs then); it writes the primary hit
// where the raster passes would have, so the frame's AOVs read back alike.
//
// Prepended: common.wgsl, cell_decode.wgsl, cell_data.wgsl or trace_pages.wgsl, trace.wgsl; grids
// of more pages than one pass binds append wavefront.wgsl.

// Final world normal (xyz; zero on a miss) and eye distance (w) from the shading pass.
@group(2) @binding(0) var gbuffer: texture_2d<f32>;
// Running sum of linear radiance (rgb) and sample count (a) per pixel, row-major.
@group(2) @binding(1) var<storage, read_write> accumulation: array<vec4<f32>>;
@group(2) @binding(2) var output: texture_storage_2d<rgba8unorm, write>;
// Equirectangular RGB radiance (rgba32float, a unused); a 1×1 dummy when the built-in sky is used.
@group(2) @binding(3) var env: texture_2d<f32>;
// Traced primaries only, instead of `gbuffer`: the primary hit's world normal (xyz; zero on a
// miss) and eye distance (w), and its cluster (x; NO_CLUSTER on a miss; y unused). Bindings 4
// and 5 are trace.wgsl's `rays` and `hits`.
@group(2) @binding(6) var primary_surface: texture_storage_2d<rgba32float, write>;
@group(2) @binding(7) var primary_ids: texture_storage_2d<rg32uint, write>;
// Surface colour (color.wgsl): every surface's albedo is its attribute's colour (COLOR_RECORDS)
// or its label's (COLOR_LABELS), else `trace.albedo`. Raster primaries take their value, or for
// labels their cluster's bits, from the shading pass's value target.
@group(0) @binding(4) var<uniform> coloring: ColorUniforms;
@group(0) @binding(5) var<storage, read> color_data: array<u32>;
@group(0) @binding(6) var primary_values: texture_2d<f32>;

const PI: f32 = 3.14159265358979;

// Built-in sky (world +y up, the camera presets' up): horizon → zenith gradient above, horizon →
// ground below, plus a smooth sun lobe. Twin of `sky` in crates/isogrid/src/env_map.rs.
const SKY_ZENITH: vec3<f32> = vec3<f32>(0.20, 0.40, 0.90);
const SKY_HORIZON: vec3<f32> = vec3<f32>(0.85, 0.90, 1.00);
const SKY_GROUND: vec3<f32> = vec3<f32>(0.30, 0.27, 0.24);
const SUN_DIR: vec3<f32> = vec3<f32>(-0.35, 0.80, 0.50);
const SUN_RADIANCE: vec3<f32> = vec3<f32>(12.0, 11.0, 9.5);
const SUN_EXPONENT: f32 = 64.0;

fn sky(d: vec3<f32>) -> vec3<f32> {
    var base: vec3<f32>;
    if d.y >= 0.0 {
        base = mix(SKY_HORIZON, SKY_ZENITH, sqrt(d.y));
    } else {
        base = mix(SKY_HORIZON, SKY_GROUND, sqrt(-d.y));
    }
    return base + SUN_RADIANCE * pow(max(dot(d, normalize(SUN_DIR)), 0.0), SUN_EXPONENT);
}

// Radiance arriving from direction d (unit, world): the environment map, or the sky. Twin of
// `EnvMap::radiance` in crates/isogrid/src/env_map.rs, whose doc gives the orientation (centre
// column −z, row 0 +y, +x a quarter right of the centre): column (φ + π) / 2π · width with
// φ = atan2(d.x, −d.z); row acos(d.y) / π · height; bilinear between texel centres, wrapping in φ
// and clamping at the poles.
fn environment(d: vec3<f32>) -> vec3<f32> {
    if trace.sample.y == 0u {
        return sky(d);
    }
    let size = vec2<i32>(textureDimensions(env));
    let phi = atan2(d.x, -d.z);
    let theta = acos(clamp(d.y, -1.0, 1.0));
    let uv = vec2<f32>((phi + PI) / (2.0 * PI), theta / PI) * vec2<f32>(size) - 0.5;
    let base = floor(uv);
    let f = uv - base;
    let x0 = ((i32(base.x) % size.x) + size.x) % size.x;
    let x1 = (x0 + 1) % size.x;
    let y0 = clamp(i32(base.y), 0, size.y - 1);
    let y1 = clamp(i32(base.y) + 1, 0, size.y - 1);
    let top = mix(textureLoad(env, vec2<i32>(x0, y0), 0).rgb, textureLoad(env, vec2<i32>(x1, y0), 0).rgb, f.x);
    let bottom = mix(textureLoad(env, vec2<i32>(x0, y1), 0).rgb, textureLoad(env, vec2<i32>(x1, y1), 0).rgb, f.x);
    return mix(top, bottom, f.y);
}

// PCG hash (Jarzynski & Olano 2020, "Hash functions for GPU rendering").
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1) from the 24 high bits of the next state.
fn random(state: ptr<function, u32>) -> f32 {
    *state = pcg(*state);
    return f32(*state >> 8u) * (1.0 / 16777216.0);
}

// Cosine-weighted direction about unit n (pdf cos θ / π), with the branchless orthonormal basis
// of Duff et al. 2017.
fn cosine_direction(n: vec3<f32>, u1: f32, u2: f32) -> vec3<f32> {
    let flip = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (flip + n.z);
    let b = n.x * n.y * a;
    let tangent = vec3<f32>(1.0 + flip * n.x * n.x * a, flip * b, -flip * n.x);
    let bitangent = vec3<f32>(b, flip + n.y * n.y * a, -n.y);
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    return normalize(r * cos(phi) * tangent + r * sin(phi) * bitangent + sqrt(max(1.0 - u1, 0.0)) * n);
}

fn pixel_index(pixel: vec2<u32>) -> u32 {
    return pixel.x + pixel.y * u32(frame.viewport.x);
}

// The random stream of a pixel's path in this frame's sample.
fn path_rng(index: u32) -> u32 {
    return pcg(index ^ pcg(trace.sample.x));
}

// A unit normal turned to face against direction `dir`.
fn facing(normal: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    return select(normal, -normal, dot(normal, dir) > 0.0);
}

struct BounceRay {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// The next ray of a path at surface point p with facing normal n: a cosine-weighted direction,
// from just off the surface.
fn bounce_ray(p: vec3<f32>, n: vec3<f32>, rng: ptr<function, u32>) -> BounceRay {
    let u1 = random(rng);
    let u2 = random(rng);
    return BounceRay(p + trace.cell_dims.w * n, cosine_direction(n, u1, u2));
}

// The diffuse albedo of a surface in cluster `cluster` whose cell has attribute code `code`.
fn surface_albedo(code: u32, cluster: u32) -> vec3<f32> {
    if coloring.params.x == COLOR_RECORDS {
        return albedo_of(code_value(code));
    }
    if coloring.params.x == COLOR_LABELS {
        return cluster_albedo(cluster);
    }
    return trace.albedo.rgb;
}

// The albedo of pixel `pixel`'s raster primary hit (the value the shading pass coloured it by).
fn raster_primary_albedo(pixel: vec2<u32>) -> vec3<f32> {
    let value = textureLoad(primary_values, vec2<i32>(pixel), 0).r;
    if coloring.params.x == COLOR_RECORDS {
        return albedo_of(value);
    }
    if coloring.params.x == COLOR_LABELS {
        return cluster_albedo(bitcast<u32>(value));
    }
    return trace.albedo.rgb;
}

// Adds a path's radiance to pixel `pixel`'s sum and writes the tone-mapped mean.
fn add_sample(index: u32, pixel: vec2<u32>, radiance: vec3<f32>) {
    let sum = accumulation[index] + vec4<f32>(radiance, 1.0);
    accumulation[index] = sum;
    let mean = sum.rgb / sum.a;
    textureStore(output, vec2<i32>(pixel), vec4<f32>(to_srgb8(mean.r), to_srgb8(mean.g), to_srgb8(mean.b), 1.0));
}

// Follows the path of pixel `pixel` (ray direction `dir` from the eye) from its primary hit
// `primary` (world normal xyz, zero on a miss; eye distance w) of albedo `albedo`, and adds its
// radiance to the pixel's sum and tone-mapped mean. wavefront.wgsl takes the same steps, one pass
// each.
fn follow_path(pixel: vec2<u32>, dir: vec3<f32>, primary: vec4<f32>, albedo: vec3<f32>) {
    let index = pixel_index(pixel);
    var rng = path_rng(index);
    var radiance = vec3<f32>(0.0);
    if dot(primary.xyz, primary.xyz) == 0.0 {
        radiance = environment(dir);
    } else {
        var p = frame.eye.xyz + primary.w * dir;
        var n = facing(primary.xyz, dir);
        var throughput = albedo;
        for (var bounce = 0u; bounce < trace.block_dims.w; bounce++) {
            let ray = bounce_ray(p, n, &rng);
            let hit = trace_ray(ray.origin, ray.direction, 0.0, NO_HIT);
            if hit.t >= NO_HIT {
                radiance = throughput * environment(ray.direction);
                break;
            }
            p = ray.origin + hit.t * ray.direction;
            n = facing(hit.normal, ray.direction);
            throughput *= surface_albedo(hit.code, hit.cluster);
        }
    }
    add_sample(index, pixel, radiance);
}

fn outside_image(gid: vec3<u32>) -> bool {
    return gid.x >= u32(frame.viewport.x) || gid.y >= u32(frame.viewport.y);
}

// Raster primaries: the shading pass's G-buffer.
@compute @workgroup_size(8, 8)
fn path_trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let dir = ray_direction(frame, vec2<f32>(gid.xy) + 0.5);
    follow_path(gid.xy, dir, textureLoad(gbuffer, vec2<i32>(gid.xy), 0), raster_primary_albedo(gid.xy));
}

// Traced primaries: from the eye through the pixel centre, exactly the raster's ray.
@compute @workgroup_size(8, 8)
fn path_trace_traced_primary(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let dir = ray_direction(frame, vec2<f32>(gid.xy) + 0.5);
    let hit = trace_ray(frame.eye.xyz, dir, 0.0, NO_HIT);
    let primary = select(vec4<f32>(0.0), vec4<f32>(hit.normal, hit.t), hit.t < NO_HIT);
    textureStore(primary_surface, vec2<i32>(gid.xy), primary);
    textureStore(primary_ids, vec2<i32>(gid.xy), vec4<u32>(hit.cluster, 0u, 0u, 0u));
    follow_path(gid.xy, dir, primary, surface_albedo(hit.code, hit.cluster));
}

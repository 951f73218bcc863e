// Wavefront path tracing (paper §3.6) for grids in more pages than one pass binds: pathtrace.wgsl's
// `follow_path` cut into passes, with each pixel's path state kept in `paths` between them. Per
// frame: `wave_start` (raster primaries) or `wave_start_traced` + traces + `wave_resolve_primary`
// (traced primaries) set up each path's first bounce ray; then per bounce, `wave_trace` runs once
// per group of bound pages, each keeping the nearer crossing, and `wave_resolve` takes the bounce
// (or adds the sample of a path that escaped or ran out of bounces). The closest crossing over the
// groups is the closest crossing in the grid, and every step does `follow_path`'s arithmetic, so
// paths and samples are those of a trace with the whole grid bound.
//
// Appended after pathtrace.wgsl (over trace_pages.wgsl).

// One pixel's path between passes (64 bytes; src/pathtrace/wavefront.rs sizes the buffer).
struct PathState {
    origin: vec3<f32>,     // the ray in flight: origin (world)
    bounce: u32,           // its bounce (0 for the first after the primary); PATH_DONE once the sample is added
    direction: vec3<f32>,  // and unit direction
    rng: u32,              // the path's random stream after drawing this ray
    hit: vec4<f32>,        // nearest crossing of the ray over the groups traced so far: normal xyz, t w (NO_HIT)
    throughput: vec3<f32>, // albedo product of the surfaces so far
    cluster: u32,          // cluster of the nearest crossing (NO_CLUSTER)
    code: u32,             // and its cell's attribute code (read while its page is bound)
}

const PATH_DONE: u32 = 0xffffffffu;

@group(2) @binding(8) var<storage, read_write> paths: array<PathState>;

fn no_path() -> PathState {
    return PathState(vec3<f32>(0.0), PATH_DONE, vec3<f32>(0.0), 0u, vec4<f32>(0.0, 0.0, 0.0, NO_HIT), vec3<f32>(0.0), NO_CLUSTER, 0u);
}

// Starts the path of pixel `pixel` (eye ray direction `dir`) from its primary hit `primary`
// (world normal xyz, zero on a miss; eye distance w): a miss, or a hit with no bounces to take,
// adds its sample at once; otherwise the first bounce ray waits for the traces.
fn wave_begin(pixel: vec2<u32>, dir: vec3<f32>, primary: vec4<f32>, albedo: vec3<f32>) {
    let index = pixel_index(pixel);
    var rng = path_rng(index);
    if dot(primary.xyz, primary.xyz) == 0.0 {
        add_sample(index, pixel, environment(dir));
        paths[index] = no_path();
    } else if trace.block_dims.w == 0u {
        add_sample(index, pixel, vec3<f32>(0.0));
        paths[index] = no_path();
    } else {
        let p = frame.eye.xyz + primary.w * dir;
        let ray = bounce_ray(p, facing(primary.xyz, dir), &rng);
        paths[index] = PathState(ray.origin, 0u, ray.direction, rng, vec4<f32>(0.0, 0.0, 0.0, NO_HIT), albedo, NO_CLUSTER, 0u);
    }
}

// Raster primaries: the shading pass's G-buffer.
@compute @workgroup_size(8, 8)
fn wave_start(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let dir = ray_direction(frame, vec2<f32>(gid.xy) + 0.5);
    wave_begin(gid.xy, dir, textureLoad(gbuffer, vec2<i32>(gid.xy), 0), raster_primary_albedo(gid.xy));
}

// Traced primaries: the eye ray through the pixel centre, traced next like a bounce.
@compute @workgroup_size(8, 8)
fn wave_start_traced(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let index = pixel_index(gid.xy);
    let dir = ray_direction(frame, vec2<f32>(gid.xy) + 0.5);
    paths[index] = PathState(frame.eye.xyz, 0u, dir, 0u, vec4<f32>(0.0, 0.0, 0.0, NO_HIT), vec3<f32>(0.0), NO_CLUSTER, 0u);
}

// One group of pages: each path's ray keeps the nearer of its crossing so far and this group's.
@compute @workgroup_size(8, 8)
fn wave_trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let index = pixel_index(gid.xy);
    let s = paths[index];
    if s.bounce == PATH_DONE {
        return;
    }
    let hit = trace_ray_until(s.origin, s.direction, 0.0, NO_HIT, s.hit.w);
    if hit.t < s.hit.w {
        paths[index].hit = vec4<f32>(hit.normal, hit.t);
        paths[index].cluster = hit.cluster;
        paths[index].code = hit.code;
    }
}

// Traced primaries, after their traces: the primary hit goes where the raster passes would have
// put it, and the path starts from it as `path_trace_traced_primary` starts it.
@compute @workgroup_size(8, 8)
fn wave_resolve_primary(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let s = paths[pixel_index(gid.xy)];
    let primary = select(vec4<f32>(0.0), s.hit, s.hit.w < NO_HIT);
    textureStore(primary_surface, vec2<i32>(gid.xy), primary);
    textureStore(primary_ids, vec2<i32>(gid.xy), vec4<u32>(s.cluster, 0u, 0u, 0u));
    wave_begin(gid.xy, s.direction, primary, surface_albedo(s.code, s.cluster));
}

// A bounce, after its traces: an escaped path adds the environment, a path out of bounces adds
// nothing, and the others draw their next bounce ray.
@compute @workgroup_size(8, 8)
fn wave_resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    if outside_image(gid) {
        return;
    }
    let index = pixel_index(gid.xy);
    let s = paths[index];
    if s.bounce == PATH_DONE {
        return;
    }
    if s.hit.w >= NO_HIT {
        add_sample(index, gid.xy, s.throughput * environment(s.direction));
        paths[index].bounce = PATH_DONE;
        return;
    }
    if s.bounce + 1u >= trace.block_dims.w {
        add_sample(index, gid.xy, vec3<f32>(0.0));
        paths[index].bounce = PATH_DONE;
        return;
    }
    let p = s.origin + s.hit.w * s.direction;
    var rng = s.rng;
    let ray = bounce_ray(p, facing(s.hit.xyz, s.direction), &rng);
    paths[index] = PathState(ray.origin, s.bounce + 1u, ray.direction, rng, vec4<f32>(0.0, 0.0, 0.0, NO_HIT), s.throughput * surface_albedo(s.code, s.cluster), NO_CLUSTER, 0u);
}

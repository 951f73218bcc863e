// EWA normal splatting in compute passes (paper §3.4, see ewa_splat.wgsl), the companion of the
// compute cell raster (cells_compute.wgsl): one thread per listed cell walks its splat's rectangle
// and adds the weighted normal and the weight to per-pixel integer sums with atomics (WGSL has no
// float atomics everywhere); a per-pixel pass then writes the sums to the EWA target that the
// shading pass reads, as the hardware splats' additive blending leaves it.
//
// Prepended: common.wgsl, cell_decode.wgsl, cell_data.wgsl, compute_lists.wgsl, ewa_splat.wgsl.

// Weighted normal xyz and weight per pixel, row-major, in units of 1 / EWA_FIXED_ONE.
@group(2) @binding(0) var<storage, read_write> ewa_sum: array<atomic<i32>>;
@group(2) @binding(1) var raster_surface: texture_2d<f32>;
@group(2) @binding(2) var ewa_target: texture_storage_2d<rgba16float, write>;

// Fixed-point scale of the sums: 2^16 keeps a contribution's rounding (≈ 1e-5) under the half-float
// target's precision, and the sum of up to 32767 unit weights per pixel inside an i32. A pixel
// gathers splats of the cells within two sigma of its surface point, a few dozen at most.
const EWA_FIXED_ONE: f32 = 65536.0;

// The list a splat pipeline walks (LIST_FULL or LIST_NEW), set when the pipeline is created.
override EWA_LIST: u32 = LIST_FULL;

@compute @workgroup_size(64)
fn splat_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let entry = list_instance(EWA_LIST, gid, groups);
    if entry.x == 0u {
        return;
    }
    let splat = cell_splat(entry.y);
    let span = pixel_span(splat.rect);
    let width = i32(frame.viewport.x);
    for (var y = span.y; y <= span.w; y++) {
        for (var x = span.x; x <= span.z; x++) {
            let pixel = vec2<f32>(f32(x), f32(y)) + 0.5;
            let w = splat_weight(splat.center, splat.normal, pixel, textureLoad(raster_surface, vec2<i32>(x, y), 0));
            if w > 0.0 {
                let sum = vec4<i32>(round(vec4<f32>(w * splat.normal, w) * EWA_FIXED_ONE));
                let at = 4 * (x + y * width);
                atomicAdd(&ewa_sum[at], sum.x);
                atomicAdd(&ewa_sum[at + 1], sum.y);
                atomicAdd(&ewa_sum[at + 2], sum.z);
                atomicAdd(&ewa_sum[at + 3], sum.w);
            }
        }
    }
}

@compute @workgroup_size(8, 8)
fn resolve_splats(@builtin(global_invocation_id) gid: vec3<u32>) {
    let width = u32(frame.viewport.x);
    if gid.x >= width || gid.y >= u32(frame.viewport.y) {
        return;
    }
    let at = 4u * (gid.x + gid.y * width);
    let sum = vec4<i32>(atomicLoad(&ewa_sum[at]), atomicLoad(&ewa_sum[at + 1u]), atomicLoad(&ewa_sum[at + 2u]), atomicLoad(&ewa_sum[at + 3u]));
    textureStore(ewa_target, vec2<i32>(gid.xy), vec4<f32>(sum) / EWA_FIXED_ONE);
}

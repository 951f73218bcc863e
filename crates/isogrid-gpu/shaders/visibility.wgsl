// Visibility buffer update (paper §3.3): after the frame's raster passes, every cluster whose ID is
// in the cluster-ID target gets its bit in the visibility buffer used by the next frame's
// expansion (the buffer was cleared just before this pass).

@group(0) @binding(1) var<storage, read_write> visible_last_frame: array<atomic<u32>>;
@group(1) @binding(0) var cluster_ids: texture_2d<u32>;

@compute @workgroup_size(8, 8)
fn update_visibility(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(cluster_ids);
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let cluster = textureLoad(cluster_ids, vec2<i32>(gid.xy), 0).r;
    if cluster != NO_CLUSTER {
        atomicOr(&visible_last_frame[cluster >> 5u], 1u << (cluster & 31u));
    }
}

// Visibility probes (paper §3.3): cells of clusters that were not visible last frame are splatted
// so that clusters becoming visible are found. A probe covers the cell's projected rectangle at the
// depth of the box's nearest corner and marks its cluster in the "new" visibility buffer where that
// depth is not behind the first raster pass's depth. This is conservative: any visible surface
// point of the cell lies inside the rectangle and no nearer than that corner, so a cluster with a
// visible pixel is always marked. (The paper's probes are single pixels; a whole rectangle costs
// more fragments but cannot miss a partly occluded cluster.) The depth test is done by hand
// against the depth texture because the probe writes nothing but the visibility bit.

@group(0) @binding(3) var<storage, read_write> visible_new: array<atomic<u32>>;
@group(1) @binding(3) var<storage, read> instances: array<u32>;
@group(2) @binding(0) var raster_depth: texture_depth_2d;

struct ProbeVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) cluster: u32,
    @location(1) @interpolate(flat) near_depth: f32,
}

@vertex
fn vs_probe(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> ProbeVarying {
    let c = cell_instance(instances[instance]);
    let box = cell_box_world(c.cell);
    let rect = project_box(box[0], box[1]);
    var out: ProbeVarying;
    out.position = rect_vertex(rect, vertex);
    out.cluster = c.cluster;
    out.near_depth = rect.depth;
    return out;
}

@fragment
fn fs_probe(in: ProbeVarying) {
    let occluder = textureLoad(raster_depth, vec2<i32>(in.position.xy), 0);
    if in.near_depth >= occluder {
        atomicOr(&visible_new[in.cluster >> 5u], 1u << (in.cluster & 31u));
    }
}

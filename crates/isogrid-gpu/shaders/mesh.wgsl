// The Marching Cubes baseline (paper Table 4, "MC"): an indexed triangle mesh with snorm16
// positions (Table 3 layout: 6 bytes per vertex, pulled from a storage buffer because there is no
// 3-component 16-bit vertex format) and no stored normals; the face normal comes from screen-space
// derivatives of the world position. Writes the same G-buffer as the cell passes; the record
// channel of the ID target carries the vertex attribute interpolated to the pixel (f32 bits) for
// the shading pass's `COLOR_MESH`. A label mesh (one label per triangle) writes its label's index
// where the cell passes write the cluster, and its colour words name each label itself
// (`label_mesh_color_words`, upload.rs), so `COLOR_LABELS` shades it as it shades a label grid; a
// label mesh with values also writes the interpolated value, which `COLOR_MESH` shades.

@group(0) @binding(0) var<uniform> frame: FrameUniforms;

// Keep in sync with `MeshUniforms` in src/gpu_types.rs.
struct MeshUniforms {
    center: vec4<f32>,      // world, xyz; w: a label mesh's back-face slack (world units), else 0
    half_extent: vec4<f32>, // world, xyz: position = center + half_extent * q / 32767; w: 1 for
                            // two words per vertex (label mesh with values), else 0
}

@group(1) @binding(0) var<uniform> mesh: MeshUniforms;
@group(1) @binding(1) var<storage, read> positions: array<u32>;
// One word per vertex: an attribute value's f32 bits, a label mesh's label index, or a dummy when
// the mesh has neither (the shading pass then ignores the record channel); two for a label mesh
// with values: the label index, then the value's bits.
@group(1) @binding(2) var<storage, read> vertex_words: array<u32>;

fn snorm16(index: u32) -> f32 {
    let half_word = (positions[index / 2u] >> (16u * (index % 2u))) & 0xffffu;
    let signed = i32(half_word << 16u) >> 16u;
    return f32(signed) / 32767.0;
}

struct MeshVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) value: f32,
    @location(2) @interpolate(flat) label: u32,
    @location(3) @interpolate(flat) slack: f32, // a label mesh's back-face slack; 0 otherwise
    @location(4) @interpolate(flat) valued: u32, // 1 for a label mesh with values
}

@vertex
fn vs_mesh(@builtin(vertex_index) vertex: u32) -> MeshVarying {
    let q = vec3<f32>(snorm16(3u * vertex), snorm16(3u * vertex + 1u), snorm16(3u * vertex + 2u));
    let p = mesh.center.xyz + mesh.half_extent.xyz * q;
    var out: MeshVarying;
    out.position = clip_from_world(frame, p);
    out.world = p;
    let last = arrayLength(&vertex_words) - 1u;
    out.valued = select(0u, 1u, mesh.half_extent.w > 0.0);
    let first = select(vertex, 2u * vertex, out.valued == 1u);
    let word = vertex_words[min(first, last)];
    out.label = word;
    out.value = bitcast<f32>(vertex_words[min(first + out.valued, last)]);
    out.slack = mesh.center.w;
    return out;
}

struct MeshOut {
    @location(0) surface: vec4<f32>,
    @location(1) ids: vec2<u32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_mesh(in: MeshVarying, @builtin(front_facing) front: bool) -> MeshOut {
    var n = cross(dpdy(in.world), dpdx(in.world));
    let len = length(n);
    let to_eye = frame.eye.xyz - in.world;
    n = select(normalize(to_eye), n / len, len > 0.0);
    // Triangles wind counter-clockwise seen from outside, so a front face's outward normal (−∇f)
    // points towards the eye and a back face's away from it.
    if (dot(n, to_eye) > 0.0) != front {
        n = -n;
    }
    var out: MeshOut;
    out.surface = vec4<f32>(n, length(to_eye));
    out.depth = in.position.z;
    if in.slack > 0.0 {
        out.ids = vec2<u32>(in.label, select(0u, bitcast<u32>(in.value), in.valued == 1u));
        // Touching labels' meshes share their boundary's vertices but not always its
        // triangulation (Marching Cubes splits a cell and its complement along different
        // diagonals), so the two can part by up to half a cell: a back face (the label the ray
        // leaves) is pushed back along the view by the slack, half the grid's smallest spacing,
        // and the face the ray enters wins, as at coinciding cell surfaces (label_back_face_depth).
        if !front {
            let distance = frame.eye.w / in.position.z;
            out.depth = label_back_face_depth(frame.eye.w / (distance + in.slack));
        }
    } else {
        out.ids = vec2<u32>(0u, bitcast<u32>(in.value));
    }
    return out;
}

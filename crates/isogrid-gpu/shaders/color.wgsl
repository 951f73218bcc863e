// Surface colour (`isogrid::colormap`, `isogrid::attribute`, `isogrid::labels`): the colouring
// uniforms and the rules that turn a cell's 16-bit attribute code into a value and a value into
// an albedo, or give a label grid's cluster its label's albedo; shared by the deferred shading
// pass (shade.wgsl) and the path tracer (pathtrace.wgsl). The codes live in the pages, after the
// corner records (`record_code_in`, cell_decode.wgsl): the cell raster writes the hit cell's code
// into the ID target, the tracer reads it at the hit. Each user declares, at its own group and
// binding, `coloring: ColorUniforms` and `color_data: array<u32>`, for COLOR_LABELS the label
// colour words: word 0 the first word of the albedo table, then each cluster's label index (and
// one more, a miss's, naming the table's last entry), then the table, the linear albedo of each
// label (f32 bits, four words per label) and a zero entry. Twins:
// `Coloring::index` (the table entry), `AttributeInfo::code_mapping` (the decoding),
// `Label::albedo` (uploaded as it is), `label_color_words` (upload.rs, colors.ts).

// Keep in sync with `ColorUniforms` in src/gpu_types.rs.
struct ColorUniforms {
    mapping: vec4<f32>,  // value of code 0, value step per code, colour range low end, 1 / its width
    params: vec4<u32>,   // x: COLOR_* source; y: the NaN code; z: the bits of a NaN (WGSL has no NaN constant)
    nan_albedo: vec4<f32>,
    table: array<vec4<f32>, 256>, // linear albedo of the colour map's entries
}
const COLOR_NONE: u32 = 0u;
const COLOR_RECORDS: u32 = 1u;
const COLOR_MESH: u32 = 2u;
const COLOR_LABELS: u32 = 3u;

// The albedo of cluster `cluster` of a label grid (COLOR_LABELS).
fn cluster_albedo(cluster: u32) -> vec3<f32> {
    let at = color_data[0] + 4u * color_data[1u + cluster];
    return bitcast<vec3<f32>>(vec3<u32>(color_data[at], color_data[at + 1u], color_data[at + 2u]));
}

// The attribute value of a cell's 16-bit attribute code; NaN for the NaN code.
fn code_value(code: u32) -> f32 {
    if code == coloring.params.y {
        return bitcast<f32>(coloring.params.z);
    }
    return coloring.mapping.x + f32(code) * coloring.mapping.y;
}

// `Coloring::index`: the nearest of the 256 entries over the colour range, clamped; NaN apart.
fn albedo_of(value: f32) -> vec3<f32> {
    // By its bits: compilers may assume floats are never NaN and fold `value != value` away.
    if (bitcast<u32>(value) & 0x7fffffffu) > 0x7f800000u {
        return coloring.nan_albedo.rgb;
    }
    let t = clamp((value - coloring.mapping.z) * coloring.mapping.w, 0.0, 1.0);
    // Halves round up, as Rust's `f64::round` does for these non-negative values.
    return coloring.table[min(u32(floor(t * 255.0 + 0.5)), 255u)].rgb;
}

// Declarations shared by every isogrid-gpu shader; the Rust side prepends this file to each role's
// file. Structs here are keep-in-sync twins of `src/gpu_types.rs`.
//
// Spaces: *cell space* has one unit per cell (= per sample spacing), sample (i, j, k) at (i, j, k);
// *world space* is cell space scaled by the spacing (`frame.cell_to_world.xyz`), as in
// `isogrid::camera`. Depth is reversed-Z with an infinite far plane: depth = near / z_view, so 1 is
// the near plane and 0 is infinitely far; tests use `greater`.

// Keep in sync with `FrameUniforms` in src/gpu_types.rs.
struct FrameUniforms {
    eye: vec4<f32>,           // world eye; w = near plane distance along `forward`
    right: vec4<f32>,         // world image right; w = tan(fovy / 2) · aspect
    up: vec4<f32>,            // world image up; w = tan(fovy / 2)
    forward: vec4<f32>,       // world view direction; w = EWA Gaussian sigma in cells
    viewport: vec4<f32>,      // width, height, 1 / width, 1 / height (pixels)
    cell_to_world: vec4<f32>, // spacing xyz; w = isovalue in corner units (codes, or data units for the volume)
    params: vec4<u32>,        // x: precision bits (1, 4, 8, 16, 32); y: corner source; z: FLAG_*; w: frame index
    clip: vec4<f32>,          // clip plane (world): points with dot(xyz, p) > w are cut away; all 0: none
}

const SOURCE_RECORDS: u32 = 0u;
const SOURCE_VOLUME: u32 = 1u;
const FLAG_OCCLUSION: u32 = 1u;
const FLAG_BACKFACE: u32 = 2u;
const FLAG_EWA: u32 = 4u; // the EWA target holds the normals to shade with
const FLAG_LABELS: u32 = 8u; // a label grid: at equal depth a front face wins (label_back_face_depth)
const NO_CLUSTER: u32 = 0xffffffffu;

// Units in the last place of the reversed-Z depth (about 6·10⁻⁵ of the eye distance) by which a
// label grid's back faces lose to front faces: far more than the two labels' crossings differ by
// (rounding of complementary indicators), far less than any visible gap.
const LABEL_BACK_FACE_BIAS: u32 = 1024u;

// The depth of a label surface that the view ray leaves (a back face), pushed back by
// LABEL_BACK_FACE_BIAS: touching labels' surfaces coincide, and each is drawn, so the one the ray
// enters must win the depth test however rounding orders the two (as the tracers' tie rule). The
// cell passes (cell_hit.wgsl) and the label mesh (mesh.wgsl) both use it.
fn label_back_face_depth(depth: f32) -> f32 {
    let bits = bitcast<u32>(depth);
    return bitcast<f32>(bits - min(bits, LABEL_BACK_FACE_BIAS));
}

// Keep in sync with `PageUniforms` in src/gpu_types.rs.
struct PageUniforms {
    first_slot: u32,  // global index of the page's first metacell slot
    first_cell: u32,  // global index of the page's first corner record
    slot_count: u32,
    codes_word: u32,  // word of the page's first attribute code in its records buffer; 0: none
}

// The ray through a pixel position (pixels from the top-left corner), exactly `Camera::ray_at`.
fn ray_direction(frame: FrameUniforms, pixel: vec2<f32>) -> vec3<f32> {
    let sx = (2.0 * pixel.x * frame.viewport.z - 1.0) * frame.right.w;
    let sy = (1.0 - 2.0 * pixel.y * frame.viewport.w) * frame.up.w;
    return normalize(frame.forward.xyz + sx * frame.right.xyz + sy * frame.up.xyz);
}

// Whether the frame has a clip plane (`clip` all zero: none; every point then keeps 0 <= 0).
fn clip_enabled(frame: FrameUniforms) -> bool {
    return any(frame.clip.xyz != vec3<f32>(0.0));
}

// Whether a world point survives the clip plane.
fn clip_keeps(frame: FrameUniforms, p: vec3<f32>) -> bool {
    return dot(frame.clip.xyz, p) <= frame.clip.w;
}

// Whether a whole world box [lo, hi] is cut away by the clip plane (its lowest corner along the
// plane normal is on the clipped side).
fn clip_removes_box(frame: FrameUniforms, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    let n = frame.clip.xyz;
    let lowest = min(n * lo, n * hi);
    return lowest.x + lowest.y + lowest.z > frame.clip.w;
}

// The part [t.x, t.y] of the ray eye + t·dir (world, t in world units along the unit `dir`) kept
// by the clip plane; empty (t.y < t.x) when the plane cuts it all away. The raster clips each
// cell's segment before looking for the crossing, so a cell cut by the plane shows the surface
// behind the cut (the far side of the solid) rather than nothing.
fn clip_segment(frame: FrameUniforms, dir: vec3<f32>, t: vec2<f32>) -> vec2<f32> {
    let a = dot(frame.clip.xyz, dir);
    let b = frame.clip.w - dot(frame.clip.xyz, frame.eye.xyz);
    if a > 0.0 {
        return vec2<f32>(t.x, min(t.y, b / a));
    }
    if a < 0.0 {
        return vec2<f32>(max(t.x, b / a), t.y);
    }
    return select(vec2<f32>(1.0, 0.0), t, b >= 0.0);
}

// Clip position of a world point: x, y as the camera's perspective, depth = near / z_view.
fn clip_from_world(frame: FrameUniforms, p: vec3<f32>) -> vec4<f32> {
    let v = p - frame.eye.xyz;
    return vec4<f32>(dot(v, frame.right.xyz) / frame.right.w, dot(v, frame.up.xyz) / frame.up.w, frame.eye.w, dot(v, frame.forward.xyz));
}

// Linear → sRGB 8-bit code / 255, rounded like `to_srgb8` so a unorm target stores it exactly;
// keep in sync with `isogrid::shading::to_srgb8`.
fn to_srgb8(linear: f32) -> f32 {
    let x = clamp(linear, 0.0, 1.0);
    var s: f32;
    if x <= 0.0031308 {
        s = 12.92 * x;
    } else {
        s = 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    }
    return floor(s * 255.0 + 0.5) / 255.0;
}

// Trilinear interpolation of 8 corner values (corner c at (c&1, c>>1&1, c>>2&1)) at p in [0,1]^3.
fn trilinear(a: vec4<f32>, b: vec4<f32>, p: vec3<f32>) -> f32 {
    let x00 = mix(a.x, a.y, p.x);
    let x10 = mix(a.z, a.w, p.x);
    let x01 = mix(b.x, b.y, p.x);
    let x11 = mix(b.z, b.w, p.x);
    return mix(mix(x00, x10, p.y), mix(x01, x11, p.y), p.z);
}

// Gradient of `trilinear` in cell units.
fn trilinear_gradient(a: vec4<f32>, b: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    let gx = mix(mix(a.y - a.x, a.w - a.z, p.y), mix(b.y - b.x, b.w - b.z, p.y), p.z);
    let gy = mix(mix(a.z - a.x, a.w - a.y, p.x), mix(b.z - b.x, b.w - b.y, p.x), p.z);
    let gz = mix(mix(b.x - a.x, b.y - a.y, p.x), mix(b.z - a.z, b.w - a.w, p.x), p.y);
    return vec3<f32>(gx, gy, gz);
}

// Refines a crossing of `trilinear(a, b, ·) - iso` bracketed by [ta, tb] along o + t·d (cell
// units; the field is on the `inside_at_entry` side at ta and on the other at tb): 12 bisection
// steps, then a secant step inside the last bracket. Shared by the raster (§3.2) and the tracer
// (§3.6) so both find the same surface.
fn refine_crossing(a: vec4<f32>, b: vec4<f32>, o: vec3<f32>, d: vec3<f32>, t_a: f32, t_b: f32, iso: f32, inside_at_entry: bool) -> f32 {
    var ta = t_a;
    var tb = t_b;
    var fa = trilinear(a, b, o + ta * d) - iso;
    var fb = trilinear(a, b, o + tb * d) - iso;
    for (var i = 0u; i < 12u; i++) {
        let tm = 0.5 * (ta + tb);
        let fm = trilinear(a, b, o + tm * d) - iso;
        if (fm >= 0.0) == inside_at_entry {
            ta = tm;
            fa = fm;
        } else {
            tb = tm;
            fb = fm;
        }
    }
    // fa and fb have opposite sides, so the secant weight is in [0, 1].
    let w = clamp(fa / (fa - fb), 0.0, 1.0);
    return select(mix(ta, tb, w), tb, fa == fb);
}

// Slab test (Majercik et al.) of a ray against the unit box [0,1]^3: (t_enter, t_exit).
fn slab_unit_box(origin: vec3<f32>, dir: vec3<f32>) -> vec2<f32> {
    // A zero component would give 0/0 on a face; a tiny one keeps the slab test well defined.
    let safe = select(dir, vec3<f32>(1e-30), abs(dir) < vec3<f32>(1e-30));
    let inv = 1.0 / safe;
    let t0 = (vec3<f32>(0.0) - origin) * inv;
    let t1 = (vec3<f32>(1.0) - origin) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    return vec2<f32>(max(max(lo.x, lo.y), lo.z), min(min(hi.x, hi.y), hi.z));
}

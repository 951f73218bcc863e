//! Shading constants shared by every renderer (deferred normalised Blinn–Phong, paper §3.2), so
//! the GPU passes and the CPU tracer produce the same image. Keep in sync with
//! `crates/isogrid-gpu/shaders/shade.wgsl`.
//!
//! Lighting is in camera space: a key light from the upper left behind the viewer plus a weaker
//! fill from the right, on a white surface. Colours are linear; output is sRGB-encoded 8-bit.

/// Direction *towards* the key light in camera space (x right, y up, z towards the viewer).
pub const KEY_LIGHT_DIR: [f32; 3] = [-0.40, 0.55, 0.73];
pub const KEY_LIGHT_RADIANCE: f32 = 2.6;
/// Direction towards the fill light in camera space.
pub const FILL_LIGHT_DIR: [f32; 3] = [0.70, -0.10, 0.70];
pub const FILL_LIGHT_RADIANCE: f32 = 0.6;
/// Constant ambient term (linear).
pub const AMBIENT: f32 = 0.06;
/// Diffuse albedo (linear) of the surface.
pub const ALBEDO: [f32; 3] = [0.80, 0.74, 0.66];
/// Specular colour and Blinn–Phong exponent; the specular lobe is normalised by (n + 8) / (8π).
pub const SPECULAR: f32 = 0.25;
pub const SHININESS: f32 = 48.0;
/// Background (sRGB 8-bit) where no surface is hit.
pub const BACKGROUND_SRGB: [u8; 3] = [28, 30, 36];

fn normalize3(v: [f32; 3]) -> [f32; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / n)
}

fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Linear RGB of a surface point with camera-space unit normal `n` (facing the viewer or not:
/// back faces are shaded as if flipped, like two-sided lighting) seen along camera-space `view`
/// (unit vector from the point towards the eye).
pub fn shade(n: [f32; 3], view: [f32; 3]) -> [f32; 3] {
    shade_albedo(n, view, ALBEDO)
}

/// [`shade`] with another diffuse albedo (linear): a surface coloured by an attribute.
pub fn shade_albedo(n: [f32; 3], view: [f32; 3], albedo: [f32; 3]) -> [f32; 3] {
    let n = if dot3(n, view) < 0.0 {
        n.map(|c| -c)
    } else {
        n
    };
    let mut rgb = albedo.map(|a| a * AMBIENT);
    for (dir, radiance) in [
        (KEY_LIGHT_DIR, KEY_LIGHT_RADIANCE),
        (FILL_LIGHT_DIR, FILL_LIGHT_RADIANCE),
    ] {
        let l = normalize3(dir);
        let ndl = dot3(n, l).max(0.0);
        if ndl <= 0.0 {
            continue;
        }
        let h = normalize3([l[0] + view[0], l[1] + view[1], l[2] + view[2]]);
        let spec = SPECULAR * (SHININESS + 8.0) / (8.0 * std::f32::consts::PI)
            * dot3(n, h).max(0.0).powf(SHININESS);
        for c in 0..3 {
            rgb[c] += radiance * ndl * (albedo[c] / std::f32::consts::PI + spec);
        }
    }
    rgb
}

/// Linear [0, ∞) → sRGB 8-bit (clamped).
pub fn to_srgb8(linear: f32) -> u8 {
    let x = linear.clamp(0.0, 1.0);
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn facing_the_key_light_is_brighter_than_grazing_and_srgb_is_monotonic() {
        let view = [0.0, 0.0, 1.0];
        let lit = shade(normalize3(KEY_LIGHT_DIR), view);
        let grazing = shade(normalize3([0.4, -0.55, 0.05]), view);
        assert!(lit[0] > grazing[0]);
        assert_eq!(shade([0.0, 0.0, -1.0], view), shade([0.0, 0.0, 1.0], view));
        assert_eq!((to_srgb8(0.0), to_srgb8(1.0), to_srgb8(7.0)), (0, 255, 255));
        assert!((1..=100).all(|i| to_srgb8(i as f32 / 100.0) >= to_srgb8((i - 1) as f32 / 100.0)));
    }
}

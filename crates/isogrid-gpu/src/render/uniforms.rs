//! The per-frame uniforms every cell, mesh and shading shader reads: camera basis and near plane,
//! viewport, cell spacing, the isovalue in the scene's units, and the frame's flags.

use crate::gpu_types::{FrameUniforms, FLAG_LABELS, SOURCE_RECORDS, SOURCE_VOLUME};
use crate::upload::GpuGrid;
use isogrid::Camera;

/// EWA Gaussian standard deviation in cells: neighbours one cell apart weigh exp(−1/(2·0.7²)) ≈ 0.36.
const EWA_SIGMA_CELLS: f64 = 0.7;

/// The uniforms of frame `frame` of `camera`'s view of `grid` (or of a mesh in `bounds`), its
/// corners read from the records or, with `volume`, from the original samples.
pub(super) fn frame_uniforms(
    camera: &Camera,
    grid: Option<&GpuGrid>,
    volume: bool,
    bounds: ([f64; 3], [f64; 3]),
    flags: u32,
    frame: u32,
) -> FrameUniforms {
    let (right, up, forward) = camera.basis();
    let tan = (camera.fovy_degrees.to_radians() * 0.5).tan();
    let aspect = camera.width as f64 / camera.height as f64;
    let center: [f64; 3] = std::array::from_fn(|a| 0.5 * (bounds.0[a] + bounds.1[a]));
    let radius = (0..3)
        .map(|a| (bounds.1[a] - bounds.0[a]).powi(2))
        .sum::<f64>()
        .sqrt()
        * 0.5;
    let distance = (0..3)
        .map(|a| (camera.eye[a] - center[a]).powi(2))
        .sum::<f64>()
        .sqrt();
    // Reversed-Z keeps precision far away, so a near plane well in front of anything costs nothing.
    let near = 1e-5 * (distance + radius).max(1e-6);
    let v4 = |v: [f64; 3], w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
    let (spacing, iso, precision) = match grid {
        Some(g) => {
            let iso = if volume {
                g.info.iso as f32
            } else {
                g.info.mapping.iso_code
            };
            (g.info.spacing, iso, g.info.precision.bits())
        }
        None => ([1.0; 3], 0.0, 0),
    };
    // For the volume, the smallest f32 at or above the isovalue keeps `value >= iso` exact.
    let iso = match grid {
        Some(g) if volume && (iso as f64) < g.info.iso => iso.next_up(),
        _ => iso,
    };
    FrameUniforms {
        eye: v4(camera.eye, near),
        right: v4(right, tan * aspect),
        up: v4(up, tan),
        forward: v4(forward, EWA_SIGMA_CELLS),
        viewport: [
            camera.width as f32,
            camera.height as f32,
            1.0 / camera.width as f32,
            1.0 / camera.height as f32,
        ],
        cell_to_world: [spacing[0] as f32, spacing[1] as f32, spacing[2] as f32, iso],
        params: [
            precision,
            if volume {
                SOURCE_VOLUME
            } else {
                SOURCE_RECORDS
            },
            match grid {
                Some(g) if g.label_albedo.is_some() => flags | FLAG_LABELS,
                _ => flags,
            },
            frame,
        ],
        clip: [0.0; 4],
    }
}

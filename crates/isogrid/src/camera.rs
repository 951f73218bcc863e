//! Pinhole cameras in world space, shared by every renderer (GPU raster, CPU tracer, baselines)
//! so that their images and AOVs line up pixel for pixel.
//!
//! World space: sample (i, j, k) sits at (i·sx, j·sy, k·sz) with the volume's spacing; origin and
//! direction cosines are not applied (of the directions only their handedness counts, below). Perspective projection with a vertical field of
//! view; pixel (0, 0) is the top-left; one ray passes through the centre of each pixel. Image right
//! is `forward × up` and image up is the camera's up, made orthogonal to the view direction.
//!
//! A grid whose axes are a mirror image of its world's (a negative determinant of its directions,
//! as FreeSurfer's LIA and FSL's LAS volumes have) drawn so would show its world mirrored: left and
//! right swapped. Its cameras are [`Camera::mirrored`]: image right is `up × forward`, so the picture
//! is the mirror image of the index × spacing drawing, which is the world as it lies, seen from
//! the camera's mirror point. Every renderer takes the image axes from [`Camera::basis`], so all
//! of them (and their AOVs, and the lights, which are fixed in the image) follow.

use crate::error::{Error, Result};

/// A ray with a unit direction, in world units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: [f64; 3],
    pub direction: [f64; 3],
}

/// Where the camera is and what it sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub fovy_degrees: f64,
    pub width: u32,
    pub height: u32,
    /// Image right is `up × forward` rather than `forward × up`: the camera of a grid whose axes
    /// mirror its world (`crate::directions_mirror`), which it then shows as it lies.
    pub mirrored: bool,
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// Dot product of two 3-vectors (the CPU renderer in `isogrid-trace` shades with it per pixel).
#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// `a / |a|`, scaled first so that long vectors (|a| > 1e154) do not overflow the dot product.
pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let a = a.map(|v| v / scale);
    let n = dot(a, a).sqrt();
    a.map(|v| v / n)
}

/// Largest camera coordinate magnitude: beyond it an f64 position is coarser than 1/8 of a world
/// unit (2⁵³ ≈ 9·10¹⁵), so rays from there cannot resolve a grid of unit-sized cells.
pub const MAX_CAMERA_COORDINATE: f64 = 1e15;

/// Default vertical field of view of the presets, in degrees.
pub const PRESET_FOVY: f64 = 35.0;

impl Camera {
    /// Standard views of a world-space box `[lo, hi]` (the paper's scenes 1 and 2):
    /// view 1 looks at the front, from +z towards −z with +y up (x to the right, like a slice);
    /// view 2 is oblique, from the (+x, +y, +z) side, elevated about 25°. Both frame the box's
    /// bounding sphere with a small margin.
    pub fn preset(view: u8, lo: [f64; 3], hi: [f64; 3], width: u32, height: u32) -> Result<Camera> {
        // A box past the limit (a huge spacing) would put the eye at inf or NaN: say so here.
        if let Some(c) = lo
            .iter()
            .chain(&hi)
            .find(|c| !(c.abs() <= MAX_CAMERA_COORDINATE))
        {
            return Err(Error::invalid(format!(
                "the grid's box reaches {c:e}, beyond ±{MAX_CAMERA_COORDINATE:e}, where f64 \
                 positions are too coarse to trace: its spacing is too large to render"
            )));
        }
        let center = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
        let radius = 0.5 * dot(sub(hi, lo), sub(hi, lo)).sqrt().max(1e-9);
        let half = PRESET_FOVY.to_radians() * 0.5;
        let aspect = width as f64 / height.max(1) as f64;
        // Fit the sphere vertically and horizontally.
        let half_h = (half.tan() * aspect.min(1.0)).atan();
        let distance = 1.05 * radius / half_h.sin();
        let dir = match view {
            1 => [0.0, 0.0, 1.0],
            2 => normalize([0.62, 0.42, 0.66]),
            _ => return Err(Error::invalid(format!("view {view} is not 1 or 2"))),
        };
        Ok(Camera {
            eye: [0, 1, 2].map(|a| center[a] + distance * dir[a]),
            target: center,
            up: [0.0, 1.0, 0.0],
            fovy_degrees: PRESET_FOVY,
            width,
            height,
            mirrored: false,
        })
    }

    /// Parses `EYE:TARGET:UP:FOVY`, each point as comma-separated world coordinates, e.g.
    /// `100,50,300:100,50,0:0,1,0:40`.
    pub fn parse(spec: &str, width: u32, height: u32) -> Result<Camera> {
        let bad = || {
            Error::invalid(format!(
                "camera {spec:?} is not EYE:TARGET:UP:FOVY (points as x,y,z; FOVY in degrees)"
            ))
        };
        let parts: Vec<&str> = spec.split(':').collect();
        if parts.len() != 4 {
            return Err(bad());
        }
        let point = |s: &str| -> Result<[f64; 3]> {
            let v: Vec<f64> = s
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| bad())?;
            let p: [f64; 3] = v.try_into().map_err(|_| bad())?;
            if p.iter().all(|c| c.is_finite()) {
                Ok(p)
            } else {
                Err(bad())
            }
        };
        let fovy: f64 = parts[3].trim().parse().map_err(|_| bad())?;
        let camera = Camera {
            eye: point(parts[0])?,
            target: point(parts[1])?,
            up: point(parts[2])?,
            fovy_degrees: fovy,
            width,
            height,
            mirrored: false,
        };
        camera.validate()?;
        Ok(camera)
    }

    /// Rejects degenerate cameras: zero-size image, eye on the target, up along the view, silly FOV.
    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 {
            return Err(Error::invalid("image size must be at least 1x1"));
        }
        if !(self.fovy_degrees > 0.0 && self.fovy_degrees < 180.0) {
            return Err(Error::invalid(format!(
                "field of view {} is not in (0, 180) degrees",
                self.fovy_degrees
            )));
        }
        for (name, point) in [("eye", self.eye), ("target", self.target), ("up", self.up)] {
            if let Some(c) = point.iter().find(|c| !(c.abs() <= MAX_CAMERA_COORDINATE)) {
                return Err(Error::invalid(format!(
                    "camera {name} coordinate {c:e} is beyond ±{MAX_CAMERA_COORDINATE:e}, where \
                     f64 positions are too coarse to trace"
                )));
            }
        }
        let forward = sub(self.target, self.eye);
        if forward == [0.0; 3] {
            return Err(Error::invalid("camera eye and target coincide"));
        }
        if self.up == [0.0; 3] {
            return Err(Error::invalid("camera up is the zero vector"));
        }
        // Unit vectors, so the parallel test neither overflows nor underflows.
        let right = cross(normalize(forward), normalize(self.up));
        if dot(right, right) <= 1e-12 {
            return Err(Error::invalid(
                "camera up is parallel to the view direction",
            ));
        }
        Ok(())
    }

    /// Orthonormal (right, up, forward) of the view: image right, image up and the view
    /// direction (right-handed, or left-handed when [`Camera::mirrored`]).
    pub fn basis(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let forward = normalize(sub(self.target, self.eye));
        let right = normalize(cross(forward, self.up));
        let up = cross(right, forward);
        let right = if self.mirrored {
            right.map(|c| -c)
        } else {
            right
        };
        (right, up, forward)
    }

    /// This camera, its image mirrored when `mirrored` (the camera of a grid whose axes are a
    /// mirror image of its world's).
    pub fn with_mirror(self, mirrored: bool) -> Camera {
        Camera { mirrored, ..self }
    }

    /// The ray through the centre of pixel (x, y), (0, 0) being the top-left.
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        self.ray_at(x as f64 + 0.5, y as f64 + 0.5)
    }

    /// The ray through image position (px, py) in pixels from the top-left corner.
    pub fn ray_at(&self, px: f64, py: f64) -> Ray {
        let (right, up, forward) = self.basis();
        let tan = (self.fovy_degrees.to_radians() * 0.5).tan();
        let aspect = self.width as f64 / self.height as f64;
        let sx = (2.0 * px / self.width as f64 - 1.0) * tan * aspect;
        let sy = (1.0 - 2.0 * py / self.height as f64) * tan;
        let d = [0, 1, 2].map(|a| forward[a] + sx * right[a] + sy * up[a]);
        Ray {
            origin: self.eye,
            direction: normalize(d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_the_target_and_corners_follow_the_image_axes() {
        let cam = Camera {
            eye: [0.0, 0.0, 10.0],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fovy_degrees: 90.0,
            width: 2,
            height: 2,
            mirrored: false,
        };
        let r = cam.ray_at(1.0, 1.0);
        assert!((r.direction[2] + 1.0).abs() < 1e-12);
        // Top-left pixel centre: left (−x) and up (+y); 90° FOV and 2 px → ±0.5·tan(45°).
        let tl = cam.ray(0, 0).direction;
        assert!(tl[0] < 0.0 && tl[1] > 0.0);
        assert!((tl[0] / tl[2] - 0.5).abs() < 1e-12 && (tl[1] / -tl[2] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn presets_see_the_whole_box_and_parse_rejects_nonsense() {
        for view in [1, 2] {
            let cam = Camera::preset(view, [0.0; 3], [100.0, 50.0, 20.0], 160, 90).unwrap();
            cam.validate().unwrap();
            let (right, up, forward) = cam.basis();
            let tan = (cam.fovy_degrees.to_radians() / 2.0).tan();
            for c in 0..8 {
                let p = [
                    (c & 1) as f64 * 100.0,
                    (c >> 1 & 1) as f64 * 50.0,
                    (c >> 2 & 1) as f64 * 20.0,
                ];
                let d = sub(p, cam.eye);
                let z = dot(d, forward);
                assert!(z > 0.0);
                assert!(
                    (dot(d, up) / z).abs() <= tan
                        && (dot(d, right) / z).abs() <= tan * 160.0 / 90.0,
                    "view {view} corner {c}"
                );
            }
        }
        assert!(Camera::preset(3, [0.0; 3], [1.0; 3], 10, 10).is_err());
        let ok = Camera::parse("1,2,3:0,0,0:0,1,0:40", 8, 8).unwrap();
        assert_eq!(ok.eye, [1.0, 2.0, 3.0]);
        for bad in [
            "1,2,3:0,0,0:0,1,0",
            "1,2:0,0,0:0,1,0:40",
            "0,0,0:0,0,0:0,1,0:40",
            "0,0,5:0,0,0:0,0,1:40",
            "0,0,5:0,0,0:0,1,0:190",
        ] {
            assert!(Camera::parse(bad, 8, 8).is_err(), "{bad}");
        }
    }
}

//! Orbit camera: turntable rotation around a target point, panning in the view plane and dolly
//! zoom, producing the world-space [`isogrid::Camera`] every renderer shares.
//!
//! World space is `isogrid::camera`'s (sample (i, j, k) at (i·sx, j·sy, k·sz)). The up axis is
//! world +y, as in the presets, so that yaw turns around the vertical and the horizon stays level.
//! Angles are in radians; drag deltas are in screen points, zoom in wheel points.

use isogrid::camera::{Camera, PRESET_FOVY};

/// Pitch stays this far from ±90° so that the view direction never becomes parallel to up.
const MAX_PITCH: f64 = 89.0 * std::f64::consts::PI / 180.0;
/// Radians of rotation per point of drag.
const ROTATE_PER_POINT: f64 = 0.008;
/// Relative distance change per point of wheel scroll (exponential, so zoom feels uniform).
const ZOOM_PER_POINT: f64 = 0.002;

/// An orbit around `target` at `distance`, looking along −(yaw, pitch) direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    pub target: [f64; 3],
    pub distance: f64,
    /// Rotation of the eye around world +y, 0 = eye on +z of the target.
    pub yaw: f64,
    /// Elevation of the eye above the target's horizontal plane.
    pub pitch: f64,
    pub fovy_degrees: f64,
    /// Radius of the scene's bounding sphere: bounds zoom and scales panning before any view.
    pub scene_radius: f64,
    /// The scene's axes mirror its world: the image is mirrored back ([`Camera::mirrored`]).
    pub mirrored: bool,
}

impl Orbit {
    /// The orbit that reproduces `camera` (eye, target, field of view); `camera.up` is assumed
    /// to be world +y, as in `Camera::preset`.
    pub fn from_camera(camera: &Camera, scene_radius: f64) -> Orbit {
        let d = [0, 1, 2].map(|a| camera.eye[a] - camera.target[a]);
        let distance = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-9);
        let pitch = (d[1] / distance)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-MAX_PITCH, MAX_PITCH);
        let yaw = d[0].atan2(d[2]);
        Orbit {
            target: camera.target,
            distance,
            yaw,
            pitch,
            fovy_degrees: camera.fovy_degrees,
            scene_radius: scene_radius.max(1e-9),
            mirrored: camera.mirrored,
        }
    }

    /// `Camera::preset(view, lo, hi, ..)` as an orbit, mirrored for a scene whose axes mirror its
    /// world; the image size does not matter except through the aspect ratio the preset frames
    /// for.
    pub fn preset(
        view: u8,
        lo: [f64; 3],
        hi: [f64; 3],
        width: u32,
        height: u32,
        mirrored: bool,
    ) -> Option<Orbit> {
        let camera = Camera::preset(view, lo, hi, width.max(1), height.max(1))
            .ok()?
            .with_mirror(mirrored);
        let d = [0, 1, 2].map(|a| hi[a] - lo[a]);
        let radius = 0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        Some(Orbit::from_camera(&camera, radius))
    }

    /// The camera for an image of `width × height` pixels.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let dir = [cp * sy, sp, cp * cy];
        Camera {
            eye: [0, 1, 2].map(|a| self.target[a] + self.distance * dir[a]),
            target: self.target,
            up: [0.0, 1.0, 0.0],
            fovy_degrees: self.fovy_degrees,
            width,
            height,
            mirrored: self.mirrored,
        }
    }

    /// Turntable rotation by a drag of (dx, dy) points: right drag turns the object right,
    /// down drag tilts it towards the viewer (in a mirrored image too, where the yaw that does
    /// so turns the other way).
    pub fn rotate(&mut self, dx: f64, dy: f64) {
        let dx = if self.mirrored { -dx } else { dx };
        self.yaw -= dx * ROTATE_PER_POINT;
        self.pitch = (self.pitch + dy * ROTATE_PER_POINT).clamp(-MAX_PITCH, MAX_PITCH);
        self.yaw = self.yaw.rem_euclid(std::f64::consts::TAU);
    }

    /// Moves the target in the view plane so that the point under the cursor follows a drag of
    /// (dx, dy) points in a view `view_height` points tall.
    pub fn pan(&mut self, dx: f64, dy: f64, view_height: f64) {
        let camera = self.camera(1, 1);
        let (right, up, _) = camera.basis();
        let world_per_point = 2.0 * self.distance * (self.fovy_degrees.to_radians() * 0.5).tan()
            / view_height.max(1.0);
        for a in 0..3 {
            self.target[a] += (-dx * right[a] + dy * up[a]) * world_per_point;
        }
    }

    /// Dolly towards (positive `scroll`) or away from the target, staying within a range around
    /// the scene size.
    pub fn zoom(&mut self, scroll: f64) {
        let d = self.distance * (-scroll * ZOOM_PER_POINT).exp();
        self.distance = d.clamp(self.scene_radius * 0.02, self.scene_radius * 200.0);
    }
}

impl Default for Orbit {
    fn default() -> Self {
        Orbit {
            target: [0.0; 3],
            distance: 3.0,
            yaw: 0.0,
            pitch: 0.0,
            fovy_degrees: PRESET_FOVY,
            scene_radius: 1.0,
            mirrored: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-9 * (1.0 + b[i].abs()))
    }

    #[test]
    fn presets_round_trip_through_the_orbit() {
        let (lo, hi) = ([0.0; 3], [63.0, 40.0, 80.0]);
        for view in [1, 2] {
            let preset = Camera::preset(view, lo, hi, 320, 200).unwrap();
            let camera = Orbit::preset(view, lo, hi, 320, 200, false)
                .unwrap()
                .camera(320, 200);
            assert!(
                close(camera.eye, preset.eye),
                "{:?} vs {:?}",
                camera.eye,
                preset.eye
            );
            assert_eq!(camera.target, preset.target);
            assert_eq!(camera.up, preset.up);
            assert_eq!(camera.fovy_degrees, preset.fovy_degrees);
        }
    }

    #[test]
    fn rotation_keeps_distance_and_never_reaches_the_pole() {
        let mut orbit = Orbit::preset(2, [0.0; 3], [10.0; 3], 100, 100, false).unwrap();
        let d0 = orbit.distance;
        orbit.rotate(123.0, 1e6);
        let c = orbit.camera(100, 100);
        c.validate().unwrap();
        let d: f64 = (0..3)
            .map(|a| (c.eye[a] - c.target[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!((d - d0).abs() < 1e-9 * d0);
        assert!(orbit.pitch <= MAX_PITCH);
    }

    #[test]
    fn pan_moves_the_target_in_the_view_plane_only() {
        let mut orbit = Orbit::preset(1, [0.0; 3], [10.0; 3], 100, 100, false).unwrap();
        let before = orbit.target;
        orbit.pan(10.0, 0.0, 100.0);
        // View 1 looks down −z with +x to the right: a rightward drag moves the target to −x.
        assert!(orbit.target[0] < before[0]);
        assert_eq!(orbit.target[1], before[1]);
        assert!((orbit.target[2] - before[2]).abs() < 1e-12);
    }

    /// Image x of world point `p` (right of centre positive), as the camera draws it.
    fn image_x(camera: &Camera, p: [f64; 3]) -> f64 {
        let (right, _, forward) = camera.basis();
        let d = [0, 1, 2].map(|a| p[a] - camera.eye[a]);
        let dot = |u: [f64; 3]| (0..3).map(|a| u[a] * d[a]).sum::<f64>();
        dot(right) / dot(forward)
    }

    #[test]
    fn drags_move_the_picture_alike_whether_or_not_it_is_mirrored() {
        for mirrored in [false, true] {
            // A right drag turns the object right: its near side moves right in the picture.
            let mut orbit = Orbit::preset(1, [0.0; 3], [10.0; 3], 100, 100, mirrored).unwrap();
            let near = [orbit.target[0], orbit.target[1], orbit.target[2] + 4.0];
            let before = image_x(&orbit.camera(100, 100), near);
            orbit.rotate(20.0, 0.0);
            let after = image_x(&orbit.camera(100, 100), near);
            assert!(after > before, "mirrored {mirrored}: {before} → {after}");
            // A right drag pans the picture right: the point under the cursor follows it.
            let mut orbit = Orbit::preset(1, [0.0; 3], [10.0; 3], 100, 100, mirrored).unwrap();
            let point = orbit.target;
            let before = image_x(&orbit.camera(100, 100), point);
            orbit.pan(10.0, 0.0, 100.0);
            let after = image_x(&orbit.camera(100, 100), point);
            assert!(after > before, "mirrored {mirrored}: {before} → {after}");
        }
    }

    #[test]
    fn zoom_is_bounded_by_the_scene_size() {
        let mut orbit = Orbit::preset(1, [0.0; 3], [10.0; 3], 100, 100, false).unwrap();
        orbit.zoom(1e9);
        assert!(orbit.distance >= orbit.scene_radius * 0.02 * (1.0 - 1e-12));
        orbit.zoom(-1e9);
        assert!(orbit.distance <= orbit.scene_radius * 200.0 * (1.0 + 1e-12));
    }
}

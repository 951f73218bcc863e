//! Which view to render next and at what size: reduced while the camera moves, a preview and
//! then the full size when it rests, refined sample by sample in path-tracing mode.

use super::state::{App, ViewKey};
use crate::render_worker::RenderMsg;
use crate::Mode;
use isogrid::Camera;
use isogrid_render::{Backend, CameraSpec, ColorSpec, RenderRequest, RequestParts};
use std::time::Duration;

/// Samples per pixel the viewer accumulates while the camera rests in path-tracing mode.
const PATH_TRACE_SAMPLES: u32 = 256;
/// Render time aimed at while the view moves.
const INTERACTIVE_MS: f64 = 70.0;
/// Render time aimed at for the first image after the view stops; the full size follows.
const PREVIEW_MS: f64 = 500.0;
/// The view counts as moving for this long after the last drag or wheel event.
const SETTLE: Duration = Duration::from_millis(250);

impl App {
    /// Whether the extraction worker should also run Marching Cubes.
    pub(super) fn wants_mesh(&self) -> bool {
        self.compare_mc || self.mode == Mode::Mc
    }

    /// Sends the next render request when the frame on screen is out of date and none is
    /// rendering; returns when to look again if the view is still settling.
    pub(super) fn schedule_render(&mut self, full_size: [u32; 2]) -> Option<Duration> {
        if !self.has_view || self.renderer_error.is_some() || self.in_flight.is_some() {
            return None;
        }
        let settling = self
            .last_interaction
            .map(|t| t.elapsed())
            .filter(|&e| e < SETTLE);
        let scene = match self.mode {
            Mode::Mc => self.mesh_version,
            _ => self.grid_version,
        };
        let shown_width = self
            .shown
            .filter(|k| k.mode == self.mode && k.scene == scene)
            .filter(|k| same_view(&k.camera, &self.orbit.camera(1, 1)))
            .map(|k| k.camera.width);
        // Moving: a size rendered within the interactive budget. Still: a preview within a
        // larger budget, then the full size. Scripted runs go straight to the full size.
        let size = if self.script.is_some() {
            full_size
        } else if settling.is_some() {
            self.cost.size_for(full_size, INTERACTIVE_MS)
        } else {
            let preview = self.cost.size_for(full_size, PREVIEW_MS);
            match (shown_width, self.shown) {
                (Some(w), _) if w >= preview[0] && self.full_when_idle => full_size,
                (Some(w), Some(k)) if w >= preview[0] => [w, k.camera.height],
                _ => preview,
            }
        };
        let key = ViewKey {
            camera: self.orbit.camera(size[0], size[1]),
            mode: self.mode,
            scene,
            color: self.color.spec(),
            labels: self.labels.version,
        };
        let recheck = settling.map(|e| SETTLE - e);
        // Path tracing refines while the camera rests: the same view is asked for again, each
        // call adding a sample, until PATH_TRACE_SAMPLES.
        let refining = key.mode == Mode::PathTrace && self.shown_samples < PATH_TRACE_SAMPLES;
        if (self.shown == Some(key) && !refining) || self.refused == Some(key) {
            return recheck;
        }
        self.refused = None;
        let request = match render_request(&key) {
            Ok(r) => r,
            Err(e) => {
                // Not asked again until the view changes.
                self.refused = Some(key);
                self.fail(format!("render request: {e}"));
                return recheck;
            }
        };
        self.next_request += 1;
        let id = self.next_request;
        let msg = RenderMsg::Render { id, request };
        if self.render.sender().send(msg).is_ok() {
            self.in_flight = Some((id, key));
        }
        recheck
    }
}

/// The front door's request for one frame of `key`'s view: the orbit camera as a look-at camera,
/// one frame (path tracing: one more sample, accumulated by the render worker's view). On the
/// GPU, where the scene and the view's state live between frames.
fn render_request(key: &ViewKey) -> isogrid::Result<RenderRequest> {
    let c = &key.camera;
    RenderRequest::new(RequestParts {
        mode: key.mode,
        backend: Backend::Gpu,
        camera: CameraSpec::LookAt {
            eye: c.eye,
            target: c.target,
            up: c.up,
            fovy_degrees: c.fovy_degrees,
        },
        size: (c.width, c.height),
        samples: 1,
        frames: 1,
        color: key.color.map(|(map, clim)| ColorSpec { map, clim }),
        ..RequestParts::default()
    })
}

/// Whether two cameras show the same view (image size aside).
fn same_view(a: &Camera, b: &Camera) -> bool {
    (a.eye, a.target, a.up, a.fovy_degrees) == (b.eye, b.target, b.up, b.fovy_degrees)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The request carries the orbit camera exactly: the front door renders the view the key
    /// names, whatever the scene's box.
    #[test]
    fn requests_carry_the_orbit_camera_and_mode() {
        let orbit = crate::orbit::Orbit::preset(2, [0.0; 3], [40.0, 30.0, 20.0], 320, 240, false)
            .expect("a preset view of a box");
        let key = ViewKey {
            camera: orbit.camera(320, 240),
            mode: Mode::PathTrace,
            scene: 1,
            color: None,
            labels: 0,
        };
        let request = render_request(&key).unwrap();
        assert_eq!(request.mode(), Mode::PathTrace);
        assert_eq!((request.width(), request.height()), (320, 240));
        assert_eq!(request.parts().samples, 1);
        let camera = request.camera(([-5.0; 3], [99.0; 3]), None, false).unwrap();
        assert_eq!(camera, key.camera);
    }
}

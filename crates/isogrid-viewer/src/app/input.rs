//! Keyboard shortcuts and mouse orbit, pan and zoom of the camera.

use super::state::App;
use crate::orbit::Orbit;
use eframe::egui;
use std::time::Instant;

impl App {
    /// Puts the camera at `Camera::preset` view `preset` for the open input, once it is open.
    pub(super) fn set_view(&mut self, preset: u8, size: [u32; 2]) {
        if let Some(source) = &self.source {
            let (lo, hi) = source.world_bounds();
            if let Some(orbit) = Orbit::preset(preset, lo, hi, size[0], size[1], source.mirrored) {
                self.orbit = orbit;
                self.has_view = true;
            }
        }
    }

    /// Keys, unless a text field has the keyboard.
    pub(super) fn handle_keys(&mut self, ctx: &egui::Context, full_size: [u32; 2]) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let (one, two, reset, shot) = ctx.input(|i| {
            (
                i.key_pressed(egui::Key::Num1),
                i.key_pressed(egui::Key::Num2),
                i.key_pressed(egui::Key::R),
                i.key_pressed(egui::Key::S),
            )
        });
        if one {
            self.set_view(1, full_size);
        }
        if two {
            self.set_view(2, full_size);
        }
        if reset {
            self.set_view(self.options.view, full_size);
        }
        if shot {
            self.request_capture(ctx, None);
        }
    }

    /// Orbit (primary drag), pan (secondary or middle drag) and zoom (wheel, pinch) of the
    /// camera over the image at `rect`.
    pub(super) fn orbit_with_pointer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        rect: egui::Rect,
    ) {
        let mut moved = false;
        if self.has_view {
            let delta = response.drag_delta();
            if response.dragged_by(egui::PointerButton::Primary) && delta != egui::Vec2::ZERO {
                self.orbit.rotate(delta.x as f64, delta.y as f64);
                moved = true;
            }
            if (response.dragged_by(egui::PointerButton::Secondary)
                || response.dragged_by(egui::PointerButton::Middle))
                && delta != egui::Vec2::ZERO
            {
                self.orbit
                    .pan(delta.x as f64, delta.y as f64, rect.height() as f64);
                moved = true;
            }
            if response.hovered() {
                let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta().y, i.zoom_delta()));
                if scroll != 0.0 {
                    self.orbit.zoom(scroll as f64);
                    moved = true;
                }
                if zoom != 1.0 {
                    self.orbit.distance /= zoom as f64;
                    self.orbit.zoom(0.0);
                    moved = true;
                }
            }
        }
        if moved || response.dragged() {
            self.last_interaction = Some(Instant::now());
        }
    }
}

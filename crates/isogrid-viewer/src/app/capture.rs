//! Screenshots: the whole window through egui's capture, or the rendered image alone.

use super::state::App;
use crate::screenshot;
use eframe::egui;
use std::path::PathBuf;

impl App {
    /// Asks egui for the window's pixels; they are saved to `path` (default: the next free
    /// `isogrid-view-NNN.png` in the working directory) when they arrive.
    pub(super) fn request_capture(&mut self, ctx: &egui::Context, path: Option<PathBuf>) {
        let path = path.unwrap_or_else(|| {
            screenshot::next_free_name(&std::env::current_dir().unwrap_or_default())
        });
        self.capture_path = Some(path);
        let slot = self.capture.clone();
        let wake = ctx.clone();
        log::debug!("requesting a screenshot");
        ctx.request_screenshot(move |image| {
            log::debug!("screenshot arrived: {:?}", image.size);
            if let Ok(mut s) = slot.lock() {
                *s = Some(image);
            }
            wake.request_repaint();
        });
    }

    /// Saves a capture that has arrived; returns whether one was saved.
    pub(super) fn save_capture(&mut self) -> bool {
        let Some(image) = self.capture.lock().ok().and_then(|mut s| s.take()) else {
            return false;
        };
        let Some(path) = self.capture_path.take() else {
            return false;
        };
        let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
        let rgb = screenshot::rgba_to_rgb(&rgba);
        let [w, h] = image.size;
        let region = match self.image_rect_px {
            Some(r) => format!(
                "rendered image at {},{} size {}x{} px",
                r.min.x.round(),
                r.min.y.round(),
                r.width().round(),
                r.height().round()
            ),
            None => "no rendered image".into(),
        };
        let saved = screenshot::write_png(&path, w as u32, h as u32, &rgb);
        self.report_saved(saved, || {
            format!("saved {} ({w}x{h} px window); {region}", path.display())
        })
    }

    /// Saves the rendered image alone (the button, and scripted runs whose capture never came).
    pub(super) fn save_render(&mut self, path: PathBuf) -> bool {
        let Some((w, h, rgb)) = &self.shown_pixels else {
            self.fail_or_note("no rendered image to save yet".into());
            return false;
        };
        let (w, h) = (*w, *h);
        let saved = screenshot::write_png(&path, w, h, rgb);
        self.report_saved(saved, || {
            format!(
                "saved {} (rendered image only); rendered image at 0,0 size {w}x{h} px",
                path.display()
            )
        })
    }

    /// Says in the window (and on stdout in scripted runs, where tests read it) what a screenshot
    /// write did; returns whether it succeeded.
    fn report_saved<E: std::fmt::Display>(
        &mut self,
        saved: Result<(), E>,
        text: impl FnOnce() -> String,
    ) -> bool {
        match saved {
            Ok(()) => {
                let text = text();
                if self.script.is_some() {
                    println!("isogrid view: {text}");
                }
                self.note(text, false);
                true
            }
            Err(e) => {
                self.fail(format!("screenshot: {e}"));
                false
            }
        }
    }
}

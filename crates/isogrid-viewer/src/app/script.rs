//! Scripted runs (`--frames`): render a number of full-size frames, capture the window, close.
//! Tests drive the viewer this way under Xvfb; with `wait_for_drop` the frames are those of a
//! file dropped on the window, or the window showing why it could not be opened.

use super::state::{App, ScriptState};
use eframe::egui;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// A scripted run that has not finished by then reports failure instead of hanging.
const SCRIPT_TIMEOUT: Duration = Duration::from_secs(300);
/// How long a scripted run waits for the window capture before saving the rendered image alone.
const CAPTURE_TIMEOUT: Duration = Duration::from_secs(15);

impl App {
    /// Advances a scripted run; returns whether the window should close.
    pub(super) fn advance_script(&mut self, ctx: &egui::Context, full_size: [u32; 2]) -> bool {
        let Some(script) = &self.script else {
            return false;
        };
        let (frames, state, started) = (script.frames, script.state, script.started);
        let screenshot = script.screenshot.clone();
        if started.elapsed() > SCRIPT_TIMEOUT {
            self.fail(format!(
                "scripted run did not finish within {} s",
                SCRIPT_TIMEOUT.as_secs()
            ));
            return true;
        }
        match state {
            ScriptState::Finished => true,
            ScriptState::AwaitingDrop | ScriptState::OpeningDrop => false,
            ScriptState::Rendering { done } if done >= frames => {
                let current = self.shown.is_some_and(|k| {
                    [k.camera.width, k.camera.height] == full_size && k.mode == self.mode
                });
                current
                    && self.capture_or_close(ctx, screenshot, format!("rendered {frames} frames"))
            }
            ScriptState::Rendering { .. } => false,
            ScriptState::ShowingError => self.capture_or_close(
                ctx,
                screenshot,
                "showed why the dropped file cannot be opened".into(),
            ),
            ScriptState::Capturing { since } => {
                if self.save_capture() {
                    return true;
                }
                if since.elapsed() > CAPTURE_TIMEOUT {
                    let path = screenshot.unwrap_or_default();
                    self.note("the window could not be captured".into(), true);
                    self.save_render(path);
                    return true;
                }
                false
            }
        }
    }

    /// The last step of a scripted run: says what was done, then asks for the window capture
    /// when there is a screenshot to save (the run closes once it is saved) or closes now.
    fn capture_or_close(
        &mut self,
        ctx: &egui::Context,
        screenshot: Option<PathBuf>,
        done: String,
    ) -> bool {
        println!("isogrid view: {done}");
        match screenshot {
            Some(path) => {
                self.request_capture(ctx, Some(path));
                self.set_script_state(ScriptState::Capturing {
                    since: Instant::now(),
                });
                false
            }
            None => true,
        }
    }

    fn set_script_state(&mut self, state: ScriptState) {
        if let Some(script) = &mut self.script {
            script.state = state;
        }
    }

    fn script_state(&self) -> Option<ScriptState> {
        self.script.as_ref().map(|s| s.state)
    }

    /// A file was dropped on the window.
    pub(super) fn script_on_drop(&mut self) {
        if matches!(self.script_state(), Some(ScriptState::AwaitingDrop)) {
            self.set_script_state(ScriptState::OpeningDrop);
        }
    }

    /// The newest input is open: a dropped file's frames count from now on.
    pub(super) fn script_on_opened(&mut self) {
        if matches!(self.script_state(), Some(ScriptState::OpeningDrop)) {
            self.set_script_state(ScriptState::Rendering { done: 0 });
        }
    }

    /// The newest input could not be opened; returns whether that is what the scripted run
    /// tests (a dropped file), so that the error is shown rather than ending the run.
    pub(super) fn script_expects_open_error(&mut self) -> bool {
        let expected = matches!(self.script_state(), Some(ScriptState::OpeningDrop));
        if expected {
            self.set_script_state(ScriptState::ShowingError);
        }
        expected
    }
}

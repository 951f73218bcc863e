//! The window's state and the order of work in each frame: worker reports, input, panels,
//! the next render request, the scripted run.
//!
//! The UI thread never renders or extracts. It keeps the settings (camera, isovalue, precision,
//! mode), tells the workers what it wants, and shows the newest finished frame as a texture. One
//! render request is in flight at a time; while the user drags or zooms, views are rendered at a
//! reduced size picked from the measured cost per pixel, and the full size follows when the
//! interaction stops.

mod capture;
mod controls;
mod input;
mod labels;
mod messages;
mod opening;
mod schedule;
mod script;
mod state;
mod viewport;
mod window;
mod worker_reports;

pub use window::run;

/// Why CR is not offered for a label volume's grid (shown on the mode button, and in the note when
/// one opens in CR mode).
const CR_OF_LABELS: &str = "samples the volume's values, and a label volume's are no surface";
/// Why CR and MC are not offered for a grid without its volume (a `.cgc` file without labels).
const NEEDS_VOLUME: &str = "needs the original volume; a .cgc file holds only the cells";

use crate::cost::CostModel;
use crate::events::Notifier;
use crate::extract_worker::{ExtractWorker, Wanted};
use crate::orbit::Orbit;
use crate::panel::{self, Measurements};
use crate::render_worker::RenderWorker;
use crate::{Mode, ViewerOptions};
use eframe::egui;
use state::{App, ColorState, Script, ScriptState, MEASUREMENTS_WIDTH, PANEL_WIDTH};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

impl App {
    fn new(
        ctx: &egui::Context,
        options: ViewerOptions,
        failure: Arc<Mutex<Option<String>>>,
    ) -> App {
        let (tx, events) = std::sync::mpsc::channel();
        let notify = Notifier::new(tx, ctx.clone());
        let render = RenderWorker::spawn(notify.clone());
        let compare_mc = true;
        let extractor = ExtractWorker::spawn(
            Wanted {
                open: None,
                iso: options.iso,
                precision: options.precision,
                mesh: compare_mc || options.mode == Mode::Mc,
                shutdown: false,
            },
            render.sender().clone(),
            notify,
        );
        let script = options.frames.map(|frames| Script {
            frames: frames.max(1),
            screenshot: options.screenshot.clone(),
            state: if options.wait_for_drop {
                ScriptState::AwaitingDrop
            } else {
                ScriptState::Rendering { done: 0 }
            },
            started: Instant::now(),
        });
        let mut app = App {
            path_text: String::new(),
            iso_value: 0.0,
            precision: options.precision,
            mode: options.mode,
            compare_mc,
            full_when_idle: true,
            events,
            extractor,
            render,
            generation: 0,
            source: None,
            orbit: Orbit::default(),
            has_view: false,
            grid_version: 0,
            mesh_version: 0,
            texture: None,
            shown: None,
            shown_pixels: None,
            shown_values: None,
            color: ColorState {
                attribute: None,
                on: true,
                map: options.cmap,
                clim: options.clim,
                under_cursor: None,
            },
            labels: Default::default(),
            shown_samples: 0,
            in_flight: None,
            refused: None,
            next_request: 0,
            cost: CostModel::default(),
            cost_of: None,
            last_interaction: None,
            image_rect_px: None,
            busy: None,
            renderer_error: None,
            open_error: None,
            measurements: Measurements::default(),
            messages: Vec::new(),
            capture: Arc::default(),
            capture_path: None,
            script,
            failure,
            options,
        };
        match app.options.input.clone() {
            Some(path) => {
                let read_options = app.options.read_options.clone();
                app.open(path, read_options, app.options.iso);
            }
            None => {
                if app.script.is_some() && !app.options.wait_for_drop {
                    app.fail("a scripted run needs an input file".into());
                }
            }
        }
        app
    }
}

impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        // The size the image area had last frame (or the fixed size) is the render size.
        let full_size = self.full_size(&ctx);
        self.handle_events(&ctx, full_size);
        self.handle_drops(&ctx);
        self.handle_keys(&ctx, full_size);
        if self.script.is_none() {
            self.save_capture();
        }

        let panel = egui::Panel::left("controls");
        // A fixed render size gets a fixed layout, so that the image keeps one texel per pixel.
        let panel = if self.options.size.is_some() {
            panel.exact_size(PANEL_WIDTH)
        } else {
            panel.resizable(true).default_size(PANEL_WIDTH)
        };
        panel.show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui, &ctx, full_size));
        });
        let right = egui::Panel::right("measurements");
        let right = if self.options.size.is_some() {
            right.exact_size(MEASUREMENTS_WIDTH)
        } else {
            right
                .resizable(true)
                .default_size(MEASUREMENTS_WIDTH)
                .min_size(MEASUREMENTS_WIDTH - 40.0)
        };
        right.show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.heading("Measurements");
                let dt = ui.input(|i| i.stable_dt) as f64 * 1e3;
                panel::show(ui, &self.measurements, dt);
            });
        });
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let area = ui.available_rect_before_wrap();
            ctx.data_mut(|d| d.insert_temp(egui::Id::unique("isogrid-view-area"), area));
            self.viewport(ui, full_size);
        });

        let recheck = self.schedule_render(full_size);
        if self.advance_script(&ctx, full_size) {
            if let Some(script) = &mut self.script {
                script.state = ScriptState::Finished;
            }
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        if let Some(after) = recheck {
            ctx.request_repaint_after(after);
        }
        if self.busy.is_some() {
            // The worker counts its steps without waking the window: look again for the bar.
            ctx.request_repaint_after(Duration::from_millis(100));
        }
        if self.script.is_some() {
            // Timeouts need a look now and then even when no worker reports.
            ctx.request_repaint_after(Duration::from_millis(500));
        }
    }
}

//! The window: controls and measurements on the left, the rendered isosurface in the middle.
//!
//! The UI thread never renders or extracts. It keeps the settings (camera, isovalue, precision,
//! mode), tells the workers what it wants, and shows the newest finished frame as a texture. One
//! render request is in flight at a time; while the user drags or zooms, views are rendered at a
//! reduced size picked from the measured cost per pixel, and the full size follows when the
//! interaction stops.

use crate::cost::CostModel;
use crate::events::{Event, Failure, Notifier, RenderedFrame, SourceInfo};
use crate::extract_worker::{ExtractWorker, OpenRequest, Wanted};
use crate::orbit::Orbit;
use crate::panel::{self, FrameFacts, GridFacts, Measurements, MeshFacts};
use crate::render_worker::{self, RenderMsg, RenderRequest};
use crate::screenshot;
use crate::{ViewMode, ViewerOptions};
use eframe::egui;
use isogrid::{Camera, Error, Iso, Precision};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Width of the control panel in points.
/// Samples per pixel the viewer accumulates while the camera rests in path-tracing mode.
const PATH_TRACE_SAMPLES: u32 = 256;
const PANEL_WIDTH: f32 = 300.0;
/// Width of the measurement panel in points.
const MEASUREMENTS_WIDTH: f32 = 270.0;
/// Render time aimed at while the view moves.
const INTERACTIVE_MS: f64 = 70.0;
/// Render time aimed at for the first image after the view stops; the full size follows.
const PREVIEW_MS: f64 = 500.0;
/// The view counts as moving for this long after the last drag or wheel event.
const SETTLE: Duration = Duration::from_millis(250);
/// A scripted run that has not finished by then reports failure instead of hanging.
const SCRIPT_TIMEOUT: Duration = Duration::from_secs(300);
/// How long a scripted run waits for the window capture before saving the rendered image alone.
const CAPTURE_TIMEOUT: Duration = Duration::from_secs(15);

pub fn run(options: ViewerOptions) -> isogrid::Result<()> {
    crate::logging::init();
    let failure: Arc<Mutex<Option<String>>> = Arc::default();
    let inner_size = match options.size {
        // Room for the image at one pixel per point next to the panel.
        Some([w, h]) => [
            w as f32 + PANEL_WIDTH + MEASUREMENTS_WIDTH + 64.0,
            (h as f32 + 24.0).max(640.0),
        ],
        None => [1280.0, 800.0],
    };
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("isogrid view")
            .with_inner_size(inner_size)
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    let app_failure = failure.clone();
    eframe::run_native(
        "isogrid view",
        native,
        Box::new(move |cc| Ok(Box::new(App::new(&cc.egui_ctx, options, app_failure)))),
    )
    .map_err(|e| Error::unsupported(format!("cannot open the viewer window: {e}")))?;
    let failed = failure.lock().ok().and_then(|mut f| f.take());
    match failed {
        Some(message) => Err(Error::invalid(message)),
        None => Ok(()),
    }
}

/// What a frame shows: a different key means the frame on screen is out of date.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ViewKey {
    camera: Camera,
    mode: ViewMode,
    /// Grid (or, in MC mode, mesh) uploads so far.
    scene: u64,
}

struct Message {
    text: String,
    error: bool,
}

#[derive(Clone, Copy)]
enum ScriptState {
    Rendering { done: u32 },
    Capturing { since: Instant },
    Finished,
}

/// A scripted run (`--frames`): render, capture, close.
struct Script {
    frames: u32,
    screenshot: Option<PathBuf>,
    state: ScriptState,
    started: Instant,
}

/// The window pixels from egui's capture, and where to save them.
type Capture = Arc<Mutex<Option<Arc<egui::ColorImage>>>>;

struct App {
    options: ViewerOptions,
    events: Receiver<Event>,
    render: Sender<RenderMsg>,
    extractor: ExtractWorker,

    generation: u64,
    source: Option<SourceInfo>,
    path_text: String,
    iso_value: f64,
    precision: Option<Precision>,
    mode: ViewMode,
    compare_mc: bool,
    full_when_idle: bool,
    orbit: Orbit,
    has_view: bool,

    grid_version: u64,
    mesh_version: u64,
    texture: Option<egui::TextureHandle>,
    shown: Option<ViewKey>,
    /// The frame's image (RGBA), kept for saving the render alone.
    shown_pixels: Option<(u32, u32, Vec<u8>)>,
    /// Path-tracing samples accumulated in the shown image.
    shown_samples: u32,
    in_flight: Option<(u64, ViewKey)>,
    /// A view the render worker could not draw: not asked again until something changes.
    refused: Option<ViewKey>,
    next_request: u64,
    cost: CostModel,
    /// The mode and scene version the cost model has frames of.
    cost_of: Option<(ViewMode, u64)>,
    last_interaction: Option<Instant>,
    /// The last painted image rectangle, in window pixels.
    image_rect_px: Option<egui::Rect>,

    busy: Option<String>,
    renderer_error: Option<String>,
    measurements: Measurements,
    messages: Vec<Message>,
    capture: Capture,
    capture_path: Option<PathBuf>,
    script: Option<Script>,
    failure: Arc<Mutex<Option<String>>>,
}

impl App {
    fn new(
        ctx: &egui::Context,
        options: ViewerOptions,
        failure: Arc<Mutex<Option<String>>>,
    ) -> App {
        let (tx, events) = std::sync::mpsc::channel();
        let notify = Notifier::new(tx, ctx.clone());
        let render = render_worker::spawn(notify.clone());
        let compare_mc = true;
        let extractor = ExtractWorker::spawn(
            Wanted {
                open: None,
                iso: options.iso,
                precision: options.precision,
                mesh: compare_mc || options.mode == ViewMode::Mc,
                shutdown: false,
            },
            render.clone(),
            notify,
        );
        let script = options.frames.map(|frames| Script {
            frames: frames.max(1),
            screenshot: options.screenshot.clone(),
            state: ScriptState::Rendering { done: 0 },
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
            render,
            extractor,
            generation: 0,
            source: None,
            orbit: Orbit::default(),
            has_view: false,
            grid_version: 0,
            mesh_version: 0,
            texture: None,
            shown: None,
            shown_pixels: None,
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
            measurements: Measurements::default(),
            messages: Vec::new(),
            capture: Arc::default(),
            capture_path: None,
            script,
            failure,
            options,
        };
        if app.mode.gpu_mode().is_none() {
            app.fail_or_note(format!(
                "mode {} is not available in this build; showing cgc",
                app.mode
            ));
            app.mode = ViewMode::Cgc;
        }
        match app.options.input.clone() {
            Some(path) => {
                let read_options = app.options.read_options.clone();
                app.open(path, read_options, app.options.iso);
            }
            None => {
                if app.script.is_some() {
                    app.fail("a scripted run needs an input file".into());
                }
            }
        }
        app
    }

    fn note(&mut self, text: String, error: bool) {
        if self.messages.last().is_some_and(|m| m.text == text) {
            return;
        }
        if error {
            eprintln!("isogrid view: {text}");
        }
        self.messages.push(Message { text, error });
        let excess = self.messages.len().saturating_sub(8);
        self.messages.drain(..excess);
    }

    /// Stops a scripted run with `message`; an interactive run shows it.
    fn fail(&mut self, message: String) {
        if let Some(script) = &mut self.script {
            if !matches!(script.state, ScriptState::Finished) {
                script.state = ScriptState::Finished;
                if let Ok(mut f) = self.failure.lock() {
                    f.get_or_insert(message.clone());
                }
            }
        }
        self.note(message, true);
    }

    fn fail_or_note(&mut self, message: String) {
        if self.script.is_some() {
            self.fail(message);
        } else {
            self.note(message, false);
        }
    }

    fn open(&mut self, path: PathBuf, read_options: isogrid_io::ReadOptions, iso: Iso) {
        self.generation += 1;
        self.path_text = path.display().to_string();
        self.source = None;
        self.measurements.grid = None;
        self.measurements.mesh = None;
        self.has_view = false;
        let generation = self.generation;
        self.extractor.update(|w| {
            w.open = Some(OpenRequest {
                generation,
                path,
                read_options,
            });
            w.iso = iso;
        });
    }

    /// The isovalue as a fraction of the value range, when there is one.
    fn normalized(&self, value: f64) -> Option<f64> {
        let (lo, hi) = self.source.as_ref()?.value_range?;
        (hi > lo).then(|| (value - lo) / (hi - lo))
    }

    fn wants_mesh(&self) -> bool {
        self.compare_mc || self.mode == ViewMode::Mc
    }

    fn set_view(&mut self, preset: u8, size: [u32; 2]) {
        if let Some(source) = &self.source {
            let (lo, hi) = source.world_bounds();
            if let Some(orbit) = Orbit::preset(preset, lo, hi, size[0], size[1]) {
                self.orbit = orbit;
                self.has_view = true;
            }
        }
    }

    fn handle_events(&mut self, ctx: &egui::Context, full_size: [u32; 2]) {
        while let Ok(event) = self.events.try_recv() {
            match event {
                Event::RendererReady { adapter } => self.measurements.adapter = Some(adapter),
                Event::Opened { generation, info } if generation == self.generation => {
                    self.on_opened(info, full_size)
                }
                Event::Opened { .. } => {}
                Event::Busy(what) => self.busy = what,
                Event::GridShown {
                    generation,
                    iso,
                    precision,
                    stats,
                    extract_seconds,
                } if generation == self.generation => {
                    self.measurements.grid = Some(GridFacts {
                        iso,
                        precision,
                        stats,
                        extract_seconds,
                    });
                    self.grid_version += 1;
                }
                Event::MeshShown {
                    generation,
                    iso,
                    triangles,
                    vertices,
                    bytes,
                    seconds,
                } if generation == self.generation => {
                    self.measurements.mesh = Some(MeshFacts {
                        iso,
                        triangles,
                        vertices,
                        bytes,
                        seconds,
                    });
                    self.mesh_version += 1;
                }
                Event::GridShown { .. } | Event::MeshShown { .. } => {}
                Event::Frame(frame) => self.on_frame(ctx, *frame, full_size),
                Event::NotRendered { request } => {
                    if let Some((id, key)) = self.in_flight {
                        if id == request {
                            self.in_flight = None;
                            self.refused = Some(key);
                        }
                    }
                }
                Event::Error { failure, message } => {
                    if failure == Failure::Renderer {
                        self.renderer_error = Some(message.clone());
                    }
                    // Without a mesh the memory comparison is just missing; MC mode says so.
                    if failure == Failure::Mesh && self.mode != ViewMode::Mc {
                        self.note(message, true);
                    } else {
                        self.fail(message);
                    }
                }
            }
        }
    }

    fn on_opened(&mut self, info: SourceInfo, full_size: [u32; 2]) {
        self.iso_value = match (&info.grid_info, info.value_range) {
            (Some(grid), _) => grid.iso,
            (None, Some((lo, hi))) => match self.options.iso {
                Iso::Value(v) if self.generation == 1 => v,
                // Later inputs keep the normalised position of the slider.
                _ => {
                    let t = match self.options.iso {
                        Iso::Normalized(t) => t,
                        Iso::Value(_) => 0.5,
                    };
                    lo + t * (hi - lo)
                }
            },
            (None, None) => 0.0,
        };
        if !info.has_volume() && self.mode.needs_volume() {
            self.fail_or_note(format!(
                "mode {} needs the original volume; a .cgc file holds only the cells: showing cgc",
                self.mode
            ));
            self.mode = ViewMode::Cgc;
        }
        self.note(format!("opened {}", info.path.display()), false);
        self.source = Some(info);
        self.texture = None;
        self.shown = None;
        self.shown_pixels = None;
        self.set_view(self.options.view, full_size);
    }

    fn on_frame(&mut self, ctx: &egui::Context, rendered: RenderedFrame, full_size: [u32; 2]) {
        let RenderedFrame {
            request,
            camera,
            mode,
            frame,
            seconds,
        } = rendered;
        let Some((id, key)) = self.in_flight else {
            return;
        };
        if id != request {
            return;
        }
        self.in_flight = None;
        if self.cost_of != Some((key.mode, key.scene)) {
            self.cost.reset();
            self.cost_of = Some((key.mode, key.scene));
        }
        self.cost
            .record(frame.width as u64 * frame.height as u64, seconds * 1e3);
        let full = [frame.width, frame.height] == full_size;
        let image = egui::ColorImage::from_rgba_unmultiplied(
            [frame.width as usize, frame.height as usize],
            &frame.rgba8,
        );
        // One texel per pixel at full size; smooth magnification of reduced frames.
        let filter = if full {
            egui::TextureOptions::NEAREST
        } else {
            egui::TextureOptions::LINEAR
        };
        match &mut self.texture {
            Some(t) => t.set(image, filter),
            None => self.texture = Some(ctx.load_texture("isosurface", image, filter)),
        }
        self.measurements.frame = Some(FrameFacts {
            width: frame.width,
            height: frame.height,
            timings: frame.timings,
            drawn_cells: frame.drawn_cells,
            probed_cells: frame.probed_cells,
            seconds,
        });
        debug_assert_eq!((key.camera, key.mode), (camera, mode));
        self.shown = Some(key);
        self.shown_samples = frame.samples;
        self.shown_pixels = Some((frame.width, frame.height, frame.rgba8));
        if let Some(script) = &mut self.script {
            if let ScriptState::Rendering { done } = &mut script.state {
                if full {
                    *done += 1;
                    if *done < script.frames {
                        // The same view again: the visibility buffer carries over (paper §3.3).
                        self.shown = None;
                    }
                }
            }
        }
    }

    /// Keys and dropped files, unless a text field has the keyboard.
    fn handle_input(&mut self, ctx: &egui::Context, full_size: [u32; 2]) {
        let dropped: Option<PathBuf> =
            ctx.input(|i| i.raw.dropped_files.first().map(|f| f.path().to_path_buf()));
        if let Some(path) = dropped {
            let iso = self.current_normalized_iso();
            self.open(path, Default::default(), iso);
        }
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

    /// Where the next input's isovalue starts: the slider's normalised position.
    fn current_normalized_iso(&self) -> Iso {
        match self.normalized(self.iso_value) {
            Some(t) if self.source.as_ref().is_some_and(|s| s.has_volume()) => {
                Iso::Normalized(t.clamp(0.0, 1.0))
            }
            _ => Iso::Normalized(0.5),
        }
    }

    /// Asks egui for the window's pixels; they are saved to `path` (default: the next free
    /// `isogrid-view-NNN.png` in the working directory) when they arrive.
    fn request_capture(&mut self, ctx: &egui::Context, path: Option<PathBuf>) {
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
    fn save_capture(&mut self) -> bool {
        let Some(image) = self.capture.lock().ok().and_then(|mut s| s.take()) else {
            return false;
        };
        let Some(path) = self.capture_path.take() else {
            return false;
        };
        let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
        let rgb = screenshot::rgba_to_rgb(&rgba);
        let [w, h] = image.size;
        match screenshot::write_png(&path, w as u32, h as u32, &rgb) {
            Ok(()) => {
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
                let text = format!("saved {} ({w}x{h} px window); {region}", path.display());
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

    /// Saves the rendered image alone (the button, and scripted runs whose capture never came).
    fn save_render(&mut self, path: PathBuf) -> bool {
        let Some((w, h, rgba)) = &self.shown_pixels else {
            self.fail_or_note("no rendered image to save yet".into());
            return false;
        };
        let (w, h) = (*w, *h);
        match screenshot::write_png(&path, w, h, &screenshot::rgba_to_rgb(rgba)) {
            Ok(()) => {
                let text = format!(
                    "saved {} (rendered image only); rendered image at 0,0 size {w}x{h} px",
                    path.display()
                );
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

    fn controls(&mut self, ui: &mut egui::Ui, ctx: &egui::Context, full_size: [u32; 2]) {
        ui.heading("isogrid view");
        ui.add_space(4.0);

        ui.label("Input (or drop a file on the window)");
        ui.horizontal(|ui| {
            let field = ui.add(
                egui::TextEdit::singleline(&mut self.path_text)
                    .desired_width(PANEL_WIDTH - 70.0)
                    .hint_text("volume or .cgc path"),
            );
            let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Open").clicked() || enter) && !self.path_text.trim().is_empty() {
                let path = PathBuf::from(self.path_text.trim());
                let iso = self.current_normalized_iso();
                self.open(path, Default::default(), iso);
            }
        });
        if let Some(s) = &self.source {
            ui.label(
                egui::RichText::new(format!(
                    "{}×{}×{} {} samples",
                    s.dims[0],
                    s.dims[1],
                    s.dims[2],
                    s.scalar_type.name()
                ))
                .small(),
            );
        }
        ui.separator();

        self.iso_controls(ui);
        ui.separator();

        ui.label("Mode");
        let has_volume = self.source.as_ref().is_none_or(|s| s.has_volume());
        ui.horizontal_wrapped(|ui| {
            for mode in ViewMode::ALL {
                let reason = if mode.gpu_mode().is_none() {
                    Some("path tracing is not in the GPU renderer yet (it is being added)")
                } else if mode.needs_volume() && !has_volume {
                    Some("needs the original volume; a .cgc file holds only the cells")
                } else {
                    None
                };
                let button = egui::Button::selectable(self.mode == mode, mode.name());
                let response = ui.add_enabled(reason.is_none(), button);
                let response = match reason {
                    Some(r) => response.on_disabled_hover_text(r),
                    None => response,
                };
                if response.clicked() && self.mode != mode {
                    self.mode = mode;
                    let mesh = self.wants_mesh();
                    self.extractor.update(|w| w.mesh = mesh);
                }
            }
        });
        if self.mode == ViewMode::Mc && self.measurements.mesh.is_none() {
            ui.label("Marching Cubes mesh: extracting…");
        }
        let compare = ui
            .add_enabled(
                has_volume,
                egui::Checkbox::new(&mut self.compare_mc, "extract MC too (memory comparison)"),
            )
            .on_hover_text("Runs Marching Cubes in the background after each extraction")
            .on_disabled_hover_text("needs the original volume");
        if compare.changed() {
            let mesh = self.wants_mesh();
            self.extractor.update(|w| w.mesh = mesh);
        }
        ui.separator();

        ui.label("View (drag: orbit, right/middle drag: pan, wheel: zoom)");
        ui.horizontal(|ui| {
            if ui.button("1 front").on_hover_text("key 1").clicked() {
                self.set_view(1, full_size);
            }
            if ui.button("2 oblique").on_hover_text("key 2").clicked() {
                self.set_view(2, full_size);
            }
            if ui.button("Reset").on_hover_text("key R").clicked() {
                self.set_view(self.options.view, full_size);
            }
        });
        ui.horizontal(|ui| {
            if ui
                .button("Screenshot")
                .on_hover_text("key S: the whole window")
                .clicked()
            {
                self.request_capture(ctx, None);
            }
            if ui
                .button("Save render")
                .on_hover_text("the rendered image alone")
                .clicked()
            {
                let path = screenshot::next_free_name(&std::env::current_dir().unwrap_or_default());
                self.save_render(path);
            }
        });
        ui.separator();

        ui.horizontal(|ui| {
            if let Some(what) = &self.busy {
                ui.spinner();
                ui.label(what);
            } else if self.in_flight.is_some() {
                ui.spinner();
                ui.label("rendering");
            } else {
                ui.label("idle");
            }
        });
        ui.checkbox(&mut self.full_when_idle, "full resolution when idle")
            .on_hover_text(
                "Off: stay at the preview resolution (about 0.5 s per frame); \
                 useful on CPU adapters, where large images take seconds",
            );
        if !self.messages.is_empty() {
            ui.separator();
            for m in self.messages.iter().rev() {
                let text = egui::RichText::new(&m.text).small();
                ui.label(if m.error {
                    text.color(ui.visuals().error_fg_color)
                } else {
                    text
                });
            }
            if ui.small_button("clear messages").clicked() {
                self.messages.clear();
            }
        }
    }

    fn iso_controls(&mut self, ui: &mut egui::Ui) {
        let Some(source) = &self.source else {
            ui.label("Isovalue: open a volume first");
            return;
        };
        if let Some(grid) = &source.grid_info {
            ui.label(format!(
                "Isovalue {} ({}-bit corners)",
                panel::fmt_value(grid.iso),
                grid.precision.bits()
            ));
            ui.label(
                egui::RichText::new(
                    "A .cgc file holds one extracted isosurface and no volume: open the volume \
                     to change the isovalue or precision.",
                )
                .small(),
            );
            return;
        }
        let Some((lo, hi)) = source.value_range else {
            ui.label("Isovalue: the volume has no finite sample");
            return;
        };
        ui.label("Isovalue (data units)");
        let slider = egui::Slider::new(&mut self.iso_value, lo..=hi.max(lo))
            .clamping(egui::SliderClamping::Never);
        if ui.add(slider).changed() {
            let iso = self.iso_value;
            self.extractor.update(|w| w.iso = Iso::Value(iso));
        }
        if let Some(t) = self.normalized(self.iso_value) {
            ui.label(format!("normalised {t:.4}"));
        }
        ui.horizontal(|ui| {
            ui.label("Precision");
            let mut changed = false;
            changed |= ui
                .selectable_value(&mut self.precision, None, "auto")
                .on_hover_text("the default for the sample type")
                .changed();
            for bits in [4, 8, 16, 32] {
                let p = Precision::from_bits(bits);
                changed |= ui
                    .selectable_value(&mut self.precision, p, bits.to_string())
                    .changed();
            }
            if changed {
                let p = self.precision;
                self.extractor.update(|w| w.precision = p);
            }
        });
    }

    /// The image area: mouse interaction, the frame texture, and what to render next.
    fn viewport(&mut self, ui: &mut egui::Ui, full_size: [u32; 2]) {
        let area = ui.available_rect_before_wrap();
        let response = ui.interact(
            area,
            ui.scope_id().with("view"),
            egui::Sense::click_and_drag(),
        );
        let ppp = ui.ctx().pixels_per_point();
        let rect = image_rect(area, full_size, self.options.size.is_some(), ppp);
        self.image_rect_px = Some(egui::Rect::from_min_max(
            (rect.min.to_vec2() * ppp).to_pos2(),
            (rect.max.to_vec2() * ppp).to_pos2(),
        ));

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

        let painter = ui.painter_at(area);
        painter.rect_filled(area, 0.0, background());
        if let Some(texture) = &self.texture {
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            painter.image(texture.id(), rect, uv, egui::Color32::WHITE);
        } else {
            let text = if let Some(e) = &self.renderer_error {
                e.clone()
            } else if self.source.is_none() && self.busy.is_none() {
                "Drop a volume or .cgc file here, or type its path on the left".to_string()
            } else if self.mode.gpu_mode().is_some() {
                "waiting for the first frame…".to_string()
            } else {
                String::new()
            };
            painter.text(
                area.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(16.0),
                ui.visuals().text_color(),
            );
        }
    }

    /// Sends the next render request when the frame on screen is out of date and none is
    /// rendering; returns when to look again if the view is still settling.
    fn schedule_render(&mut self, full_size: [u32; 2]) -> Option<Duration> {
        if !self.has_view || self.renderer_error.is_some() || self.in_flight.is_some() {
            return None;
        }
        let settling = self
            .last_interaction
            .map(|t| t.elapsed())
            .filter(|&e| e < SETTLE);
        let scene = match self.mode {
            ViewMode::Mc => self.mesh_version,
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
        };
        let recheck = settling.map(|e| SETTLE - e);
        // Path tracing refines while the camera rests: the same view is asked for again, each
        // call adding a sample, until PATH_TRACE_SAMPLES.
        let refining = key.mode == ViewMode::PathTrace && self.shown_samples < PATH_TRACE_SAMPLES;
        if (self.shown == Some(key) && !refining)
            || self.refused == Some(key)
            || key.mode.gpu_mode().is_none()
        {
            return recheck;
        }
        self.refused = None;
        self.next_request += 1;
        let id = self.next_request;
        let request = RenderRequest {
            id,
            camera: key.camera,
            mode: key.mode,
        };
        if self.render.send(RenderMsg::Render(request)).is_ok() {
            self.in_flight = Some((id, key));
        }
        recheck
    }

    /// Advances a scripted run; returns whether the window should close.
    fn advance_script(&mut self, ctx: &egui::Context, full_size: [u32; 2]) -> bool {
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
            ScriptState::Rendering { done } if done >= frames => {
                let current = self.shown.is_some_and(|k| {
                    [k.camera.width, k.camera.height] == full_size && k.mode == self.mode
                });
                if !current {
                    return false;
                }
                match screenshot {
                    Some(path) => {
                        self.request_capture(ctx, Some(path));
                        if let Some(s) = &mut self.script {
                            s.state = ScriptState::Capturing {
                                since: Instant::now(),
                            };
                        }
                        false
                    }
                    None => {
                        println!("isogrid view: rendered {frames} frames");
                        true
                    }
                }
            }
            ScriptState::Rendering { .. } => false,
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
}

impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        // The size the image area had last frame (or the fixed size) is the render size.
        let full_size = self.full_size(&ctx);
        self.handle_events(&ctx, full_size);
        self.handle_input(&ctx, full_size);
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
        if self.script.is_some() {
            // Timeouts need a look now and then even when no worker reports.
            ctx.request_repaint_after(Duration::from_millis(500));
        }
    }
}

impl App {
    /// Render size in pixels: fixed, or the image area of the last frame.
    fn full_size(&self, ctx: &egui::Context) -> [u32; 2] {
        if let Some(size) = self.options.size {
            return size;
        }
        let ppp = ctx.pixels_per_point();
        let area: Option<egui::Rect> =
            ctx.data(|d| d.get_temp(egui::Id::unique("isogrid-view-area")));
        match area {
            Some(a) => [
                ((a.width() * ppp).floor() as u32).clamp(1, 4096),
                ((a.height() * ppp).floor() as u32).clamp(1, 4096),
            ],
            None => [640, 480],
        }
    }
}

/// The renderer's background, so that the image blends with the area around it.
fn background() -> egui::Color32 {
    let [r, g, b] = isogrid::shading::BACKGROUND_SRGB;
    egui::Color32::from_rgb(r, g, b)
}

/// Where the image goes in `area` (points): at one texel per pixel for a fixed render size when
/// it fits (scaled down to fit otherwise), centred, with its corner on the pixel grid.
fn image_rect(area: egui::Rect, size: [u32; 2], fixed: bool, ppp: f32) -> egui::Rect {
    if !fixed {
        // The render size is the area's size floored to whole pixels: show it texel for pixel.
        let min = (area.min.to_vec2() * ppp).round() / ppp;
        let size = egui::vec2(size[0] as f32, size[1] as f32) / ppp;
        return egui::Rect::from_min_size(min.to_pos2(), size);
    }
    let natural = egui::vec2(size[0] as f32, size[1] as f32) / ppp;
    let scale = (area.width() / natural.x)
        .min(area.height() / natural.y)
        .min(1.0);
    let shown = natural * scale;
    let min = area.center() - shown * 0.5;
    let min = (min.to_vec2() * ppp).round() / ppp;
    egui::Rect::from_min_size(min.to_pos2(), shown)
}

/// Whether two cameras show the same view (image size aside).
fn same_view(a: &Camera, b: &Camera) -> bool {
    (a.eye, a.target, a.up, a.fovy_degrees) == (b.eye, b.target, b.up, b.fovy_degrees)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_images_sit_on_the_pixel_grid_at_one_texel_per_pixel() {
        let area = egui::Rect::from_min_size(egui::pos2(300.5, 0.0), egui::vec2(700.0, 600.0));
        let r = image_rect(area, [320, 240], true, 1.0);
        assert_eq!(r.size(), egui::vec2(320.0, 240.0));
        assert_eq!(r.min.x, r.min.x.round());
        assert!(area.contains_rect(r));
        // Too big: scaled down to fit, aspect kept.
        let r = image_rect(area, [1400, 600], true, 1.0);
        assert!((r.width() / r.height() - 1400.0 / 600.0).abs() < 1e-3);
        assert!(r.width() <= 700.0 + 1e-3);
    }
}

//! The window's state ([`App`]) and the records it holds (messages, the shown view's key, the
//! scripted run, the capture slot). The `app` modules below implement its behaviour on it; they
//! import from here and not from `app` itself, so no module imports its parent.

use crate::cost::CostModel;
use crate::events::{Event, SourceInfo, Task};
use crate::extract_worker::ExtractWorker;
use crate::label_list::LabelList;
use crate::orbit::Orbit;
use crate::panel::Measurements;
use crate::render_worker::RenderWorker;
use crate::{Mode, ViewerOptions};
use eframe::egui;
use isogrid::colormap::{ColorMap, Coloring};
use isogrid::{Camera, Precision};
use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Width of the control panel in points.
pub(super) const PANEL_WIDTH: f32 = 300.0;
/// Width of the measurement panel in points.
pub(super) const MEASUREMENTS_WIDTH: f32 = 270.0;

/// Everything the UI thread keeps between frames; the workers own the rest.
pub(super) struct App {
    pub(super) options: ViewerOptions,
    pub(super) events: Receiver<Event>,
    pub(super) extractor: ExtractWorker,
    pub(super) render: RenderWorker,

    pub(super) generation: u64,
    pub(super) source: Option<SourceInfo>,
    pub(super) path_text: String,
    pub(super) iso_value: f64,
    pub(super) precision: Option<Precision>,
    pub(super) mode: Mode,
    pub(super) compare_mc: bool,
    pub(super) full_when_idle: bool,
    pub(super) orbit: Orbit,
    pub(super) has_view: bool,

    pub(super) grid_version: u64,
    pub(super) mesh_version: u64,
    pub(super) texture: Option<egui::TextureHandle>,
    pub(super) shown: Option<ViewKey>,
    /// The frame's image (sRGB, 3 bytes per pixel), kept for saving the render alone.
    pub(super) shown_pixels: Option<(u32, u32, Vec<u8>)>,
    /// The attribute value under each pixel of the frame on screen (width, values; `None` off the
    /// surface), when coloured.
    pub(super) shown_values: Option<(u32, Vec<Option<f32>>)>,
    pub(super) color: ColorState,
    pub(super) labels: LabelState,
    /// Path-tracing samples accumulated in the shown image.
    pub(super) shown_samples: u32,
    pub(super) in_flight: Option<(u64, ViewKey)>,
    /// A view the render worker could not draw: not asked again until something changes.
    pub(super) refused: Option<ViewKey>,
    pub(super) next_request: u64,
    pub(super) cost: CostModel,
    /// The mode and scene version the cost model has frames of.
    pub(super) cost_of: Option<(Mode, u64)>,
    pub(super) last_interaction: Option<Instant>,
    /// The last painted image rectangle, in window pixels.
    pub(super) image_rect_px: Option<egui::Rect>,

    /// The extraction worker's task in progress.
    pub(super) busy: Option<Task>,
    pub(super) renderer_error: Option<String>,
    /// Why the newest input could not be opened, shown where its image would be.
    pub(super) open_error: Option<String>,
    pub(super) measurements: Measurements,
    pub(super) messages: Vec<Message>,
    pub(super) capture: Capture,
    pub(super) capture_path: Option<PathBuf>,
    pub(super) script: Option<Script>,
    pub(super) failure: Arc<Mutex<Option<String>>>,
}

/// Colouring by the grid's attribute: what the panel sets and the requests carry.
pub(super) struct ColorState {
    /// The attribute of the grid shown (`None`: nothing to colour by).
    pub(super) attribute: Option<isogrid::AttributeInfo>,
    /// Colour by it (off: the one fixed colour).
    pub(super) on: bool,
    pub(super) map: ColorMap,
    /// `None`: the attribute's range on the surface, which follows the isovalue.
    pub(super) clim: Option<[f64; 2]>,
    /// The value under the mouse pointer in the frame on screen (NaN: a NaN value; `None`: not
    /// over the surface).
    pub(super) under_cursor: Option<f32>,
}

impl ColorState {
    /// The request's colouring: map and range, when there is an attribute and colouring is on.
    pub(super) fn spec(&self) -> Option<(ColorMap, Option<[f64; 2]>)> {
        self.attribute
            .as_ref()
            .filter(|_| self.on)
            .map(|_| (self.map, self.clim))
    }

    /// The range the map spans now.
    pub(super) fn effective_clim(&self) -> Option<[f64; 2]> {
        let range = self.attribute.as_ref()?.range;
        Some(self.clim.unwrap_or_else(|| Coloring::default_clim(range)))
    }
}

/// The label list of a label grid, and the labels under the pointer.
#[derive(Default)]
pub(super) struct LabelState {
    /// The labels of the grid shown (`None`: not a label grid), with their flags.
    pub(super) list: Option<LabelList>,
    /// Label choices sent to the render worker so far: part of the view key, so that a frame
    /// drawn before a choice is not taken for one after it.
    pub(super) version: u64,
    /// The search box's text.
    pub(super) query: String,
    /// The label value under each pixel of the frame on screen (width, values; `u64::MAX` off
    /// the surface): the render's label AOV.
    pub(super) frame_labels: Option<(u32, Vec<u64>)>,
    /// The label value under the mouse pointer, and the one last clicked on.
    pub(super) under_cursor: Option<u64>,
    pub(super) picked: Option<u64>,
    /// The label (table index) whose name was clicked: the camera is to frame it.
    pub(super) frame: Option<usize>,
}

impl LabelState {
    /// The label value at pixel `(x, y)` of the frame on screen; `None` off the surface.
    pub(super) fn at_pixel(&self, x: u32, y: u32) -> Option<u64> {
        let (width, values) = self.frame_labels.as_ref()?;
        let v = *values.get((x + width * y) as usize)?;
        (v != u64::MAX).then_some(v)
    }
}

/// The window pixels from egui's capture, and where to save them.
pub(super) type Capture = Arc<Mutex<Option<Arc<egui::ColorImage>>>>;

/// A line listed in the window's message area.
pub(super) struct Message {
    pub(super) text: String,
    pub(super) error: bool,
}

/// What a frame shows: a different key means the frame on screen is out of date.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ViewKey {
    pub(super) camera: Camera,
    pub(super) mode: Mode,
    /// Grid (or, in MC mode, mesh) uploads so far.
    pub(super) scene: u64,
    /// The colour map and range (`None` range: the attribute's), or `None` for one colour.
    pub(super) color: Option<(ColorMap, Option<[f64; 2]>)>,
    /// The label choices sent ([`LabelState::version`]).
    pub(super) labels: u64,
}

#[derive(Clone, Copy)]
pub(super) enum ScriptState {
    /// `wait_for_drop`: frames of the initial input, if any, do not count.
    AwaitingDrop,
    /// A dropped file is being read: its errors are shown, as in an interactive run.
    OpeningDrop,
    Rendering {
        done: u32,
    },
    /// The dropped file could not be opened: the window shows why, and is captured so.
    ShowingError,
    Capturing {
        since: Instant,
    },
    Finished,
}

/// A scripted run (`--frames`): render, capture, close.
pub(super) struct Script {
    pub(super) frames: u32,
    pub(super) screenshot: Option<PathBuf>,
    pub(super) state: ScriptState,
    pub(super) started: Instant,
}

//! Messages from the worker threads to the UI thread. Every send also wakes the UI
//! (`egui::Context::request_repaint`), which otherwise sleeps until the next input event.

use eframe::egui;
use isogrid::{GridInfo, GridStats, Precision, Progress, ScalarType};
use isogrid_render::Rendered;
use std::path::PathBuf;
use std::sync::mpsc::Sender;
use std::sync::Arc;

/// What the UI learns about an input when it has been opened.
#[derive(Debug, Clone)]
pub struct SourceInfo {
    pub path: PathBuf,
    pub dims: [u32; 3],
    pub spacing: [f64; 3],
    pub scalar_type: ScalarType,
    /// Smallest and largest finite sample; `None` for a volume without finite samples.
    pub value_range: Option<(f64, f64)>,
    /// A `.cgc` file's header: it fixes the isovalue and precision, and there is no volume.
    pub grid_info: Option<GridInfo>,
    /// The name of a `.cgc` file's per-cell attribute, when it has one.
    pub attribute: Option<String>,
    /// The source's axes mirror its world (`isogrid::directions_mirror`): the view is drawn by
    /// mirrored cameras, which show the world as it lies.
    pub mirrored: bool,
}

impl SourceInfo {
    pub fn has_volume(&self) -> bool {
        self.grid_info.is_none()
    }
    /// World-space box, as `GridInfo::world_bounds`.
    pub fn world_bounds(&self) -> ([f64; 3], [f64; 3]) {
        (
            [0.0; 3],
            [0, 1, 2].map(|a| self.dims[a].saturating_sub(1) as f64 * self.spacing[a]),
        )
    }
}

/// A rendered image, and the id of the request it answers.
pub struct RenderedFrame {
    pub request: u64,
    pub image: Rendered,
    /// Wall-clock seconds of the `render` call, read-back included.
    pub seconds: f64,
}

/// A task of the extraction worker (reading an input, extracting, Marching Cubes), shown in the
/// window while it runs. The worker counts its steps in `progress` (`isogrid::Progress`: reading a
/// `.cgc` file counts bytes checksummed and blocks checked, extraction two steps per block,
/// Marching Cubes sample planes); reading a volume file does not count its work and leaves it at
/// 0 of 0.
#[derive(Debug, Clone)]
pub struct Task {
    pub what: String,
    pub progress: Arc<Progress>,
}

impl Task {
    /// The fraction done, where the task counts its steps.
    pub fn fraction(&self) -> Option<f32> {
        let (done, total) = self.progress.counts();
        (total > 0).then(|| (done.min(total) as f64 / total as f64) as f32)
    }
}

/// Which part failed; scripted runs stop on any of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    Open,
    Extract,
    Mesh,
    Renderer,
    Render,
}

pub enum Event {
    /// The renderer started on this adapter.
    RendererReady {
        adapter: String,
    },
    /// An input is open (`generation` counts opened inputs).
    Opened {
        generation: u64,
        info: SourceInfo,
    },
    /// The extraction worker started (`Some`) or finished (`None`) a task.
    Busy(Option<Task>),
    /// A grid is uploaded and drawn from now on.
    GridShown {
        generation: u64,
        iso: f64,
        precision: Precision,
        stats: GridStats,
        extract_seconds: f64,
        /// The grid's attribute, which the view can be coloured by.
        attribute: Option<isogrid::AttributeInfo>,
        /// The labels of a label grid: their table, cell counts and index.
        labels: Option<isogrid::GridLabels>,
        /// Why the grid has no active cell (`GridInfo::empty_surface_note`), when it has none.
        empty_note: Option<String>,
    },
    /// A Marching Cubes mesh is uploaded and drawn in MC mode from now on.
    MeshShown {
        generation: u64,
        iso: f64,
        triangles: u64,
        vertices: u64,
        bytes: u64,
        seconds: f64,
    },
    Frame(Box<RenderedFrame>),
    /// The render request could not be served (no scene for its mode yet, or it failed).
    NotRendered {
        request: u64,
    },
    Error {
        failure: Failure,
        message: String,
    },
}

/// The sending half the workers share.
#[derive(Clone)]
pub struct Notifier {
    tx: Sender<Event>,
    ctx: egui::Context,
}

impl Notifier {
    pub fn new(tx: Sender<Event>, ctx: egui::Context) -> Self {
        Notifier { tx, ctx }
    }
    /// Sends `event` and wakes the UI; a closed window just drops it.
    pub fn send(&self, event: Event) {
        if self.tx.send(event).is_ok() {
            self.ctx.request_repaint();
        }
    }
    pub fn error(&self, failure: Failure, message: impl Into<String>) {
        self.send(Event::Error {
            failure,
            message: message.into(),
        });
    }
}

/// Runs `f`, turning a panic (a bug, or a driver failure that wgpu reports by panicking) into an
/// error message in the window instead of a silently dead worker.
pub fn guarded(notify: &Notifier, failure: Failure, what: &str, f: impl FnOnce()) -> bool {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(()) => true,
        Err(payload) => {
            let reason = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            notify.error(failure, format!("{what} failed unexpectedly: {reason}"));
            false
        }
    }
}

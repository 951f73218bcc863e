//! Interactive isosurface viewer for clustered grid cells (issue 5 §1): an eframe/egui window
//! showing the isosurface rendered through the render front door (`isogrid_render`, on the GPU
//! renderer), with an orbit camera, an isovalue slider that re-extracts in the background, a mode
//! switch between CGC and the paper's baselines, and a panel with what the paper measures (cells,
//! clusters, memory, pass times).
//!
//! Threads, so that the window never waits for the CPU or the GPU:
//! - the UI thread (eframe) owns the camera and settings, builds an
//!   [`isogrid_render::RenderRequest`] for each view it wants, and only displays finished frames;
//! - the extraction worker (`extract_worker.rs`) reads files and runs `isogrid::extract` and
//!   Marching Cubes for the latest requested isovalue and precision, counting its steps in an
//!   `isogrid::Progress` that the window shows as a progress bar;
//! - the render worker (`render_worker.rs`) owns the front door's `UploadedScene` of the open input
//!   and the window's `SceneView`, renders the latest request offscreen and sends back the
//!   [`isogrid_render::Rendered`] image, which the UI shows as a texture. The window's own wgpu
//!   device (eframe's) is a separate one.
//!   Closing the window stops this thread and waits for it, so that its wgpu instance is gone
//!   before the process exits.
//!
//! Scripted runs (`frames` with an optional `screenshot`) render a fixed number of full-quality
//! frames, save a screenshot of the whole window and close; tests use them under Xvfb, and with
//! `wait_for_drop` to test dropping files on the window.

mod app;
mod cost;
mod events;
mod extract_worker;
mod label_list;
mod logging;
mod panel;
mod render_worker;
mod screenshot;
mod source;

pub mod orbit;

use std::path::PathBuf;

pub use isogrid::Iso;
pub use isogrid::Precision;
/// What the viewer draws: the render front door's modes, listed in its mode switch in
/// [`Mode::ALL`] order (path tracing is the GPU hybrid, refined while the camera rests).
pub use isogrid_render::Mode;

/// How to start the viewer.
#[derive(Debug, Clone)]
pub struct ViewerOptions {
    /// A volume (any format `isogrid_io::read_volume` reads) or a `.cgc` file; `None` opens an
    /// empty window waiting for a dropped or typed path.
    pub input: Option<PathBuf>,
    /// How to read `input` when its format needs telling (raw files).
    pub read_options: isogrid_io::ReadOptions,
    /// Initial isovalue; ignored for `.cgc` inputs, which carry theirs.
    pub iso: Iso,
    /// Corner precision; `None` is the default for the volume's sample type.
    pub precision: Option<Precision>,
    pub mode: Mode,
    /// Initial camera: `Camera::preset` view 1 (front) or 2 (oblique).
    pub view: u8,
    /// Fixed render size in pixels; `None` renders at the size of the window's image area.
    pub size: Option<[u32; 2]>,
    /// Scripted run: render this many full-quality frames, then close.
    pub frames: Option<u32>,
    /// Scripted run: save a PNG of the window (or, where the window cannot be captured, of the
    /// rendered image) after the last frame.
    pub screenshot: Option<PathBuf>,
    /// Scripted run, for tests of drag and drop: nothing counts until a file is dropped on the
    /// window; then the dropped file's frames are rendered, or, when it cannot be opened, its
    /// error is shown in the window (not a failure of the run) and captured.
    pub wait_for_drop: bool,
    /// A second volume the surface of a volume input is coloured by, sampled again after every
    /// extraction (a `.cgc` file brings its own attribute).
    pub attribute: Option<AttributeSource>,
    /// The initial colour map and range (`None`: the attribute's range on the surface).
    pub cmap: isogrid::colormap::ColorMap,
    pub clim: Option<[f64; 2]>,
    /// A label grid's labels drawn at first: those `show` selects (all when `None`) that `hide`
    /// does not, as `isogrid render --show / --hide`; the label list changes them.
    pub show: Option<isogrid::LabelSelection>,
    pub hide: Option<isogrid::LabelSelection>,
    /// Read `input`, a volume, as a label volume and show these labels' surfaces (extracted once,
    /// as `isogrid extract --labels`); files opened later are read as usual.
    pub labels: Option<isogrid::LabelOptions>,
}

/// Where an attribute's samples come from: a volume file (or another entry of the input's extra
/// axes, read with `read_options`), and what to call it.
#[derive(Debug, Clone)]
pub struct AttributeSource {
    pub path: PathBuf,
    pub read_options: isogrid_io::ReadOptions,
    pub name: String,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        ViewerOptions {
            input: None,
            read_options: Default::default(),
            iso: Iso::Normalized(0.5),
            precision: None,
            mode: Mode::Cgc,
            view: 2,
            size: None,
            frames: None,
            screenshot: None,
            wait_for_drop: false,
            attribute: None,
            cmap: Default::default(),
            clim: None,
            show: None,
            hide: None,
            labels: None,
        }
    }
}

/// Opens the viewer window and returns when it is closed (or, in a scripted run, after the last
/// frame and the screenshot). Errors: no window could be opened (no display), or a scripted run
/// failed (the input could not be read, no GPU adapter, extraction or rendering failed). In an
/// interactive run such failures are shown in the window instead.
pub fn run(options: ViewerOptions) -> isogrid::Result<()> {
    app::run(options)
}

//! The render front door of isogrid: a validated [`RenderRequest`], the backend [`policy`], and
//! dispatch to the CPU tracer (isogrid-trace, paper §3.6) or the GPU renderer (isogrid-gpu,
//! §3.2–3.4 and §3.6) with progress and cancellation. The CLI's `render`, the Python package's
//! `render` and the viewer's mode switch all go through it; `docs/design/rendering.md` follows a
//! request from flags to pixels.
//!
//! Modules, lowest first (none imports one above it; `scripts/check_module_cycles.py` checks):
//! `mode` (the names of modes, backends, primary rays and AOVs) and `environment` (the one place
//! that knows the tracers' environment-map types); `request`; `policy`; `output` and `context`
//! (the process's adapter and GPU renderer); `scene` (data uploaded to the GPU renderer once and
//! the per-view state drawn across frames, for interactive use); `cpu` and `gpu` (one-shot
//! requests, `gpu` through a fresh scene); `dispatch`.
//!
//! ```no_run
//! use isogrid_render::{render, RenderContext, RenderRequest, RequestParts, Mode};
//! # fn main() -> isogrid::Result<()> {
//! # let grid: isogrid::CellGrid = unimplemented!();
//! let request = RenderRequest::new(RequestParts {
//!     mode: Mode::PathTrace,
//!     size: (320, 240),
//!     samples: 8,
//!     ..RequestParts::default()
//! })?;
//! let ctx = RenderContext::new();
//! let decision = ctx.decide(&request)?; // no device is opened here
//! let image = render(&ctx, &request, decision.placement, &grid, None, &isogrid::Progress::new())?;
//! assert_eq!(image.rgb8.len(), 320 * 240 * 3);
//! # Ok(()) }
//! ```

pub mod colorbar;
mod context;
mod cpu;
mod dispatch;
mod environment;
mod gpu;
mod mode;
mod output;
pub mod policy;
mod request;
mod scene;

pub use context::RenderContext;
pub use dispatch::{label_aov, label_choice, render};
pub use environment::EnvSource;
pub use isogrid_gpu::{AdapterSummary, CellRaster};
pub use isogrid_trace::{Crossing, Traversal};
pub use mode::{cpu_draws, Aov, Backend, Mode, Primary};
pub use output::{CpuStats, GpuStats, Rendered};
pub use policy::{decide, Decision, Placement};
pub use request::{
    CameraSpec, ColorSpec, RenderRequest, RequestParts, MAX_BOUNCES, MAX_FRAMES, MAX_PIXELS,
};
pub use scene::{SceneView, UploadedScene};

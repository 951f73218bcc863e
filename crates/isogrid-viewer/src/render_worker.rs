//! The render worker: a thread that owns the GPU renderer (through an
//! [`isogrid_render::RenderContext`]), the [`UploadedScene`] of the open input and the window's
//! [`SceneView`], and renders the most recent [`RenderRequest`] the UI built. Rendering on a CPU
//! adapter (lavapipe) takes hundreds of milliseconds, so it must not run on the UI thread;
//! requests that arrive while a frame renders replace each other, and only the newest is drawn.
//!
//! Dropping the [`RenderWorker`] stops the thread and waits for it: its wgpu instance must be
//! destroyed before the process exits. Destroying a Vulkan instance unloads the driver libraries,
//! and doing that while `exit` runs their finalisers on the main thread crashed the viewer with
//! SIGSEGV at exit (about one scripted run in 25 on lavapipe).

use crate::events::{guarded, Event, Failure, Notifier, RenderedFrame};
use crate::Mode;
use isogrid::extract::attribute::values_at_surface_points;
use isogrid::mc::McMesh;
use isogrid::{CellGrid, GridStats, Progress, Volume};
use isogrid_render::{RenderContext, RenderRequest, SceneView, UploadedScene};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

pub enum RenderMsg {
    /// Draw this grid from now on; `volume` is its source (for CR), `None` for `.cgc` inputs.
    Grid {
        generation: u64,
        grid: Box<CellGrid>,
        volume: Option<Arc<Volume>>,
        stats: GridStats,
        extract_seconds: f64,
    },
    /// Draw this mesh in MC mode from now on.
    Mesh {
        generation: u64,
        iso: f64,
        mesh: McMesh,
        seconds: f64,
    },
    /// Render `request`; `id` names the frame (or the refusal) in the reply.
    Render { id: u64, request: RenderRequest },
    /// Free the scene and the renderer and end the thread, whoever else still holds a sender.
    Shutdown,
}

/// How long closing the viewer waits for the render thread to finish the frame or upload in
/// progress. A frame on lavapipe takes well under a second; a thread still busy after this is
/// taken to be stuck, and the viewer exits without it rather than hang.
const SHUTDOWN_WAIT: Duration = Duration::from_secs(20);

/// The render thread: messages go in through [`RenderWorker::sender`]; dropping this stops the
/// thread and waits for it (up to [`SHUTDOWN_WAIT`]).
pub struct RenderWorker {
    tx: Sender<RenderMsg>,
    thread: Option<JoinHandle<()>>,
}

impl RenderWorker {
    pub fn spawn(notify: Notifier) -> RenderWorker {
        let (tx, rx) = std::sync::mpsc::channel();
        let spawned = std::thread::Builder::new()
            .name("isogrid-render".into())
            .spawn(move || run(rx, notify));
        let thread = match spawned {
            Ok(thread) => Some(thread),
            Err(e) => {
                eprintln!("isogrid view: cannot start the render thread: {e}");
                None
            }
        };
        RenderWorker { tx, thread }
    }

    pub fn sender(&self) -> &Sender<RenderMsg> {
        &self.tx
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        let Some(thread) = self.thread.take() else {
            return;
        };
        // A thread that already ended (its receiver gone) makes this send fail, which is fine.
        let _ = self.tx.send(RenderMsg::Shutdown);
        let deadline = Instant::now() + SHUTDOWN_WAIT;
        while !thread.is_finished() {
            if Instant::now() > deadline {
                eprintln!(
                    "isogrid view: the render thread did not stop within {} s; exiting without it",
                    SHUTDOWN_WAIT.as_secs()
                );
                return;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        // A panic in the thread was already reported (by `guarded` or the panic hook).
        let _ = thread.join();
    }
}

/// The open input's scene.
struct Shown<'r> {
    generation: u64,
    scene: UploadedScene<'r>,
    /// The grid's source volume on the CPU, uploaded to the scene when CR first needs it.
    volume: Option<Arc<Volume>>,
    /// The grid shown, when it has an attribute: MC meshes take their vertex values from it.
    colored_grid: Option<Box<CellGrid>>,
}

fn run(rx: Receiver<RenderMsg>, notify: Notifier) {
    // Building the pipelines takes a while on a CPU adapter; the window is already up.
    let ctx = RenderContext::new();
    let ready = match ctx.renderer() {
        Ok(r) => {
            notify.send(Event::RendererReady {
                adapter: r.adapter_info(),
            });
            true
        }
        Err(e) => {
            notify.error(Failure::Renderer, format!("GPU renderer unavailable: {e}"));
            false
        }
    };
    // Dropped before the context and its renderer (reverse declaration order).
    let mut shown: Option<Shown<'_>> = None;
    // The window's view: visibility bits and path-traced samples kept between frames.
    let mut view = SceneView::new();
    while let Ok(first) = rx.recv() {
        // Apply every scene change that is waiting, and keep only the newest render request.
        let mut newest: Option<(u64, RenderRequest)> = None;
        for msg in std::iter::once(first).chain(rx.try_iter()) {
            match msg {
                RenderMsg::Shutdown => return,
                RenderMsg::Render { id, request } => {
                    if let Some((old, _)) = newest.replace((id, request)) {
                        notify.send(Event::NotRendered { request: old });
                    }
                }
                other => {
                    if ready {
                        guarded(&notify, Failure::Render, "uploading", || {
                            apply(&ctx, &mut shown, other, &notify)
                        });
                    }
                }
            }
        }
        if let Some((id, request)) = newest {
            let drawn = ready
                && guarded(&notify, Failure::Render, "rendering", || {
                    render(&mut shown, &mut view, id, &request, &notify)
                });
            if !drawn {
                notify.send(Event::NotRendered { request: id });
            }
        }
    }
}

fn apply<'r>(
    ctx: &'r RenderContext,
    shown: &mut Option<Shown<'r>>,
    msg: RenderMsg,
    notify: &Notifier,
) {
    match msg {
        RenderMsg::Grid {
            generation,
            grid,
            volume,
            stats,
            extract_seconds,
        } => {
            if shown.as_ref().is_none_or(|s| s.generation != generation) {
                // Free the old input's uploads first: two large inputs may not fit at once.
                *shown = None;
                match UploadedScene::new(ctx, grid.info()) {
                    Ok(scene) => {
                        *shown = Some(Shown {
                            generation,
                            scene,
                            volume: None,
                            colored_grid: None,
                        })
                    }
                    Err(e) => {
                        notify.error(Failure::Render, format!("uploading the cells: {e}"));
                        return;
                    }
                }
            }
            let Some(s) = shown.as_mut() else { return };
            s.volume = volume;
            match s.scene.show_grid(&grid) {
                Ok(()) => {
                    let info = grid.info();
                    notify.send(Event::GridShown {
                        generation,
                        iso: info.iso,
                        precision: info.precision,
                        stats,
                        extract_seconds,
                        attribute: grid.attribute().map(|a| a.info().clone()),
                    });
                    s.colored_grid = grid.attribute().is_some().then_some(grid);
                }
                Err(e) => notify.error(Failure::Render, format!("uploading the cells: {e}")),
            }
        }
        RenderMsg::Mesh {
            generation,
            iso,
            mesh,
            seconds,
        } => {
            // A mesh follows its input's first grid, which made the scene.
            let Some(s) = shown.as_mut().filter(|s| s.generation == generation) else {
                return;
            };
            // Coloured like the cells: each vertex takes the values of the cells it lies on, from
            // the grid of the same isovalue.
            let values = s
                .colored_grid
                .as_ref()
                .filter(|g| g.info().iso.to_bits() == iso.to_bits())
                .and_then(|g| {
                    let points = mesh.index_positions(g.info().spacing);
                    let values = values_at_surface_points(g, &points).ok()?;
                    Some((values, g.attribute()?.info().clone()))
                });
            let shown_mesh = s
                .scene
                .show_mesh(&mesh, values.as_ref().map(|(v, info)| (&v[..], info)));
            match shown_mesh {
                Ok(()) => notify.send(Event::MeshShown {
                    generation,
                    iso,
                    triangles: mesh.triangle_count() as u64,
                    vertices: mesh.vertex_count() as u64,
                    bytes: mesh.memory_bytes(),
                    seconds,
                }),
                Err(e) => notify.error(Failure::Render, format!("uploading the mesh: {e}")),
            }
        }
        RenderMsg::Render { .. } | RenderMsg::Shutdown => {}
    }
}

/// Renders `request` into a frame for the UI, or says it was not rendered: the scene has nothing
/// for its mode yet (still extracting) or cannot have (CR of a `.cgc` file), or rendering failed.
fn render(
    shown: &mut Option<Shown<'_>>,
    view: &mut SceneView,
    id: u64,
    request: &RenderRequest,
    notify: &Notifier,
) {
    let refuse = || notify.send(Event::NotRendered { request: id });
    let Some(s) = shown.as_mut() else {
        return refuse();
    };
    // CR samples the original volume: upload it the first time CR is drawn for this input.
    if request.mode() == Mode::Cr && !s.scene.has_volume() {
        if let Some(volume) = &s.volume {
            if let Err(e) = s.scene.show_volume(volume) {
                notify.error(Failure::Render, format!("uploading the volume for CR: {e}"));
                return refuse();
            }
        }
    }
    if !s.scene.can_draw(request.mode()) {
        return refuse();
    }
    let start = Instant::now();
    match s.scene.render(view, request, &Progress::new()) {
        Ok(image) => notify.send(Event::Frame(Box::new(RenderedFrame {
            request: id,
            image,
            seconds: start.elapsed().as_secs_f64(),
        }))),
        Err(e) => {
            notify.error(Failure::Render, format!("rendering: {e}"));
            refuse();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eframe::egui;

    /// The extraction worker holds a sender of its own, so the channel closing cannot be what ends
    /// the thread: dropping the worker must, and must wait for it.
    #[test]
    fn dropping_the_worker_ends_its_thread_while_another_sender_lives() {
        let (tx, events) = std::sync::mpsc::channel();
        let worker = RenderWorker::spawn(Notifier::new(tx, egui::Context::default()));
        // Once this arrives the thread owns a renderer (or knows it has none).
        let first = events
            .recv_timeout(Duration::from_secs(300))
            .expect("the render thread reports its renderer");
        assert!(matches!(
            first,
            Event::RendererReady { .. } | Event::Error { .. }
        ));
        let extractors_sender = worker.sender().clone();
        drop(worker);
        assert!(
            extractors_sender.send(RenderMsg::Shutdown).is_err(),
            "the render thread outlived the dropped worker"
        );
    }
}

//! The render worker: a thread that owns the headless [`Renderer`] and the scene uploaded to it,
//! and renders the most recent view the UI asked for. Rendering on a CPU adapter (lavapipe) takes
//! hundreds of milliseconds, so it must not run on the UI thread; requests that arrive while a
//! frame renders replace each other, and only the newest is drawn.
//!
//! Dropping the [`RenderWorker`] stops the thread and waits for it: its wgpu instance must be
//! destroyed before the process exits. Destroying a Vulkan instance unloads the driver libraries,
//! and doing that while `exit` runs their finalisers on the main thread crashed the viewer with
//! SIGSEGV at exit (about one scripted run in 25 on lavapipe).

use crate::events::{guarded, Event, Failure, Notifier, RenderedFrame};
use crate::ViewMode;
use isogrid::mc::McMesh;
use isogrid::{Camera, CellGrid, GridStats, Volume};
use isogrid_gpu::{GpuGrid, GpuMesh, GpuVolume, RenderOptions, Renderer, Scene, ViewState};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A view to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderRequest {
    pub id: u64,
    pub camera: Camera,
    pub mode: ViewMode,
}

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
    Render(RenderRequest),
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

/// What is uploaded.
#[derive(Default)]
struct Uploaded {
    generation: Option<u64>,
    grid: Option<GpuGrid>,
    /// The grid's source volume on the CPU, uploaded to `gpu_volume` when CR first needs it.
    volume: Option<Arc<Volume>>,
    gpu_volume: Option<GpuVolume>,
    mesh: Option<GpuMesh>,
    /// The window's view: visibility bits and path-traced samples kept between frames.
    view: ViewState,
}

fn run(rx: Receiver<RenderMsg>, notify: Notifier) {
    // Building the pipelines takes a while on a CPU adapter; the window is already up.
    let renderer = match Renderer::new() {
        Ok(r) => {
            notify.send(Event::RendererReady {
                adapter: r.adapter_info(),
            });
            Some(r)
        }
        Err(e) => {
            notify.error(Failure::Renderer, format!("GPU renderer unavailable: {e}"));
            None
        }
    };
    let mut scene = Uploaded::default();
    while let Ok(first) = rx.recv() {
        // Apply every scene change that is waiting, and keep only the newest render request.
        let mut request = None;
        for msg in std::iter::once(first).chain(rx.try_iter()) {
            match msg {
                // The scene is dropped before the renderer (reverse declaration order).
                RenderMsg::Shutdown => return,
                RenderMsg::Render(r) => {
                    if let Some(old) = request.replace(r) {
                        notify.send(Event::NotRendered { request: old.id });
                    }
                }
                other => {
                    if let Some(renderer) = &renderer {
                        guarded(&notify, Failure::Render, "uploading", || {
                            apply(renderer, &mut scene, other, &notify)
                        });
                    }
                }
            }
        }
        if let Some(request) = request {
            match &renderer {
                Some(renderer) => {
                    let id = request.id;
                    let ok = guarded(&notify, Failure::Render, "rendering", || {
                        render(renderer, &mut scene, request, &notify)
                    });
                    if !ok {
                        notify.send(Event::NotRendered { request: id });
                    }
                }
                None => notify.send(Event::NotRendered {
                    request: request.id,
                }),
            }
        }
    }
}

fn apply(renderer: &Renderer, scene: &mut Uploaded, msg: RenderMsg, notify: &Notifier) {
    match msg {
        RenderMsg::Grid {
            generation,
            grid,
            volume,
            stats,
            extract_seconds,
        } => {
            // Free the old grid first: two large grids may not fit at once.
            scene.grid = None;
            if scene.generation != Some(generation) {
                scene.generation = Some(generation);
                scene.gpu_volume = None;
                scene.mesh = None;
            }
            scene.volume = volume;
            match renderer.upload_grid(&grid) {
                Ok(gpu) => {
                    scene.grid = Some(gpu);
                    let info = grid.info();
                    notify.send(Event::GridShown {
                        generation,
                        iso: info.iso,
                        precision: info.precision,
                        stats,
                        extract_seconds,
                    });
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
            if scene.generation != Some(generation) {
                return;
            }
            scene.mesh = None;
            match renderer.upload_mesh(&mesh) {
                Ok(gpu) => {
                    scene.mesh = Some(gpu);
                    notify.send(Event::MeshShown {
                        generation,
                        iso,
                        triangles: mesh.triangle_count() as u64,
                        vertices: mesh.vertex_count() as u64,
                        bytes: mesh.memory_bytes(),
                        seconds,
                    });
                }
                Err(e) => notify.error(Failure::Render, format!("uploading the mesh: {e}")),
            }
        }
        RenderMsg::Render(_) | RenderMsg::Shutdown => {}
    }
}

fn render(renderer: &Renderer, scene: &mut Uploaded, request: RenderRequest, notify: &Notifier) {
    let mode = request.mode.gpu_mode();
    // CR samples the original volume: upload it the first time CR is drawn for this input.
    if request.mode == ViewMode::Cr && scene.gpu_volume.is_none() {
        if let (Some(volume), Some(grid)) = (&scene.volume, &scene.grid) {
            match renderer.upload_volume(&volume.view(), grid) {
                Ok(v) => scene.gpu_volume = Some(v),
                Err(e) => {
                    notify.error(Failure::Render, format!("uploading the volume for CR: {e}"));
                    notify.send(Event::NotRendered {
                        request: request.id,
                    });
                    return;
                }
            }
        }
    }
    let target = match (request.mode, &scene.grid, &scene.gpu_volume, &scene.mesh) {
        (ViewMode::Mc, _, _, Some(mesh)) => Scene::Mesh(mesh),
        (ViewMode::Cr, Some(grid), Some(volume), _) => Scene::Volume { grid, volume },
        (ViewMode::Cgc | ViewMode::CgcNoEwa | ViewMode::PathTrace, Some(grid), _, _) => {
            Scene::Grid(grid)
        }
        // Not there yet (still extracting), or not possible (CR of a .cgc file): the UI says which.
        _ => {
            notify.send(Event::NotRendered {
                request: request.id,
            });
            return;
        }
    };
    let start = Instant::now();
    let options = RenderOptions {
        frames: 1,
        ..Default::default()
    };
    match renderer.render_view(&mut scene.view, target, &request.camera, mode, &options) {
        Ok(frame) => notify.send(Event::Frame(Box::new(RenderedFrame {
            request: request.id,
            camera: request.camera,
            mode: request.mode,
            frame,
            seconds: start.elapsed().as_secs_f64(),
        }))),
        Err(e) => {
            notify.error(Failure::Render, format!("rendering: {e}"));
            notify.send(Event::NotRendered {
                request: request.id,
            });
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

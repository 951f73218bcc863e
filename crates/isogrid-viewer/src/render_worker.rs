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
use isogrid::mc::{labelled_mesh, labelled_mesh_with_values, McMesh};
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
    /// Draw only the labels flagged (one flag per label of the label grid `generation` shows):
    /// the grid of those labels (`CellGrid::showing_labels`, through the label index) replaces
    /// the uploaded one; nothing is extracted again. Of several waiting, only the newest is
    /// uploaded.
    ShowLabels { generation: u64, shown: Vec<bool> },
    /// Make the Marching Cubes meshes of the labels the label grid `generation` draws, if they
    /// are not made yet, and report them (the memory comparison; MC mode makes them itself).
    LabelMesh { generation: u64 },
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
    /// The grid shown, when it is a label grid.
    labels: Option<LabelScene>,
}

/// A label grid and the part of it uploaded.
struct LabelScene {
    /// Every label's cells, from which the grid of the shown labels is made.
    full: Box<CellGrid>,
    /// The grid of the shown labels when some are hidden (`None`: `full` is uploaded). Its labels
    /// map the frames' cluster AOV to label values.
    drawn: Option<Box<CellGrid>>,
    /// Whether the scene holds the MC meshes of the drawn labels (made when MC is drawn and they
    /// are not, first or after a change of the labels shown).
    mesh_shown: bool,
}

impl LabelScene {
    fn drawn(&self) -> &CellGrid {
        self.drawn.as_deref().unwrap_or(&self.full)
    }
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
        let batch: Vec<RenderMsg> = std::iter::once(first).chain(rx.try_iter()).collect();
        // Label choices replace each other: a click on each of many checkboxes uploads once.
        let last_choice = batch
            .iter()
            .rposition(|m| matches!(m, RenderMsg::ShowLabels { .. }));
        for (i, msg) in batch.into_iter().enumerate() {
            match msg {
                RenderMsg::Shutdown => return,
                RenderMsg::Render { id, request } => {
                    if let Some((old, _)) = newest.replace((id, request)) {
                        notify.send(Event::NotRendered { request: old });
                    }
                }
                RenderMsg::ShowLabels { .. } if Some(i) != last_choice => {}
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
                            labels: None,
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
                    let empty_note = (grid.active_cells() == 0).then(|| {
                        let labels = grid.labels().map(|l| l.table());
                        info.empty_surface_note(labels, || {
                            s.volume
                                .as_ref()
                                .is_some_and(|v| v.view().value_range().is_none())
                        })
                    });
                    notify.send(Event::GridShown {
                        generation,
                        iso: info.iso,
                        precision: info.precision,
                        stats,
                        extract_seconds,
                        attribute: grid.attribute().map(|a| a.info().clone()),
                        labels: grid.labels().cloned(),
                        empty_note,
                    });
                    s.labels = None;
                    if grid.labels().is_some() {
                        s.labels = Some(LabelScene {
                            full: grid,
                            drawn: None,
                            mesh_shown: false,
                        });
                    } else {
                        s.colored_grid = grid.attribute().is_some().then_some(grid);
                    }
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
        RenderMsg::ShowLabels {
            generation,
            shown: flags,
        } => {
            let Some(s) = shown.as_mut().filter(|s| s.generation == generation) else {
                return;
            };
            let Some(labels) = s.labels.as_mut() else {
                return;
            };
            let drawn = if flags.iter().all(|&f| f) {
                None
            } else {
                match labels.full.showing_labels(&flags) {
                    Ok(grid) => Some(Box::new(grid)),
                    Err(e) => {
                        return notify.error(Failure::Render, format!("hiding labels: {e}"));
                    }
                }
            };
            labels.drawn = drawn;
            if let Err(e) = s.scene.show_grid(labels.drawn()) {
                notify.error(Failure::Render, format!("uploading the shown labels: {e}"));
            }
            // Made again from the new grid when MC is next drawn.
            labels.mesh_shown = false;
        }
        RenderMsg::LabelMesh { generation } => {
            let Some(s) = shown.as_mut().filter(|s| s.generation == generation) else {
                return;
            };
            if s.labels.as_ref().is_some_and(|l| !l.mesh_shown) {
                show_label_mesh(s, generation, notify);
            }
        }
        RenderMsg::Render { .. } | RenderMsg::Shutdown => {}
    }
}

/// Uploads the Marching Cubes meshes of the cells of the labels `s` draws
/// ([`isogrid::mc::labelled_mesh`]), each drawn in its label's colour (or, for a grid with an
/// attribute, with its values), and reports them as the input's MC mesh.
fn show_label_mesh(s: &mut Shown<'_>, generation: u64, notify: &Notifier) {
    let Some(labels) = s.labels.as_mut() else {
        return;
    };
    labels.mesh_shown = true;
    let start = Instant::now();
    let grid = labels.drawn();
    let table = grid.labels().map(|l| l.table()).unwrap_or_default();
    let spacing = grid.info().spacing;
    // Coloured like the cells when the grid has an attribute: each vertex takes the values of its
    // label's cells around it.
    let shown = match grid.attribute() {
        Some(attribute) => {
            labelled_mesh_with_values(grid).and_then(|(mesh, vertex_labels, values)| {
                let values = Some((&values[..], attribute.info()));
                s.scene
                    .show_label_mesh(&mesh, &vertex_labels, table, spacing, values)?;
                Ok(mesh)
            })
        }
        None => labelled_mesh(grid).and_then(|(mesh, vertex_labels)| {
            s.scene
                .show_label_mesh(&mesh, &vertex_labels, table, spacing, None)?;
            Ok(mesh)
        }),
    };
    match shown {
        Ok(mesh) => notify.send(Event::MeshShown {
            generation,
            iso: grid.info().iso,
            triangles: mesh.triangle_count() as u64,
            vertices: mesh.vertex_count() as u64,
            bytes: mesh.memory_bytes(),
            seconds: start.elapsed().as_secs_f64(),
        }),
        Err(e) => notify.error(Failure::Mesh, format!("the labels' meshes: {e}")),
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
    // A label grid's MC mode draws its labels' meshes, made from the drawn grid's cells.
    if request.mode() == Mode::Mc && s.labels.as_ref().is_some_and(|l| !l.mesh_shown) {
        let generation = s.generation;
        show_label_mesh(s, generation, notify);
    }
    if !s.scene.can_draw(request.mode()) {
        return refuse();
    }
    let start = Instant::now();
    match s.scene.render(view, request, &Progress::new()) {
        Ok(mut image) => {
            // The label under each pixel, through the labels of the grid uploaded.
            if let Some(labels) = s.labels.as_ref().and_then(|l| l.drawn().labels()) {
                let mode = request.mode();
                image.label = Some(isogrid_render::label_aov(labels, mode, &image.cluster));
            }
            notify.send(Event::Frame(Box::new(RenderedFrame {
                request: id,
                image,
                seconds: start.elapsed().as_secs_f64(),
            })))
        }
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
    use isogrid_render::Rendered;

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

    /// The message that shows `grid` as the first input's (generation 1), without a volume.
    fn first_grid(grid: CellGrid) -> RenderMsg {
        RenderMsg::Grid {
            generation: 1,
            stats: GridStats::of(&grid),
            grid: Box::new(grid),
            volume: None,
            extract_seconds: 0.0,
        }
    }

    /// A render worker whose renderer has started, and its events; `None` (said on stderr)
    /// without a GPU adapter.
    fn started_worker() -> Option<(RenderWorker, std::sync::mpsc::Receiver<Event>)> {
        let (tx, events) = std::sync::mpsc::channel();
        let worker = RenderWorker::spawn(Notifier::new(tx, egui::Context::default()));
        match events
            .recv_timeout(Duration::from_secs(300))
            .expect("the renderer reports")
        {
            Event::RendererReady { .. } => Some((worker, events)),
            Event::Error { message, .. } => {
                eprintln!("skipping: no GPU renderer: {message}");
                None
            }
            _ => panic!("the renderer reports first"),
        }
    }

    /// The frame the worker draws of a label grid with `shown` labels, as the window asks for it
    /// (the grid uploaded once, the label choice uploaded after, one GPU frame of view 2); `None`
    /// without a GPU adapter.
    fn worker_frame(
        grid: CellGrid,
        shown: Option<Vec<bool>>,
        size: (u32, u32),
    ) -> Option<Rendered> {
        let (worker, events) = started_worker()?;
        let wait = Duration::from_secs(300);
        let send = |m| worker.sender().send(m).unwrap();
        send(first_grid(grid));
        if let Some(shown) = shown {
            send(RenderMsg::ShowLabels {
                generation: 1,
                shown,
            });
        }
        send(RenderMsg::Render {
            id: 7,
            request: request(size, None),
        });
        loop {
            match events.recv_timeout(wait).expect("the worker answers") {
                Event::Frame(f) if f.request == 7 => return Some(f.image),
                Event::NotRendered { .. } => panic!("the worker did not render"),
                Event::Error { message, .. } => panic!("{message}"),
                _ => {}
            }
        }
    }

    /// Asked for the labels' meshes (the memory comparison), the worker makes them from the grid
    /// it draws and reports their size: the triangles `labelled_mesh` makes of the shown labels,
    /// made again after the shown labels change.
    #[test]
    fn label_meshes_are_made_on_request_and_again_for_other_labels() {
        let volume = isogrid::generate::labelled_cubes(18);
        let options = isogrid::LabelOptions::new(isogrid::LabelSelection::All);
        let grid = isogrid::extract_labels(&volume.view(), &options).unwrap();
        let count = |g: &CellGrid| labelled_mesh(g).unwrap().0.triangle_count() as u64;
        let all = count(&grid);
        let mut shown = vec![true; grid.labels().unwrap().table().len()];
        shown[0] = false;
        let fewer = count(&grid.showing_labels(&shown).unwrap());
        assert!(0 < fewer && fewer < all);

        let Some((worker, events)) = started_worker() else {
            return;
        };
        let wait = Duration::from_secs(300);
        let send = |m| worker.sender().send(m).unwrap();
        let next_mesh = || loop {
            match events.recv_timeout(wait).expect("the worker answers") {
                Event::MeshShown { triangles, .. } => return triangles,
                Event::Error { message, .. } => panic!("{message}"),
                _ => {}
            }
        };
        send(first_grid(grid));
        send(RenderMsg::LabelMesh { generation: 1 });
        assert_eq!(next_mesh(), all);
        send(RenderMsg::ShowLabels {
            generation: 1,
            shown,
        });
        send(RenderMsg::LabelMesh { generation: 1 });
        assert_eq!(next_mesh(), fewer);
    }

    /// A label grid with an attribute in MC mode: the worker uploads its labels' meshes with their
    /// values, and draws what `isogrid render --mode mc` draws of the same grid, coloured (not in
    /// the labels' colours), naming the same labels.
    #[test]
    fn a_coloured_label_grid_draws_its_meshes_by_the_attribute_in_mc_mode() {
        let volume = isogrid::generate::labelled_cubes(18);
        let options = isogrid::LabelOptions::new(isogrid::LabelSelection::All);
        let n = 18usize;
        let field: Vec<f32> = (0..n * n * n).map(|i| (i % n) as f32).collect();
        let field = isogrid::Volume::new([n; 3], isogrid::VolumeData::F32(field)).unwrap();
        let extract = || {
            let grid = isogrid::extract_labels(&volume.view(), &options).unwrap();
            let attribute = isogrid::extract::attribute::sample_attribute_in_memory(
                &grid,
                &field.view(),
                "x",
                isogrid::AttributePrecision::Code16,
            )
            .unwrap();
            grid.with_attribute(attribute).unwrap()
        };
        let size = (160u32, 120u32);
        let mc = |color: bool| {
            isogrid_render::RenderRequest::new(isogrid_render::RequestParts {
                mode: Mode::Mc,
                backend: isogrid_render::Backend::Gpu,
                camera: isogrid_render::CameraSpec::View(2),
                size,
                color: color.then(isogrid_render::ColorSpec::default),
                aovs: vec![isogrid_render::Aov::Label],
                ..Default::default()
            })
            .unwrap()
        };
        let Some((worker, events)) = started_worker() else {
            return;
        };
        let wait = Duration::from_secs(300);
        let send = |m| worker.sender().send(m).unwrap();
        send(first_grid(extract()));
        send(RenderMsg::LabelMesh { generation: 1 });
        send(RenderMsg::Render {
            id: 9,
            request: mc(true),
        });
        let viewer = loop {
            match events.recv_timeout(wait).expect("the worker answers") {
                Event::Frame(f) if f.request == 9 => break f.image,
                Event::NotRendered { .. } => panic!("the worker did not render"),
                Event::Error { message, .. } => panic!("{message}"),
                _ => {}
            }
        };
        let ctx = RenderContext::new();
        let grid = extract();
        let render = |request| {
            isogrid_render::render(
                &ctx,
                &request,
                isogrid_render::Placement::Gpu,
                &grid,
                None,
                &Progress::new(),
            )
            .unwrap()
        };
        let (coloured, by_label) = (render(mc(true)), render(mc(false)));
        let pixels = (size.0 * size.1) as usize;
        let same = |a: &Rendered, b: &Rendered| {
            (0..pixels)
                .filter(|&i| a.rgb8[3 * i..3 * i + 3] == b.rgb8[3 * i..3 * i + 3])
                .count()
        };
        let (like_render, like_labels) = (same(&viewer, &coloured), same(&viewer, &by_label));
        eprintln!("viewer = render --mode mc on {like_render}/{pixels} pixels, = the label colours on {like_labels}");
        assert!(like_render as f64 >= 0.999 * pixels as f64);
        let hits = coloured.label.as_ref().unwrap();
        let hit = hits.iter().filter(|&&l| l != u64::MAX).count();
        assert!(hit > pixels / 10, "{hit} of {pixels} pixels hit");
        assert!(
            like_labels < pixels - hit / 2,
            "the viewer drew the labels' colours"
        );
        let same_labels = |other: &Rendered| {
            let other = other.label.as_ref().expect("a label AOV");
            (0..pixels).filter(|&i| other[i] == hits[i]).count()
        };
        let (viewer_labels, uncoloured_labels) = (same_labels(&viewer), same_labels(&by_label));
        eprintln!("labels as render's on {viewer_labels} (viewer), {uncoloured_labels} (uncoloured render)");
        assert!(viewer_labels as f64 >= 0.999 * pixels as f64);
        assert_eq!(uncoloured_labels, pixels);
    }

    /// A GPU request for view 2 at `size`, hiding `hide`, with the label AOV.
    fn request(size: (u32, u32), hide: Option<&str>) -> RenderRequest {
        isogrid_render::RenderRequest::new(isogrid_render::RequestParts {
            mode: Mode::Cgc,
            backend: isogrid_render::Backend::Gpu,
            camera: isogrid_render::CameraSpec::View(2),
            size,
            hide: hide.map(|h| isogrid::LabelSelection::parse(h).unwrap()),
            aovs: vec![isogrid_render::Aov::Label],
            ..Default::default()
        })
        .unwrap()
    }

    /// Hiding a label in the viewer (the label list's flags, uploaded by the worker) draws what
    /// `isogrid render --hide V` draws of the same grid, and the label the viewer names under
    /// each pixel is the label AOV of that render there. On 3³ cubes of 11 touching labels,
    /// where hiding one reveals its neighbours' faces.
    #[test]
    fn hiding_a_label_draws_what_render_hide_draws_and_names_its_labels() {
        let volume = isogrid::generate::labelled_cubes(18);
        let options = isogrid::LabelOptions::new(isogrid::LabelSelection::All);
        let extract = || isogrid::extract_labels(&volume.view(), &options).unwrap();
        let grid = extract();
        let labels = grid.labels().unwrap();
        let hidden_value = 4u64;
        let shown: Vec<bool> = labels
            .table()
            .iter()
            .map(|l| l.value != hidden_value)
            .collect();
        assert_eq!(shown.iter().filter(|s| !**s).count(), 1);
        let size = (160, 120);
        let Some(viewer) = worker_frame(extract(), Some(shown), size) else {
            return;
        };
        let all = worker_frame(extract(), None, size).unwrap();

        let ctx = RenderContext::new();
        let reference = isogrid_render::render(
            &ctx,
            &request(size, Some("4")),
            isogrid_render::Placement::Gpu,
            &grid,
            None,
            &Progress::new(),
        )
        .unwrap();
        let n = (size.0 * size.1) as usize;
        let same_pixels = (0..n)
            .filter(|&i| viewer.rgb8[3 * i..3 * i + 3] == reference.rgb8[3 * i..3 * i + 3])
            .count();
        let changed = (0..n)
            .filter(|&i| viewer.rgb8[3 * i..3 * i + 3] != all.rgb8[3 * i..3 * i + 3])
            .count();
        eprintln!(
            "viewer = render --hide on {same_pixels}/{n} pixels; hiding changed {changed} pixels"
        );
        assert!(
            changed > n / 50,
            "hiding label 4 changed only {changed} pixels"
        );
        assert!(
            same_pixels as f64 >= 0.999 * n as f64,
            "viewer and render --hide agree on {same_pixels} of {n} pixels"
        );

        // The label under each pixel, as the window reads it, against the render's label AOV.
        let viewer_labels = viewer.label.as_ref().expect("the worker names the labels");
        let reference_labels = reference
            .label
            .as_ref()
            .expect("render gives the label AOV");
        let hits = reference_labels.iter().filter(|&&l| l != u64::MAX).count();
        assert!(hits > n / 10, "{hits} of {n} pixels hit");
        let same_labels = (0..n)
            .filter(|&i| viewer_labels[i] == reference_labels[i])
            .count();
        eprintln!("viewer label = render label AOV on {same_labels}/{n} pixels");
        assert!(same_labels as f64 >= 0.999 * n as f64);
        assert!(!viewer_labels.contains(&hidden_value));
        let all_labels = all.label.as_ref().unwrap();
        assert!(
            all_labels.contains(&hidden_value),
            "label 4 shows when not hidden"
        );
    }
}

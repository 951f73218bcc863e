//! The extraction worker: a thread that brings the scene up to date with what the UI wants —
//! open the requested input, extract clustered grid cells (`isogrid::extract`, paper §3.1) at the
//! wanted isovalue and precision, and, when asked, the Marching Cubes mesh at the same isovalue —
//! and hands the results to the render worker.
//!
//! The UI only ever overwrites one shared [`Wanted`]; the worker compares it with what it has
//! done after each step, so a slider dragged across many values costs one extraction per step
//! the worker finishes, never a queue of stale ones. Extraction itself cannot be interrupted.
//!
//! Each task is announced with an [`isogrid::Progress`] the window reads while it runs (a
//! progress bar where the task counts its steps: reading a `.cgc` file, extraction, Marching
//! Cubes).

use crate::events::{guarded, Event, Failure, Notifier, SourceInfo, Task};
use crate::render_worker::RenderMsg;
use crate::source::{self, Source};
use isogrid::extract::attribute::sample_attribute_in_memory;
use isogrid::mc::{try_marching_cubes_with_progress, Inside};
use isogrid::{
    extract_with_progress, CellGrid, ExtractOptions, GridStats, Iso, Precision, Progress, Volume,
};
use isogrid::{AttributePrecision, ResultExt};
use std::path::PathBuf;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

/// An input to open; `generation` increases with every request, so that reopening the same
/// path reloads it.
#[derive(Debug, Clone)]
pub struct OpenRequest {
    pub generation: u64,
    pub path: PathBuf,
    pub read_options: isogrid_io::ReadOptions,
    /// What a volume's surfaces are coloured by (ignored for `.cgc` files).
    pub attribute: Option<crate::AttributeSource>,
    /// Read a volume as a label volume and extract these labels' surfaces, once (ignored for
    /// `.cgc` files).
    pub labels: Option<isogrid::LabelOptions>,
}

/// What the scene should be.
#[derive(Debug, Clone)]
pub struct Wanted {
    pub open: Option<OpenRequest>,
    pub iso: Iso,
    pub precision: Option<Precision>,
    /// Also extract the MC mesh (MC mode, and the memory comparison).
    pub mesh: bool,
    pub shutdown: bool,
}

/// The UI's handle: set what is wanted, the worker follows.
pub struct ExtractWorker {
    shared: Arc<(Mutex<Wanted>, Condvar)>,
}

impl ExtractWorker {
    pub fn spawn(initial: Wanted, render: Sender<RenderMsg>, notify: Notifier) -> Self {
        let shared = Arc::new((Mutex::new(initial), Condvar::new()));
        let for_thread = shared.clone();
        let spawned = std::thread::Builder::new()
            .name("isogrid-extract".into())
            .spawn(move || Worker::new(render, notify.clone()).run(&for_thread));
        if let Err(e) = spawned {
            // Without the thread nothing will ever load; say so in the window.
            eprintln!("isogrid view: cannot start the extraction thread: {e}");
        }
        ExtractWorker { shared }
    }

    /// Changes what is wanted and wakes the worker.
    pub fn update(&self, f: impl FnOnce(&mut Wanted)) {
        let (lock, wake) = &*self.shared;
        if let Ok(mut wanted) = lock.lock() {
            f(&mut wanted);
            wake.notify_one();
        }
    }
}

impl Drop for ExtractWorker {
    fn drop(&mut self) {
        self.update(|w| w.shutdown = true);
    }
}

/// A grid or mesh identity: input generation, isovalue in data units (bit pattern, so that it
/// compares exactly) and precision.
type GridKey = (u64, u64, Option<Precision>);
type MeshKey = (u64, u64);
/// An open volume and its finite value range.
type OpenVolume = (Arc<Volume>, Option<(f64, f64)>);

enum Step {
    Open(Box<OpenRequest>),
    Grid(Arc<Volume>, f64, Option<Precision>),
    Mesh(Arc<Volume>, f64),
    Shutdown,
}

struct Worker {
    render: Sender<RenderMsg>,
    notify: Notifier,
    /// The open input's generation and, for volumes, the volume and its value range.
    generation: Option<u64>,
    volume: Option<OpenVolume>,
    /// The open volume's attribute volume and name, sampled on every grid extracted from it.
    attribute: Option<(Arc<Volume>, String)>,
    /// What was last extracted (or failed to; not retried until something changes).
    grid_done: Option<GridKey>,
    mesh_done: Option<MeshKey>,
}

impl Worker {
    fn new(render: Sender<RenderMsg>, notify: Notifier) -> Self {
        Worker {
            render,
            notify,
            generation: None,
            volume: None,
            attribute: None,
            grid_done: None,
            mesh_done: None,
        }
    }

    fn run(mut self, shared: &(Mutex<Wanted>, Condvar)) {
        let (lock, wake) = shared;
        loop {
            let step = {
                let Ok(mut wanted) = lock.lock() else { return };
                loop {
                    if let Some(step) = self.next_step(&wanted) {
                        break step;
                    }
                    wanted = match wake.wait(wanted) {
                        Ok(w) => w,
                        Err(_) => return,
                    };
                }
            };
            match step {
                Step::Shutdown => return,
                Step::Open(request) => {
                    let notify = self.notify.clone();
                    guarded(&notify, Failure::Open, "opening", || self.open(*request));
                }
                Step::Grid(volume, iso, precision) => {
                    let notify = self.notify.clone();
                    guarded(&notify, Failure::Extract, "extraction", || {
                        self.extract_grid(&volume, iso, precision)
                    });
                }
                Step::Mesh(volume, iso) => {
                    let notify = self.notify.clone();
                    guarded(&notify, Failure::Mesh, "Marching Cubes", || {
                        self.extract_mesh(&volume, iso)
                    });
                }
            }
        }
    }

    /// The isovalue in data units for the open volume, as `Iso::resolve` computes it.
    fn resolve(iso: Iso, range: Option<(f64, f64)>) -> Option<f64> {
        let value = match iso {
            Iso::Value(v) => v,
            Iso::Normalized(t) => {
                let (lo, hi) = range?;
                lo + t * (hi - lo)
            }
        };
        value.is_finite().then_some(value)
    }

    fn next_step(&self, wanted: &Wanted) -> Option<Step> {
        if wanted.shutdown {
            return Some(Step::Shutdown);
        }
        let open = wanted.open.as_ref()?;
        if self.generation != Some(open.generation) {
            return Some(Step::Open(Box::new(open.clone())));
        }
        let (volume, range) = self.volume.as_ref()?;
        let iso = Self::resolve(wanted.iso, *range)?;
        let grid_key = (open.generation, iso.to_bits(), wanted.precision);
        if self.grid_done != Some(grid_key) {
            return Some(Step::Grid(volume.clone(), iso, wanted.precision));
        }
        let mesh_key = (open.generation, iso.to_bits());
        if wanted.mesh && self.mesh_done != Some(mesh_key) {
            return Some(Step::Mesh(volume.clone(), iso));
        }
        None
    }

    /// Tells the window that a task starts; its steps are counted in the returned progress.
    fn start_task(&self, what: String) -> Arc<Progress> {
        let progress = Arc::new(Progress::new());
        self.notify.send(Event::Busy(Some(Task {
            what,
            progress: progress.clone(),
        })));
        progress
    }

    fn end_task(&self) {
        self.notify.send(Event::Busy(None));
    }

    fn open(&mut self, request: OpenRequest) {
        let progress = self.start_task(format!("reading {}", request.path.display()));
        // Forget the old input first: a failed open leaves nothing half-shown.
        self.generation = Some(request.generation);
        self.volume = None;
        self.attribute = None;
        self.grid_done = None;
        self.mesh_done = None;
        if let Some(labels) = request
            .labels
            .as_ref()
            .filter(|_| !source::is_cgc(&request.path))
        {
            self.open_labels(&request, labels);
            return self.end_task();
        }
        match source::open(&request.path, &request.read_options, &progress) {
            Err(e) => self.notify.error(Failure::Open, e.to_string()),
            Ok(Source::Volume(volume)) => {
                let range = volume.value_range();
                let info = SourceInfo {
                    path: request.path.clone(),
                    dims: volume.dims().map(|d| d as u32),
                    spacing: volume.spacing(),
                    scalar_type: volume.scalar_type(),
                    value_range: range,
                    grid_info: None,
                    attribute: None,
                    mirrored: isogrid::directions_mirror(&volume.geometry().direction),
                };
                self.notify.send(Event::Opened {
                    generation: request.generation,
                    info,
                });
                if range.is_none() {
                    self.notify.error(
                        Failure::Open,
                        "the volume has no finite sample: nothing to show",
                    );
                }
                self.open_attribute(&request, &progress);
                self.volume = Some((volume, range));
            }
            Ok(Source::Grid(grid)) => {
                let info = grid.info().clone();
                self.notify.send(Event::Opened {
                    generation: request.generation,
                    info: SourceInfo {
                        path: request.path.clone(),
                        dims: info.dims,
                        spacing: info.spacing,
                        scalar_type: info.scalar_type,
                        value_range: Some((info.value_range[0], info.value_range[1])),
                        mirrored: info.mirrors_world(),
                        grid_info: Some(info),
                        attribute: grid.attribute().map(|a| a.info().name.clone()),
                    },
                });
                let stats = GridStats::of(&grid);
                let _ = self.render.send(RenderMsg::Grid {
                    generation: request.generation,
                    grid,
                    volume: None,
                    stats,
                    extract_seconds: 0.0,
                });
            }
        }
        self.end_task();
    }

    /// Reads the volume of `--color-by` into `self.attribute`, or says why it cannot.
    fn open_attribute(&mut self, request: &OpenRequest, progress: &Arc<Progress>) {
        let Some(a) = &request.attribute else {
            return;
        };
        match source::open(&a.path, &a.read_options, progress) {
            Ok(Source::Volume(v)) => self.attribute = Some((v, a.name.clone())),
            Ok(Source::Grid(_)) => self.notify.error(
                Failure::Open,
                format!(
                    "{}: a .cgc file holds no samples to colour by",
                    a.path.display()
                ),
            ),
            Err(e) => self.notify.error(Failure::Open, e.to_string()),
        }
    }

    /// `grid` with the attribute of `--color-by`, sampled at its cells, if there is one.
    fn with_attribute(&self, grid: CellGrid) -> isogrid::Result<CellGrid> {
        match &self.attribute {
            Some((attribute, name)) => {
                let values = sample_attribute_in_memory(
                    &grid,
                    &attribute.view(),
                    name,
                    AttributePrecision::Code16,
                )?;
                grid.with_attribute(values)
            }
            None => Ok(grid),
        }
    }

    /// A label volume: its labels' surfaces, extracted once (no isovalue applies), coloured by
    /// `--color-by` when given, shown as a `.cgc` label grid is.
    fn open_labels(&mut self, request: &OpenRequest, options: &isogrid::LabelOptions) {
        let path = &request.path;
        let start = Instant::now();
        let progress = Arc::new(Progress::new());
        self.open_attribute(request, &progress);
        let extracted = isogrid_io::labels::read_label_volume(path, &request.read_options)
            .and_then(|(source, _notices)| {
                self.notify.send(Event::Busy(Some(Task {
                    what: format!("extracting the labels of {}", path.display()),
                    progress,
                })));
                // Names (`--labels liver`) are the file's, as `extract --labels` takes them.
                let selection = isogrid_io::labels::resolve_label_names(
                    &options.selection,
                    &source.names,
                    None,
                )?;
                let options = isogrid::LabelOptions {
                    selection,
                    ..options.clone()
                };
                isogrid_io::labels::extract_label_volume(&source, &options)
            })
            .at_path(path)
            .and_then(|grid| self.with_attribute(grid));
        let grid = match extracted {
            Ok(grid) => grid,
            Err(e) => return self.notify.error(Failure::Open, e.to_string()),
        };
        let info = grid.info().clone();
        self.notify.send(Event::Opened {
            generation: request.generation,
            info: SourceInfo {
                path: path.clone(),
                dims: info.dims,
                spacing: info.spacing,
                scalar_type: info.scalar_type,
                value_range: Some((info.value_range[0], info.value_range[1])),
                mirrored: info.mirrors_world(),
                grid_info: Some(info),
                attribute: grid.attribute().map(|a| a.info().name.clone()),
            },
        });
        let stats = GridStats::of(&grid);
        let _ = self.render.send(RenderMsg::Grid {
            generation: request.generation,
            grid: Box::new(grid),
            volume: None,
            stats,
            extract_seconds: start.elapsed().as_secs_f64(),
        });
    }

    fn extract_grid(&mut self, volume: &Arc<Volume>, iso: f64, precision: Option<Precision>) {
        let Some(generation) = self.generation else {
            return;
        };
        self.grid_done = Some((generation, iso.to_bits(), precision));
        let progress = self.start_task(format!(
            "extracting cells at {}",
            crate::panel::fmt_value(iso)
        ));
        let start = Instant::now();
        let options = ExtractOptions {
            iso: Iso::Value(iso),
            precision,
        };
        // Sampled again at every isovalue: the slider keeps the colouring.
        let extracted = extract_with_progress(&volume.view(), &options, &progress)
            .and_then(|grid| self.with_attribute(grid));
        match extracted {
            Ok(grid) => {
                let stats = GridStats::of(&grid);
                let _ = self.render.send(RenderMsg::Grid {
                    generation,
                    grid: Box::new(grid),
                    volume: Some(volume.clone()),
                    stats,
                    extract_seconds: start.elapsed().as_secs_f64(),
                });
            }
            Err(e) => self
                .notify
                .error(Failure::Extract, format!("extraction: {e}")),
        }
        self.end_task();
    }

    fn extract_mesh(&mut self, volume: &Arc<Volume>, iso: f64) {
        let Some(generation) = self.generation else {
            return;
        };
        self.mesh_done = Some((generation, iso.to_bits()));
        let progress = self.start_task(format!(
            "Marching Cubes at {}",
            crate::panel::fmt_value(iso)
        ));
        let start = Instant::now();
        match try_marching_cubes_with_progress(&volume.view(), iso, Inside::AtOrAbove, &progress) {
            Ok(mesh) => {
                let _ = self.render.send(RenderMsg::Mesh {
                    generation,
                    iso,
                    mesh,
                    seconds: start.elapsed().as_secs_f64(),
                });
            }
            Err(e) => self
                .notify
                .error(Failure::Mesh, format!("Marching Cubes: {e}")),
        }
        self.end_task();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::Event;
    use eframe::egui;
    use isogrid::generate::{generate, Field};
    use isogrid::mc::marching_cubes;
    use isogrid::{extract, CellGrid};
    use std::sync::mpsc::{channel, Receiver};
    use std::time::Duration;

    const WAIT: Duration = Duration::from_secs(60);

    fn next_grid(rx: &Receiver<RenderMsg>) -> (u64, CellGrid) {
        loop {
            match rx.recv_timeout(WAIT).expect("a grid arrives") {
                RenderMsg::Grid {
                    generation, grid, ..
                } => return (generation, *grid),
                _ => continue,
            }
        }
    }

    fn reference(volume: &Volume, iso: Iso, precision: Option<Precision>) -> CellGrid {
        extract(&volume.view(), &ExtractOptions { iso, precision }).unwrap()
    }

    fn open_request(generation: u64, path: &std::path::Path) -> OpenRequest {
        OpenRequest {
            generation,
            path: path.to_path_buf(),
            read_options: Default::default(),
            attribute: None,
            labels: None,
        }
    }

    /// A worker opening `path` (generation 1) at the normalised isovalue 0.5, without meshes,
    /// and the receivers of what it sends to the render worker and to the window.
    fn spawn_opening(
        path: &std::path::Path,
    ) -> (ExtractWorker, Receiver<RenderMsg>, Receiver<Event>) {
        let (render_tx, render_rx) = channel();
        let (event_tx, event_rx) = channel();
        let worker = ExtractWorker::spawn(
            Wanted {
                open: Some(open_request(1, path)),
                iso: Iso::Normalized(0.5),
                precision: None,
                mesh: false,
                shutdown: false,
            },
            render_tx,
            Notifier::new(event_tx, egui::Context::default()),
        );
        (worker, render_rx, event_rx)
    }

    #[test]
    fn follows_the_wanted_isovalue_precision_and_mesh() {
        let dir =
            std::env::temp_dir().join(format!("isogrid-viewer-worker-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("sphere.nrrd");
        let volume = generate(Field::Sphere, 24, 1);
        isogrid_io::write_nrrd(&path, &volume).unwrap();

        let (worker, render_rx, event_rx) = spawn_opening(&path);

        let (generation, grid) = next_grid(&render_rx);
        let expected = reference(&volume, Iso::Normalized(0.5), None);
        assert_eq!(generation, 1);
        assert_eq!(grid.info(), expected.info());
        assert_eq!(grid.cells(), expected.cells());

        // A burst of slider positions: the worker ends on the last one, in at most one
        // extraction per position.
        let values: Vec<f64> = (0..10).map(|i| 100.0 + 10.0 * i as f64).collect();
        for &v in &values {
            worker.update(|w| {
                w.iso = Iso::Value(v);
                w.precision = Some(Precision::Bits16);
            });
        }
        let last = *values.last().unwrap();
        let mut extractions = 0;
        let grid = loop {
            let (_, grid) = next_grid(&render_rx);
            extractions += 1;
            assert!(values.contains(&grid.info().iso));
            if grid.info().iso == last {
                break grid;
            }
        };
        assert!(extractions <= values.len());
        let expected = reference(&volume, Iso::Value(last), Some(Precision::Bits16));
        assert_eq!(grid.info(), expected.info());
        assert_eq!(grid.cells(), expected.cells());

        worker.update(|w| w.mesh = true);
        let mesh = loop {
            if let RenderMsg::Mesh { iso, mesh, .. } = render_rx.recv_timeout(WAIT).unwrap() {
                assert_eq!(iso, last);
                break mesh;
            }
        };
        assert_eq!(mesh, marching_cubes(&volume.view(), last));

        // A missing file is reported with its path; nothing is extracted for it.
        let missing = dir.join("missing.nrrd");
        worker.update(|w| w.open = Some(open_request(2, &missing)));
        let message = loop {
            if let Event::Error { failure, message } = event_rx.recv_timeout(WAIT).unwrap() {
                assert_eq!(failure, Failure::Open);
                break message;
            }
        };
        assert!(message.contains("missing.nrrd"), "{message}");
        drop(worker);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Follows one task from its `Busy` announcement to its end, reading its counts as the window
    /// does; returns the task's name and every count seen, the last taken after it ended.
    fn follow_task(events: &Receiver<Event>) -> (String, Vec<(u64, u64)>) {
        let task = loop {
            match events.recv_timeout(WAIT).expect("the worker reports") {
                Event::Busy(Some(task)) => break task,
                Event::Error { message, .. } => panic!("{message}"),
                _ => continue,
            }
        };
        let mut seen = vec![task.progress.counts()];
        loop {
            match events.try_recv() {
                Ok(Event::Busy(None)) => break,
                Ok(Event::Error { message, .. }) => panic!("{message}"),
                Ok(_) => {}
                Err(std::sync::mpsc::TryRecvError::Empty) => std::thread::yield_now(),
                Err(e) => panic!("{e}"),
            }
            seen.push(task.progress.counts());
        }
        seen.push(task.progress.counts());
        (task.what, seen)
    }

    /// Counts only grow, against one total once it is set, and end with every step done.
    fn assert_counts_to_done(what: &str, seen: &[(u64, u64)]) {
        let (done, total) = *seen.last().unwrap();
        assert!(
            total > 0 && done == total,
            "{what}: ended at {done} of {total}"
        );
        for pair in seen.windows(2) {
            let ((d0, t0), (d1, t1)) = (pair[0], pair[1]);
            assert!(d1 >= d0, "{what}: done went back from {d0} to {d1}");
            assert!(
                t0 == 0 || t0 == t1,
                "{what}: total changed from {t0} to {t1}"
            );
            assert!(d1 <= t1, "{what}: {d1} done of {t1}");
        }
    }

    /// A `.cgc` file's attribute reaches the UI by name (the window says the viewer draws one
    /// colour), and a file without one says none.
    #[test]
    fn opening_a_cgc_file_tells_the_ui_its_attribute() {
        let dir =
            std::env::temp_dir().join(format!("isogrid-viewer-attribute-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let volume = generate(Field::Sphere, 32, 1);
        let grid = reference(&volume, Iso::Normalized(0.5), None);
        let values: Vec<f32> = (0..grid.active_cells()).map(|i| i as f32).collect();
        let attribute =
            isogrid::CellAttribute::from_values("pet", isogrid::AttributePrecision::Code8, &values);
        let cgc_path = dir.join("colored.cgc");
        isogrid::cgc::write(&cgc_path, &grid.with_attribute(attribute).unwrap()).unwrap();
        let (worker, _render_rx, event_rx) = spawn_opening(&cgc_path);
        let opened = loop {
            match event_rx.recv_timeout(WAIT).expect("the worker reports") {
                Event::Opened { info, .. } => break info,
                Event::Error { message, .. } => panic!("{message}"),
                _ => continue,
            }
        };
        assert_eq!(opened.attribute.as_deref(), Some("pet"));
        drop(worker);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn loading_reports_progress_that_grows_to_done() {
        let dir =
            std::env::temp_dir().join(format!("isogrid-viewer-progress-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let volume_path = dir.join("sphere.nrrd");
        let volume = generate(Field::Sphere, 80, 1);
        isogrid_io::write_nrrd(&volume_path, &volume).unwrap();
        let cgc_path = dir.join("sphere.cgc");
        let grid = reference(&volume, Iso::Normalized(0.5), None);
        isogrid::cgc::write(&cgc_path, &grid).unwrap();

        let (worker, render_rx, event_rx) = spawn_opening(&volume_path);
        // A volume read by region counts its planes; extraction counts two steps per block.
        let (what, seen) = follow_task(&event_rx);
        assert!(
            what.starts_with("reading") && what.contains("sphere.nrrd"),
            "{what}"
        );
        assert_counts_to_done(&what, &seen);
        assert_eq!(seen.last().unwrap().1, 80);
        let (what, seen) = follow_task(&event_rx);
        assert!(what.starts_with("extracting cells"), "{what}");
        assert_counts_to_done(&what, &seen);
        assert_eq!(seen.last().unwrap().1, 2 * grid.blocks().len() as u64);
        let (_, extracted) = next_grid(&render_rx);
        assert_eq!(extracted.cells(), grid.cells());
        // Marching Cubes counts sample planes.
        worker.update(|w| w.mesh = true);
        let (what, seen) = follow_task(&event_rx);
        assert!(what.starts_with("Marching Cubes"), "{what}");
        assert_counts_to_done(&what, &seen);
        assert_eq!(seen.last().unwrap().1, 80);

        // A .cgc file: its checksums and blocks are counted while it is read.
        worker.update(|w| w.open = Some(open_request(2, &cgc_path)));
        let (what, seen) = follow_task(&event_rx);
        assert!(what.contains("sphere.cgc"), "{what}");
        assert_counts_to_done(&what, &seen);
        let (generation, opened) = next_grid(&render_rx);
        assert_eq!((generation, opened.cells()), (2, grid.cells()));
        drop(worker);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

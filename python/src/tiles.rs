//! Tiled extraction for `isogrid.dask` (the Rust side is `isogrid::extract::tiles`): the task
//! functions a Dask worker runs on one tile (a box of whole blocks plus the halo on its high
//! sides: one pass, or a scan and then an emit), and the coordinating object that collects their
//! fragments, plans emit jobs and writes the `.cgc` file from their output.
//!
//! Tasks take a C-ordered array of shape (z, y, x) and return bytes; they run with the GIL
//! released, on rayon's global pool. Blocks and sample ranges cross as (x, y, z).

use crate::array::{spacing3, triple, VolumeArg};
use crate::errors::{invalid, to_py};
use crate::grid::{iso_arg, precision_arg, stats_dict};
use crate::volume_io::scalar_type_named;
use isogrid::extract::tiles::{self, EmitJob};
use isogrid::{ExtractOptions, Geometry};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;
use std::sync::Arc;

/// The stop flag of the tile tasks of one `isogrid.dask` pass in this process. The driver (or, on
/// a distributed worker, the task's watcher of the run's stop event) cancels it, and every task
/// running on it stops at its next block row (scan) or block (emit), raising the library's "interrupted" error:
/// without it a running tile, seconds of work, would run to its end after the run had stopped.
/// Its counts are those of all the tasks on it together, and nobody reads them.
#[pyclass(module = "isogrid", frozen)]
pub struct _TaskCancel {
    progress: Arc<isogrid::Progress>,
}

#[pymethods]
impl _TaskCancel {
    #[new]
    fn new() -> Self {
        _TaskCancel {
            progress: Arc::new(isogrid::Progress::new()),
        }
    }

    /// Stops the tasks running on this flag, and those that start on it later.
    fn cancel(&self) {
        self.progress.cancel();
    }

    #[getter]
    fn cancelled(&self) -> bool {
        self.progress.is_cancelled()
    }
}

/// The progress a task runs on: its `cancel` flag's, else a fresh one nobody cancels.
fn task_progress(cancel: Option<&Bound<'_, _TaskCancel>>) -> Arc<isogrid::Progress> {
    cancel.map_or_else(Default::default, |c| Arc::clone(&c.get().progress))
}

/// Pass 1 of one tile: its scan fragment (see `isogrid.dask`).
#[pyfunction]
#[pyo3(signature = (tile, volume_dims, first_block, iso, cancel=None))]
pub fn _scan_tile<'py>(
    py: Python<'py>,
    tile: &Bound<'py, PyAny>,
    volume_dims: [usize; 3],
    first_block: [usize; 3],
    iso: f64,
    cancel: Option<&Bound<'py, _TaskCancel>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let tile = VolumeArg::new(tile, false, [1.0; 3])?;
    let view = tile.view()?;
    let progress = task_progress(cancel);
    let fragment = py
        .detach(move || tiles::scan_tile(&view, volume_dims, first_block, iso, &progress))
        .map_err(to_py)?;
    Ok(PyBytes::new(py, &fragment))
}

/// Pass 2 of one emit job: its output fragment (see `isogrid.dask`).
#[pyfunction]
#[pyo3(signature = (tile, job, index, cancel=None))]
pub fn _emit_tile<'py>(
    py: Python<'py>,
    tile: &Bound<'py, PyAny>,
    job: &[u8],
    index: u32,
    cancel: Option<&Bound<'py, _TaskCancel>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let tile = VolumeArg::new(tile, false, [1.0; 3])?;
    let view = tile.view()?;
    let progress = task_progress(cancel);
    let fragment = py
        .detach(move || tiles::emit_tile(&view, job, index, &progress))
        .map_err(to_py)?;
    Ok(PyBytes::new(py, &fragment))
}

/// One pass over one tile: its scan records, and its output when that fits `output_bytes` (see
/// `isogrid.dask`).
#[pyfunction]
#[pyo3(signature = (tile, task, first_block, output_bytes, cancel=None))]
pub fn _extract_tile<'py>(
    py: Python<'py>,
    tile: &Bound<'py, PyAny>,
    task: &[u8],
    first_block: [usize; 3],
    output_bytes: u64,
    cancel: Option<&Bound<'py, _TaskCancel>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let tile = VolumeArg::new(tile, false, [1.0; 3])?;
    let view = tile.view()?;
    let progress = task_progress(cancel);
    let fragment = py
        .detach(move || tiles::extract_tile(&view, task, first_block, output_bytes, &progress))
        .map_err(to_py)?;
    Ok(PyBytes::new(py, &fragment))
}

/// The coordinating side of a tiled extraction: scan fragments in, emit jobs out, then the file.
#[pyclass(module = "isogrid")]
pub struct _TileExtraction {
    inner: tiles::TileExtraction,
    jobs: Vec<EmitJob>,
}

#[pymethods]
impl _TileExtraction {
    /// `dims` (nx, ny, nz); `value_range` (min, max) of all samples, NaN for none finite, or None
    /// when not computed (needed only for `iso_normalized` and volumes one sample thick);
    /// `direction` rows are the world directions of x, y and z (default the identity).
    #[new]
    #[pyo3(signature = (dims, dtype, spacing, origin, iso=None, iso_normalized=None, precision=None, value_range=None, direction=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        dims: [usize; 3],
        dtype: &str,
        spacing: Vec<f64>,
        origin: Vec<f64>,
        iso: Option<f64>,
        iso_normalized: Option<f64>,
        precision: Option<u32>,
        value_range: Option<(f64, f64)>,
        direction: Option<[[f64; 3]; 3]>,
    ) -> PyResult<Self> {
        let scalar_type = scalar_type_named(dtype, "dtype")?;
        let mut geometry = Geometry {
            spacing: spacing3(spacing)?,
            origin: triple(origin, "origin")?,
            ..Geometry::new(dims)
        };
        if let Some(direction) = direction {
            geometry.direction = direction;
        }
        let mut options = ExtractOptions::new(iso_arg(iso, iso_normalized)?);
        options.precision = precision.map(precision_arg).transpose()?;
        let value_range =
            value_range.map(|(lo, hi)| (!lo.is_nan() && !hi.is_nan()).then_some((lo, hi)));
        let inner = tiles::TileExtraction::new(geometry, scalar_type, &options, value_range)
            .map_err(to_py)?;
        Ok(_TileExtraction {
            inner,
            jobs: Vec::new(),
        })
    }

    /// The isovalue in data units.
    #[getter]
    fn iso(&self) -> f64 {
        self.inner.iso()
    }

    /// Adds a tile's scan fragment (tiles in any order, each block exactly once).
    fn add_scan(&mut self, fragment: &[u8]) -> PyResult<()> {
        self.inner.add_scan(fragment).map_err(to_py)
    }

    /// The task `_extract_tile` runs on every tile when one pass over the samples suffices (the
    /// quantiser is known before any tile is scanned), else None: scan, then emit.
    fn one_pass_task<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyBytes>> {
        self.inner
            .one_pass_task()
            .map(|task| PyBytes::new(py, &task))
    }

    /// Keeps one-pass tiles' output in a scratch file in the folder `dir` until `write`.
    fn spool_in(&mut self, dir: PathBuf) {
        self.inner.spool_in(&dir);
    }

    /// Adds a one-pass tile's fragment (tiles in any order, each block exactly once); its output,
    /// if any, waits in the spool.
    fn add_tile(&mut self, fragment: &[u8]) -> PyResult<()> {
        self.inner.add_tile(fragment).map_err(to_py)
    }

    /// Plans the emit jobs from tiles of `tile_blocks` (x, y, z) blocks, halved until samples plus
    /// output fit `job_bytes` where one block allows; returns one `(samples, job)` per job, where
    /// `samples` is the ((x0, x1), (y0, y1), (z0, z1)) sample ranges it reads.
    #[allow(clippy::type_complexity)]
    fn plan_emits<'py>(
        &mut self,
        py: Python<'py>,
        tile_blocks: [usize; 3],
        job_bytes: u64,
    ) -> PyResult<Vec<([(usize, usize); 3], Bound<'py, PyBytes>)>> {
        self.jobs = self
            .inner
            .plan_emits(tile_blocks, job_bytes)
            .map_err(to_py)?;
        Ok(self
            .jobs
            .iter()
            .map(|job| {
                let samples = job.samples.clone().map(|r| (r.start, r.end));
                (samples, PyBytes::new(py, &job.bytes))
            })
            .collect())
    }

    /// Writes `path` atomically from the output fragments `fragments` yields (any order); returns
    /// the statistics. An exception raised by `fragments` propagates, and no file is left.
    fn write<'py>(
        &self,
        py: Python<'py>,
        path: PathBuf,
        fragments: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut iterator = fragments.try_iter()?;
        let mut raised: Option<PyErr> = None;
        let mut next_fragment = || -> isogrid::Result<Option<Vec<u8>>> {
            let next = iterator.next().map(|item| {
                let item = item?;
                let bytes = item.cast::<PyBytes>().map_err(|_| {
                    invalid(format!("fragments must be bytes, not {}", item.get_type()))
                })?;
                Ok::<_, PyErr>(bytes.as_bytes().to_vec())
            });
            match next {
                None => Ok(None),
                Some(Ok(bytes)) => Ok(Some(bytes)),
                Some(Err(err)) => {
                    raised = Some(err);
                    Err(isogrid::Error::invalid("a task failed"))
                }
            }
        };
        let summary = self.inner.write(&path, &self.jobs, &mut next_fragment);
        if let Some(err) = raised {
            return Err(err);
        }
        stats_dict(py, &summary.map_err(to_py)?.stats, None)
    }
}

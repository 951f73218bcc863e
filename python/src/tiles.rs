//! Tiled extraction for `isogrid.dask` (the Rust side is `isogrid::extract::tiles`): the task
//! functions a Dask worker runs on one tile (a box of whole blocks plus the halo on its high
//! sides: one pass, or a scan and then an emit), and the coordinating object that collects their
//! fragments, plans emit jobs and writes the `.cgc` file from their output.
//!
//! Label volumes go by slabs of whole block layers instead (`isogrid::extract::label_stream`):
//! `_label_slab` runs the label pass on one, and `_LabelWriter` puts the file together.
//!
//! Tasks take a C-ordered array of shape (z, y, x) and return bytes; they run with the GIL
//! released, on rayon's global pool. Blocks and sample ranges cross as (x, y, z).

use crate::array::{spacing3, triple, VolumeArg};
use crate::errors::{invalid, to_py};
use crate::grid::{iso_arg, label_dicts, label_options, precision_arg, resolve_names, stats_dict};
use crate::volume_io::scalar_type_named;
use isogrid::extract::label_stream;
use isogrid::extract::tiles::{self, EmitJob};
use isogrid::{ExtractOptions, Geometry, LabelOptions};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;
use std::sync::Arc;

/// The geometry a driver is given: dims (x, y, z), spacing, origin and, when given, the rows of
/// the world directions of x, y and z.
fn driver_geometry(
    dims: [usize; 3],
    spacing: Vec<f64>,
    origin: Vec<f64>,
    direction: Option<[[f64; 3]; 3]>,
) -> PyResult<Geometry> {
    let mut geometry = Geometry {
        spacing: spacing3(spacing)?,
        origin: triple(origin, "origin")?,
        ..Geometry::new(dims)
    };
    if let Some(direction) = direction {
        geometry.direction = direction;
    }
    Ok(geometry)
}

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
        let geometry = driver_geometry(dims, spacing, origin, direction)?;
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

/// One task of a label extraction: the fragment of the run of blocks `blocks` (b0, b1) of a
/// volume of `volume_dims` (x, y, z), from `slab`, the samples `_LabelWriter.sample_box` names
/// for them, whole in x. It stops once its output holds `output_cap` bytes; returns the blocks
/// it covers (b0, end) and the fragment, encoded straight into the returned `bytes`.
#[pyfunction]
#[pyo3(signature = (slab, volume_dims, blocks, labels, smooth, output_cap, precision=None, cancel=None))]
#[allow(clippy::too_many_arguments)]
pub fn _label_slab<'py>(
    py: Python<'py>,
    slab: &Bound<'py, PyAny>,
    volume_dims: [usize; 3],
    blocks: (usize, usize),
    labels: &str,
    smooth: f64,
    output_cap: u64,
    precision: Option<u32>,
    cancel: Option<&Bound<'py, _TaskCancel>>,
) -> PyResult<((usize, usize), Bound<'py, PyBytes>)> {
    // Dask's tasks see samples alone: labels are chosen by value.
    let options = resolve_names(label_options(labels, smooth, precision)?, &[], None, None)?;
    let slab = VolumeArg::new(slab, false, [1.0; 3])?;
    let view = slab.view()?;
    let progress = task_progress(cancel);
    let fragment = py
        .detach(move || {
            label_stream::label_fragment(
                &view,
                volume_dims,
                blocks.0..blocks.1,
                &options,
                output_cap,
                &progress,
            )
        })
        .map_err(to_py)?;
    let covered = fragment.blocks();
    let bytes = PyBytes::new_with(py, fragment.encoded_len(), |buf| {
        fragment.encode_into(buf);
        Ok(())
    })?;
    Ok(((covered.start, covered.end), bytes))
}

/// The coordinating side of a label extraction on Dask: slab fragments in (any order), the file
/// out, byte-identical to the in-memory and streamed extractions.
#[pyclass(module = "isogrid")]
pub struct _LabelWriter {
    inner: Option<label_stream::LabelWriter>,
    options: LabelOptions,
    dims: [usize; 3],
}

#[pymethods]
impl _LabelWriter {
    /// `dims` (nx, ny, nz); `labels` the selection text; the scratch file goes in `spool_dir`.
    #[new]
    #[pyo3(signature = (dims, dtype, spacing, origin, labels, smooth, spool_dir, precision=None, direction=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        dims: [usize; 3],
        dtype: &str,
        spacing: Vec<f64>,
        origin: Vec<f64>,
        labels: &str,
        smooth: f64,
        spool_dir: PathBuf,
        precision: Option<u32>,
        direction: Option<[[f64; 3]; 3]>,
    ) -> PyResult<Self> {
        let scalar_type = scalar_type_named(dtype, "dtype")?;
        let geometry = driver_geometry(dims, spacing, origin, direction)?;
        let options = resolve_names(label_options(labels, smooth, precision)?, &[], None, None)?;
        let inner = label_stream::LabelWriter::new(geometry, scalar_type, &options, &spool_dir)
            .map_err(to_py)?;
        Ok(_LabelWriter {
            inner: Some(inner),
            options,
            dims,
        })
    }

    /// Planes a slab reads beyond its own on each side: the smoothing kernel's radius `⌈3σ⌉`.
    #[getter]
    fn halo(&self) -> usize {
        isogrid::extract::labels::label_halo(self.options.smooth)
    }

    /// The samples (y0, y1, z0, z1) that the run of blocks (b0, b1) reads, whole in x: the rows
    /// and planes of the block rows and layers it meets and the smoothing halo (`⌈3σ⌉` samples
    /// each side), clipped to the volume; a run within one block layer reads only its block rows.
    fn sample_box(&self, blocks: (usize, usize)) -> PyResult<(usize, usize, usize, usize)> {
        let [y, z] = label_stream::fragment_box(self.dims, blocks.0..blocks.1, &self.options)
            .map_err(to_py)?;
        Ok((y.start, y.end, z.start, z.end))
    }

    /// Adds a slab's fragment (slabs in any order, each block exactly once).
    fn add(&mut self, fragment: &[u8]) -> PyResult<()> {
        self.writer()?.add_fragment(fragment).map_err(to_py)
    }

    /// Writes `path` atomically, the labels named by the local OME-Zarr label image `names_of`
    /// (its `image-label` metadata, if any), then by the colour table `label_table`; returns the
    /// statistics with the labels, and the notices (a table's labels the grid lacks).
    #[pyo3(signature = (path, label_table=None, names_of=None))]
    fn write<'py>(
        &mut self,
        py: Python<'py>,
        path: PathBuf,
        label_table: Option<PathBuf>,
        names_of: Option<PathBuf>,
    ) -> PyResult<(Bound<'py, PyDict>, Vec<String>)> {
        let table = label_table
            .as_deref()
            .map(isogrid_io::labels::read_label_table)
            .transpose()
            .map_err(to_py)?;
        let names = match names_of.as_deref().filter(|p| p.is_dir()) {
            Some(dir) => isogrid_io::labels::ome_label_names(dir).map_err(to_py)?,
            None => Vec::new(),
        };
        let writer = self
            .inner
            .take()
            .ok_or_else(|| invalid("this label extraction was written already"))?;
        let mut absent = Vec::new();
        let summary = py
            .detach(|| {
                writer.write(&path, &isogrid::Progress::new(), &mut |labels| {
                    isogrid_io::labels::name_labels(labels, &names);
                    if let Some(table) = &table {
                        absent = isogrid_io::labels::name_labels(labels, table);
                    }
                })
            })
            .map_err(to_py)?;
        let signed = isogrid::labels::signed_labels(summary.info.scalar_type);
        let stats = stats_dict(py, &summary.stats, None)?;
        stats.set_item(
            "labels",
            label_dicts(py, &summary.table, &summary.index, signed)?,
        )?;
        let notices = label_table
            .as_deref()
            .and_then(|t| {
                isogrid_io::labels::absent_labels_notice(
                    t,
                    &absent,
                    &self.options.selection,
                    signed,
                )
            })
            .into_iter()
            .collect();
        Ok((stats, notices))
    }
}

impl _LabelWriter {
    fn writer(&mut self) -> PyResult<&mut label_stream::LabelWriter> {
        self.inner
            .as_mut()
            .ok_or_else(|| invalid("this label extraction was written already"))
    }
}

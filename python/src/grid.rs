//! `CellGrid`: an extracted or memory-mapped clustered grid cell structure (paper §3.1), with its
//! three packed buffers exposed as read-only numpy views that keep the grid alive.

use crate::array::{spacing3, VolumeArg};
use crate::errors::{invalid, to_py};
use crate::pool::{check_callback, run_detached, run_watched};
use isogrid::extract::attribute::{sample_attribute, sample_attribute_in_memory};
use isogrid::{
    layout, AttributePrecision, ExtractOptions, GridStats, Iso, LabelOptions, LabelSelection,
    Precision, Progress, ScalarType,
};
use numpy::ndarray::{ArrayView1, ArrayView2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDescr, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;

/// Clustered grid cells of one isosurface (paper §3.1), from `isogrid.extract` or `isogrid.load`.
///
/// Attributes: `stats` (counts and bytes, named as `isogrid extract --json`), `info` (dims,
/// spacing, origin, direction, scalar_type, value_range, iso, precision, iso_code, mapping,
/// world_bounds), `active_cells`, `is_mapped`, and three read-only NumPy views of the packed
/// buffers, which keep the grid alive:
///
/// - `blocks`: one per 16³ cells, x fastest; fields metacell_count (slots), metacell_pointer,
///   min, max (data units).
/// - `metacells`: all slots, in clusters of 16 whose slot 15 is the cluster bound (lo, hi as
///   3×u2 each: view it with dtype [("lo", "3<u2"), ("hi", "3<u2")]); fields position (3×u2,
///   in units of 2 cells), cell_mask (bit b = cell (b&1, b>>1&1, b>>2&1)), cell_pointer.
/// - `cells`: uint8 (active_cells, bytes_per_cell), 8 corner codes per cell at `precision` bits.
///
/// `attribute` (float32 per active cell, or `None`) and `attribute_info` (name, bits, range) give
/// the per-cell attribute of `extract(..., attribute=...)` or of a `.cgc` file.
///
/// `labels` and `cluster_labels` describe a label volume's grid (`None` for an isosurface),
/// which `extract_labels` and `load` give as a `LabelGrid`.
///
/// Methods: `cell_positions()`, `corners()`, `save(path)`, `to_bytes()`.
///
/// `CellGrid(data)` rebuilds a grid from the bytes of a `.cgc` file (validated as `load` does);
/// pickling goes through those bytes, so a grid crosses process boundaries (multiprocessing,
/// Dask) and comes back byte-identical.
#[pyclass(frozen, weakref, subclass, module = "isogrid")]
pub struct CellGrid {
    inner: isogrid::CellGrid,
}

impl CellGrid {
    pub(crate) fn inner(&self) -> &isogrid::CellGrid {
        &self.inner
    }

    /// `inner` as the Python class its content calls for: a `LabelGrid` when it holds a label
    /// volume's labels, else a `CellGrid`.
    pub(crate) fn wrap(py: Python<'_>, inner: isogrid::CellGrid) -> PyResult<Bound<'_, PyAny>> {
        if inner.labels().is_some() {
            let init = PyClassInitializer::from(CellGrid { inner }).add_subclass(LabelGrid);
            Ok(Bound::new(py, init)?.into_any())
        } else {
            Ok(Bound::new(py, CellGrid { inner })?.into_any())
        }
    }
}

/// The grid of a label volume (`isogrid.extract_labels`, or `isogrid.load` of a file with
/// labels): a `CellGrid` whose clusters each belong to one label, with `labels` (per-label
/// statistics: value, name, colour, cell count, cell box) and `meshes()`.
///
/// `LabelGrid(data)` rebuilds one from the bytes of a `.cgc` file that holds labels.
#[pyclass(frozen, extends = CellGrid, module = "isogrid")]
pub struct LabelGrid;

/// Extracts the active cells of a 3-D array (see `isogrid.extract`, which prepares `array`).
#[pyfunction]
#[pyo3(signature = (array, fortran, spacing, iso=None, iso_normalized=None, precision=None, threads=None, origin=None, direction=None, attribute=None, progress=None, frame=None))]
#[allow(clippy::too_many_arguments)]
pub fn extract(
    py: Python<'_>,
    array: &Bound<'_, PyAny>,
    fortran: bool,
    spacing: Vec<f64>,
    iso: Option<f64>,
    iso_normalized: Option<f64>,
    precision: Option<u32>,
    threads: Option<usize>,
    origin: Option<Vec<f64>>,
    direction: Option<Vec<Vec<f64>>>,
    attribute: Option<AttributeArg<'_, '_>>,
    progress: Option<Bound<'_, PyAny>>,
    frame: Option<String>,
) -> PyResult<CellGrid> {
    let volume = VolumeArg::new(array, fortran, spacing3(spacing)?)?.place(
        origin,
        direction,
        frame.as_deref(),
    )?;
    let view = volume.view()?;
    let mut options = ExtractOptions::new(iso_arg(iso, iso_normalized)?);
    options.precision = precision.map(precision_arg).transpose()?;
    check_callback(progress.as_ref())?;
    // Ctrl-C and the callback are watched while the extraction runs; either stops it.
    let watch = Progress::new();
    let mut inner = run_watched(py, threads, &watch, progress.as_ref(), || {
        isogrid::extract_with_progress(&view, &options, &watch)
    })?;
    if let Some((array, fortran, spacing, origin, direction, frame, name, bits)) = attribute {
        let precision = AttributePrecision::from_bits(bits).ok_or_else(|| {
            invalid(format!(
                "attribute precision must be 8, 16 or 32, not {bits}"
            ))
        })?;
        let volume = VolumeArg::new(&array, fortran, spacing3(spacing)?)?.place(
            origin,
            direction,
            frame.as_deref(),
        )?;
        let view = volume.view()?;
        let grid = &inner;
        let sampled = run_detached(py, threads, move || {
            sample_attribute_in_memory(grid, &view, &name, precision)
        })?
        .map_err(to_py)?;
        inner.set_attribute(sampled).map_err(to_py)?;
    }
    Ok(CellGrid { inner })
}

/// Extracts the surface of each selected label of a 3-D label array (see `isogrid.extract`, which
/// prepares `array` and writes `labels` as `all` or a list such as `1,5-9`), named and coloured by
/// the colour table file `label_table` when given. Returns the grid and notices for the user (the
/// table's labels the grid lacks).
#[pyfunction]
#[pyo3(signature = (array, fortran, spacing, labels, smooth=0.0, precision=None, threads=None, origin=None, direction=None, label_table=None, progress=None, frame=None))]
#[allow(clippy::too_many_arguments)]
pub fn extract_labels<'py>(
    py: Python<'py>,
    array: &Bound<'_, PyAny>,
    fortran: bool,
    spacing: Vec<f64>,
    labels: &str,
    smooth: f64,
    precision: Option<u32>,
    threads: Option<usize>,
    origin: Option<Vec<f64>>,
    direction: Option<Vec<Vec<f64>>>,
    label_table: Option<PathBuf>,
    progress: Option<Bound<'py, PyAny>>,
    frame: Option<String>,
) -> PyResult<(Bound<'py, PyAny>, Vec<String>)> {
    let volume = VolumeArg::new(array, fortran, spacing3(spacing)?)?.place(
        origin,
        direction,
        frame.as_deref(),
    )?;
    let view = volume.view()?;
    let options = label_options(labels, smooth, precision)?;
    check_callback(progress.as_ref())?;
    let table = read_table(py, label_table.as_deref())?;
    let options = resolve_names(options, &[], table.as_ref(), None)?;
    // Ctrl-C and the callback are watched while the labels are extracted; either stops it.
    let watch = Progress::new();
    let grid = run_watched(py, threads, &watch, progress.as_ref(), || {
        isogrid::extract_labels_with_progress(&view, &options, &watch)
    })?;
    named(py, grid, table, &options.selection)
}

/// Extracts the labels of a label volume file as `isogrid extract --labels` does: the names and
/// colours its file gives (a 3D Slicer `.seg.nrrd`, layered or not; an OME-Zarr label image, or
/// the image at `path` with `labels_of` naming one of its label images), then `label_table`'s.
/// `spacing`, `origin` and `direction` replace the file's. Returns the grid and notices.
#[pyfunction]
#[pyo3(signature = (path, labels, smooth=0.0, precision=None, threads=None, labels_of=None, label_table=None, series=None, spacing=None, origin=None, direction=None, progress=None, index=None))]
#[allow(clippy::too_many_arguments)]
pub fn extract_labels_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    labels: &str,
    smooth: f64,
    precision: Option<u32>,
    threads: Option<usize>,
    labels_of: Option<String>,
    label_table: Option<PathBuf>,
    series: Option<String>,
    spacing: Option<Vec<f64>>,
    origin: Option<Vec<f64>>,
    direction: Option<Vec<Vec<f64>>>,
    progress: Option<Bound<'py, PyAny>>,
    index: Option<Vec<(String, u64)>>,
) -> PyResult<(Bound<'py, PyAny>, Vec<String>)> {
    let options = label_options(labels, smooth, precision)?;
    check_callback(progress.as_ref())?;
    let table = read_table(py, label_table.as_deref())?;
    let place = crate::array::Placement::new(spacing, origin, direction)?;
    let read_options = crate::volume_io::file_read_options(series, index, "index");
    let (mut source, mut notices) = py
        .detach(|| isogrid_io::labels::read_labels_of(&path, labels_of.as_deref(), &read_options))
        .map_err(to_py)?;
    for layer in &mut source.layers {
        place.apply(&mut layer.volume).map_err(to_py)?;
    }
    let options = resolve_names(options, &source.names, table.as_ref(), Some(&path))?;
    let watch = Progress::new();
    let grid = run_watched(py, threads, &watch, progress.as_ref(), || {
        isogrid_io::labels::extract_label_volume_with_progress(&source, &options, &watch)
    })?;
    let (grid, more) = named(py, grid, table, &options.selection)?;
    notices.extend(more);
    Ok((grid, notices))
}

/// The label options of an extraction: the selection text (`all`, `1,5-9`; names where a file
/// gives them, resolved by the caller), σ and corner bits.
pub(crate) fn label_options(
    labels: &str,
    smooth: f64,
    precision: Option<u32>,
) -> PyResult<LabelOptions> {
    Ok(LabelOptions {
        selection: LabelSelection::parse_with_names(labels).map_err(to_py)?,
        smooth,
        precision: precision.map(precision_arg).transpose()?,
    })
}

/// `options` with the names its selection gives resolved to values: against the names the label
/// file gives (`file_names`) and the colour table's (`table`, which win); errors name `path`.
pub(crate) fn resolve_names(
    options: LabelOptions,
    file_names: &[isogrid::Label],
    table: Option<&(PathBuf, Vec<isogrid::Label>)>,
    path: Option<&std::path::Path>,
) -> PyResult<LabelOptions> {
    let table = table.map(|(_, t)| t.as_slice());
    let selection = isogrid_io::labels::resolve_label_names(&options.selection, file_names, table)
        .map_err(|e| match path {
            Some(p) => to_py(e.with_path(p)),
            None => to_py(e),
        })?;
    Ok(LabelOptions {
        selection,
        ..options
    })
}

/// A colour table file, read before the volume so that a malformed one fails first.
pub(crate) fn read_table(
    py: Python<'_>,
    path: Option<&std::path::Path>,
) -> PyResult<Option<(PathBuf, Vec<isogrid::Label>)>> {
    path.map(|p| {
        py.detach(|| isogrid_io::labels::read_label_table(p))
            .map(|t| (p.to_path_buf(), t))
            .map_err(to_py)
    })
    .transpose()
}

/// The grid named by the table, and the notice on the table's labels `selection` asks for and
/// the grid lacks.
fn named<'py>(
    py: Python<'py>,
    mut inner: isogrid::CellGrid,
    table: Option<(PathBuf, Vec<isogrid::Label>)>,
    selection: &LabelSelection,
) -> PyResult<(Bound<'py, PyAny>, Vec<String>)> {
    let mut notices = Vec::new();
    if let Some((path, table)) = table {
        let absent = isogrid_io::labels::apply_label_names(&mut inner, &table);
        let signed = isogrid::labels::signed_labels(inner.info().scalar_type);
        notices.extend(isogrid_io::labels::absent_labels_notice(
            &path, &absent, selection, signed,
        ));
    }
    Ok((CellGrid::wrap(py, inner)?, notices))
}

/// Why `grid` has no active cell ([`isogrid::GridInfo::empty_surface_note`]), the text of
/// `EmptySurfaceWarning`; `all_nan` says whether its volume had no finite sample.
#[pyfunction]
#[pyo3(signature = (grid, all_nan=false))]
pub fn _empty_surface_note(grid: &Bound<'_, CellGrid>, all_nan: bool) -> String {
    let inner = grid.get().inner();
    inner
        .info()
        .empty_surface_note(inner.labels().map(|l| l.table()), || all_nan)
}

/// The anatomical directions of the i, j and k axes of `direction` (rows) in `frame`
/// ([`isogrid::WorldFrame::axis_codes`]): `Volume.axes` and `grid.info["axes"]`.
#[pyfunction]
#[pyo3(signature = (direction, frame=None))]
pub fn _axis_codes(direction: [[f64; 3]; 3], frame: Option<&str>) -> PyResult<Option<String>> {
    Ok(crate::array::frame_arg(frame)?.axis_codes(&direction))
}

/// Gives the `.cgc` file `path` the attribute of the volume file `attribute_path` (read by region
/// where its format allows, as `isogrid extract --color-by`), or of `array` (an `AttributeArg`),
/// sampled at each active cell's surface point; the file is rewritten atomically. For
/// `isogrid.dask.extract`, whose driver writes the surface first.
#[pyfunction]
#[pyo3(signature = (path, attribute_path=None, array=None, bits=16, threads=None, attribute_index=None))]
pub fn _attach_attribute(
    py: Python<'_>,
    path: PathBuf,
    attribute_path: Option<PathBuf>,
    array: Option<AttributeArg<'_, '_>>,
    bits: u32,
    threads: Option<usize>,
    attribute_index: Option<Vec<(String, u64)>>,
) -> PyResult<()> {
    let grid = py.detach(|| isogrid::cgc::open(&path)).map_err(to_py)?;
    let path_of = attribute_path.map(|p| (p, attribute_index.unwrap_or_default()));
    let sampled = sampled_attribute(py, &grid, path_of, array, bits, threads)?;
    let grid = grid.with_attribute(sampled).map_err(to_py)?;
    py.detach(|| isogrid::cgc::write(&path, &grid))
        .map_err(to_py)
}

/// A new grid: `grid` (a copy) with the attribute of the volume file `attribute_path` or of
/// `array`, sampled as [`_attach_attribute`] samples it. For `extract_labels(..., attribute=)`,
/// whose label extraction comes first.
#[pyfunction]
#[pyo3(signature = (grid, attribute_path=None, array=None, bits=16, threads=None, attribute_index=None))]
pub fn _with_attribute<'py>(
    py: Python<'py>,
    grid: &Bound<'py, CellGrid>,
    attribute_path: Option<PathBuf>,
    array: Option<AttributeArg<'_, 'py>>,
    bits: u32,
    threads: Option<usize>,
    attribute_index: Option<Vec<(String, u64)>>,
) -> PyResult<Bound<'py, PyAny>> {
    let inner = grid.get().inner();
    let path_of = attribute_path.map(|p| (p, attribute_index.unwrap_or_default()));
    let sampled = sampled_attribute(py, inner, path_of, array, bits, threads)?;
    // The grid is frozen: the copy goes through its bytes, checked again as any file's are.
    let copy = py
        .detach(|| isogrid::cgc::read_bytes(&isogrid::cgc::to_bytes(inner)))
        .map_err(to_py)?;
    CellGrid::wrap(py, copy.with_attribute(sampled).map_err(to_py)?)
}

/// The attribute of the volume file `attribute_path` (read by region where its format allows,
/// with the entries of its extra axes given as `attribute_index`) or of `array`, sampled at each
/// active cell's surface point of `grid`, at `bits`.
fn sampled_attribute(
    py: Python<'_>,
    grid: &isogrid::CellGrid,
    attribute_path: Option<(PathBuf, Vec<(String, u64)>)>,
    array: Option<AttributeArg<'_, '_>>,
    bits: u32,
    threads: Option<usize>,
) -> PyResult<isogrid::CellAttribute> {
    let precision = AttributePrecision::from_bits(bits).ok_or_else(|| {
        invalid(format!(
            "attribute precision must be 8, 16 or 32, not {bits}"
        ))
    })?;
    match (attribute_path, array) {
        (Some((attribute_path, indices)), None) => {
            let mut name = attribute_path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            // Named as the CLI names it: `pet.nii.gz t=3`.
            if !indices.is_empty() {
                let picked: Vec<String> = indices.iter().map(|(a, i)| format!("{a}={i}")).collect();
                name = format!("{name} {}", picked.join(","));
            }
            let options =
                crate::volume_io::file_read_options(None, Some(indices), "attribute_index");
            run_detached(py, threads, move || -> isogrid::Result<_> {
                match isogrid_io::open_region(&attribute_path, &options)? {
                    Some(mut region) => sample_attribute(grid, region.as_mut(), &name, precision),
                    None => {
                        let volume = isogrid_io::read_volume(&attribute_path, &options)?;
                        sample_attribute_in_memory(grid, &volume.view(), &name, precision)
                    }
                }
                .map_err(|e| e.with_path(&attribute_path))
            })?
        }
        (None, Some((array, fortran, spacing, origin, direction, frame, name, _))) => {
            let volume = VolumeArg::new(&array, fortran, spacing3(spacing)?)?.place(
                origin,
                direction,
                frame.as_deref(),
            )?;
            let view = volume.view()?;
            run_detached(py, threads, move || {
                sample_attribute_in_memory(grid, &view, &name, precision)
            })?
        }
        _ => return Err(invalid("give the attribute as a path or as an array, once")),
    }
    .map_err(to_py)
}

/// The attribute volume of `extract` and `marching_cubes`: (array, fortran, spacing, origin,
/// direction, frame, name, bits).
pub(crate) type AttributeArg<'a, 'py> = (
    Bound<'py, PyAny>,
    bool,
    Vec<f64>,
    Option<Vec<f64>>,
    Option<Vec<Vec<f64>>>,
    Option<String>,
    String,
    u32,
);

/// Labels as `CellGrid.labels` lists them (`signed`: values shown with their sign).
pub fn label_dicts<'py>(
    py: Python<'py>,
    table: &[isogrid::Label],
    index: &[isogrid::labels::LabelEntry],
    signed: bool,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    table
        .iter()
        .zip(index)
        .map(|(label, entry)| {
            let d = PyDict::new(py);
            set_label_value(&d, label.value, signed)?;
            d.set_item("name", &label.name)?;
            d.set_item("color", label.color_hex())?;
            d.set_item("cells", entry.cell_count)?;
            d.set_item("lo", entry.lo.to_vec())?;
            d.set_item("hi", entry.hi.to_vec())?;
            Ok(d)
        })
        .collect()
}

/// `d["value"]`: a label key as the label's value, a signed type's as its negative where it is.
pub(crate) fn set_label_value(d: &Bound<'_, PyDict>, key: u64, signed: bool) -> PyResult<()> {
    if signed {
        d.set_item("value", key as i64)
    } else {
        d.set_item("value", key)
    }
}

/// `stats` as a dict with the names of the CLI's `--json` output (without `seconds`), with the
/// grid's `attribute` (`None` without one) as `isogrid extract --color-by --json` gives it.
pub fn stats_dict<'py>(
    py: Python<'py>,
    s: &GridStats,
    attribute: Option<&isogrid::CellAttribute>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("dims", tuple3(s.dims))?;
    d.set_item("iso", s.iso)?;
    d.set_item("precision", s.precision_bits)?;
    d.set_item("active_cells", s.active_cells)?;
    d.set_item("metacells", s.metacells)?;
    d.set_item("metacell_slots", s.metacell_slots)?;
    d.set_item("clusters", s.clusters)?;
    d.set_item("blocks", s.blocks)?;
    d.set_item("nonempty_blocks", s.nonempty_blocks)?;
    let bytes = PyDict::new(py);
    bytes.set_item("blocks", s.bytes.blocks)?;
    bytes.set_item("metacells", s.bytes.metacells)?;
    bytes.set_item("cells", s.bytes.cells)?;
    bytes.set_item("paper_total", s.bytes.paper_total)?;
    d.set_item("bytes", bytes)?;
    d.set_item("bytes_per_cell", s.bytes_per_cell())?;
    match attribute {
        None => d.set_item("attribute", py.None())?,
        Some(a) => {
            let info = a.info();
            let entry = PyDict::new(py);
            entry.set_item("name", &info.name)?;
            entry.set_item("bits", info.precision.bits())?;
            entry.set_item("range", vec![info.range[0], info.range[1]])?;
            entry.set_item(
                "bytes",
                (a.head_bytes().len() + a.value_bytes().len()) as u64,
            )?;
            entry.set_item("bytes_per_cell", info.precision.bytes() as f64)?;
            d.set_item("attribute", entry)?;
        }
    }
    Ok(d)
}

/// Memory-maps and validates a `.cgc` file: a `LabelGrid` when it holds labels.
#[pyfunction]
pub fn load(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    let inner = py.detach(|| isogrid::cgc::open(&path)).map_err(to_py)?;
    CellGrid::wrap(py, inner)
}

/// Exactly one of `iso` (data units) and `iso_normalized` (fraction of the value range).
pub fn iso_arg(iso: Option<f64>, iso_normalized: Option<f64>) -> PyResult<Iso> {
    match (iso, iso_normalized) {
        (Some(v), None) => Ok(Iso::Value(v)),
        (None, Some(t)) => Ok(Iso::Normalized(t)),
        _ => Err(invalid("give exactly one of iso and iso_normalized")),
    }
}

pub fn precision_arg(bits: u32) -> PyResult<Precision> {
    Precision::parse_bits(&bits.to_string()).map_err(invalid)
}

/// Checks a precision in bits before work starts (`isogrid.dask`), with the message of the Rust
/// rule ([`Precision::parse_bits`]).
#[pyfunction]
pub fn _check_precision(bits: u32) -> PyResult<()> {
    precision_arg(bits).map(|_| ())
}

pub fn dtype_name(t: ScalarType) -> &'static str {
    match t {
        ScalarType::U8 => "uint8",
        ScalarType::U16 => "uint16",
        ScalarType::I16 => "int16",
        ScalarType::F32 => "float32",
        ScalarType::U32 => "uint32",
        ScalarType::I32 => "int32",
        ScalarType::U64 => "uint64",
        ScalarType::I64 => "int64",
        ScalarType::F64 => "float64",
    }
}

/// A read-only numpy array over `bytes`, which live inside `owner`'s grid: the array's base is
/// `owner`, so the grid stays alive (and its buffers unmoved: they are never modified) as long as
/// any view does. Views of a mapped file could not be written anyway.
fn byte_view<'py>(
    owner: &Bound<'py, CellGrid>,
    bytes: &[u8],
    row: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let rows = bytes.len().checked_div(row).unwrap_or(0);
    let view = ArrayView2::from_shape((rows, row), bytes)
        .map_err(|e| invalid(format!("buffer of {} bytes: {e}", bytes.len())))?;
    // SAFETY: `bytes` is one of the grid's buffers (a Vec or the mapping), which are immutable
    // and live until the grid is dropped; the array holds a reference to the grid.
    let array = unsafe { PyArray2::borrow_from_array(&view, owner.clone().into_any()) };
    drop(array.readwrite().make_nonwriteable());
    Ok(array.into_any())
}

fn struct_view<'py>(
    owner: &Bound<'py, CellGrid>,
    bytes: &[u8],
    fields: &[(&str, &str)],
) -> PyResult<Bound<'py, PyAny>> {
    let py = owner.py();
    let view = ArrayView1::from(bytes);
    // SAFETY: as in `byte_view`.
    let array = unsafe { PyArray1::borrow_from_array(&view, owner.clone().into_any()) };
    drop(array.readwrite().make_nonwriteable());
    let dtype = PyArrayDescr::new(py, fields.to_vec())?;
    array.call_method1("view", (dtype,))
}

#[pymethods]
impl CellGrid {
    /// A grid from the bytes of a `.cgc` file, fully validated.
    #[new]
    fn new(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let inner = py
            .detach(|| isogrid::cgc::read_bytes(data))
            .map_err(to_py)?;
        Ok(CellGrid { inner })
    }

    /// The grid as the bytes of a `.cgc` file (what `save` writes).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let bytes = py.detach(|| isogrid::cgc::to_bytes(&self.inner));
        PyBytes::new(py, &bytes)
    }

    /// Pickles as `CellGrid(self.to_bytes())`.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let class = slf.get_type().into_any();
        Ok((class, (slf.get().to_bytes(slf.py()),)))
    }

    /// Counts and sizes, with the names of the CLI's `--json` output (without `seconds`).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = stats_dict(py, &GridStats::of(&self.inner), self.inner.attribute())?;
        if let Some(labels) = self.labels(py)? {
            d.set_item("labels", labels)?;
        }
        Ok(d)
    }

    /// Geometry, isovalue and value mapping (the `.cgc` header).
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let i = self.inner.info();
        let d = PyDict::new(py);
        d.set_item("dims", tuple3(i.dims))?;
        d.set_item("spacing", tuple3(i.spacing))?;
        d.set_item("origin", tuple3(i.origin))?;
        d.set_item("direction", tuple3(i.direction.map(tuple3)))?;
        d.set_item("axes", i.frame.axis_codes(&i.direction))?;
        d.set_item("frame", crate::array::frame_name(i.frame))?;
        d.set_item("scalar_type", dtype_name(i.scalar_type))?;
        d.set_item("value_range", (i.value_range[0], i.value_range[1]))?;
        d.set_item("iso", i.iso)?;
        d.set_item("precision", i.precision.bits())?;
        d.set_item("iso_code", i.mapping.iso_code)?;
        let mapping = PyDict::new(py);
        mapping.set_item("offset", i.mapping.offset)?;
        mapping.set_item("step", i.mapping.step)?;
        mapping.set_item("iso_code", i.mapping.iso_code)?;
        d.set_item("mapping", mapping)?;
        let (lo, hi) = i.world_bounds();
        d.set_item("world_bounds", (tuple3(lo), tuple3(hi)))?;
        Ok(d)
    }

    #[getter]
    fn active_cells(&self) -> usize {
        self.inner.active_cells()
    }

    /// The per-cell attribute's values as float32 (one per active cell, in cell order, NaN where
    /// there is none), decoded from their stored codes; `None` without an attribute.
    #[getter]
    fn attribute<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f32>>> {
        let a = self.inner.attribute()?;
        let values: Vec<f32> = (0..a.len()).map(|i| a.value(i)).collect();
        Some(values.into_pyarray(py))
    }

    /// The attribute as stored, one per active cell: a read-only view (no copy) of uint8 or
    /// uint16 codes (value = lo + code·(hi − lo)/(2^bits − 2) over `attribute_info["range"]`,
    /// code 2^bits − 1 for NaN), or of the float32 values at 32 bits; `None` without one.
    #[getter]
    fn attribute_codes<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(a) = slf.get().inner.attribute() else {
            return Ok(None);
        };
        let dtype = match a.info().precision.bits() {
            8 => "<u1",
            16 => "<u2",
            _ => "<f4",
        };
        let view = ArrayView1::from(a.value_bytes());
        // SAFETY: as in `byte_view`: the attribute's bytes live, unmoved, as long as the grid.
        let array = unsafe { PyArray1::borrow_from_array(&view, slf.clone().into_any()) };
        drop(array.readwrite().make_nonwriteable());
        Ok(Some(array.call_method1("view", (dtype,))?))
    }

    /// The attribute's name, stored bits (8, 16 or 32) and finite range on the surface; `None`
    /// without an attribute.
    #[getter]
    fn attribute_info<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(a) = self.inner.attribute() else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("name", &a.info().name)?;
        d.set_item("bits", a.info().precision.bits())?;
        d.set_item("range", (a.info().range[0], a.info().range[1]))?;
        Ok(Some(d))
    }

    /// The labels of a label volume's grid, in increasing value, as `isogrid extract --labels
    /// --json` lists them: one dict each with `value`, `name`, `color` (`#rrggbbaa`), `cells`
    /// (active cells of its surface) and `lo`, `hi` (its cells' box in cell indices, `[lo, hi)`);
    /// `None` for an isosurface.
    #[getter]
    fn labels<'py>(&self, py: Python<'py>) -> PyResult<Option<Vec<Bound<'py, PyDict>>>> {
        let Some(labels) = self.inner.labels() else {
            return Ok(None);
        };
        let signed = isogrid::labels::signed_labels(self.inner.info().scalar_type);
        label_dicts(py, labels.table(), labels.index(), signed).map(Some)
    }

    /// The label of every cluster, as an index into `labels` (uint32, one per 16 metacell slots);
    /// `None` for an isosurface.
    #[getter]
    fn cluster_labels<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<u32>>> {
        Some(
            self.inner
                .labels()?
                .cluster_labels()
                .to_vec()
                .into_pyarray(py),
        )
    }

    /// Whether the buffers are views of a memory-mapped `.cgc` file.
    #[getter]
    fn is_mapped(&self) -> bool {
        self.inner.is_mapped()
    }

    /// One record per 16³-cell block, x-fastest: read-only structured view.
    #[getter]
    fn blocks<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let bytes: &[u8] = bytemuck::cast_slice(slf.get().inner.blocks());
        struct_view(
            slf,
            bytes,
            &[
                ("metacell_count", "<u4"),
                ("metacell_pointer", "<u4"),
                ("min", "<f4"),
                ("max", "<f4"),
            ],
        )
    }

    /// All metacell slots (slot 15 of each cluster of 16 is the cluster bound): read-only view.
    #[getter]
    fn metacells<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let bytes: &[u8] = bytemuck::cast_slice(slf.get().inner.metacells());
        struct_view(
            slf,
            bytes,
            &[
                ("position", "(3,)<u2"),
                ("cell_mask", "<u2"),
                ("cell_pointer", "<u4"),
            ],
        )
    }

    /// Corner records, shape (active_cells, bytes_per_cell), uint8: read-only view.
    #[getter]
    fn cells<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let grid = &slf.get().inner;
        byte_view(slf, grid.cells(), grid.info().precision.bytes_per_cell())
    }

    /// Grid position (x, y, z) of every active cell, in record order: uint32 array (N, 3).
    fn cell_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let grid = &self.inner;
        let mut out = vec![[0u32; 3]; grid.active_cells()];
        for chunk in grid.metacells().chunks_exact(layout::CLUSTER_SLOTS) {
            for m in &chunk[..layout::BOUND_SLOT] {
                let mut index = m.cell_pointer as usize;
                for bit in 0..8 {
                    if m.cell_mask >> bit & 1 == 1 {
                        // The file was validated on open, so pointers are in range.
                        if let Some(slot) = out.get_mut(index) {
                            *slot = m.cell_position(bit);
                        }
                        index += 1;
                    }
                }
            }
        }
        to_array2(py, out)
    }

    /// The eight corner codes of every active cell (corner c = (c&1, c>>1&1, c>>2&1)), float32
    /// array (N, 8); a corner is inside when its code >= `info["iso_code"]`. At 32-bit precision
    /// the codes are the values; otherwise value = mapping offset + code · step.
    fn corners<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let grid = &self.inner;
        let precision = grid.info().precision;
        let out: Vec<[f32; 8]> = grid
            .cells()
            .chunks_exact(precision.bytes_per_cell())
            .map(|record| layout::read_corners(record, precision))
            .collect();
        to_array2(py, out)
    }

    /// Writes a `.cgc` file, or, to a name ending in `.cgcz`, its packed transfer form (what
    /// `isogrid pack` writes, for the web viewer); atomically: a temporary file renamed into place.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let packed = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("cgcz"));
        py.detach(|| {
            if !packed {
                return isogrid::cgc::write(&path, &self.inner);
            }
            isogrid::fs::write_atomic_file(&path, |f| {
                isogrid::cgc::pack_into(&self.inner, f)?;
                Ok(())
            })
        })
        .map_err(to_py)
    }

    fn __repr__(&self) -> String {
        let i = self.inner.info();
        let [x, y, z] = i.dims;
        format!(
            "CellGrid(dims=({x}, {y}, {z}), iso={}, precision={}, active_cells={}{}, mapped={})",
            i.iso,
            i.precision.bits(),
            self.inner.active_cells(),
            attribute_repr(&self.inner),
            if self.inner.is_mapped() {
                "True"
            } else {
                "False"
            }
        )
    }
}

#[pymethods]
impl LabelGrid {
    /// A label grid from the bytes of a `.cgc` file, fully validated; refuses a file without
    /// labels.
    #[new]
    fn new(py: Python<'_>, data: &[u8]) -> PyResult<PyClassInitializer<Self>> {
        let inner = py
            .detach(|| isogrid::cgc::read_bytes(data))
            .map_err(to_py)?;
        if inner.labels().is_none() {
            return Err(invalid(
                "the .cgc data holds an isosurface, not a label volume's labels: open it as CellGrid",
            ));
        }
        Ok(PyClassInitializer::from(CellGrid { inner }).add_subclass(LabelGrid))
    }

    /// Each label's mesh, Marching Cubes over its stored cells (what `isogrid mc --labels`
    /// writes): a dict from label value to `(vertices, faces)`, in the order of `labels`;
    /// vertices float32 (V, 3) as (x, y, z), faces uint32 (F, 3) counter-clockwise seen from
    /// outside. `space="world"` places sample (i, j, k) in the volume's patient space (origin,
    /// spacing, directions), `"index"` at (i, j, k). `values=True` adds each vertex's value of
    /// the grid's attribute, float32 (V,): the mean of the values its label's cells around the
    /// vertex hold (NaN where they are all NaN), as `mc --labels` writes from a `.cgc`.
    #[pyo3(signature = (space="world", threads=None, *, values=false))]
    fn meshes<'py>(
        slf: &Bound<'py, Self>,
        space: &str,
        threads: Option<usize>,
        values: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let py = slf.py();
        let space = mesh_space(space)?;
        let grid = slf.as_super().get().inner();
        let labels = grid
            .labels()
            .ok_or_else(|| invalid("a LabelGrid holds labels"))?;
        if values && grid.attribute().is_none() {
            return Err(invalid(
                "values=True takes the grid's attribute, and this grid has none (extract it with \
                 attribute=)",
            ));
        }
        let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
        let meshes = run_detached(py, threads, move || placed_meshes(grid, space, values))?
            .map_err(to_py)?;
        let out = PyDict::new(py);
        for (label, (mesh, mesh_values)) in labels.table().iter().zip(meshes) {
            let vertices = to_array2(py, mesh.positions)?;
            let faces = to_array2(py, mesh.triangles)?;
            let arrays = match mesh_values {
                Some(v) => {
                    (vertices, faces, PyArray1::from_vec(py, v).into_any()).into_pyobject(py)?
                }
                None => (vertices, faces).into_pyobject(py)?,
            };
            if signed {
                out.set_item(label.value as i64, arrays)?;
            } else {
                out.set_item(label.value, arrays)?;
            }
        }
        Ok(out)
    }

    /// Writes each label's mesh (as `meshes` gives them) where `path` says, as `isogrid mc
    /// --labels -o PATH` writes them: a `.glb` or `.vtp` of every label, a new folder of
    /// neuroglancer precomputed meshes (a name without an extension), or one file per label from a
    /// template holding `{name}` or `{value}` (`"organs/{name}.stl"`; .stl, .obj, .ply, .vtp or
    /// .glb). The grid's attribute goes with the vertices where the format keeps values.
    /// Atomically: all the files or none.
    #[pyo3(signature = (path, space="world", threads=None))]
    fn write_meshes(
        slf: &Bound<'_, Self>,
        path: PathBuf,
        space: &str,
        threads: Option<usize>,
    ) -> PyResult<()> {
        let py = slf.py();
        let space = mesh_space(space)?;
        let grid = slf.as_super().get().inner();
        let output = isogrid_io::label_meshes::LabelMeshOutput::of(&path).map_err(to_py)?;
        let labels = grid
            .labels()
            .ok_or_else(|| invalid("a LabelGrid holds labels"))?;
        let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
        let values = output.holds_values() && grid.attribute().is_some();
        run_detached(py, threads, move || -> isogrid::Result<()> {
            let meshes = placed_meshes(grid, space, values)?;
            let shown: Vec<String> = labels
                .table()
                .iter()
                .map(|l| isogrid::labels::display_value(l.value, signed))
                .collect();
            let label_meshes: Vec<isogrid_io::label_meshes::LabelMesh> = labels
                .table()
                .iter()
                .zip(&shown)
                .zip(&meshes)
                .map(
                    |((label, value), (mesh, values))| isogrid_io::label_meshes::LabelMesh {
                        label,
                        value,
                        mesh,
                        values: values.as_deref(),
                    },
                )
                .collect();
            let attribute = grid.attribute().map(|a| a.info().name.as_str());
            output.write(&label_meshes, attribute)
        })?
        .map_err(to_py)
    }

    fn __repr__(slf: &Bound<'_, Self>) -> String {
        let grid = slf.as_super().get().inner();
        let [x, y, z] = grid.info().dims;
        let labels = grid.labels().map_or(0, |l| l.table().len());
        format!(
            "LabelGrid(dims=({x}, {y}, {z}), labels={labels}, active_cells={}{}, mapped={})",
            grid.active_cells(),
            attribute_repr(grid),
            if grid.is_mapped() { "True" } else { "False" }
        )
    }
}

/// `, attribute='NAME'` in a grid's repr when it has an attribute (quoted as Python quotes a
/// string).
fn attribute_repr(grid: &isogrid::CellGrid) -> String {
    grid.attribute().map_or_else(String::new, |a| {
        let name = a.info().name.replace('\\', "\\\\").replace('\'', "\\'");
        format!(", attribute='{name}'")
    })
}

/// Rows of N values as an (rows, N) array, moving the vector into numpy without a copy.
pub fn to_array2<T: numpy::Element, const N: usize>(
    py: Python<'_>,
    rows: Vec<[T; N]>,
) -> PyResult<Bound<'_, PyArray2<T>>> {
    let n = rows.len();
    let flat = numpy::ndarray::Array2::from_shape_vec((n, N), rows.into_flattened())
        .map_err(|e| invalid(e.to_string()))?;
    Ok(numpy::IntoPyArray::into_pyarray(flat, py))
}

/// `[a, b, c]` as a Python tuple rather than a list.
pub fn tuple3<T>(v: [T; 3]) -> (T, T, T) {
    let [a, b, c] = v;
    (a, b, c)
}

/// Every label's mesh of `grid`, placed in `space`, with its values of the grid's attribute when
/// `values` is set.
fn placed_meshes(
    grid: &isogrid::CellGrid,
    space: isogrid::mc::MeshSpace,
    values: bool,
) -> isogrid::Result<Vec<(isogrid::mc::McMesh, Option<Vec<f32>>)>> {
    let geometry = isogrid::extract::attribute::grid_geometry(grid.info());
    let mut meshes: Vec<(isogrid::mc::McMesh, Option<Vec<f32>>)> = match values {
        true => isogrid::mc::label_meshes_with_values(grid)?,
        false => isogrid::mc::label_meshes(grid)?
            .into_iter()
            .map(|m| (m, None))
            .collect(),
    };
    for (mesh, _) in &mut meshes {
        mesh.place(&geometry, space)?;
    }
    Ok(meshes)
}

/// `space="world"` or `"index"` of the mesh methods.
fn mesh_space(space: &str) -> PyResult<isogrid::mc::MeshSpace> {
    match space {
        "world" => Ok(isogrid::mc::MeshSpace::World),
        "index" => Ok(isogrid::mc::MeshSpace::Index),
        other => Err(invalid(format!(
            "space must be 'world' or 'index', not {other:?}"
        ))),
    }
}

//! `label_statistics`: segment statistics of a label volume (array or file) before any surface is
//! extracted, as `isogrid info VOLUME --labels --json` lists them.

use crate::array::{spacing3, VolumeArg};
use crate::errors::to_py;
use crate::grid::{read_table, set_label_value};
use crate::pool::{check_callback, run_watched};
use isogrid::{LabelSelection, Progress};
use isogrid_io::label_statistics::{GivenTable, VolumeLabels};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The selected labels of a 3-D label array (`labels`: `all`, `1,5-9`, or names of
/// `label_table`'s), named and coloured by the colour table file `label_table` when given.
/// Returns one dict per label and notices for the user. The count is one step of `progress`.
#[pyfunction]
#[pyo3(signature = (array, fortran, spacing, labels, label_table=None, progress=None))]
pub fn label_statistics<'py>(
    py: Python<'py>,
    array: &Bound<'_, PyAny>,
    fortran: bool,
    spacing: Vec<f64>,
    labels: &str,
    label_table: Option<PathBuf>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Vec<Bound<'py, PyDict>>, Vec<String>)> {
    let volume = VolumeArg::new(array, fortran, spacing3(spacing)?)?;
    let view = volume.view()?;
    let selection = LabelSelection::parse_with_names(labels).map_err(to_py)?;
    check_callback(progress.as_ref())?;
    let table = read_table(py, label_table.as_deref())?;
    let given = table
        .as_ref()
        .map(|(path, labels)| GivenTable { path, labels });
    let watch = Progress::new();
    watch.start(1);
    let stats = run_watched(py, None, &watch, progress.as_ref(), || {
        let stats =
            isogrid_io::label_statistics::volume_label_statistics(&view, &selection, given)?;
        watch.advance(1);
        Ok(stats)
    })?;
    statistics_dicts(py, stats)
}

/// [`label_statistics`] of a label volume file, read by region where its format allows (within a
/// quarter of the machine's memory, less where less may be allocated), with the names and colours
/// the file gives (a 3D Slicer `.seg.nrrd`, layered or not; an OME-Zarr label image, or the image
/// at `path` with `labels_of` naming one of its label images), then `label_table`'s. `spacing`
/// replaces the file's. Ctrl-C, or an exception from `progress(done, total)` (blocks counted, about
/// ten calls a second while a file is read by region), stops the count.
#[pyfunction]
#[pyo3(signature = (path, labels, labels_of=None, label_table=None, series=None, spacing=None, index=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn label_statistics_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    labels: &str,
    labels_of: Option<String>,
    label_table: Option<PathBuf>,
    series: Option<String>,
    spacing: Option<Vec<f64>>,
    index: Option<Vec<(String, u64)>>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Vec<Bound<'py, PyDict>>, Vec<String>)> {
    let selection = LabelSelection::parse_with_names(labels).map_err(to_py)?;
    check_callback(progress.as_ref())?;
    let spacing = spacing.map(spacing3).transpose()?;
    let table = read_table(py, label_table.as_deref())?;
    let given = table
        .as_ref()
        .map(|(path, labels)| GivenTable { path, labels });
    let options = crate::volume_io::file_read_options(series, index, "index");
    let watch = Progress::new();
    let stats = run_watched(py, None, &watch, progress.as_ref(), || {
        isogrid_io::label_statistics::file_label_statistics(
            &path,
            labels_of.as_deref(),
            &options,
            &selection,
            given,
            spacing,
            isogrid::memory::streaming_budget(None).0,
            &watch,
        )
    })?;
    statistics_dicts(py, stats)
}

/// One dict per label, with the keys of `isogrid info --labels --json`'s `labels` entries.
fn statistics_dicts(
    py: Python<'_>,
    stats: VolumeLabels,
) -> PyResult<(Vec<Bound<'_, PyDict>>, Vec<String>)> {
    let dicts = stats
        .labels
        .iter()
        .map(|l| {
            let d = PyDict::new(py);
            set_label_value(&d, l.label.value, stats.signed)?;
            d.set_item("name", &l.label.name)?;
            d.set_item("color", l.label.color_hex())?;
            d.set_item("voxels", l.voxels)?;
            d.set_item("volume", l.volume)?;
            d.set_item("lo", l.lo.to_vec())?;
            d.set_item("hi", l.hi.to_vec())?;
            Ok(d)
        })
        .collect::<PyResult<_>>()?;
    Ok((dicts, stats.notices))
}

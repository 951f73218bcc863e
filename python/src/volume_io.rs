//! Volume files and mesh voxelisation, returning samples as numpy arrays without copying them.

use crate::errors::{invalid, to_py};
use crate::grid::tuple3;
use crate::pool::run_detached;
use isogrid::{ScalarType, Volume, VolumeData};
use isogrid_io::mesh::TriMesh;
use isogrid_io::voxelize::VoxelizeOptions;
use isogrid_io::{RawSpec, ReadOptions, ZarrOptions};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Reads a volume file, a Zarr / OME-Zarr store (a folder or an `http://` URL; `level` and
/// `index` pick the resolution level and the entries of non-spatial axes); returns a dict with
/// `array` (C order, shape (nz, ny, nx), the reader's buffer moved into numpy), `spacing`,
/// `origin`, `direction` (all in x, y, z order) and `notices` (the reader's messages for the
/// user, e.g. other DICOM series left out). `series` picks a DICOM series by
/// SeriesInstanceUID, as the CLI's `--series`.
#[pyfunction]
#[pyo3(signature = (path, raw_shape=None, raw_dtype=None, big_endian=false, series=None, level=0, index=None, index_keyword="index"))]
#[allow(clippy::too_many_arguments)]
pub fn load_volume<'py>(
    py: Python<'py>,
    path: PathBuf,
    raw_shape: Option<[usize; 3]>,
    raw_dtype: Option<String>,
    big_endian: bool,
    series: Option<String>,
    level: usize,
    index: Option<Vec<(String, u64)>>,
    index_keyword: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let raw = match (raw_shape, raw_dtype.as_deref()) {
        (None, None) => None,
        (Some(dims), Some(name)) => Some(RawSpec {
            dims,
            scalar: scalar_type_named(name, "raw_dtype")?,
            big_endian,
        }),
        _ => {
            return Err(invalid(
                "raw files need both raw_shape (nx, ny, nz) and raw_dtype",
            ))
        }
    };
    let options = ReadOptions {
        raw,
        series,
        zarr: ZarrOptions {
            level,
            indices: index.unwrap_or_default(),
            trusted_certificates: isogrid_io::ssl_cert_file_from_env(),
            index_flag: index_flag(index_keyword)?,
        },
    };
    let (volume, notices) = py
        .detach(|| isogrid_io::read_volume_noted(&path, &options))
        .map_err(to_py)?;
    let d = volume_dict(py, volume)?;
    d.set_item("notices", notices)?;
    Ok(d)
}

/// The read options of a volume file argument: the DICOM `series`, the entries `index` of extra
/// axes (named `keyword` in errors: `index`, `attribute_index`), and the certificates
/// `SSL_CERT_FILE` names for Zarr URLs.
pub(crate) fn file_read_options(
    series: Option<String>,
    index: Option<Vec<(String, u64)>>,
    keyword: &'static str,
) -> ReadOptions {
    ReadOptions {
        series,
        zarr: ZarrOptions {
            indices: index.unwrap_or_default(),
            trusted_certificates: isogrid_io::ssl_cert_file_from_env(),
            index_flag: isogrid_io::IndexFlag::Python(keyword),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// The keyword argument that picks entries of extra axes (`index`, or `attribute_index` for the
/// volume a surface is coloured by), as the readers' errors name it.
pub(crate) fn index_flag(keyword: &str) -> PyResult<isogrid_io::IndexFlag> {
    match keyword {
        "index" => Ok(isogrid_io::IndexFlag::Python("index")),
        "attribute_index" => Ok(isogrid_io::IndexFlag::Python("attribute_index")),
        other => Err(invalid(format!(
            "index_keyword must be 'index' or 'attribute_index', not {other:?}"
        ))),
    }
}

/// For `isogrid.dask`: the array path of level `level` of the OME-Zarr image at `location`, whose
/// root group attributes are `attrs_json` (read by zarr-python, which opens any fsspec URL).
#[pyfunction]
pub fn _ome_level_path(location: &str, attrs_json: &str, level: usize) -> PyResult<String> {
    isogrid_io::region::zarr::ome_level_path(attrs_json, level, location).map_err(to_py)
}

/// For `isogrid.dask`: how a Zarr array of `shape` maps to a volume, decided as `load_volume` and
/// the CLI decide it. `axes` names its axes (`dimension_names` or `_ARRAY_DIMENSIONS`; None when
/// unnamed), `group_attrs` is the OME-Zarr root group's attributes (JSON; None for a plain
/// array). Returns a dict: `spatial` (the array axes of x, y, z), `fixed` ((axis, entry) of every
/// other axis), `spacing`, `origin` and `direction` (x, y, z order).
#[pyfunction]
#[pyo3(signature = (location, shape, axes=None, group_attrs=None, level=0, index=None))]
pub fn _zarr_selection<'py>(
    py: Python<'py>,
    location: &str,
    shape: Vec<u64>,
    axes: Option<Vec<String>>,
    group_attrs: Option<&str>,
    level: usize,
    index: Option<Vec<(String, u64)>>,
) -> PyResult<Bound<'py, PyDict>> {
    let options = ZarrOptions {
        level,
        indices: index.unwrap_or_default(),
        index_flag: isogrid_io::IndexFlag::Python("index"),
        ..ZarrOptions::default()
    };
    let selection = isogrid_io::region::zarr::select(group_attrs, axes, &shape, &options, location)
        .map_err(to_py)?;
    let g = selection.geometry;
    let d = PyDict::new(py);
    d.set_item("spatial", selection.spatial)?;
    d.set_item("fixed", selection.fixed)?;
    d.set_item("spacing", tuple3(g.spacing))?;
    d.set_item("origin", tuple3(g.origin))?;
    d.set_item("direction", tuple3(g.direction.map(tuple3)))?;
    Ok(d)
}

/// The sample type a numpy dtype name (`uint8`, ..., `float64`: [`crate::grid::dtype_name`])
/// names; errors name the argument `what`.
pub fn scalar_type_named(name: &str, what: &str) -> PyResult<ScalarType> {
    ScalarType::ALL
        .into_iter()
        .find(|&t| crate::grid::dtype_name(t) == name)
        .ok_or_else(|| {
            let names: Vec<&str> = ScalarType::ALL.map(crate::grid::dtype_name).to_vec();
            invalid(format!(
                "{what} must be one of {}, not {name}",
                names.join(", ")
            ))
        })
}

/// Solid voxelisation into an 8-bit coverage volume (paper §4). See `isogrid.voxelize`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, resolution, supersample=3, padding=2, cube=false, threads=None))]
pub fn voxelize<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    faces: PyReadonlyArray2<'py, u32>,
    resolution: usize,
    supersample: usize,
    padding: usize,
    cube: bool,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = TriMesh {
        vertices: rows3(&vertices, "vertices")?,
        triangles: rows3(&faces, "faces")?,
    };
    let options = VoxelizeOptions {
        resolution,
        supersample,
        padding,
        cube,
    };
    let volume = run_detached(py, threads, move || {
        isogrid_io::voxelize::voxelize(&mesh, &options, &|_, _| {})
    })?
    .map_err(to_py)?;
    volume_dict(py, volume)
}

pub(crate) fn rows3<T: numpy::Element + Copy>(
    array: &PyReadonlyArray2<'_, T>,
    name: &str,
) -> PyResult<Vec<[T; 3]>> {
    let view = array.as_array();
    if view.ncols() != 3 {
        return Err(invalid(format!(
            "{name} must have shape (N, 3), got {:?}",
            view.shape()
        )));
    }
    Ok(view
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect())
}

fn volume_dict(py: Python<'_>, volume: Volume) -> PyResult<Bound<'_, PyDict>> {
    let g = *volume.geometry();
    let [nx, ny, nz] = g.dims;
    let shape = (nz, ny, nx);
    let shape_err = |e: numpy::ndarray::ShapeError| invalid(e.to_string());
    macro_rules! array {
        ($($v:ident),*) => {
            match volume.into_data() {
                $(VolumeData::$v(v) => Array3::from_shape_vec(shape, v)
                    .map_err(shape_err)?
                    .into_pyarray(py)
                    .into_any(),)*
            }
        };
    }
    let array = array!(U8, U16, I16, F32, U32, I32, U64, I64, F64);
    let d = PyDict::new(py);
    d.set_item("array", array)?;
    d.set_item("spacing", tuple3(g.spacing))?;
    d.set_item("origin", tuple3(g.origin))?;
    d.set_item("direction", tuple3(g.direction.map(tuple3)))?;
    d.set_item("frame", crate::array::frame_name(g.frame))?;
    Ok(d)
}

//! `isogrid._isogrid`: the native half of the Python package (PyO3).
//!
//! Thin bindings: arrays are checked for type and memory order here, everything else is the Rust
//! library's. The pure-Python `isogrid/__init__.py` converts dtypes and memory orders and documents
//! the axis convention; these functions expect arrays already in a supported form and refuse
//! others rather than guess. Every long computation runs with the GIL released.
//!
//! Adding a function: write it in the file of its topic (or a new one), `#[pyfunction]` it, add
//! it to [`_isogrid`] below, to `_isogrid.pyi`, and re-export it from `isogrid/__init__.py`.

mod array;
mod errors;
mod grid;
mod label_statistics;
mod mesh;
mod pool;
mod render;
mod skimage;
mod tiles;
mod volume_io;

use pyo3::prelude::*;

/// Native core of the isogrid package; use the functions of `isogrid` instead.
#[pymodule]
fn _isogrid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("IsogridError", m.py().get_type::<errors::IsogridError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Cells per block edge: isogrid.dask tiles along blocks, and the rule lives in the library.
    m.add("BLOCK_CELLS", isogrid::layout::BLOCK_CELLS)?;
    m.add_class::<grid::CellGrid>()?;
    m.add_class::<grid::LabelGrid>()?;
    m.add_function(wrap_pyfunction!(grid::extract, m)?)?;
    m.add_function(wrap_pyfunction!(grid::extract_labels, m)?)?;
    m.add_function(wrap_pyfunction!(grid::_check_precision, m)?)?;
    m.add_function(wrap_pyfunction!(grid::extract_labels_file, m)?)?;
    m.add_function(wrap_pyfunction!(label_statistics::label_statistics, m)?)?;
    m.add_function(wrap_pyfunction!(
        label_statistics::label_statistics_file,
        m
    )?)?;
    m.add_function(wrap_pyfunction!(grid::load, m)?)?;
    m.add_function(wrap_pyfunction!(grid::_attach_attribute, m)?)?;
    m.add_function(wrap_pyfunction!(grid::_with_attribute, m)?)?;
    m.add_function(wrap_pyfunction!(grid::_empty_surface_note, m)?)?;
    m.add_function(wrap_pyfunction!(grid::_axis_codes, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::marching_cubes, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::_isosurface_empty_note, m)?)?;
    m.add_function(wrap_pyfunction!(skimage::skimage_normals_values, m)?)?;
    m.add_function(wrap_pyfunction!(volume_io::load_volume, m)?)?;
    m.add_function(wrap_pyfunction!(volume_io::voxelize, m)?)?;
    m.add_function(wrap_pyfunction!(volume_io::_ome_level_path, m)?)?;
    m.add_function(wrap_pyfunction!(volume_io::_zarr_selection, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_class::<tiles::_TileExtraction>()?;
    m.add_class::<tiles::_LabelWriter>()?;
    m.add_function(wrap_pyfunction!(tiles::_label_slab, m)?)?;
    m.add_class::<tiles::_TaskCancel>()?;
    m.add_function(wrap_pyfunction!(tiles::_scan_tile, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::_emit_tile, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::_extract_tile, m)?)?;
    Ok(())
}

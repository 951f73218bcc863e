//! Marching Cubes on a numpy array: the indexed triangle mesh baseline (paper Table 3).

use crate::array::{spacing3, VolumeArg};
use crate::errors::to_py;
use crate::grid::{iso_arg, to_array2};
use crate::pool::run_detached;
use isogrid::mc::{Inside, MeshSpace};
use numpy::PyArray2;
use pyo3::prelude::*;

/// Vertices (V, 3) float32 in world space (x, y, z) = origin + i·sx·d_i + j·sy·d_j + k·sz·d_k
/// (`direction` rows d_i, d_j, d_k; `index_space`: (i, j, k) instead), and faces (T, 3) uint32,
/// counter-clockwise seen from outside (value < iso). With `above`, inside is `value > iso`
/// (scikit-image's rule) instead of `value >= iso`. See `isogrid.marching_cubes`.
#[pyfunction]
#[pyo3(signature = (array, fortran, spacing, iso=None, iso_normalized=None, threads=None, origin=None, above=false, direction=None, index_space=false))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn marching_cubes<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    fortran: bool,
    spacing: Vec<f64>,
    iso: Option<f64>,
    iso_normalized: Option<f64>,
    threads: Option<usize>,
    origin: Option<Vec<f64>>,
    above: bool,
    direction: Option<Vec<Vec<f64>>>,
    index_space: bool,
) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<u32>>)> {
    let volume = VolumeArg::new(array, fortran, spacing3(spacing)?)?.place(origin, direction)?;
    let view = volume.view()?;
    let iso = iso_arg(iso, iso_normalized)?;
    let inside = if above {
        Inside::Above
    } else {
        Inside::AtOrAbove
    };
    let mesh = run_detached(py, threads, move || {
        let iso = iso.resolve(&view)?;
        let mut mesh = isogrid::mc::try_marching_cubes_with(&view, iso, inside)?;
        // The library's positions are in the renderer's frame (origin and directions left out).
        let space = if index_space {
            MeshSpace::Index
        } else {
            MeshSpace::World
        };
        mesh.place(&view.geometry(), space)?;
        Ok::<_, isogrid::Error>(mesh)
    })?
    .map_err(to_py)?;
    Ok((
        to_array2(py, mesh.positions)?,
        to_array2(py, mesh.triangles)?,
    ))
}

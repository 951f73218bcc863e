//! Marching Cubes on a numpy array: the indexed triangle mesh baseline (paper Table 3).

use crate::array::{spacing3, VolumeArg};
use crate::errors::to_py;
use crate::grid::{iso_arg, to_array2};
use crate::pool::run_detached;
use isogrid::mc::Inside;
use numpy::PyArray2;
use pyo3::prelude::*;

/// Vertices (V, 3) float32 in world units (x, y, z) = origin + (i·sx, j·sy, k·sz), and faces
/// (T, 3) uint32, counter-clockwise seen from outside (value < iso). With `above`, inside is
/// `value > iso` (scikit-image's rule) instead of `value >= iso`. See `isogrid.marching_cubes`.
#[pyfunction]
#[pyo3(signature = (array, fortran, spacing, iso=None, iso_normalized=None, threads=None, origin=None, above=false))]
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
) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<u32>>)> {
    let volume = VolumeArg::new(array, fortran, spacing3(spacing)?)?.place(origin, None)?;
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
        // The library's positions leave the origin out (the renderer's frame); Python's are the
        // volume's own world coordinates.
        let origin = view.geometry().origin;
        if origin != [0.0; 3] {
            for p in &mut mesh.positions {
                *p = [0, 1, 2].map(|a| (p[a] as f64 + origin[a]) as f32);
            }
        }
        Ok::<_, isogrid::Error>(mesh)
    })?
    .map_err(to_py)?;
    Ok((
        to_array2(py, mesh.positions)?,
        to_array2(py, mesh.triangles)?,
    ))
}

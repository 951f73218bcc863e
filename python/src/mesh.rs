//! Marching Cubes on a numpy array: the indexed triangle mesh baseline (paper Table 3).

use crate::array::{spacing3, VolumeArg};
use crate::grid::{iso_arg, to_array2, AttributeArg};
use crate::pool::{check_callback, run_watched};
use isogrid::extract::attribute::sample_points_in_memory;
use isogrid::mc::{Inside, MeshSpace};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// Vertices (V, 3) float32 in world space (x, y, z) = origin + i·sx·d_i + j·sy·d_j + k·sz·d_k
/// (`direction` rows d_i, d_j, d_k; `index_space`: (i, j, k) instead), and faces (T, 3) uint32,
/// counter-clockwise seen from outside (value < iso). With `above`, inside is `value > iso`
/// (scikit-image's rule) instead of `value >= iso`. See `isogrid.marching_cubes`.
#[pyfunction]
#[pyo3(signature = (array, fortran, spacing, iso=None, iso_normalized=None, threads=None, origin=None, above=false, direction=None, index_space=false, attribute=None, progress=None, frame=None))]
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
    attribute: Option<AttributeArg<'_, 'py>>,
    progress: Option<Bound<'py, PyAny>>,
    frame: Option<String>,
) -> PyResult<Bound<'py, PyTuple>> {
    check_callback(progress.as_ref())?;
    let volume = VolumeArg::new(array, fortran, spacing3(spacing)?)?.place(
        origin,
        direction,
        frame.as_deref(),
    )?;
    let view = volume.view()?;
    let iso = iso_arg(iso, iso_normalized)?;
    let inside = if above {
        Inside::Above
    } else {
        Inside::AtOrAbove
    };
    let attribute = attribute
        .map(
            |(array, fortran, spacing, origin, direction, frame, _, _)| {
                VolumeArg::new(&array, fortran, spacing3(spacing)?)?.place(
                    origin,
                    direction,
                    frame.as_deref(),
                )
            },
        )
        .transpose()?;
    let attribute_view = attribute.as_ref().map(|a| a.view()).transpose()?;
    // Ctrl-C and the callback are watched while Marching Cubes runs; either stops it.
    let watch = isogrid::Progress::new();
    let (mesh, values) = run_watched(py, threads, &watch, progress.as_ref(), || {
        let iso = iso.resolve(&view)?;
        let mut mesh = isogrid::mc::try_marching_cubes_with_progress(&view, iso, inside, &watch)?;
        // The attribute at each vertex, from its index-space position.
        let values = match &attribute_view {
            Some(attribute) => {
                let points = mesh.index_positions(view.geometry().spacing);
                Some(sample_points_in_memory(
                    view.geometry(),
                    &points,
                    attribute,
                )?)
            }
            None => None,
        };
        // The library's positions are in the renderer's frame (origin and directions left out).
        let space = if index_space {
            MeshSpace::Index
        } else {
            MeshSpace::World
        };
        mesh.place(view.geometry(), space)?;
        Ok::<_, isogrid::Error>((mesh, values))
    })?;
    let vertices = to_array2(py, mesh.positions)?.into_any();
    let faces = to_array2(py, mesh.triangles)?.into_any();
    match values {
        Some(values) => PyTuple::new(py, [vertices, faces, values.into_pyarray(py).into_any()]),
        None => PyTuple::new(py, [vertices, faces]),
    }
}

/// Why Marching Cubes of `array` at the isovalue gives no triangle
/// (`isogrid::grid::isosurface_empty_note`, the note of `isogrid mc`): the text of
/// `EmptySurfaceWarning`. Asked only for an empty mesh; a normalised isovalue is resolved as
/// `marching_cubes` resolves it.
#[pyfunction]
#[pyo3(signature = (array, fortran, iso=None, iso_normalized=None))]
pub fn _isosurface_empty_note(
    array: &Bound<'_, PyAny>,
    fortran: bool,
    iso: Option<f64>,
    iso_normalized: Option<f64>,
) -> PyResult<String> {
    let volume = VolumeArg::new(array, fortran, [1.0; 3])?;
    let view = volume.view()?;
    let iso = iso_arg(iso, iso_normalized)?
        .resolve(&view)
        .map_err(crate::errors::to_py)?;
    let range = view.value_range();
    Ok(isogrid::grid::isosurface_empty_note(
        view.dims().map(|d| d as u32),
        view.scalar_type(),
        range.map_or([0.0; 2], |(lo, hi)| [lo, hi]),
        iso,
        || range.is_none(),
    ))
}

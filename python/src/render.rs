//! `isogrid.render`: the keywords become an [`isogrid_render::RenderRequest`], placed and run by the
//! render front door (the CPU tracer or the GPU renderer, lavapipe included), with the depth /
//! normal / cluster AOVs of `isogrid render`, a `progress` callback and Ctrl-C.

use crate::errors::{invalid, to_py};
use crate::grid::CellGrid;
use crate::pool::run_watched;
use isogrid::colormap::ColorMap;
use isogrid::{LabelSelection, Progress};
use isogrid_render::{
    Backend, CameraSpec, ColorSpec, EnvSource, Mode, Placement, RenderContext, RenderRequest,
    RequestParts, Traversal,
};
use numpy::ndarray::{Array2, Array3};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::LazyLock;

/// One context per process: the adapter is looked up once, and the GPU renderer (whose device
/// and pipelines are the slow part) opened once, on the first render placed on the GPU.
static CONTEXT: LazyLock<RenderContext> = LazyLock::new(RenderContext::new);

/// `1`, `2` or `(eye, target, up, fovy_degrees)`; a standard view frames the box `frame` names
/// (`"grid"` or `"surface"`).
fn camera_spec(camera: &Bound<'_, PyAny>, frame: &str) -> PyResult<CameraSpec> {
    if let Ok(view) = camera.extract::<u8>() {
        return match frame {
            "grid" => Ok(CameraSpec::View(view)),
            "surface" => Ok(CameraSpec::SurfaceView(view)),
            _ => Err(invalid(format!(
                "frame must be 'grid' or 'surface', not {frame:?}"
            ))),
        };
    }
    if frame != "grid" {
        return Err(invalid(
            "frame chooses what the standard views 1 and 2 frame; an (eye, target, up, \
             fovy_degrees) camera is placed as given",
        ));
    }
    let (eye, target, up, fovy_degrees): ([f64; 3], [f64; 3], [f64; 3], f64) = camera
        .extract()
        .map_err(|_| invalid("camera must be 1, 2 or (eye, target, up, fovy_degrees)"))?;
    Ok(CameraSpec::LookAt {
        eye,
        target,
        up,
        fovy_degrees,
    })
}

/// Renders `grid`; see `isogrid.render` for the arguments.
#[pyfunction]
#[pyo3(signature = (grid, camera, width, height, mode, backend, frames=1, spp=16, bounces=3, threads=None, traversal="blocks", env=None, progress=None, cmap=None, clim=None, show=None, hide=None, frame="grid"))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    grid: &CellGrid,
    camera: Bound<'py, PyAny>,
    width: u32,
    height: u32,
    mode: &str,
    backend: &str,
    frames: u32,
    spp: u32,
    bounces: u32,
    threads: Option<usize>,
    traversal: &str,
    env: Option<PathBuf>,
    progress: Option<Bound<'py, PyAny>>,
    cmap: Option<&str>,
    clim: Option<(f64, f64)>,
    show: Option<&str>,
    hide: Option<&str>,
    frame: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let grid = grid.inner();
    // A grid with an attribute is drawn in colour; a colour map or range needs one.
    let color = match grid.attribute() {
        Some(_) => Some(ColorSpec {
            map: cmap
                .map(ColorMap::from_name)
                .transpose()
                .map_err(to_py)?
                .unwrap_or_default(),
            clim: clim.map(|(lo, hi)| [lo, hi]),
        }),
        None if cmap.is_some() || clim.is_some() => {
            return Err(invalid(
                "cmap and clim colour by the grid's attribute, and it has none \
                 (extract with attribute=...)",
            ))
        }
        None => None,
    };
    let traversal = Traversal::from_name(traversal).ok_or_else(|| {
        invalid(format!(
            "traversal must be 'blocks' or 'bvh', not {traversal:?}"
        ))
    })?;
    let mode: Mode = mode.parse().map_err(to_py)?;
    let backend: Backend = backend.parse().map_err(to_py)?;
    let request = RenderRequest::new(RequestParts {
        mode,
        backend,
        camera: camera_spec(&camera, frame)?,
        size: (width, height),
        environment: env.map_or(EnvSource::Sky, EnvSource::Map),
        samples: spp,
        frames,
        bounces,
        traversal,
        color,
        show: show
            .map(LabelSelection::parse_with_names)
            .transpose()
            .map_err(to_py)?,
        hide: hide
            .map(LabelSelection::parse_with_names)
            .transpose()
            .map_err(to_py)?,
        ..RequestParts::default()
    })
    .map_err(to_py)?;
    crate::pool::check_callback(progress.as_ref())?;
    // The adapter lookup loads the Vulkan drivers: without the GIL.
    let decision = py.detach(|| CONTEXT.decide(&request)).map_err(to_py)?;
    let watch = Progress::new();
    let out = run_watched(py, threads, &watch, progress.as_ref(), || {
        isogrid_render::render(&CONTEXT, &request, decision.placement, grid, None, &watch)
    })?;
    let backend = match out.placement {
        Placement::Cpu => "cpu",
        Placement::Gpu => "gpu",
    };
    let (h, w) = (height as usize, width as usize);
    let shape_err = |e: numpy::ndarray::ShapeError| invalid(e.to_string());
    let dict = PyDict::new(py);
    dict.set_item(
        "image",
        Array3::from_shape_vec((h, w, 3), out.rgb8)
            .map_err(shape_err)?
            .into_pyarray(py),
    )?;
    dict.set_item(
        "depth",
        Array2::from_shape_vec((h, w), out.depth)
            .map_err(shape_err)?
            .into_pyarray(py),
    )?;
    let normal: Vec<f32> = out.normal.into_iter().flatten().collect();
    dict.set_item(
        "normal",
        Array3::from_shape_vec((h, w, 3), normal)
            .map_err(shape_err)?
            .into_pyarray(py),
    )?;
    dict.set_item(
        "cluster",
        Array2::from_shape_vec((h, w), out.cluster)
            .map_err(shape_err)?
            .into_pyarray(py),
    )?;
    if let Some(value) = out.value {
        dict.set_item(
            "value",
            Array2::from_shape_vec((h, w), value)
                .map_err(shape_err)?
                .into_pyarray(py),
        )?;
    }
    if let Some(label) = out.label {
        dict.set_item(
            "label",
            Array2::from_shape_vec((h, w), label)
                .map_err(shape_err)?
                .into_pyarray(py),
        )?;
    }
    dict.set_item("backend", backend)?;
    dict.set_item("adapter", out.adapter)?;
    dict.set_item("samples", out.samples)?;
    Ok(dict)
}

//! `isogrid.render`: an image of a grid with the GPU renderer (any wgpu adapter, lavapipe included)
//! or the CPU ray tracer, plus depth / normal / cluster AOVs (conventions of `isogrid render`).

use crate::errors::{invalid, to_py};
use crate::grid::CellGrid;
use crate::pool::run_detached;
use isogrid::Camera;
use isogrid_trace::{Environment, PathTraceOptions, RenderOptions, Shading, Traversal};
use numpy::ndarray::{Array2, Array3};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::OnceLock;

/// One renderer per process: creating a device and its pipelines is the slow part.
static GPU: OnceLock<Option<isogrid_gpu::Renderer>> = OnceLock::new();

fn gpu() -> PyResult<Option<&'static isogrid_gpu::Renderer>> {
    if let Some(r) = GPU.get() {
        return Ok(r.as_ref());
    }
    let renderer = match isogrid_gpu::Renderer::new() {
        Ok(r) => Some(r),
        Err(e) if e.kind() == isogrid_gpu::GpuErrorKind::NoAdapter => None,
        Err(e) => return Err(to_py(e.into())),
    };
    Ok(GPU.get_or_init(|| renderer).as_ref())
}

struct Rendered {
    rgb: Vec<u8>,
    depth: Vec<f32>,
    normal: Vec<[f32; 3]>,
    cluster: Vec<u32>,
    backend: &'static str,
    adapter: String,
}

/// Renders `grid`; see `isogrid.render` for the arguments.
#[pyfunction]
#[pyo3(signature = (grid, camera, width, height, mode, backend, frames=1, spp=16, bounces=3, threads=None, traversal="blocks"))]
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
) -> PyResult<Bound<'py, PyDict>> {
    let grid = grid.inner();
    let traversal = Traversal::from_name(traversal).ok_or_else(|| {
        invalid(format!(
            "traversal must be 'blocks' or 'bvh', not {traversal:?}"
        ))
    })?;
    if width == 0 || height == 0 || width as u64 * height as u64 > 64 << 20 {
        return Err(invalid(format!(
            "image size {width}x{height} is empty or too large"
        )));
    }
    let camera = if let Ok(view) = camera.extract::<u8>() {
        let (lo, hi) = grid.info().world_bounds();
        Camera::preset(view, lo, hi, width, height).map_err(to_py)?
    } else {
        let (eye, target, up, fovy): ([f64; 3], [f64; 3], [f64; 3], f64) = camera
            .extract()
            .map_err(|_| invalid("camera must be 1, 2 or (eye, target, up, fovy_degrees)"))?;
        let c = Camera {
            eye,
            target,
            up,
            fovy_degrees: fovy,
            width,
            height,
        };
        c.validate().map_err(to_py)?;
        c
    };
    let gpu_mode = match mode {
        "cgc" => Some(isogrid_gpu::Mode::Cgc),
        "cgc-noewa" => Some(isogrid_gpu::Mode::CgcNoEwa),
        "pathtrace" => None,
        _ => {
            return Err(invalid(format!(
                "mode must be 'cgc', 'cgc-noewa' or 'pathtrace', not {mode:?}"
            )))
        }
    };
    let renderer = match (backend, gpu_mode) {
        ("cpu", Some(isogrid_gpu::Mode::CgcNoEwa)) => {
            return Err(invalid("mode 'cgc-noewa' needs the GPU backend"))
        }
        ("cpu", _) | ("auto", None) => None,
        ("gpu", None) => {
            return Err(invalid(
                "path tracing runs on the CPU: use backend='cpu' or 'auto'",
            ))
        }
        ("gpu", Some(_)) => Some(gpu()?.ok_or_else(|| invalid("no GPU adapter found"))?),
        ("auto", Some(m)) => match gpu()? {
            Some(r) => Some(r),
            None if m == isogrid_gpu::Mode::CgcNoEwa => {
                return Err(invalid("mode 'cgc-noewa' needs a GPU adapter"))
            }
            None => None,
        },
        _ => {
            return Err(invalid(format!(
                "backend must be 'auto', 'gpu' or 'cpu', not {backend:?}"
            )))
        }
    };
    let out = run_detached(py, threads, move || -> isogrid::Result<Rendered> {
        if let (Some(r), Some(m)) = (renderer, gpu_mode) {
            let gpu_grid = r.upload_grid(grid)?;
            let options = isogrid_gpu::RenderOptions {
                frames: frames.max(1),
                ..Default::default()
            };
            let f = r.render_with(isogrid_gpu::Scene::Grid(&gpu_grid), &camera, m, &options)?;
            let rgb = f
                .rgba8
                .chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect();
            return Ok(Rendered {
                rgb,
                depth: f.depth,
                normal: f.normal,
                cluster: f.cluster,
                backend: "gpu",
                adapter: r.adapter_info(),
            });
        }
        let shading = match gpu_mode {
            None => Shading::PathTrace(PathTraceOptions {
                samples_per_pixel: spp.max(1),
                bounces,
                environment: Environment::Sky,
                ..PathTraceOptions::default()
            }),
            Some(_) => Shading::Phong,
        };
        let options = RenderOptions {
            shading,
            traversal,
            ..RenderOptions::default()
        };
        let image = isogrid_trace::render(grid, &camera, &options)?;
        Ok(Rendered {
            rgb: image.rgb8,
            depth: image.depth,
            normal: image.normal,
            cluster: image.cluster,
            backend: "cpu",
            adapter: "CPU ray tracer".into(),
        })
    })?
    .map_err(to_py)?;
    let (h, w) = (height as usize, width as usize);
    let shape_err = |e: numpy::ndarray::ShapeError| invalid(e.to_string());
    let dict = PyDict::new(py);
    dict.set_item(
        "image",
        Array3::from_shape_vec((h, w, 3), out.rgb)
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
    dict.set_item("backend", out.backend)?;
    dict.set_item("adapter", out.adapter)?;
    Ok(dict)
}

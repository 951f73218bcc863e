//! The per-vertex normals and values of `isogrid.skimage.marching_cubes`, formed as scikit-image's
//! Lewiner marching cubes forms them (Lewiner et al. 2003, as ported to scikit-image).

use crate::array::VolumeArg;
use crate::errors::invalid;
use crate::grid::to_array2;
use crate::volume_io::rows3;
use isogrid::{Samples, Scalar, VolumeView};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use rayon::prelude::*;

/// Per-vertex normals and values of a Marching Cubes mesh as scikit-image's Lewiner marching
/// cubes forms them (see `isogrid.skimage`), for `positions` in sample units (x, y, z) and the
/// faces of the mesh:
/// - each face adds, for each of its vertices and at both ends of the vertex's edge, the
///   differences `f(low) − f(high)` along the three edges of the face's cell through that end,
///   weighted by `1 / (ε + |f − level|)` there; the sum, normalised, is the normal (−∇f);
/// - the value is the largest, over the faces using the vertex, of the face's cell's
///   `max(0, max(c − level)) − min(0, min(c − level))` over its corners `c`.
///
/// A face's cell is the one holding its centroid (isogrid never puts a triangle in a cell's face).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn skimage_normals_values<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    fortran: bool,
    positions: PyReadonlyArray2<'py, f32>,
    faces: PyReadonlyArray2<'py, u32>,
    level: f64,
) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>)> {
    let volume = VolumeArg::new(array, fortran, [1.0; 3])?;
    let view = volume.view()?;
    let positions = rows3(&positions, "positions")?;
    let faces = rows3(&faces, "faces")?;
    if let Some(bad) = faces
        .iter()
        .flatten()
        .find(|&&v| v as usize >= positions.len())
    {
        return Err(invalid(format!(
            "face index {bad} is not below the vertex count {}",
            positions.len()
        )));
    }
    let (normals, values) = py.detach(|| lewiner_normals_values(&view, &positions, &faces, level));
    Ok((to_array2(py, normals)?, values.into_pyarray(py)))
}

/// scikit-image's FLT_EPSILON (`numpy.spacing(1.0)`), which keeps the weights finite.
const WEIGHT_EPSILON: f64 = f64::EPSILON;

fn lewiner_normals_values(
    view: &VolumeView,
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    level: f64,
) -> (Vec<[f32; 3]>, Vec<f32>) {
    let dims = view.dims();
    match view.samples() {
        Samples::U8(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::U16(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::I16(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::F32(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::U32(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::I32(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::U64(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::I64(s) => normals_values_typed(s, dims, positions, faces, level),
        Samples::F64(s) => normals_values_typed(s, dims, positions, faces, level),
    }
}

fn normals_values_typed<T: Scalar>(
    samples: &[T],
    dims: [usize; 3],
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    level: f64,
) -> (Vec<[f32; 3]>, Vec<f32>) {
    let at = |p: [usize; 3]| samples[p[0] + dims[0] * (p[1] + dims[1] * p[2])].to_f64();
    // Each vertex's edge: its lower end, its upper end (the same sample for a vertex on one).
    let ends: Vec<[[usize; 3]; 2]> = positions
        .par_iter()
        .map(|p| {
            let below: [usize; 3] =
                std::array::from_fn(|a| (p[a].max(0.0).floor() as usize).min(dims[a] - 1));
            let mut above = below;
            if let Some(axis) = (0..3).find(|&a| p[a] > below[a] as f32) {
                above[axis] = (below[axis] + 1).min(dims[axis] - 1);
            }
            [below, above]
        })
        .collect();
    // Each face's cell and its corner samples (all the samples its vertices' sums read), which
    // every sample type holds exactly as f32; corner c = (c & 1, c >> 1 & 1, c >> 2 & 1).
    let cells: Vec<([usize; 3], [f32; 8])> = faces
        .par_iter()
        .map(|face| {
            let corners = face.map(|v| positions[v as usize]);
            let cell: [usize; 3] = std::array::from_fn(|a| {
                let centroid = (corners[0][a] + corners[1][a] + corners[2][a]) as f64 / 3.0;
                (centroid.max(0.0).floor() as usize).min(dims[a].saturating_sub(2))
            });
            let corners: [f32; 8] = std::array::from_fn(|c| {
                at([
                    cell[0] + (c & 1),
                    cell[1] + (c >> 1 & 1),
                    cell[2] + (c >> 2 & 1),
                ]) as f32
            });
            (cell, corners)
        })
        .collect();
    // The faces of each vertex, in face order (so sums do not depend on the thread count).
    let mut first = vec![0usize; positions.len() + 1];
    for &v in faces.iter().flatten() {
        first[v as usize + 1] += 1;
    }
    for v in 0..positions.len() {
        first[v + 1] += first[v];
    }
    let mut next = first.clone();
    let mut incident = vec![0u32; faces.len() * 3];
    for (f, face) in faces.iter().enumerate() {
        for &v in face {
            incident[next[v as usize]] = f as u32;
            next[v as usize] += 1;
        }
    }
    (0..positions.len())
        .into_par_iter()
        .map(|v| {
            let end_values = ends[v].map(at);
            let weights = end_values.map(|f| 1.0 / (WEIGHT_EPSILON + (f - level).abs()));
            let mut sum = [0f64; 3];
            let mut value = 0f32;
            for &f in &incident[first[v]..first[v + 1]] {
                let (cell, corners) = &cells[f as usize];
                let (lo, hi) = corners.iter().fold((0f64, 0f64), |(lo, hi), &c| {
                    let c = c as f64 - level;
                    (lo.min(c), hi.max(c))
                });
                value = value.max((hi - lo) as f32);
                for (end, weight) in ends[v].iter().zip(weights) {
                    // The end as a corner of the cell (it always is one, unless the cell was
                    // clamped at the volume's border: then read the samples themselves).
                    let offset: [usize; 3] = std::array::from_fn(|d| end[d].wrapping_sub(cell[d]));
                    let corner = offset
                        .iter()
                        .all(|&o| o <= 1)
                        .then(|| offset[0] | offset[1] << 1 | offset[2] << 2);
                    for d in 0..3 {
                        let difference = match corner {
                            Some(c) => corners[c & !(1 << d)] as f64 - corners[c | 1 << d] as f64,
                            None => {
                                let (mut low, mut high) = (*end, *end);
                                low[d] = cell[d];
                                high[d] = (cell[d] + 1).min(dims[d] - 1);
                                at(low) - at(high)
                            }
                        };
                        sum[d] += weight * difference;
                    }
                }
            }
            let length = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
            let scale = if length > 0.0 { 1.0 / length } else { 0.0 };
            (sum.map(|c| (c * scale) as f32), value)
        })
        .unzip()
}

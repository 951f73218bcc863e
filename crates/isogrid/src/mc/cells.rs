//! Marching Cubes of a grid's stored cells: one indexed mesh per label of a label grid, built from
//! the corners its cells store (the surface the renderers draw), for exports such as glTF and
//! neuroglancer's precomputed meshes.
//!
//! Each label's cells are found through the label index (its runs of clusters), so a label costs
//! its own cells, not a scan of the grid. A cell's corners are its stored codes, inside when
//! `code >= iso_code` (the grid's rule); its triangles come from the Marching Cubes case table
//! shared with `mc::marching_cubes` (same corner and edge numbering, same ambiguous-face rule,
//! counter-clockwise seen from outside), so neighbouring cells of a label agree on the segments
//! of their shared face and the mesh is closed wherever the label's surface is. A crossed edge gets
//! one vertex per label, at the linear crossing of its two codes; the vertex is shared by every
//! cell of that label that crosses the edge. A binary label grid stores codes 0 and the top code
//! with `iso_code` halfway, so each vertex is an edge midpoint, as Marching Cubes of the label's
//! indicator at ½ gives.
//!
//! Positions are in the frame of [`McMesh`]: sample `(i, j, k)` at `(i·sx, j·sy, k·sz)` (index
//! × spacing); [`McMesh::place`] moves them to world or index space.

use super::mesh::McMesh;
use super::table::{cases, edge_corners};
use crate::error::{Error, Result};
use crate::grid::CellGrid;
use crate::layout::{read_corners, BOUND_SLOT, CLUSTER_SLOTS};
use rayon::prelude::*;
use std::collections::HashMap;

/// Bytes of mesh per active cell, with room to spare: a label's cells give about one vertex
/// (12 B) and two triangles (24 B) each (36.2 B on a 128³ corner of the 256³ supervoxels), and
/// the crossed edges' map while a label is meshed.
const MESH_BYTES_PER_CELL: u64 = 48;

/// The mesh of every label of `grid`, in the order of its label table (empty for a label with no
/// cells). Fails for a grid without labels, or a label of more than 2³²−1 vertices.
pub fn label_meshes(grid: &CellGrid) -> Result<Vec<McMesh>> {
    let labels = grid
        .labels()
        .ok_or_else(|| Error::invalid("the grid has no labels to mesh one by one"))?;
    crate::memory::ensure_fits(
        "the mesh of every label",
        grid.active_cells() as u64 * MESH_BYTES_PER_CELL,
    )?;
    (0..labels.table().len())
        .into_par_iter()
        .map(|label| label_mesh(grid, label))
        .collect()
}

/// Every label's mesh of `grid` as one mesh (the labels in table order, each label's vertices
/// and triangles after the last's; positions index × spacing, as [`label_meshes`] gives them),
/// with each vertex's label (its index in the table): what a renderer draws in the labels'
/// colours. Fails as [`label_meshes`] does, and past 2³²−1
/// vertices in all.
pub fn labelled_mesh(grid: &CellGrid) -> Result<(McMesh, Vec<u32>)> {
    // The labels' meshes and their concatenation are held at once.
    crate::memory::ensure_fits(
        "the mesh of every label",
        grid.active_cells() as u64 * 2 * MESH_BYTES_PER_CELL,
    )?;
    let meshes = label_meshes(grid)?.into_iter().map(|m| (m, None));
    concatenated(meshes).map(|(mesh, labels, _)| (mesh, labels))
}

/// [`labelled_mesh`] with each vertex's value of the grid's attribute, as
/// [`label_meshes_with_values`] gives them: what a renderer draws coloured by the attribute.
/// Fails as [`labelled_mesh`] does, and for a grid without an attribute.
pub fn labelled_mesh_with_values(grid: &CellGrid) -> Result<(McMesh, Vec<u32>, Vec<f32>)> {
    if grid.attribute().is_none() {
        return Err(Error::invalid(
            "the grid has no attribute to take values from",
        ));
    }
    crate::memory::ensure_fits(
        "the mesh of every label",
        grid.active_cells() as u64 * 2 * (MESH_BYTES_PER_CELL + 16),
    )?;
    let (mesh, labels, values) = concatenated(label_meshes_with_values(grid)?)?;
    Ok((mesh, labels, values.unwrap_or_default()))
}

/// The meshes (and their values, where every one has them) one after another, with each
/// vertex's mesh index.
fn concatenated(
    meshes: impl IntoIterator<Item = (McMesh, Option<Vec<f32>>)>,
) -> Result<(McMesh, Vec<u32>, Option<Vec<f32>>)> {
    let meshes: Vec<_> = meshes.into_iter().collect();
    let vertices: usize = meshes.iter().map(|(m, _)| m.positions.len()).sum();
    if vertices > u32::MAX as usize {
        return Err(Error::invalid(
            "the labels' meshes need more than 2^32-1 vertices together",
        ));
    }
    let mut mesh = McMesh {
        positions: Vec::with_capacity(vertices),
        triangles: Vec::with_capacity(meshes.iter().map(|(m, _)| m.triangles.len()).sum()),
    };
    let mut vertex_labels = Vec::with_capacity(vertices);
    let mut values = meshes
        .iter()
        .all(|(_, v)| v.is_some())
        .then(|| Vec::with_capacity(vertices));
    for (label, (m, v)) in meshes.into_iter().enumerate() {
        let first = mesh.positions.len() as u32;
        mesh.triangles
            .extend(m.triangles.iter().map(|t| t.map(|v| v + first)));
        mesh.positions.extend_from_slice(&m.positions);
        vertex_labels.resize(mesh.positions.len(), label as u32);
        if let (Some(values), Some(v)) = (values.as_mut(), v) {
            values.extend(v);
        }
    }
    Ok((mesh, vertex_labels, values))
}

/// The mesh of label `label` (its index in the table) of a label grid.
pub fn label_mesh(grid: &CellGrid, label: usize) -> Result<McMesh> {
    mesh_of_label(grid, label, false).map(|(mesh, _)| mesh)
}

/// Every label's mesh, as [`label_meshes`] gives them, each with one value per vertex from the
/// grid's cell attribute (`None` for a grid without one): the mean of the finite values that this
/// label's cells crossing the vertex's edge hold (the values the cell renderers show on either
/// side of the vertex), NaN where all are NaN.
pub fn label_meshes_with_values(grid: &CellGrid) -> Result<Vec<(McMesh, Option<Vec<f32>>)>> {
    let labels = grid
        .labels()
        .ok_or_else(|| Error::invalid("the grid has no labels to mesh one by one"))?;
    // The meshes, and each vertex's sum and count while they are built.
    crate::memory::ensure_fits(
        "the mesh of every label",
        grid.active_cells() as u64 * (MESH_BYTES_PER_CELL + 16),
    )?;
    (0..labels.table().len())
        .into_par_iter()
        .map(|label| mesh_of_label(grid, label, grid.attribute().is_some()))
        .collect()
}

/// The mesh of label `label`, and its per-vertex values when `values` is set (see
/// [`label_meshes_with_values`]).
fn mesh_of_label(
    grid: &CellGrid,
    label: usize,
    values: bool,
) -> Result<(McMesh, Option<Vec<f32>>)> {
    let labels = grid
        .labels()
        .ok_or_else(|| Error::invalid("the grid has no labels to mesh one by one"))?;
    let info = grid.info();
    let (precision, iso) = (info.precision, info.mapping.iso_code);
    let [nx, ny, _] = info.dims.map(|d| d as u64);
    let spacing = info.spacing;
    let record_bytes = precision.bytes_per_cell();
    let mut mesh = McMesh::default();
    let attribute = grid.attribute().filter(|_| values);
    // Per vertex: the sum of the finite values of the cells crossing its edge, and their count.
    let mut sums: Vec<(f64, u32)> = Vec::new();
    // Crossed edge (lower sample's index × 3 + axis) → its vertex.
    let mut vertex_of: HashMap<u64, u32> = HashMap::new();
    for run in labels.runs_of(label) {
        for cluster in run.clusters() {
            let slots = cluster * CLUSTER_SLOTS..(cluster + 1) * CLUSTER_SLOTS;
            for (s, m) in grid.metacells()[slots].iter().enumerate() {
                if s == BOUND_SLOT {
                    continue;
                }
                let mut record = m.cell_pointer as usize;
                let mut mask = m.cell_mask;
                while mask != 0 {
                    let bit = mask.trailing_zeros();
                    mask &= mask - 1;
                    let cell = &grid.cells()[record * record_bytes..(record + 1) * record_bytes];
                    let value = attribute.map(|a| a.value(record));
                    record += 1;
                    let corners = read_corners(cell, precision);
                    let pattern =
                        (0..8).fold(0usize, |p, c| p | ((corners[c] >= iso) as usize) << c);
                    let case = &cases()[pattern];
                    let origin = m.cell_position(bit).map(|c| c as u64);
                    let mut vertex = [0u32; 12];
                    let mut crossed = case.edge_mask;
                    while crossed != 0 {
                        let e = crossed.trailing_zeros() as u8;
                        crossed &= crossed - 1;
                        let (lower, upper) = edge_corners(e);
                        let axis = (e / 4) as usize;
                        let at: [u64; 3] =
                            std::array::from_fn(|a| origin[a] + (lower as u64 >> a & 1));
                        let key = (at[0] + nx * (at[1] + ny * at[2])) * 3 + axis as u64;
                        let next = mesh.positions.len();
                        vertex[e as usize] = *vertex_of.entry(key).or_insert_with(|| next as u32);
                        if vertex[e as usize] as usize == next {
                            if next == u32::MAX as usize {
                                return Err(Error::invalid(
                                    "a label's mesh needs more than 2^32-1 vertices",
                                ));
                            }
                            let (a, b) = (corners[lower as usize], corners[upper as usize]);
                            let t = ((iso - a) / (b - a)).clamp(0.0, 1.0) as f64;
                            mesh.positions.push(std::array::from_fn(|k| {
                                let p = at[k] as f64 + if k == axis { t } else { 0.0 };
                                (p * spacing[k]) as f32
                            }));
                            if attribute.is_some() {
                                sums.push((0.0, 0));
                            }
                        }
                        if let Some(v) = value.filter(|v| v.is_finite()) {
                            let sum = &mut sums[vertex[e as usize] as usize];
                            sum.0 += v as f64;
                            sum.1 += 1;
                        }
                    }
                    for triangle in &case.triangles[..case.triangle_count as usize] {
                        mesh.triangles.push(triangle.map(|e| vertex[e as usize]));
                    }
                }
            }
        }
    }
    let values = attribute.map(|_| {
        sums.iter()
            .map(|&(sum, n)| {
                if n > 0 {
                    (sum / n as f64) as f32
                } else {
                    f32::NAN
                }
            })
            .collect()
    });
    Ok((mesh, values))
}

//! Marching Cubes: the indexed triangle mesh baseline the paper compares CGC against (Table 3).
//!
//! The paper's MC meshes are indexed (one vertex per crossed edge, no duplicates) and are counted
//! at 6 bytes per vertex (three snorm16 coordinates scaled by the mesh bounds) plus 12 bytes per
//! triangle (three u32 indices); [`McMesh::memory_bytes`] and [`McMesh::to_snorm16`] follow that.
//!
//! Conventions, shared with the CGC extraction:
//! - a sample is *inside* when `value >= iso`; NaN samples are outside;
//! - positions are in world units without the origin: sample `(i, j, k)` sits at
//!   `(i·sx, j·sy, k·sz)` with `(sx, sy, sz)` = `geometry().spacing` (the renderer's convention);
//! - an edge between samples of different insideness gets one vertex at the linear crossing
//!   `a + t·(b − a)`, `t = (iso − va) / (vb − va)` clamped to [0, 1] (the midpoint when `t` is NaN,
//!   i.e. with a NaN or infinite endpoint);
//! - a crossing exactly on a sample (`t` = 0 or 1: the sample equals the isovalue, as integer data
//!   at an integer isovalue often does) is one vertex for all the crossed edges that meet there,
//!   and the triangles that this collapses are dropped, so no two vertices share a position and
//!   no triangle has zero area;
//! - triangles wind counter-clockwise seen from the outside, so `(p1 − p0) × (p2 − p0)` points from
//!   inside to outside, down the gradient (along −∇f);
//! - faces with two diagonal inside corners keep the inside corners apart, so the mesh is
//!   watertight: away from the volume border every mesh edge is in exactly two triangles, once in
//!   each direction.
//!
//! Vertex order is fixed (see `extract.rs`): by the edge's lower sample plane `k`, then axis (x, y,
//! z), then storage order, a vertex on a sample taking the place of its first edge; triangles by
//! cell, cells in storage order. The output is the same for any number of threads.
//!
//! [`Inside::Above`] switches to scikit-image's rule (`value > iso` is inside, as in Lewiner et
//! al.'s implementation), for drop-in replacements of `skimage.measure.marching_cubes`.

mod cells;
mod extract;
mod mesh;
mod snorm;
mod table;
pub mod vtp;
mod write;

pub use cells::{
    label_mesh, label_meshes, label_meshes_with_values, labelled_mesh, labelled_mesh_with_values,
};
pub use mesh::{Inside, McMesh, MeshSpace};
pub use snorm::SnormMesh;

use crate::error::Result;
use crate::progress::Progress;
use crate::volume::VolumeView;

/// Extracts the isosurface `value = iso` of `volume` with Marching Cubes, in parallel.
///
/// # Panics
/// Only when the mesh would need more than 2³²−1 vertices (32-bit indices); use
/// [`try_marching_cubes`] to get an error instead.
pub fn marching_cubes(volume: &VolumeView, iso: f64) -> McMesh {
    match try_marching_cubes(volume, iso) {
        Ok(mesh) => mesh,
        Err(e) => panic!("marching cubes: {e}"),
    }
}

/// [`marching_cubes`], failing with `ErrorKind::TooLarge` instead of panicking when the mesh
/// would need more than 2³²−1 vertices.
pub fn try_marching_cubes(volume: &VolumeView, iso: f64) -> Result<McMesh> {
    try_marching_cubes_with(volume, iso, Inside::AtOrAbove)
}

/// [`try_marching_cubes`] with the given rule for which samples are inside.
pub fn try_marching_cubes_with(volume: &VolumeView, iso: f64, inside: Inside) -> Result<McMesh> {
    extract::extract(
        volume,
        iso,
        inside,
        extract::default_slab_planes(volume.dims()[2]),
        &Progress::new(),
    )
}

/// [`try_marching_cubes_with`], counting in `progress` the sample planes whose slab is done
/// (`total` is the volume's planes, reached with the mesh); once [`Progress::cancel`] is called it
/// stops at the next slab with an error of kind [`crate::ErrorKind::Cancelled`].
pub fn try_marching_cubes_with_progress(
    volume: &VolumeView,
    iso: f64,
    inside: Inside,
    progress: &Progress,
) -> Result<McMesh> {
    extract::extract(
        volume,
        iso,
        inside,
        extract::default_slab_planes(volume.dims()[2]),
        progress,
    )
}

/// [`try_marching_cubes`] with `planes_per_slab` sample planes per parallel work item. The output
/// does not depend on it; tests use it to check that.
#[doc(hidden)]
pub fn marching_cubes_with_slab_planes(
    volume: &VolumeView,
    iso: f64,
    planes_per_slab: usize,
) -> Result<McMesh> {
    extract::extract(
        volume,
        iso,
        Inside::AtOrAbove,
        planes_per_slab,
        &Progress::new(),
    )
}

impl McMesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
    /// Bytes in the paper's accounting (Table 3): 6 per vertex (snorm16 xyz) + 12 per triangle.
    pub fn memory_bytes(&self) -> u64 {
        6 * self.positions.len() as u64 + 12 * self.triangles.len() as u64
    }
}

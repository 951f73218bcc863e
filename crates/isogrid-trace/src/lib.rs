//! CPU ray tracing of clustered grid cells (paper §3.6): hierarchical traversal of blocks,
//! clusters, metacells and cells ([`traverse`]), the isosurface crossing inside a cell
//! ([`crossing`]), and a renderer with Blinn–Phong or path-traced shading ([`render`](mod@render)).
//!
//! World space is the camera's: sample (i, j, k) at (i·sx, j·sy, k·sz); `t` is world distance along
//! unit-direction rays.
//!
//! ```
//! use isogrid_trace::{Crossing, Tracer};
//! use isogrid::{extract, generate::{generate, Field}, ExtractOptions, Iso, Ray};
//! let volume = generate(Field::Sphere, 24, 0);
//! let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
//! let tracer = Tracer::new(&grid, Crossing::Exact);
//! // From outside, straight through the centre: the sphere of radius 0.4·23 ≈ 9.2 around 11.5.
//! let ray = Ray { origin: [11.5, 11.5, -10.0], direction: [0.0, 0.0, 1.0] };
//! let hit = tracer.closest_hit(&ray, 0.0, f64::INFINITY).unwrap();
//! assert!((hit.t - (10.0 + 11.5 - 9.2)).abs() < 0.3);
//! assert!(hit.normal[2] < -0.9); // facing the ray
//! ```

// `!(entry < exit)` is how the tracer's slab tests reject an empty interval and a NaN in one
// comparison; `partial_cmp` would hide that behind a match.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod block_walk;
pub mod bvh_traverse;
mod cell_ray;
pub mod cluster_bounds;
mod cluster_boxes;
pub mod cluster_bvh;
pub mod crossing;
pub mod env;
pub mod grid_tracer;
mod lanes;
pub mod render;
mod root_gate;
pub mod sample;
pub mod traverse;

pub use bvh_traverse::BvhTracer;
pub use cluster_bvh::ClusterBvh;
pub use crossing::Crossing;
pub use env::{EnvMap, Environment};
pub use grid_tracer::{GridTracer, Traversal};
pub use render::{render, render_with_progress, Image, PathTraceOptions, RenderOptions, Shading};
pub use traverse::{Hit, Occlusion, Tracer};

use isogrid::camera::Ray;
use rayon::prelude::*;

/// Closest hits of many rays in parallel (`t ∈ [0, ∞)`); `out[i]` answers `rays[i]`.
///
/// # Panics
/// When `out` and `rays` differ in length.
pub fn closest_hits(tracer: &Tracer, rays: &[Ray], out: &mut [Option<Hit>]) {
    assert_eq!(rays.len(), out.len(), "one output per ray");
    out.par_iter_mut()
        .zip(rays.par_iter())
        .with_min_len(256)
        .for_each(|(o, r)| *o = tracer.closest_hit(r, 0.0, f64::INFINITY));
}

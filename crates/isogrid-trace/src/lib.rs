//! CPU ray tracing of clustered grid cells (paper §3.6): two traversals that find candidate
//! metacells, the block walk ([`Tracer`]) and a hierarchy over regrouped clusters
//! ([`BvhTracer`]), one search inside a cluster that both share, the isosurface crossing inside
//! a cell ([`crossing`]), and a renderer with Blinn–Phong or path-traced shading
//! ([`render`](mod@render)). `docs/design/tracing.md` walks through a ray.
//!
//! The modules depend on each other in one direction only (no import cycles;
//! `scripts/check_module_cycles.py`): ray setup (`cell_ray`, `node_ray`) and the records the
//! traversals read (`cluster_bounds`, `cluster_boxes`, `cluster_bvh`) → SIMD lanes (`lanes`,
//! `root_gate`) → the cluster search (`cluster_search`, with `crossing`) → the two traversals
//! (`block_walk` + `block_traverse`, `bvh_traverse`) → either behind one type (`grid_tracer`) →
//! the renderer and path tracer (`render`, `env`, `sample`).
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

mod block_traverse;
mod block_walk;
pub mod bvh_traverse;
mod cell_ray;
pub mod cluster_bounds;
mod cluster_boxes;
pub mod cluster_bvh;
mod cluster_search;
pub mod crossing;
pub mod env;
pub mod grid_tracer;
mod lanes;
mod node_ray;
pub mod render;
mod root_gate;
pub mod sample;

pub use block_traverse::{closest_hits, Tracer};
pub use bvh_traverse::BvhTracer;
pub use cluster_bvh::ClusterBvh;
pub use cluster_search::{Hit, Occlusion};
pub use crossing::Crossing;
pub use env::{EnvMap, Environment};
pub use grid_tracer::{GridTracer, Traversal};
pub use render::{render, render_with_progress, Image, PathTraceOptions, RenderOptions, Shading};

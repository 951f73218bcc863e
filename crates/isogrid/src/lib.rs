//! isogrid: isosurfaces as clustered grid cells (CGC).
//!
//! Implements Nysjö, *Clustered Grid Cell Data Structure for Isosurface Rendering* (the paper in
//! `shared/paper/clustered-grid-cells.md`): active cells of a scalar volume are grouped into 2×2×2
//! metacells, clusters of 16 metacell slots and 16³-cell blocks (§3.1), each cell keeping its eight
//! corner values so that rendering never needs the volume again.
//!
//! Data flows one way: [`Volume`] → [`extract`](fn@extract) → [`CellGrid`] → (file | renderer | tracer | stats).
//! The ray tracers live in their own crates (`isogrid-trace` on the CPU, `isogrid-gpu`); the
//! empty-space structures both read are here, in [`skip`], and so is the environment both path
//! tracers light with, in [`env_map`].
//!
//! ```
//! use isogrid::{extract, ExtractOptions, Iso, Volume, VolumeData};
//! let n = 24;
//! let data: Vec<f32> = (0..n * n * n)
//!     .map(|i| {
//!         let p = [i % n, i / n % n, i / (n * n)].map(|c| c as f32 - 11.5);
//!         8.0 - (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() // > 0 inside a sphere of radius 8
//!     })
//!     .collect();
//! let volume = Volume::new([n, n, n], VolumeData::F32(data)).unwrap();
//! let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(0.0))).unwrap();
//! assert!(grid.active_cells() > 500);
//! assert_eq!(grid.metacell_slots() % 16, 0);
//! ```

pub mod attribute;
pub mod camera;
pub mod cgc;
pub mod colormap;
pub mod env_map;
pub mod error;
pub mod extract;
pub mod fs;
pub mod generate;
pub mod grid;
pub mod label_census;
pub mod label_merge;
pub mod labels;
pub mod layout;
pub mod mc;
pub mod memory;
pub mod morton;
pub mod progress;
pub mod quantize;
pub mod shading;
pub mod skip;
pub mod stats;
#[cfg(test)]
mod test_rng;
pub mod volume;

pub use attribute::{AttributeInfo, AttributePrecision, CellAttribute, CodeMapping};
pub use camera::{Camera, Ray};
pub use env_map::EnvMap;
pub use error::{Error, ErrorKind, Result, ResultExt};
pub use extract::labels::{extract_labels, extract_labels_with_progress, LabelOptions};
pub use extract::{extract, extract_with_progress, ExtractOptions, Iso};
pub use grid::{CellGrid, GridInfo};
pub use label_merge::merge_label_grids;
pub use labels::{GridLabels, Label, LabelSelection};
pub use layout::{Block, ClusterBound, Metacell, Precision};
pub use progress::Progress;
pub use quantize::ValueMapping;
pub use stats::GridStats;
pub use volume::{
    directions_mirror, Geometry, Samples, Scalar, ScalarType, Volume, VolumeData, VolumeView,
    WorldFrame, MAX_DIM,
};

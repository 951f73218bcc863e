//! isogrid: isosurfaces as clustered grid cells (CGC).
//!
//! Implements Nysjö, *Clustered Grid Cell Data Structure for Isosurface Rendering* (the paper in
//! `shared/paper/clustered-grid-cells.md`): active cells of a scalar volume are grouped into 2×2×2
//! metacells, clusters of 16 metacell slots and 16³-cell blocks (§3.1), each cell keeping its eight
//! corner values so that rendering never needs the volume again.
//!
//! Data flows one way: [`Volume`] → extraction → CGC → (file | renderer | tracer | stats).

pub mod error;
pub mod fs;
pub mod generate;
pub mod volume;

pub use error::{Error, ErrorKind, Result, ResultExt};
pub use volume::{Geometry, Samples, Scalar, ScalarType, Volume, VolumeData, VolumeView, MAX_DIM};

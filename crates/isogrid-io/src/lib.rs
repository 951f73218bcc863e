//! File formats.
pub mod mesh;
pub mod voxelize;

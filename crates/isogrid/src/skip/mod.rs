//! Empty-space skipping structures over a grid's blocks and metacells (paper §3.6), built from
//! the grid alone and read by both ray tracers: the CPU tracer (`isogrid-trace`) and the GPU one
//! (`isogrid-gpu`'s `trace.wgsl`).
//!
//! - [`octant_space`]: per block and ray octant, the largest empty cube ahead (the block walks'
//!   leaps);
//! - [`occupancy`]: per block, which metacells are occupied and where their slots lie (the GPU's
//!   in-block metacell walk);
//! - [`empty_space`]: the symmetric distance map, the reference the octant map is tested against.

pub mod empty_space;
pub mod occupancy;
pub mod octant_space;

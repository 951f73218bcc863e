//! One render call, from request to read-back: the call plans its passes (`plan.rs`), builds its
//! targets and bind groups (`bindings.rs`), writes each frame's uniforms (`uniforms.rs`), records
//! each frame's passes (`frame_passes.rs`, driven by `frames.rs`) with timestamp queries around
//! each pass (`timings.rs`), and reads back colour, depth, normal and cluster AOVs
//! (`readback.rs`).

mod bindings;
mod frame_passes;
mod frames;
mod plan;
mod readback;
mod timings;
mod uniforms;

pub(crate) use frames::{render, FrameContext};

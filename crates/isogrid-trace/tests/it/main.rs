//! Integration tests of the CPU tracer, one binary: the block walk against brute force
//! (`trace.rs`) and the cluster hierarchy against the block walk (`trace_bvh.rs`).

// The core's test volumes (random, blobs, fields), shared rather than copied; not every helper
// is used here.
#[allow(dead_code)]
#[path = "../../../isogrid/tests/it/common.rs"]
mod common;
mod trace;
mod trace_bvh;

//! Integration tests of the core crate, one binary.

mod cgc;
mod common;
mod extract;
mod mc;
mod stream;
mod tiles;
mod trace;
mod trace_bvh;

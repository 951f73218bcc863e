//! Integration tests of the core crate, one binary.

mod common;
mod extract;

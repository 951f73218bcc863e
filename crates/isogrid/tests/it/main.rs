//! Integration tests of the core crate, one binary.

mod attribute;
mod cgc;
// Also compiled into isogrid-trace's test binary, which uses helpers this one does not.
#[allow(dead_code)]
mod common;
mod extract;
mod heap;
mod label_census;
mod label_stream;
mod labels;
mod labels_many;
mod labels_shown;
mod mc;
mod pack;
mod stream;
mod tiles;
mod web_tables;

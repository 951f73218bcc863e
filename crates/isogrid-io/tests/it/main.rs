//! Integration tests of isogrid-io, one binary: readers against files written by other tools
//! (nibabel, pynrrd, numpy, pydicom, tifffile; see scripts/make_io_fixtures.py), bad input, and
//! the NRRD writer.

mod bad_input;
mod common;
mod readers;
mod region;
mod write_nrrd;
#[cfg(feature = "zarr")]
mod zarr;

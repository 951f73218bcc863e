//! Integration tests of isogrid-io, one binary: readers against files written by other tools
//! (nibabel, pynrrd, numpy, pydicom, tifffile, SimpleITK, mrcfile; see
//! scripts/make_io_fixtures.py; VTK for `.vti`), DICOM series written with dicom-object, bad input, and the NRRD
//! writer.

mod bad_input;
mod common;
mod dicom;
mod fuzz_regressions;
mod labels;
mod metaimage;
mod mgh;
mod mrc;
mod readers;
mod region;
mod vti;
mod write_nrrd;
#[cfg(feature = "zarr")]
mod zarr;
#[cfg(feature = "zarr")]
mod zarr_http;

//! Headerless raw volumes: the caller says the shape, type and byte order.
//!
//! The file holds exactly `nx·ny·nz` samples, i fastest, and nothing else; any other size is an
//! error that names the expected and actual byte counts (a wrong shape or type is by far the most
//! common mistake with raw files). Spacing is 1 and origin 0.

use crate::samples::{read_samples, sample_count, ElemType};
use isogrid::{Error, Result, ResultExt, ScalarType, Volume};
use std::io::BufReader;
use std::path::Path;

/// What a raw file holds: samples per axis (i fastest), their type and byte order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawSpec {
    pub dims: [usize; 3],
    pub scalar: ScalarType,
    pub big_endian: bool,
}

/// Reads a raw volume described by `spec`. Errors name `path`.
pub fn read_raw(path: &Path, spec: &RawSpec) -> Result<Volume> {
    read(path, spec).at_path(path)
}

fn read(path: &Path, spec: &RawSpec) -> Result<Volume> {
    let count = sample_count(spec.dims)?;
    let elem = ElemType::of(spec.scalar);
    let file = isogrid::fs::open_regular(path)?;
    let actual = file.metadata()?.len();
    let expected = count as u64 * spec.scalar.size() as u64;
    if actual != expected {
        let [nx, ny, nz] = spec.dims;
        return Err(Error::invalid(format!(
            "raw size mismatch: {nx}x{ny}x{nz} {} needs {expected} bytes but the file has {actual}",
            spec.scalar.name()
        )));
    }
    let data = read_samples(&mut BufReader::new(file), elem, spec.big_endian, count)?;
    Volume::new(spec.dims, data)
}

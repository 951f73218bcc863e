//! Opening the data files that a header names (NRRD `data file`, MetaImage `ElementDataFile`) and
//! the files the readers open themselves.

use isogrid::{Error, Result, ResultExt};
use std::fs::File;
use std::path::{Path, PathBuf};

/// `name` as a header gives it: relative to the header's folder `base` unless absolute.
pub(crate) fn resolve(base: &Path, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// Opens `path` for reading after checking it is a regular file: opening a FIFO would block and
/// a folder cannot hold samples. Errors name `path`.
pub(crate) fn open_regular(path: &Path) -> Result<File> {
    let meta = std::fs::metadata(path).at_path(path)?;
    if !meta.is_file() {
        return Err(
            Error::invalid("is not a regular file (a folder, FIFO or device)").with_path(path),
        );
    }
    File::open(path).at_path(path)
}

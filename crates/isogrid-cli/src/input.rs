//! Loading the input volume of a subcommand, with a spinner on a terminal.

use crate::progress;
use anyhow::Result;
use isogrid::Volume;
use std::path::Path;
use std::time::Instant;

/// Reads `path` (any supported format); returns the volume and the seconds it took. The
/// reader's notices (e.g. other DICOM series left out) go to stderr.
pub fn read_volume(path: &Path, options: &isogrid_io::ReadOptions) -> Result<(Volume, f64)> {
    let spinner = progress::spinner(format!("reading {}", path.display()));
    let start = Instant::now();
    let (volume, notices) = isogrid_io::read_volume_noted(path, options)?;
    spinner.finish_and_clear();
    for notice in notices {
        eprintln!("isogrid: note: {notice}");
    }
    Ok((volume, start.elapsed().as_secs_f64()))
}

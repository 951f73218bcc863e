//! Loading the input volume of a subcommand, with a spinner on a terminal.

use crate::progress;
use anyhow::Result;
use isogrid::Volume;
use std::path::Path;
use std::time::Instant;

/// Reads `path` (any supported format); returns the volume and the seconds it took. The
/// reader's notices (e.g. other DICOM series left out) go to stderr.
pub fn read_volume(path: &Path, options: &isogrid_io::ReadOptions) -> Result<(Volume, f64)> {
    timed(path, || isogrid_io::read_volume_noted(path, options))
}

/// [`read_volume`] of a label volume, with the names and colours its file gives (or of the
/// OME-Zarr label image `labels_of` of the image at `path`).
pub fn read_label_volume(
    path: &Path,
    labels_of: Option<&str>,
    options: &isogrid_io::ReadOptions,
) -> Result<(isogrid_io::labels::LabelVolume, f64)> {
    timed(path, || {
        isogrid_io::labels::read_labels_of(path, labels_of, options)
    })
}

/// Runs a reader under a spinner; its notices go to stderr.
fn timed<T>(
    path: &Path,
    read: impl FnOnce() -> isogrid::Result<(T, Vec<String>)>,
) -> Result<(T, f64)> {
    let spinner = progress::spinner(format!("reading {}", path.display()));
    let start = Instant::now();
    let (value, notices) = read()?;
    spinner.finish_and_clear();
    for notice in notices {
        eprintln!("isogrid: note: {notice}");
    }
    Ok((value, start.elapsed().as_secs_f64()))
}

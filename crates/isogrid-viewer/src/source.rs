//! What the viewer opens: a volume (any format `isogrid_io::read_volume` reads), which can be
//! re-extracted at any isovalue, or a `.cgc` file, which holds one extracted isosurface and no
//! volume.

use isogrid::{CellGrid, Progress, ResultExt, Volume};
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// The `.cgc` magic (`isogrid::cgc`'s format table), so that renamed files are recognised too.
const CGC_MAGIC: [u8; 8] = *b"\x89CGC\r\n\x1a\n";

/// An opened input.
pub enum Source {
    Volume(Arc<Volume>),
    Grid(Box<CellGrid>),
}

/// Whether `path` is a `.cgc` file: by extension, or by its first bytes.
pub fn is_cgc(path: &Path) -> bool {
    let by_name = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("cgc"));
    if by_name {
        return true;
    }
    let mut magic = [0u8; 8];
    path.is_file()
        && std::fs::File::open(path)
            .and_then(|mut f| f.read_exact(&mut magic))
            .is_ok()
        && magic == CGC_MAGIC
}

/// Reads `path`; errors name the path. `progress` counts the checks of a `.cgc` file, and the
/// planes of a volume read by region (Zarr, TIFF slices, uncompressed raw, NRRD and NIfTI); other
/// volume formats are read without counts.
pub fn open(
    path: &Path,
    read_options: &isogrid_io::ReadOptions,
    progress: &Progress,
) -> isogrid::Result<Source> {
    if is_cgc(path) {
        isogrid::cgc::open_with_progress(path, progress)
            .map(|g| Source::Grid(Box::new(g)))
            .at_path(path)
    } else {
        isogrid_io::read_volume_with_progress(path, read_options, progress)
            .map(|v| Source::Volume(Arc::new(v)))
            .at_path(path)
    }
}

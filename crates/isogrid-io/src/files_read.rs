//! The files reading a path opens, so that a command can refuse an output that would overwrite
//! one of them: the data file a detached NRRD or MetaImage header names is as much the input as
//! the header, and so is every slice of a DICOM or TIFF folder.

use std::path::{Path, PathBuf};

/// The files reading `path` opens: the path itself, the data files its header names, the slices
/// of a folder. A header that does not parse counts as itself alone (reading it fails before
/// anything is written). A Zarr store's files are left out: they are metadata and chunk keys,
/// which no output's name (`.cgc`, `.png`, `.obj`, …) can be.
pub fn files_read(path: &Path) -> Vec<PathBuf> {
    if crate::region::is_zarr(path) {
        return Vec::new();
    }
    if path.is_dir() {
        return match crate::region::slices::tiff_slices(path) {
            Ok(Some(slices)) => slices,
            _ => crate::dicom::folder_files(path).unwrap_or_default(),
        };
    }
    let mut files = vec![path.to_path_buf()];
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let data_files = if name.ends_with(".mhd") || name.ends_with(".mha") {
        crate::metaimage::data_files(path)
    } else {
        // A NRRD header of any name: the reader sniffs the magic line.
        crate::nrrd::data_files(path)
    };
    files.extend(data_files.unwrap_or_default());
    files
}

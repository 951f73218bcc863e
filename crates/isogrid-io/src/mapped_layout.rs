//! Where an uncompressed file keeps its samples, as its header reader finds them: the record that
//! lets [`crate::region::mapped`] read the file plane range by plane range through a memory map.

use crate::samples::ElemType;
use isogrid::Geometry;
use std::path::PathBuf;

/// Where and how a file stores its samples: filled in by the format's header reader.
#[derive(Debug, Clone)]
pub(crate) struct MappedLayout {
    /// The file holding the samples (the header file itself, or a detached data file).
    pub data_path: PathBuf,
    /// Byte offset of sample (0, 0, 0); the caller has checked that all samples are in the file.
    pub data_offset: u64,
    pub elem: ElemType,
    pub big_endian: bool,
    pub geometry: Geometry,
    /// NIfTI intensity scaling (slope, intercept), applied as the in-memory reader applies it.
    pub scale: Option<(f64, f64)>,
}

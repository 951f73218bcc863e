//! What a caller can tell the readers beyond the path: a raw spec, a DICOM series, a
//! Zarr level and index.

use crate::raw::RawSpec;

/// How to read files whose format cannot be detected.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Read the file as headerless raw samples with this shape, type and byte order.
    pub raw: Option<RawSpec>,
    /// DICOM: read this SeriesInstanceUID (default: the series with the most slices).
    pub series: Option<String>,
    /// Level and extra-axis indices of a Zarr / OME-Zarr input.
    pub zarr: crate::region::ZarrOptions,
}

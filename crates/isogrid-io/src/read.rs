//! Picking the reader for a path: a folder is a DICOM series, a raw spec means raw, otherwise the
//! file extension decides, and when it says nothing the first bytes do.

use crate::raw::RawSpec;
use isogrid::{Error, Result, ResultExt, Volume};
use std::io::Read;
use std::path::Path;

/// How to read files whose format cannot be detected.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Read the file as headerless raw samples with this shape, type and byte order.
    pub raw: Option<RawSpec>,
    /// Level and extra-axis indices of a Zarr / OME-Zarr input.
    pub zarr: crate::region::ZarrOptions,
}

/// Reads a volume, detecting the format from the path: a directory = DICOM series;
/// `.nii`/`.nii.gz`; `.nrrd`/`.nhdr`; `.npy`; `.tif`/`.tiff`; any file when `opts.raw` is set
/// (`.raw`/`.bin` without it are an error asking for the spec). Other names are sniffed by
/// their magic bytes. Errors name `path`.
pub fn read_volume(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    if crate::region::is_zarr(path) {
        return crate::region::read_all(crate::region::open_zarr(path, opts)?.as_mut());
    }
    if crate::region::is_tiff_slices(path) {
        return crate::region::read_all(&mut crate::region::slices::TiffSlices::open(path)?);
    }
    if path.is_dir() {
        return crate::read_dicom_series(path);
    }
    if let Some(spec) = &opts.raw {
        return crate::read_raw(path, spec);
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let ends = |ext: &str| name.ends_with(ext);
    if ends(".nii") || ends(".nii.gz") {
        return crate::read_nifti(path);
    }
    if ends(".nrrd") || ends(".nhdr") {
        return crate::read_nrrd(path);
    }
    if ends(".npy") {
        return crate::read_npy(path);
    }
    if ends(".tif") || ends(".tiff") {
        return crate::read_tiff(path);
    }
    if ends(".raw") || ends(".bin") {
        return Err(
            Error::invalid("raw files need their shape, type and byte order (a raw spec)")
                .with_path(path),
        );
    }
    sniff(path)
}

fn sniff(path: &Path) -> Result<Volume> {
    let mut head = [0u8; 348];
    let mut file = std::fs::File::open(path).at_path(path)?;
    let mut len = 0;
    while len < head.len() {
        match file.read(&mut head[len..]).at_path(path)? {
            0 => break,
            n => len += n,
        }
    }
    let head = &head[..len];
    if head.starts_with(b"NRRD") {
        crate::read_nrrd(path)
    } else if head.starts_with(b"\x93NUMPY") {
        crate::read_npy(path)
    } else if head.starts_with(b"II*\0")
        || head.starts_with(b"MM\0*")
        || head.starts_with(b"II+\0")
        || head.starts_with(b"MM\0+")
    {
        crate::read_tiff(path)
    } else if head.len() == 348 && &head[344..347] == b"n+1" {
        crate::read_nifti(path)
    } else {
        Err(Error::unsupported(
            "unknown volume format (expected .nii, .nii.gz, .nrrd, .nhdr, .npy, .tif, a DICOM folder, or a raw spec)",
        )
        .with_path(path))
    }
}

//! Picking the reader for a path: a folder is a DICOM series, a raw spec means raw, otherwise the
//! file extension decides, and when it says nothing the first bytes do. Readers may return
//! notices for the user (e.g. other DICOM series left out); the caller decides how to show them.

use crate::read_options::ReadOptions;
use isogrid::{Error, Result, ResultExt, Volume};
use std::io::Read;
use std::path::Path;

/// Reads a volume, detecting the format from the path: a Zarr store or OME-Zarr image (see
/// [`crate::region`]); a folder of 2-D TIFF slices; another directory or a `.dcm` file (or one
/// whose name names no format and that has the `DICM` marker) = DICOM (see [`crate::dicom`]); `.nii`/`.nii.gz`
/// or a `.hdr`/`.img` pair; `.nrrd`/`.nhdr`;
/// `.npy`; `.tif`/`.tiff`; `.mha`/`.mhd`; `.mgh`/`.mgz`; `.mrc`/`.map`/`.ccp4`/`.mrcs`; `.vti`; any file when `opts.raw` is set
/// (`.raw`/`.bin` without it are an error asking for the spec). Other names are sniffed by
/// their magic bytes. Errors name `path`. Notices are dropped; see [`read_volume_noted`].
pub fn read_volume(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    read_volume_noted(path, opts).map(|(volume, _)| volume)
}

/// [`read_volume`], also returning notices for the user (one line each).
pub fn read_volume_noted(path: &Path, opts: &ReadOptions) -> Result<(Volume, Vec<String>)> {
    if crate::region::is_zarr(path) {
        let volume = crate::region::read_all(crate::region::open_zarr(path, opts)?.as_mut())
            .at_path(path)?;
        return Ok((volume, Vec::new()));
    }
    crate::read_options::refuse_unused_index(path, opts)?;
    if crate::region::is_tiff_slices(path) {
        let volume = crate::region::read_all(&mut crate::region::slices::TiffSlices::open(path)?)?;
        let notices = crate::region::slices::skipped_files_notice(path);
        return Ok((volume, notices.into_iter().collect()));
    }
    if path.is_dir() {
        return crate::dicom::read_dicom(path, opts);
    }
    if opts.raw.is_none() {
        let name = file_name(path);
        if name.ends_with(".mha") || name.ends_with(".mhd") {
            return crate::metaimage::read_metaimage_noted(path);
        }
        // A name that says DICOM, or DICOM's marker in a file whose name names no format: the
        // name of another format wins over the marker, as it does for reading by region.
        if has_dicom_name(&name) || (reader_of_name(&name).is_none() && has_dicm_marker(path)) {
            return crate::dicom::read_dicom(path, opts);
        }
    }
    read_single(path, opts).map(|volume| (volume, Vec::new()))
}

/// The file name of `path`, lower case.
fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// [`read_volume`], counting the planes read in `progress` for inputs read by region (Zarr, TIFF
/// slice folders, uncompressed raw, NRRD, NIfTI and MGH), which also stop with a `Cancelled` error
/// once `progress` is cancelled; other formats are read in one go, without counts.
pub fn read_volume_with_progress(
    path: &Path,
    opts: &ReadOptions,
    progress: &isogrid::Progress,
) -> Result<Volume> {
    match crate::region::open_region(path, opts)? {
        Some(mut source) => {
            crate::region::read_all_with_progress(source.as_mut(), progress).at_path(path)
        }
        None => read_volume(path, opts),
    }
}

/// A DICOM file's name: `.dcm`, `.dicom` or `.ima`.
fn has_dicom_name(name: &str) -> bool {
    [".dcm", ".dicom", ".ima"].iter().any(|e| name.ends_with(e))
}

/// A regular file with `DICM` at byte 128 (or 0: no preamble).
fn has_dicm_marker(path: &Path) -> bool {
    if !path.is_file() {
        return false;
    }
    let mut head = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && (&head[128..] == b"DICM" || &head[..4] == b"DICM")
}

/// A reader of one file, given the caller's options.
type Reader = fn(&Path, &ReadOptions) -> Result<Volume>;

/// The reader the extension of `name` (lower case) names; `None` for a name that names no
/// format, whose content then decides.
fn reader_of_name(name: &str) -> Option<Reader> {
    let ends = |ext: &str| name.ends_with(ext);
    let reader: Reader =
        if crate::nifti::is_nifti_name(name) || crate::nifti::is_nifti_pair_name(name) {
            |path, opts| crate::nifti::read_nifti_indexed(path, opts.zarr.pick())
        } else if crate::mgh::is_mgh_name(name) {
            |path, opts| crate::mgh::read_mgh_indexed(path, opts.zarr.pick())
        } else if ends(".nrrd") || ends(".nhdr") {
            |path, _| crate::read_nrrd(path)
        } else if ends(".npy") {
            |path, _| crate::read_npy(path)
        } else if ends(".tif") || ends(".tiff") {
            |path, opts| crate::tiff::read_tiff_indexed(path, opts.zarr.pick())
        } else if ends(".mha") || ends(".mhd") {
            |path, _| crate::read_metaimage(path)
        } else if ends(".mrc") || ends(".map") || ends(".ccp4") || ends(".mrcs") {
            |path, _| crate::read_mrc(path)
        } else if ends(".vti") {
            |path, _| crate::read_vti(path)
        } else if ends(".raw") || ends(".bin") {
            |path, _| {
                Err(
                    Error::invalid("raw files need their shape, type and byte order (a raw spec)")
                        .with_path(path),
                )
            }
        } else {
            return None;
        };
    Some(reader)
}

fn read_single(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    if let Some(spec) = &opts.raw {
        return crate::read_raw(path, spec);
    }
    match reader_of_name(&file_name(path)) {
        Some(reader) => reader(path, opts),
        None => sniff(path, opts),
    }
}

fn sniff(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    let mut head = [0u8; 348];
    let mut file = isogrid::fs::open_regular(path)?;
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
        crate::tiff::read_tiff_indexed(path, opts.zarr.pick())
    } else if (head.len() == 348 && &head[344..347] == b"n+1")
        || (head.len() >= 8 && &head[4..7] == b"n+2")
    {
        crate::nifti::read_nifti_indexed(path, opts.zarr.pick())
    } else if head.len() >= 212 && &head[208..211] == b"MAP" {
        crate::read_mrc(path)
    } else if head.starts_with(b"ObjectType") || head.starts_with(b"NDims") {
        crate::read_metaimage(path)
    } else if crate::dicom::is_dicom_head(head) {
        // Last: a legacy DICOM file without `DICM` (file meta group or bare data set first) has
        // only a weak signature.
        crate::dicom::read_dicom(path, opts).map(|(volume, _)| volume)
    } else {
        Err(Error::unsupported(
            "unknown volume format (expected .nii, .nii.gz, .hdr/.img, .nrrd, .nhdr, .npy, .tif, .mha, .mhd, .mgh, .mgz, .mrc, .map, .vti, DICOM, or a raw spec)",
        )
        .with_path(path))
    }
}

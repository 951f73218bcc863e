//! Volumes read by region, for extraction in bounded memory ([`isogrid::extract::stream`]):
//! uncompressed raw, NRRD, NIfTI and MGH through memory maps ([`mapped`]), folders of 2-D TIFF slices
//! ([`slices`]), and Zarr v2/v3 and OME-Zarr ([`zarr`]) from a folder or over HTTP
//! ([`http_store`]). Formats that must be decoded from their
//! start (gzip NIfTI, MGH and NRRD, ascii NRRD, multi-page TIFF, npy, DICOM) are read whole instead.

#[cfg(feature = "zarr")]
pub mod http_store;
pub mod mapped;
pub mod slices;
#[cfg(feature = "zarr")]
pub mod zarr;

pub use crate::read_options::ZarrOptions;
pub use isogrid::extract::stream::{RegionSource, SlabMut};

use crate::read_options::ReadOptions;
use isogrid::{Progress, Result, Volume, VolumeData};
use std::path::Path;

/// Whether `path` is an `http://` or `https://` URL (read as a Zarr store).
pub fn is_url(path: &Path) -> bool {
    let text = path.to_string_lossy().to_ascii_lowercase();
    text.starts_with("http://") || text.starts_with("https://")
}

/// Whether `path` names a Zarr store: a URL, a folder with Zarr metadata at its root, or a folder
/// named `*.zarr`.
pub fn is_zarr(path: &Path) -> bool {
    is_url(path)
        || path.is_dir()
            && (["zarr.json", ".zarray", ".zgroup"]
                .iter()
                .any(|name| path.join(name).is_file())
                || path
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("zarr")))
}

/// Whether `path` is a folder of TIFF slices.
pub fn is_tiff_slices(path: &Path) -> bool {
    path.is_dir() && matches!(slices::tiff_slices(path), Ok(Some(_)))
}

/// Opens `path` for reading by region when its format allows it; `Ok(None)` when it has to be
/// read whole (see the module doc). Errors name the file at fault.
pub fn open_region(
    path: &Path,
    options: &ReadOptions,
) -> Result<Option<Box<dyn RegionSource + Send>>> {
    if !is_zarr(path) {
        crate::read_options::refuse_unused_index(path, options)?;
    }
    if let Some(spec) = &options.raw {
        let layout = mapped::raw_layout(path, spec)?;
        return Ok(Some(Box::new(mapped::MappedSource::open(layout)?)));
    }
    if is_zarr(path) {
        return open_zarr(path, options).map(Some);
    }
    if is_tiff_slices(path) {
        return Ok(Some(Box::new(slices::TiffSlices::open(path)?)));
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    // The readers name formats one way for whole and by-region reads; a gzip file's layout is
    // `None` (it is read whole).
    let layout = if crate::nifti::is_nifti_name(&name) || crate::nifti::is_nifti_pair_name(&name) {
        crate::nifti::region_layout(path, options.zarr.pick())?
    } else if crate::mgh::is_mgh_name(&name) {
        crate::mgh::region_layout(path, options.zarr.pick())?
    } else if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
        crate::nrrd::region_layout(path)?
    } else {
        None
    };
    match layout {
        Some(layout) => Ok(Some(Box::new(mapped::MappedSource::open(layout)?))),
        None => Ok(None),
    }
}

/// Opens a Zarr store (an error naming the missing feature in builds without it).
pub fn open_zarr(path: &Path, options: &ReadOptions) -> Result<Box<dyn RegionSource + Send>> {
    #[cfg(feature = "zarr")]
    return Ok(Box::new(if is_url(path) {
        zarr::open_url(&path.to_string_lossy(), &options.zarr)?
    } else {
        zarr::open_path(path, &options.zarr)?
    }));
    #[cfg(not(feature = "zarr"))]
    {
        let _ = options;
        Err(isogrid::Error::unsupported(
            "this build of isogrid-io reads no Zarr (built without the `zarr` feature)",
        )
        .with_path(path))
    }
}

/// Reads a whole region source into memory (for commands that need the volume itself).
pub fn read_all(source: &mut dyn RegionSource) -> Result<Volume> {
    read_all_with_progress(source, &Progress::new())
}

/// [`read_all`], counting planes read in `progress` (about 64 steps) and stopping with a
/// `Cancelled` error once it is cancelled.
pub fn read_all_with_progress(
    source: &mut dyn RegionSource,
    progress: &Progress,
) -> Result<Volume> {
    let geometry = source.geometry();
    let count = crate::samples::sample_count(geometry.dims)?;
    let nz = geometry.dims[2];
    // The whole volume plus what one read of all its planes takes beyond it (decoded chunks).
    let bytes = (count as u64)
        .saturating_mul(source.scalar_type().size() as u64)
        .saturating_add(source.read_overhead(nz));
    isogrid::memory::ensure_fits("the volume", bytes)?;
    let mut data = match source.scalar_type() {
        isogrid::ScalarType::U8 => VolumeData::U8(vec![0; count]),
        isogrid::ScalarType::U16 => VolumeData::U16(vec![0; count]),
        isogrid::ScalarType::I16 => VolumeData::I16(vec![0; count]),
        isogrid::ScalarType::F32 => VolumeData::F32(vec![0.0; count]),
        isogrid::ScalarType::U32 => VolumeData::U32(vec![Default::default(); count]),
        isogrid::ScalarType::I32 => VolumeData::I32(vec![Default::default(); count]),
        isogrid::ScalarType::U64 => VolumeData::U64(vec![Default::default(); count]),
        isogrid::ScalarType::I64 => VolumeData::I64(vec![Default::default(); count]),
        isogrid::ScalarType::F64 => VolumeData::F64(vec![Default::default(); count]),
    };
    let out = match &mut data {
        VolumeData::U8(v) => SlabMut::U8(v),
        VolumeData::U16(v) => SlabMut::U16(v),
        VolumeData::I16(v) => SlabMut::I16(v),
        VolumeData::F32(v) => SlabMut::F32(v),
        VolumeData::U32(v) => SlabMut::U32(v),
        VolumeData::I32(v) => SlabMut::I32(v),
        VolumeData::U64(v) => SlabMut::U64(v),
        VolumeData::I64(v) => SlabMut::I64(v),
        VolumeData::F64(v) => SlabMut::F64(v),
    };
    read_in_steps(source, out, nz, progress)?;
    Volume::with_geometry(geometry, data)
}

/// Reads all `nz` planes into `out` in about 64 steps of whole multiples of the source's
/// plane granularity (so a Zarr chunk row is not decoded once per step).
fn read_in_steps(
    source: &mut dyn RegionSource,
    mut out: SlabMut<'_>,
    nz: usize,
    progress: &Progress,
) -> Result<()> {
    let granularity = source.plane_granularity().max(1);
    let step = nz.div_ceil(64).next_multiple_of(granularity);
    let plane = out.len() / nz.max(1);
    progress.start(nz as u64);
    for z0 in (0..nz).step_by(step) {
        progress.check()?;
        let z = z0..(z0 + step).min(nz);
        let part = plane * z0..plane * z.end;
        let slab = match &mut out {
            SlabMut::U8(v) => SlabMut::U8(&mut v[part]),
            SlabMut::U16(v) => SlabMut::U16(&mut v[part]),
            SlabMut::I16(v) => SlabMut::I16(&mut v[part]),
            SlabMut::F32(v) => SlabMut::F32(&mut v[part]),
            SlabMut::U32(v) => SlabMut::U32(&mut v[part]),
            SlabMut::I32(v) => SlabMut::I32(&mut v[part]),
            SlabMut::U64(v) => SlabMut::U64(&mut v[part]),
            SlabMut::I64(v) => SlabMut::I64(&mut v[part]),
            SlabMut::F64(v) => SlabMut::F64(&mut v[part]),
        };
        source.read_planes(z.clone(), slab)?;
        progress.advance(z.len() as u64);
    }
    Ok(())
}

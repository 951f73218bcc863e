//! Zarr v2/v3 arrays and OME-Zarr 0.4/0.5 images: the metadata documents (`zarr.json`, `.zarray`,
//! `.zattrs`, `.zgroup`, at the root and under the datasets' paths) and a few chunks, written as
//! a store folder on tmpfs and opened by `region::zarr::open_path` as a user's would be; then read
//! the two ways a user's command reads it: the streaming extraction's first slab (after its
//! memory plan) and the whole volume (`read_volume`'s `region::read_all`).
//!
//! Input: entries separated by [`isogrid_fuzz::zarr_store::SEPARATOR`], each `KEY\nVALUE`
//! (`python3 fuzz/zarr_seeds.py` packs the Zarr fixtures into seeds; `seed_corpora.sh` runs it).
#![no_main]

use isogrid::extract::stream::{plan, RegionSource, SlabMut};
use isogrid::memory::try_vec;
use isogrid::ScalarType;

/// Reads planes `0..planes` (`len` samples) into a buffer of `T` as the extraction does.
fn first_slab<T: Copy + Default>(
    source: &mut dyn RegionSource,
    planes: usize,
    len: usize,
    slab: fn(&mut [T]) -> SlabMut<'_>,
) -> isogrid::Result<()> {
    let mut samples = try_vec::<T>("slab", len)?;
    samples.resize(len, T::default());
    source.read_planes(0..planes, slab(&mut samples))
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::init();
    let root = isogrid_fuzz::zarr_store::folder_store(data);
    let options = isogrid_io::ZarrOptions::default();
    let Ok(mut source) = isogrid_io::region::zarr::open_path(&root, &options) else {
        return;
    };
    let geometry = source.geometry();
    // What the streaming extraction takes from an opened source without reading it.
    assert!(
        geometry.dims.iter().all(|&d| d > 0),
        "dims {:?}",
        geometry.dims
    );
    assert!(
        geometry.spacing.iter().all(|s| s.is_finite() && *s > 0.0),
        "spacing {:?}",
        geometry.spacing
    );
    assert!(
        geometry.origin.iter().all(|o| o.is_finite()),
        "origin {:?}",
        geometry.origin
    );
    // The streaming extraction: a plan within the budget, then its first slab.
    if let Ok(memory) = plan(&source, isogrid_fuzz::MEMORY_LIMIT) {
        let [nx, ny, nz] = geometry.dims;
        let planes = (16 * memory.slab_layers + 1).min(nz);
        let len = nx * ny * planes;
        let _ = match source.scalar_type() {
            ScalarType::U8 => first_slab(&mut source, planes, len, |s| SlabMut::U8(s)),
            ScalarType::U16 => first_slab(&mut source, planes, len, |s| SlabMut::U16(s)),
            ScalarType::I16 => first_slab(&mut source, planes, len, |s| SlabMut::I16(s)),
            ScalarType::F32 => first_slab(&mut source, planes, len, |s| SlabMut::F32(s)),
            ScalarType::U32 => first_slab(&mut source, planes, len, |s| SlabMut::U32(s)),
            ScalarType::I32 => first_slab(&mut source, planes, len, |s| SlabMut::I32(s)),
            ScalarType::U64 => first_slab(&mut source, planes, len, |s| SlabMut::U64(s)),
            ScalarType::I64 => first_slab(&mut source, planes, len, |s| SlabMut::I64(s)),
            ScalarType::F64 => first_slab(&mut source, planes, len, |s| SlabMut::F64(s)),
        };
    }
    // `read_volume`: the whole array, for the commands that need the volume itself.
    if let Ok(volume) = isogrid_io::region::read_all(&mut source) {
        isogrid_fuzz::check_volume(&volume);
    }
});

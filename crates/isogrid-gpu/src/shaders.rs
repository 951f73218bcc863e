//! WGSL sources shared between passes. A pass's module is `common.wgsl` (+ `cell_decode.wgsl`
//! and the page storage, `cell_data.wgsl` or the tracer's `trace_pages.wgsl`, for passes that read
//! cells) + the role's file.

pub(crate) const COMMON: &str = include_str!("../shaders/common.wgsl");
/// Cell decoding over one page per bind group (the raster passes, the single-page tracer).
pub(crate) const CELL_DATA: &str = concat!(
    include_str!("../shaders/cell_decode.wgsl"),
    include_str!("../shaders/cell_data.wgsl")
);
/// The per-pixel cell test shared by the hardware and the compute cell raster.
pub(crate) const CELL_HIT: &str = include_str!("../shaders/cell_hit.wgsl");
/// The instance lists and pixel spans of the compute raster and splat passes.
pub(crate) const COMPUTE_LISTS: &str = include_str!("../shaders/compute_lists.wgsl");
/// EWA splat setup and per-pixel weight, shared by the hardware and the compute splats.
pub(crate) const EWA_SPLAT: &str = include_str!("../shaders/ewa_splat.wgsl");
/// Cell decoding over up to [`crate::gpu_types::TRACE_PAGES`] pages bound at once (the tracer).
pub(crate) const TRACE_PAGES_DATA: &str = concat!(
    include_str!("../shaders/cell_decode.wgsl"),
    include_str!("../shaders/trace_pages.wgsl")
);
/// The wavefront path tracer's passes, for grids of more pages than one trace pass binds.
pub(crate) const WAVEFRONT: &str = include_str!("../shaders/wavefront.wgsl");

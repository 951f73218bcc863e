//! `#[repr(C)]` structs shared with the WGSL shaders, one per uniform block. Each is a
//! keep-in-sync twin of a struct in `shaders/` (named on the struct); WGSL's uniform layout rules
//! are met by using only 16-byte vectors or four 4-byte scalars.

use bytemuck::{Pod, Zeroable};

/// Per-frame uniforms (group 0, binding 0 of every pass). Keep in sync with `FrameUniforms` in
/// `shaders/common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct FrameUniforms {
    /// World eye position; w = near plane distance along `forward` (world units).
    pub eye: [f32; 4],
    /// World image right; w = tan(fovy / 2) · aspect.
    pub right: [f32; 4],
    /// World image up; w = tan(fovy / 2).
    pub up: [f32; 4],
    /// World view direction; w = EWA Gaussian sigma in cells.
    pub forward: [f32; 4],
    /// width, height, 1 / width, 1 / height (pixels).
    pub viewport: [f32; 4],
    /// world_from_cell scale (the spacing) xyz; w = isovalue in the units of the corner source.
    pub cell_to_world: [f32; 4],
    /// x: precision bits; y: corner source (`SOURCE_*`); z: `FLAG_*`; w: frame index.
    pub params: [u32; 4],
    /// Clip plane (world): points p with dot(xyz, p) > w are cut away; all zero = no plane (the
    /// native renderer sets none; the web viewer's clip control does).
    pub clip: [f32; 4],
}

pub(crate) const SOURCE_RECORDS: u32 = 0;
pub(crate) const SOURCE_VOLUME: u32 = 1;
pub(crate) const FLAG_OCCLUSION: u32 = 1;
pub(crate) const FLAG_BACKFACE: u32 = 2;
pub(crate) const FLAG_EWA: u32 = 4;
/// A label grid: the raster lets a front face win at equal depth (`cell_hit.wgsl`).
pub(crate) const FLAG_LABELS: u32 = 8;

/// How the shading pass colours the surface (group 1, binding 3 of the shading passes). Keep in
/// sync with `ColorUniforms` in `shaders/shade.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct ColorUniforms {
    /// x: attribute value of code 0; y: value step per code; z: colour range low end; w: 1 / the
    /// colour range's width.
    pub mapping: [f32; 4],
    /// x: `COLOR_*` source; y: the NaN code; z: the bits of a quiet NaN (WGSL rejects NaN
    /// constants, so shaders read one from here); w unused.
    pub params: [u32; 4],
    /// Linear albedo of NaN values (rgb).
    pub nan_albedo: [f32; 4],
    /// The colour map's entries as linear albedo (rgb), `isogrid::colormap::TABLE_SIZE` of them.
    pub table: [[f32; 4]; isogrid::colormap::TABLE_SIZE],
}

/// One fixed albedo (`isogrid::shading::ALBEDO`): no colour map.
pub(crate) const COLOR_NONE: u32 = 0;
/// The value of the hit cell's attribute code, which the cell raster writes into the record
/// channel of the ID target and the tracer reads from the cell's page.
pub(crate) const COLOR_RECORDS: u32 = 1;
/// The value the mesh pass wrote, as f32 bits, in the record channel of the ID target.
pub(crate) const COLOR_MESH: u32 = 2;
/// The albedo of the hit cluster's label (a label grid), through `upload::label_color_words`.
pub(crate) const COLOR_LABELS: u32 = 3;

const _: () = assert!(std::mem::size_of::<ColorUniforms>() == 48 + 16 * 256);

impl ColorUniforms {
    /// The colouring of the shading pass and the path tracer: `coloring`'s table as linear albedo
    /// over its range, codes decoded with `mapping` (the grid's attribute; mesh values need none);
    /// `source` is a `COLOR_*`. Without a colouring, [`COLOR_NONE`]: the one fixed albedo.
    pub fn new(
        coloring: Option<&isogrid::colormap::Coloring>,
        source: u32,
        mapping: Option<isogrid::CodeMapping>,
    ) -> ColorUniforms {
        use isogrid::colormap::{srgb8_to_linear, NAN_SRGB};
        let mut u: ColorUniforms = Zeroable::zeroed();
        u.params[2] = f32::NAN.to_bits();
        // A label grid's colours are uploaded with it; no map or range applies.
        if source == COLOR_LABELS {
            u.params[0] = COLOR_LABELS;
            return u;
        }
        let Some(c) = coloring.filter(|_| source != COLOR_NONE) else {
            return u;
        };
        let m = mapping.unwrap_or(isogrid::CodeMapping {
            zero: 0.0,
            step: 0.0,
            nan_code: u32::MAX,
        });
        let [lo, hi] = c.clim;
        u.mapping = [
            m.zero as f32,
            m.step as f32,
            lo as f32,
            (1.0 / (hi - lo)) as f32,
        ];
        u.params[0] = source;
        u.params[1] = m.nan_code;
        let linear = |rgb: [u8; 3]| {
            let [r, g, b] = rgb.map(srgb8_to_linear);
            [r, g, b, 0.0]
        };
        u.nan_albedo = linear(NAN_SRGB);
        for (entry, rgb) in u.table.iter_mut().zip(c.table()) {
            *entry = linear(*rgb);
        }
        u
    }
}

/// One page of a grid's buffers (group 1, binding 0 of the cell passes). Keep in sync with
/// `PageUniforms` in `shaders/common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct PageUniforms {
    pub first_slot: u32,
    pub first_cell: u32,
    pub slot_count: u32,
    /// Word index, in the page's record buffer, of its first cell attribute code; 0 when the
    /// grid has no attribute uploaded ([`crate::upload::RecordLayout`]).
    pub codes_word: u32,
}

/// Decoding of snorm16 positions (group 1, binding 0 of the mesh pass). Keep in sync with
/// `MeshUniforms` in `shaders/mesh.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct MeshUniforms {
    /// World xyz; w a label mesh's back-face slack in world units (half the smallest spacing),
    /// else 0.
    pub center: [f32; 4],
    /// World xyz; w 1 for a label mesh with values (two words per vertex: the label, then the
    /// value's bits), else 0.
    pub half_extent: [f32; 4],
}

/// `wgpu::util::DrawIndirectArgs` for the full, probe and new instance lists of a page, as the
/// expansion shader's `draw_args` sees them. Keep in sync with `draw_args` in `shaders/expand.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct PageDrawArgs {
    pub lists: [[u32; 4]; 3],
}

/// `wgpu::util::DispatchIndirectArgs` of the compute raster over the full, probe and new lists of a
/// page, written by `size_dispatches`. Keep in sync with `dispatch_args` in `shaders/expand.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct PageDispatchArgs {
    pub lists: [[u32; 3]; 3],
}

impl PageDispatchArgs {
    /// Byte offset of a list's arguments.
    pub fn offset(list: u64) -> u64 {
        list * 12
    }
}

pub(crate) const LIST_FULL: u64 = 0;
pub(crate) const LIST_PROBE: u64 = 1;
pub(crate) const LIST_NEW: u64 = 2;

impl PageDrawArgs {
    /// Six vertices (one rectangle) per instance, no instances yet.
    pub fn empty() -> Self {
        PageDrawArgs {
            lists: [[6, 0, 0, 0]; 3],
        }
    }
    /// Byte offset of a list's arguments.
    pub fn offset(list: u64) -> u64 {
        list * 16
    }
}

const _: () = assert!(std::mem::size_of::<FrameUniforms>() == 128);
const _: () = assert!(std::mem::size_of::<PageDrawArgs>() == 48);
const _: () = assert!(std::mem::size_of::<PageDispatchArgs>() == 36);

/// Path tracing and ray traversal uniforms (group 0, binding 1 of the trace passes). Keep in sync
/// with `TraceUniforms` in `shaders/trace.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct TraceUniforms {
    /// Blocks per axis (0 when the grid has no blocks); w = bounces.
    pub block_dims: [u32; 4],
    /// Cells per axis; w = offset of secondary ray origins along the normal (world units).
    pub cell_dims: [f32; 4],
    /// Diffuse albedo rgb; w unused.
    pub albedo: [f32; 4],
    /// x: sample index; y: 1 = environment texture, 0 = built-in sky; z: ray count; w unused.
    pub sample: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<TraceUniforms>() == 64);

/// Pages of a grid one trace pass binds at once (`shaders/trace_pages.wgsl`, which declares
/// that many metacell and record bindings; keep in sync with `TRACE_PAGES` there); grids of more
/// pages are traced in passes over groups of this many. Six pages take 12 storage buffers, 15
/// with the tracer's others, within the 16 per shader stage that GL and most devices offer.
pub(crate) const TRACE_PAGES: usize = 6;

/// Where each bound page of a group starts (group 1, binding 0 of the several-pages trace passes). Keep in
/// sync with `TracePages` in `shaders/trace_pages.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct TracePages {
    /// x: pages bound; y: global slot just past the last bound page's; zw unused.
    pub count: [u32; 4],
    /// Global index of page p's first metacell slot at `[p / 4][p % 4]`.
    pub first_slot: [[u32; 4]; 2],
    /// Global index of page p's first corner record at `[p / 4][p % 4]`.
    pub first_cell: [[u32; 4]; 2],
    /// Page p's [`PageUniforms::codes_word`] at `[p / 4][p % 4]`.
    pub codes_word: [[u32; 4]; 2],
}

const _: () = assert!(TRACE_PAGES <= 8 && std::mem::size_of::<TracePages>() == 112);

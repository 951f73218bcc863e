//! What a render call returns: the [`Frame`] with its per-pixel AOVs and the [`PassTimings`].

use crate::options::CellRaster;

/// A rendered image with per-pixel AOVs, row-major from the top-left.
#[derive(Debug, Clone)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// sRGB colour, 4 bytes per pixel (alpha 255).
    pub rgba8: Vec<u8>,
    /// World distance from the eye to the hit along the pixel's ray; `+inf` on a miss.
    pub depth: Vec<f32>,
    /// Unit world normal −∇f (pointing out of the solid, to values below the isovalue) as shaded;
    /// NaN on a miss.
    pub normal: Vec<[f32; 3]>,
    /// Cluster index of the hit (global, slot / 16); `u32::MAX` on a miss, 0 for MC hits.
    pub cluster: Vec<u32>,
    /// With [`crate::RenderOptions::coloring`]: the attribute value each pixel is coloured by
    /// (the hit cell's, or the mesh's interpolated), NaN on a miss or a NaN value; empty otherwise.
    pub value: Vec<f32>,
    pub timings: PassTimings,
    /// Cells fully rasterised in the last frame (both visibility passes; 0 for MC).
    pub drawn_cells: u64,
    /// Probe splats drawn in the last frame.
    pub probed_cells: u64,
    /// [`crate::Mode::PathTrace`]: mean linear RGB radiance per pixel over all accumulated
    /// samples (what `rgba8` encodes as sRGB); empty in other modes.
    pub linear: Vec<[f32; 3]>,
    /// [`crate::Mode::PathTrace`]: samples per pixel accumulated so far for this view; 0 in
    /// other modes.
    pub samples: u32,
    /// The raster that drew the cells ([`CellRaster::Auto`] resolved); `None` for the MC mesh.
    pub cell_raster: Option<CellRaster>,
}

impl Frame {
    pub fn is_hit(&self, pixel: usize) -> bool {
        self.cluster[pixel] != u32::MAX
    }
}

/// GPU time of the last frames' passes in milliseconds (median over frames after the first);
/// `None` without timestamp queries or where the pass did not run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassTimings {
    /// Depth and G-buffer passes: cell raster (both visibility passes) plus EWA splatting, or the
    /// MC mesh pass (the quantity of the paper's Table 4).
    pub raster_ms: Option<f64>,
    /// The EWA splatting pass alone; `raster_ms - ewa_ms` is the raster time without EWA.
    pub ewa_ms: Option<f64>,
    /// Deferred shading.
    pub shade_ms: Option<f64>,
    /// Culling work: cluster expansion (both), probes and the visibility update.
    pub cull_ms: Option<f64>,
    /// First to last timestamp of the frame.
    pub frame_ms: Option<f64>,
    /// The path tracing pass ([`crate::Mode::PathTrace`]): secondary rays (and primary ones with
    /// [`crate::PrimaryRays::Traced`]), accumulation, tone mapping.
    pub trace_ms: Option<f64>,
}

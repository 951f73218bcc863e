//! [`Rendered`]: the image, its AOVs and what the run measured, whichever renderer made them.

use crate::policy::Placement;

/// Rendering facts of a run on the CPU tracer.
#[derive(Debug, Clone, PartialEq)]
pub struct CpuStats {
    /// The crossing solver, `samples3` or `exact`.
    pub crossing: &'static str,
    /// The traversal, `blocks` or `bvh`.
    pub traversal: &'static str,
    /// The part of the render's seconds spent building the traversal.
    pub build_seconds: f64,
    /// Closest-hit queries made.
    pub rays: u64,
}

/// Rendering facts of a run on the GPU renderer.
#[derive(Debug, Clone)]
pub struct GpuStats {
    /// Frames rendered (for path tracing, one per sample).
    pub frames: u32,
    /// Per-pass GPU times of the last frames, where the adapter measures them.
    pub timings: isogrid_gpu::PassTimings,
    /// Cells drawn and probed in the last frame.
    pub drawn_cells: u64,
    pub probed_cells: u64,
    /// The raster that drew the cells, where one did.
    pub cell_raster: Option<isogrid_gpu::CellRaster>,
}

/// A finished render: row-major from the top-left pixel, `width × height` entries per buffer.
#[derive(Debug, Clone)]
pub struct Rendered {
    pub width: u32,
    pub height: u32,
    /// sRGB, 3 bytes per pixel.
    pub rgb8: Vec<u8>,
    /// World distance along the pixel-centre ray, +∞ on a miss.
    pub depth: Vec<f32>,
    /// Unit world normal out of the solid, NaN on a miss.
    pub normal: Vec<[f32; 3]>,
    /// Cluster of the hit cell, `u32::MAX` on a miss.
    pub cluster: Vec<u32>,
    /// The grid's attribute at the hit cell, NaN on a miss; `None` where the renderer does not
    /// give it (no attribute, or the GPU renderer).
    pub value: Option<Vec<f32>>,
    /// A label grid's label value at the hit cell, `u64::MAX` on a miss; `None` for other grids.
    pub label: Option<Vec<u64>>,
    pub placement: Placement,
    /// The adapter's name and API on the GPU, `CPU ray tracer` on the CPU.
    pub adapter: String,
    /// Rendering only (not reading, extracting, uploading or writing), wall clock.
    pub seconds: f64,
    /// Path tracing: samples per pixel taken.
    pub samples: Option<u32>,
    pub cpu: Option<CpuStats>,
    pub gpu: Option<GpuStats>,
}

impl Rendered {
    /// Pixels whose centre ray hit the surface.
    pub fn hits(&self) -> usize {
        self.cluster.iter().filter(|&&c| c != u32::MAX).count()
    }
}

//! Cell rasterisation in compute passes (paper §3.2, the probes of §3.3 and the EWA splats of §3.4;
//! `shaders/cells_compute.wgsl`, `shaders/ewa_compute.wgsl`): which raster a frame uses, and how
//! the compute one is recorded.
//!
//! Both rasters run the same per-pixel test (`shaders/cell_hit.wgsl`) on the same instance lists,
//! so they find the same crossings; they differ in who walks a cell's pixels. The hardware raster
//! draws each cell as a rectangle and lets fragments do it, which is the paper's design. The
//! compute raster gives each cell one thread that loops over its rectangle, resolves visibility
//! with an atomic maximum of the reversed-Z depth, and writes the G-buffer in a second pass. The
//! compute raster wins where cells cover few pixels and where the graphics pipeline is weak next to
//! the compute units (datacenter GPUs such as the H100, see `docs/benchmarks-gpu.md`), and loses
//! where cells grow large on screen: one thread then walks many pixels.

use crate::gpu_types::{PageDispatchArgs, LIST_FULL, LIST_NEW, LIST_PROBE};
use crate::pipelines::Pipelines;
use crate::upload::Page;
use isogrid::{Camera, GridInfo};

/// Which raster draws the cells of [`crate::Mode::Cgc`], [`crate::Mode::CgcNoEwa`],
/// [`crate::Mode::Cr`] and the primary rays of [`crate::Mode::PathTrace`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum CellRaster {
    /// [`CellRaster::Compute`] unless a cell can cover more than [`MAX_COMPUTE_CELL_PIXELS`]
    /// pixels across in this view (the eye close to or inside the grid), then the hardware one.
    #[default]
    Auto,
    /// Screen rectangles through the graphics pipeline, one fragment per covered pixel (§3.2).
    Hardware,
    /// One compute thread per cell looping over its covered pixels.
    Compute,
}

/// Widest projected cell, in pixels, that [`CellRaster::Auto`] leaves to the compute raster: the
/// thread of such a cell tests up to about this many squared pixels while its neighbours in the
/// warp test a few. A bound, not a tuned optimum: standard views of 128³–512³ grids at 1080p
/// project cells to 1–8 pixels.
pub const MAX_COMPUTE_CELL_PIXELS: f64 = 32.0;

impl CellRaster {
    /// The raster `self` stands for with this camera and grid ([`CellRaster::Auto`] resolved).
    pub fn resolve(self, camera: &Camera, info: &GridInfo) -> CellRaster {
        if self != CellRaster::Auto {
            return self;
        }
        if widest_cell_pixels(camera, info) <= MAX_COMPUTE_CELL_PIXELS {
            CellRaster::Compute
        } else {
            CellRaster::Hardware
        }
    }
}

/// An upper estimate of a cell's projected width in pixels: the cell diagonal seen at the grid
/// box's nearest point, times 2 for the perspective stretch towards the image corners (at most
/// 1 / cos² of the half diagonal field of view, under 2 for fields of view up to 70°).
fn widest_cell_pixels(camera: &Camera, info: &GridInfo) -> f64 {
    let (lo, hi) = info.world_bounds();
    let distance = (0..3)
        .map(|a| (lo[a] - camera.eye[a]).max(camera.eye[a] - hi[a]).max(0.0))
        .map(|d| d * d)
        .sum::<f64>()
        .sqrt();
    let diagonal = info.spacing.iter().map(|s| s * s).sum::<f64>().sqrt();
    let focal_pixels =
        camera.height as f64 / (2.0 * (camera.fovy_degrees.to_radians() * 0.5).tan());
    if distance <= 0.0 {
        return f64::INFINITY;
    }
    2.0 * diagonal * focal_pixels / distance
}

/// The bind groups and pipelines one frame's compute raster passes use.
pub(crate) struct ComputeRaster<'a> {
    pub pipelines: &'a Pipelines,
    pub scene: &'a wgpu::BindGroup,
    /// Group 2 of `cells_compute.wgsl`: the depth words and the G-buffer storage views.
    pub targets: &'a wgpu::BindGroup,
    /// Group 2 of `ewa_compute.wgsl`: the splat sums, the G-buffer and the EWA target.
    pub ewa_targets: &'a wgpu::BindGroup,
    pub pages: &'a [Page],
    /// Image size in pixels.
    pub size: (u32, u32),
}

/// One compute raster pass over one list of every page.
#[derive(Clone, Copy)]
pub(crate) enum RasterStep {
    DepthFull,
    DepthNew,
    ResolveFull,
    ResolveNew,
    Probe,
    SplatFull,
    SplatNew,
    /// Per pixel, not per list: the splat sums into the EWA target.
    ResolveSplats,
    /// Per pixel, not per list: empty depth words, G-buffer and IDs.
    Clear,
}

impl ComputeRaster<'_> {
    /// Turns the lists' instance counts into indirect dispatch sizes; after each expansion.
    pub fn size_dispatches(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("size compute raster dispatches"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipelines.size_dispatches);
        pass.set_bind_group(0, self.scene, &[]);
        for page in self.pages {
            pass.set_bind_group(1, &page.compute_group, &[]);
            pass.set_bind_group(2, &page.dispatch_group, &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
    }

    /// Records `steps` in order, each over every page, in one timed compute pass.
    pub fn pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
        steps: &[RasterStep],
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timestamps,
        });
        let p = &self.pipelines.compute_raster;
        pass.set_bind_group(0, self.scene, &[]);
        for step in steps {
            let (pipeline, list) = match step {
                RasterStep::DepthFull => (&p.depth_full, LIST_FULL),
                RasterStep::DepthNew => (&p.depth_new, LIST_NEW),
                RasterStep::ResolveFull => (&p.resolve_full, LIST_FULL),
                RasterStep::ResolveNew => (&p.resolve_new, LIST_NEW),
                RasterStep::Probe => (&p.probe, LIST_PROBE),
                RasterStep::SplatFull => (&p.splat_full, LIST_FULL),
                RasterStep::SplatNew => (&p.splat_new, LIST_NEW),
                RasterStep::ResolveSplats | RasterStep::Clear => {
                    let (pipeline, targets) = match step {
                        RasterStep::Clear => (&p.clear, self.targets),
                        _ => (&p.resolve_splats, self.ewa_targets),
                    };
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(2, targets, &[]);
                    // Group 1 is in the layout, unused by these per-pixel entry points.
                    if let Some(page) = self.pages.first() {
                        pass.set_bind_group(1, &page.compute_group, &[]);
                    }
                    pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
                    continue;
                }
            };
            let splats = matches!(step, RasterStep::SplatFull | RasterStep::SplatNew);
            pass.set_bind_group(
                2,
                if splats {
                    self.ewa_targets
                } else {
                    self.targets
                },
                &[],
            );
            pass.set_pipeline(pipeline);
            for page in self.pages {
                pass.set_bind_group(1, &page.compute_group, &[]);
                pass.dispatch_workgroups_indirect(
                    &page.dispatch_args,
                    PageDispatchArgs::offset(list),
                );
            }
        }
    }
}

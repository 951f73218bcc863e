//! Read-back of a render call's last frame: colour, final normal and cluster id targets (and the
//! value target of a coloured render) and the pages' draw arguments are copied to mappable buffers, then unpacked into a [`Frame`].

use crate::error::GpuError;
use crate::gpu_types::{PageDrawArgs, LIST_FULL, LIST_NEW, LIST_PROBE};
use crate::options::CellRaster;
use crate::output::{Frame, PassTimings};
use crate::targets::Targets;
use crate::upload::Page;
use crate::wgpu_util::Gpu;

/// Mappable copies of the AOV targets and of the draw arguments of every page.
pub(super) struct Readbacks<'a> {
    /// Colour, final normal and cluster ids, each with its padded row pitch in bytes.
    targets: [(&'a wgpu::Texture, u32, wgpu::Buffer); 3],
    /// The value target, when the render colours by an attribute.
    value: Option<(&'a wgpu::Texture, u32, wgpu::Buffer)>,
    args: wgpu::Buffer,
    page_count: u64,
}

/// Bytes per row of a read-back copy, padded to wgpu's 256-byte alignment.
fn padded_row(width: u32, texel_bytes: u32) -> u32 {
    (width * texel_bytes).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

const ARGS_SIZE: u64 = std::mem::size_of::<PageDrawArgs>() as u64;

impl<'a> Readbacks<'a> {
    /// Read-back buffers for `targets` (the value target too when `value`) and the draw
    /// arguments of `page_count` pages.
    pub fn new(gpu: &Gpu, all: &'a Targets, page_count: u64, value: bool) -> Readbacks<'a> {
        let size = all.color.size();
        let copy = |(texture, texel, label): (&'a wgpu::Texture, u32, &str)| {
            let row = padded_row(size.width, texel);
            let buffer = gpu.readback_buffer(label, row as u64 * size.height as u64);
            (texture, row, buffer)
        };
        let targets = [
            (&all.color, 4u32, "colour readback"),
            (&all.final_normal, 16, "normal readback"),
            (&all.ids, 8, "cluster id readback"),
        ]
        .map(copy);
        let value = value.then(|| copy((&all.value, 4, "value readback")));
        let args = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("draw arguments readback"),
            size: (ARGS_SIZE * page_count).max(ARGS_SIZE),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Readbacks {
            targets,
            value,
            args,
            page_count,
        }
    }
}

impl Readbacks<'_> {
    /// Records the copies of the draw arguments of the raster's `pages` and of the targets.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, pages: &[Page]) {
        for (i, page) in pages.iter().enumerate() {
            encoder.copy_buffer_to_buffer(
                &page.args,
                0,
                &self.args,
                i as u64 * ARGS_SIZE,
                ARGS_SIZE,
            );
        }
        for (texture, row, buffer) in self.targets.iter().chain(&self.value) {
            encoder.copy_texture_to_buffer(
                texture.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(*row),
                        rows_per_image: Some(texture.height()),
                    },
                },
                texture.size(),
            );
        }
    }

    /// Maps the copies and unpacks them into a frame: AOVs per pixel, and the cells drawn and
    /// probed (the lists a frame with `occlusion` culling ran).
    pub fn frame(
        &self,
        gpu: &Gpu,
        timings: PassTimings,
        occlusion: bool,
        cell_raster: Option<CellRaster>,
    ) -> Result<Frame, GpuError> {
        let mut mapped = Vec::new();
        for (_, _, buffer) in &self.targets {
            mapped.push(gpu.read_buffer(buffer)?);
        }
        let args: Vec<PageDrawArgs> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(&self.args)?);
        let count = |list: u64| -> u64 {
            args.iter()
                .take(self.page_count as usize)
                .map(|a| a.lists[list as usize][1] as u64)
                .sum()
        };
        let size = self.targets[0].0.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let mut frame = Frame {
            width: size.width,
            height: size.height,
            rgba8: Vec::with_capacity(4 * w * h),
            depth: Vec::with_capacity(w * h),
            normal: Vec::with_capacity(w * h),
            cluster: Vec::with_capacity(w * h),
            value: Vec::new(),
            timings,
            drawn_cells: count(LIST_FULL) + if occlusion { count(LIST_NEW) } else { 0 },
            probed_cells: if occlusion { count(LIST_PROBE) } else { 0 },
            linear: Vec::new(),
            samples: 0,
            cell_raster,
        };
        let rows = |i: usize| mapped[i].chunks(self.targets[i].1 as usize);
        for ((color, normal), ids) in rows(0).zip(rows(1)).zip(rows(2)) {
            frame.rgba8.extend_from_slice(&color[..4 * w]);
            let normal: &[[f32; 4]] = bytemuck::cast_slice(&normal[..16 * w]);
            let ids: &[[u32; 2]] = bytemuck::cast_slice(&ids[..8 * w]);
            for (n, id) in normal.iter().zip(ids) {
                let hit = id[0] != u32::MAX;
                frame.cluster.push(id[0]);
                frame.depth.push(if hit { n[3] } else { f32::INFINITY });
                frame.normal.push(if hit {
                    [n[0], n[1], n[2]]
                } else {
                    [f32::NAN; 3]
                });
            }
        }
        if let Some((_, row, buffer)) = &self.value {
            let mapped = gpu.read_buffer(buffer)?;
            for (r, ids) in mapped.chunks(*row as usize).zip(frame.cluster.chunks(w)) {
                let values: &[f32] = bytemuck::cast_slice(&r[..4 * w]);
                // Misses hold NaN whatever the target was cleared to.
                frame.value.extend(values.iter().zip(ids).map(|(&v, &id)| {
                    if id == u32::MAX {
                        f32::NAN
                    } else {
                        v
                    }
                }));
            }
        }
        Ok(frame)
    }
}

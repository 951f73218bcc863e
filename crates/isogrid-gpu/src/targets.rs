//! The render targets of one image: their formats (which the passes' pipelines are built for)
//! and the textures and views of one render call.

use crate::wgpu_util::{view, Gpu};

pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// World normal (xyz) and eye distance (w) of the raster hit.
pub(crate) const SURFACE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Cluster and record index (the paper's RG32UI target).
pub(crate) const IDS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;
/// Weighted normal sum (xyz) and weight (w) of the EWA pass.
pub(crate) const EWA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Final world normal (xyz) and eye distance (w).
pub(crate) const FINAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// The attribute value the shading coloured each pixel by (NaN on a miss or uncoloured).
pub(crate) const VALUE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// Render targets of one image size, with a whole view of each.
pub(crate) struct Targets {
    /// Depth, G-buffer and EWA sums: bound through their views only, held for the call.
    _bound_only: [wgpu::Texture; 3],
    pub ids: wgpu::Texture,
    pub color: wgpu::Texture,
    pub final_normal: wgpu::Texture,
    pub value: wgpu::Texture,
    pub depth_view: wgpu::TextureView,
    pub surface_view: wgpu::TextureView,
    pub ids_view: wgpu::TextureView,
    pub ewa_view: wgpu::TextureView,
    pub color_view: wgpu::TextureView,
    pub final_view: wgpu::TextureView,
    pub value_view: wgpu::TextureView,
}

impl Targets {
    /// `final_in_compute`: the final normal is written as a storage texture (by the compute
    /// shading pass or the path tracer's traced primaries), a usage the fragment shading pass does
    /// not need (it can cost render targets their compression). The raster G-buffer (surface, ids,
    /// EWA) is always storage: the compute raster writes it.
    pub fn new(gpu: &Gpu, size: (u32, u32), final_in_compute: bool) -> Targets {
        use wgpu::TextureUsages as U;
        let rt = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING;
        let written = if final_in_compute {
            U::STORAGE_BINDING
        } else {
            U::empty()
        };
        let depth = gpu.texture_2d("raster depth (reversed-Z)", size, DEPTH_FORMAT, rt);
        // Storage: the compute raster writes these two.
        let surface = gpu.texture_2d(
            "raster normal + distance",
            size,
            SURFACE_FORMAT,
            rt | U::STORAGE_BINDING,
        );
        let ids = gpu.texture_2d(
            "cluster ids",
            size,
            IDS_FORMAT,
            rt | U::COPY_SRC | U::STORAGE_BINDING,
        );
        // Storage: the compute splats' resolve writes it.
        let ewa = gpu.texture_2d(
            "ewa normal accumulation",
            size,
            EWA_FORMAT,
            rt | U::STORAGE_BINDING,
        );
        let color = gpu.texture_2d(
            "shaded colour",
            size,
            COLOR_FORMAT,
            // Storage: the path tracer writes its tone-mapped mean here.
            U::RENDER_ATTACHMENT | U::COPY_SRC | U::STORAGE_BINDING,
        );
        let final_normal = gpu.texture_2d(
            "final normal + distance",
            size,
            FINAL_FORMAT,
            // Texture binding: the path tracer's primary hits.
            U::RENDER_ATTACHMENT | U::COPY_SRC | U::TEXTURE_BINDING | written,
        );
        let value = gpu.texture_2d(
            "shaded attribute value",
            size,
            VALUE_FORMAT,
            // Texture binding: the path tracer's raster primaries take their colour from it.
            U::RENDER_ATTACHMENT | U::COPY_SRC | U::TEXTURE_BINDING | written,
        );
        Targets {
            value_view: view(&value),
            value,
            depth_view: view(&depth),
            surface_view: view(&surface),
            ids_view: view(&ids),
            ewa_view: view(&ewa),
            color_view: view(&color),
            final_view: view(&final_normal),
            _bound_only: [depth, surface, ewa],
            ids,
            color,
            final_normal,
        }
    }
}

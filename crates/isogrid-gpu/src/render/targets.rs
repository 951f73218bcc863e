//! The render targets of one image size, their views, and the bind groups and buffers that one
//! render call's passes bind (built once per call, shared by its frames).

use super::bindings::{buffer_entry, texture_entry};
use super::plan::FramePlan;
use crate::gpu_types::{FrameUniforms, PageDrawArgs};
use crate::pipelines::{
    COLOR_FORMAT, DEPTH_FORMAT, EWA_FORMAT, FINAL_FORMAT, IDS_FORMAT, SURFACE_FORMAT,
};
use crate::Renderer;
use isogrid::Camera;

/// Render targets of one image size.
pub(super) struct Targets {
    pub depth: wgpu::Texture,
    pub surface: wgpu::Texture,
    pub ids: wgpu::Texture,
    pub ewa: wgpu::Texture,
    pub color: wgpu::Texture,
    pub final_normal: wgpu::Texture,
}

/// The targets and everything else one render call's passes bind.
pub(super) struct FrameBindings {
    pub targets: Targets,
    /// [`FrameUniforms`], rewritten before each frame.
    pub uniforms: wgpu::Buffer,
    /// Every list of a page's draw arguments empty; copied over them before the expansions.
    pub args_template: wgpu::Buffer,
    /// The compute splats' integer sums: 4 words per pixel, only when they run.
    pub ewa_sum: wgpu::Buffer,
    pub depth_view: wgpu::TextureView,
    pub surface_view: wgpu::TextureView,
    pub ids_view: wgpu::TextureView,
    pub ewa_view: wgpu::TextureView,
    pub color_view: wgpu::TextureView,
    pub final_view: wgpu::TextureView,
    pub scene_compute: wgpu::BindGroup,
    pub scene_render: wgpu::BindGroup,
    pub depth_input: wgpu::BindGroup,
    pub surface_input: wgpu::BindGroup,
    pub raster_targets: wgpu::BindGroup,
    pub ewa_targets: wgpu::BindGroup,
    pub ids_input: wgpu::BindGroup,
    pub shade_inputs: wgpu::BindGroup,
    /// Only the compute shading pass binds its outputs as storage (see `targets`).
    pub shade_outputs: Option<wgpu::BindGroup>,
}

fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor::default())
}

impl Renderer {
    fn texture(
        &self,
        label: &str,
        camera: &Camera,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: camera.width,
                height: camera.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }

    /// `final_in_compute`: the final normal is written as a storage texture (by the compute
    /// shading pass or the path tracer's traced primaries), a usage the fragment shading pass does
    /// not need (it can cost render targets their compression). The raster G-buffer (surface, ids,
    /// EWA) is always storage: the compute raster writes it.
    fn targets(&self, camera: &Camera, final_in_compute: bool) -> Targets {
        use wgpu::TextureUsages as U;
        let rt = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING;
        let written = if final_in_compute {
            U::STORAGE_BINDING
        } else {
            U::empty()
        };
        Targets {
            depth: self.texture("raster depth (reversed-Z)", camera, DEPTH_FORMAT, rt),
            // Storage: the compute raster writes these two.
            surface: self.texture(
                "raster normal + distance",
                camera,
                SURFACE_FORMAT,
                rt | U::STORAGE_BINDING,
            ),
            ids: self.texture(
                "cluster ids",
                camera,
                IDS_FORMAT,
                rt | U::COPY_SRC | U::STORAGE_BINDING,
            ),
            // Storage: the compute splats' resolve writes it.
            ewa: self.texture(
                "ewa normal accumulation",
                camera,
                EWA_FORMAT,
                rt | U::STORAGE_BINDING,
            ),
            color: self.texture(
                "shaded colour",
                camera,
                COLOR_FORMAT,
                // Storage: the path tracer writes its tone-mapped mean here.
                U::RENDER_ATTACHMENT | U::COPY_SRC | U::STORAGE_BINDING,
            ),
            final_normal: self.texture(
                "final normal + distance",
                camera,
                FINAL_FORMAT,
                // Texture binding: the path tracer's primary hits.
                U::RENDER_ATTACHMENT | U::COPY_SRC | U::TEXTURE_BINDING | written,
            ),
        }
    }

    /// The targets of `camera`'s image size and the bind groups and buffers `plan`'s passes use.
    pub(super) fn frame_bindings(&self, camera: &Camera, plan: &FramePlan<'_>) -> FrameBindings {
        let targets = self.targets(camera, plan.traced || plan.compute_raster);
        let uniforms = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let dummy_storage = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("unused visibility bits"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let dummy_volume = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("unused volume"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let dummy_volume_view = view(&dummy_volume);
        let volume_view = plan.volume.map(|v| &v.view).unwrap_or(&dummy_volume_view);
        let (vis_last, vis_new) = match plan.grid {
            Some(g) => (&g.visible_last_frame, &g.visible_new),
            None => (&dummy_storage, &dummy_storage),
        };
        let p = &self.pipelines;
        let group =
            |label: &str, layout: &wgpu::BindGroupLayout, entries: &[wgpu::BindGroupEntry]| {
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(label),
                    layout,
                    entries,
                })
            };
        let scene_compute = group(
            "scene (compute)",
            &p.scene_compute,
            &[
                buffer_entry(0, &uniforms),
                buffer_entry(1, vis_last),
                texture_entry(2, volume_view),
                buffer_entry(3, vis_new),
            ],
        );
        let scene_render = group(
            "scene (render)",
            &p.scene_render,
            &[
                buffer_entry(0, &uniforms),
                texture_entry(2, volume_view),
                buffer_entry(3, vis_new),
            ],
        );
        let depth_view = view(&targets.depth);
        let surface_view = view(&targets.surface);
        let ids_view = view(&targets.ids);
        let ewa_view = view(&targets.ewa);
        let color_view = view(&targets.color);
        let final_view = view(&targets.final_normal);
        let depth_input = group(
            "raster depth input",
            &p.depth_input,
            &[texture_entry(0, &depth_view)],
        );
        let surface_input = group(
            "raster surface input",
            &p.surface_input,
            &[texture_entry(0, &surface_view)],
        );
        // The compute passes' per-pixel words, full size only when those passes run.
        let pixel_words = |label: &str, words: u64, used: bool| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: if used {
                    4 * words * camera.width as u64 * camera.height as u64
                } else {
                    16
                },
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        // Reversed-Z depth bits per pixel, row-major.
        let raster_depth = pixel_words(
            "compute raster depth (reversed-Z bits)",
            1,
            plan.compute_raster,
        );
        let raster_targets = group(
            "compute raster targets",
            &p.raster_targets,
            &[
                buffer_entry(0, &raster_depth),
                texture_entry(1, &surface_view),
                texture_entry(2, &ids_view),
            ],
        );
        let ewa_sum = pixel_words("compute ewa sums", 4, plan.ewa && plan.compute_raster);
        let ewa_targets = group(
            "compute ewa targets",
            &p.ewa_targets,
            &[
                buffer_entry(0, &ewa_sum),
                texture_entry(1, &surface_view),
                texture_entry(2, &ewa_view),
            ],
        );
        let ids_input = group(
            "cluster id input",
            &p.ids_input,
            &[texture_entry(0, &ids_view)],
        );
        let shade_inputs = group(
            "shading inputs",
            &p.shade_inputs,
            &[
                texture_entry(0, &surface_view),
                texture_entry(1, &ewa_view),
                texture_entry(2, &ids_view),
            ],
        );
        let shade_outputs = plan.compute_raster.then(|| {
            group(
                "compute shading outputs",
                &p.shade_outputs,
                &[texture_entry(0, &color_view), texture_entry(1, &final_view)],
            )
        });
        let args_template = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("empty draw arguments"),
            size: std::mem::size_of::<PageDrawArgs>() as u64,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.queue.write_buffer(
            &args_template,
            0,
            bytemuck::bytes_of(&PageDrawArgs::empty()),
        );
        FrameBindings {
            targets,
            uniforms,
            args_template,
            ewa_sum,
            depth_view,
            surface_view,
            ids_view,
            ewa_view,
            color_view,
            final_view,
            scene_compute,
            scene_render,
            depth_input,
            surface_input,
            raster_targets,
            ewa_targets,
            ids_input,
            shade_inputs,
            shade_outputs,
        }
    }
}

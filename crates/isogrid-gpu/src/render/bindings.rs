//! The targets, buffers and bind groups one render call's passes bind, built once per call and
//! shared by its frames; each pass builds its own groups from the targets.

use super::plan::FramePlan;
use crate::gpu_types::{ColorUniforms, FrameUniforms, PageDrawArgs, COLOR_LABELS};
use crate::passes::{ComputeRasterGroups, RasterPasses, SceneGroups, SceneInputs};
use crate::targets::Targets;
use crate::view::Visibility;
use crate::wgpu_util::{view, Gpu};
use isogrid::Camera;

/// The targets and everything else one render call's passes bind.
pub(super) struct FrameBindings {
    pub targets: Targets,
    /// [`FrameUniforms`], rewritten before each frame.
    pub uniforms: wgpu::Buffer,
    /// Every list of a page's draw arguments empty; copied over them before the expansions.
    pub args_template: wgpu::Buffer,
    /// The compute splats' integer sums: 4 words per pixel, only when they run.
    pub ewa_sum: wgpu::Buffer,
    pub scene: SceneGroups,
    pub depth_input: wgpu::BindGroup,
    pub surface_input: wgpu::BindGroup,
    pub compute_raster: ComputeRasterGroups,
    pub ids_input: wgpu::BindGroup,
    pub shade_inputs: wgpu::BindGroup,
    /// Only the compute shading pass binds its outputs as storage (see [`Targets::new`]).
    pub shade_outputs: Option<wgpu::BindGroup>,
}

impl FrameBindings {
    /// The targets of `camera`'s image size and the bind groups and buffers `plan`'s passes use,
    /// with the view's `visibility` bits (`None` without a grid).
    pub fn new(
        gpu: &Gpu,
        passes: &RasterPasses,
        camera: &Camera,
        plan: &FramePlan<'_>,
        visibility: Option<&Visibility>,
    ) -> FrameBindings {
        let size = (camera.width, camera.height);
        let targets = Targets::new(gpu, size, plan.traced || plan.compute_raster);
        let uniforms = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let dummy_storage = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("unused visibility bits"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let dummy_volume = gpu.device.create_texture(&wgpu::TextureDescriptor {
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
        let attribute = plan.grid.and_then(|g| g.attribute);
        // Its own dummy: a buffer bound read-write (the visibility bits) cannot also be read-only.
        let no_color_data = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no colour data"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let coloring = gpu.uniform_buffer(
            "colouring",
            bytemuck::bytes_of(&ColorUniforms::new(
                plan.coloring,
                plan.color_source,
                attribute,
            )),
        );
        let (visible_last_frame, visible_new) = match visibility {
            Some(v) => (&v.last_frame, &v.new),
            None => (&dummy_storage, &dummy_storage),
        };
        let scene = passes.scene.bind(
            gpu,
            &SceneInputs {
                uniforms: &uniforms,
                visible_last_frame,
                visible_new,
                volume: plan.volume.map(|v| &v.view).unwrap_or(&dummy_volume_view),
            },
        );
        // The compute passes' per-pixel words, full size only when those passes run.
        let pixel_words = |label: &str, words: u64, used: bool| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
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
        let ewa_sum = pixel_words("compute ewa sums", 4, plan.ewa && plan.compute_raster);
        let compute_raster = passes.compute.bind(gpu, &targets, &raster_depth, &ewa_sum);
        let shade_outputs = plan
            .compute_raster
            .then(|| passes.shading.bind_outputs(gpu, &targets));
        let args_template = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("empty draw arguments"),
            size: std::mem::size_of::<PageDrawArgs>() as u64,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.queue.write_buffer(
            &args_template,
            0,
            bytemuck::bytes_of(&PageDrawArgs::empty()),
        );
        FrameBindings {
            depth_input: passes.hardware.bind_depth(gpu, &targets),
            surface_input: passes.ewa.bind(gpu, &targets),
            ids_input: passes.visibility.bind(gpu, &targets),
            shade_inputs: passes.shading.bind_inputs(
                gpu,
                &targets,
                &coloring,
                // Attribute codes come with the cells: the raster writes the hit cell's code.
                match (plan.color_source, plan.grid, plan.mesh) {
                    (COLOR_LABELS, Some(g), _) => g.label_albedo.as_ref().unwrap_or(&no_color_data),
                    (COLOR_LABELS, None, Some(m)) => {
                        m.label_albedo.as_ref().unwrap_or(&no_color_data)
                    }
                    _ => &no_color_data,
                },
            ),
            targets,
            uniforms,
            args_template,
            ewa_sum,
            scene,
            compute_raster,
            shade_outputs,
        }
    }
}

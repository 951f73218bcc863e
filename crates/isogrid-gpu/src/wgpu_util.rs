//! The crate's wgpu helpers: [`Gpu`] (the opened device with its queue and limits: error scopes,
//! size-checked buffers, textures, read-back) and the boilerplate of bind-group layout entries,
//! bind-group entries, shader modules, pipelines and dispatch sizes that every pass shares.

use crate::error::GpuError;
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;
use wgpu::{BindGroupLayout, ComputePipeline, Device, RenderPipeline, ShaderStages};

/// An opened device: what every upload and pass records through.
pub(crate) struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    /// The device measures pass times (timestamp queries).
    pub timestamps: bool,
    /// Validation errors outside an error scope land here instead of panicking.
    pub uncaptured: Arc<Mutex<Vec<String>>>,
}

impl Gpu {
    /// Runs `f` inside validation and out-of-memory error scopes, turning what they catch into a
    /// [`GpuError`] (`what` names the operation).
    pub fn scoped<T>(
        &self,
        what: &str,
        f: impl FnOnce() -> Result<T, GpuError>,
    ) -> Result<T, GpuError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let validation = pollster::block_on(validation.pop());
        let oom = pollster::block_on(oom.pop());
        if let Some(e) = oom {
            return Err(GpuError::too_large(format!(
                "{what}: out of GPU memory: {e}"
            )));
        }
        if let Some(e) = validation {
            return Err(GpuError::device(format!("{what}: {e}")));
        }
        if let Some(e) = self.uncaptured.lock().ok().and_then(|mut v| v.pop()) {
            return Err(GpuError::device(format!("{what}: {e}")));
        }
        out
    }

    /// The device's largest storage binding.
    pub fn binding_limit(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// A buffer holding `contents`, zero-padded to a non-zero multiple of 4 bytes (what storage
    /// bindings need), or `TooLarge` where it exceeds the device's largest buffer. The contents
    /// are copied straight into the buffer's mapping: a memory-mapped grid file is read once,
    /// with no copy of it on the heap.
    pub fn buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        self.buffer_init_parts(label, &[contents], usage)
    }

    /// Like [`Gpu::buffer_init`], holding `parts` one after another, each from a word boundary
    /// (the bytes between zero), in one mapping.
    pub fn buffer_init_parts(
        &self,
        label: &str,
        parts: &[&[u8]],
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        let padded = |n: usize| (n as u64).div_ceil(4) * 4;
        let bytes: u64 = parts.iter().map(|p| padded(p.len())).sum();
        let size = bytes.max(4);
        if size > self.limits.max_buffer_size {
            return Err(GpuError::too_large(format!(
                "{label}: {bytes} bytes exceed the device's largest buffer ({} bytes)",
                self.limits.max_buffer_size
            )));
        }
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: true,
        });
        // A mapping at creation starts zeroed, so the padding needs no writing.
        if bytes > 0 {
            let mut mapped = buffer
                .get_mapped_range_mut(..)
                .map_err(|e| GpuError::device(format!("{label}: mapping the new buffer: {e}")))?;
            let mut at = 0usize;
            for part in parts {
                mapped.slice(at..at + part.len()).copy_from_slice(part);
                at += padded(part.len()) as usize;
            }
        }
        buffer.unmap();
        Ok(buffer)
    }

    /// A zeroed buffer of at least `size` bytes (16 at least, a multiple of 4), or `TooLarge`
    /// where it exceeds the device's largest buffer.
    pub fn buffer(
        &self,
        label: &str,
        size: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        if size > self.limits.max_buffer_size {
            return Err(GpuError::too_large(format!(
                "{label}: {size} bytes exceed the device's largest buffer ({} bytes)",
                self.limits.max_buffer_size
            )));
        }
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16).div_ceil(4) * 4,
            usage,
            mapped_at_creation: false,
        }))
    }

    /// A uniform buffer holding `contents`, rewritable.
    pub fn uniform_buffer(&self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// A mappable buffer that copies are read back through ([`Gpu::read_buffer`]).
    pub fn readback_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Maps a MAP_READ buffer and copies its bytes out.
    pub fn read_buffer(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::device(format!("waiting for the GPU: {e}")))?;
        rx.recv()
            .map_err(|_| GpuError::device("read-back was cancelled"))?
            .map_err(|e| GpuError::device(format!("read-back failed: {e}")))?;
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| GpuError::device(format!("read-back failed: {e}")))?
            .to_vec();
        buffer.unmap();
        Ok(bytes)
    }

    /// A 2D texture of `width × height` texels.
    pub fn texture_2d(
        &self,
        label: &str,
        (width, height): (u32, u32),
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.device.create_texture(&texture_2d_descriptor(
            label,
            (width, height),
            format,
            usage,
        ))
    }

    /// An `Rgba32Float` texture holding `rgba` (row-major from the top), viewed whole.
    pub fn float_texture(
        &self,
        label: &str,
        width: u32,
        height: u32,
        rgba: &[f32],
    ) -> wgpu::TextureView {
        self.device
            .create_texture_with_data(
                &self.queue,
                &texture_2d_descriptor(
                    label,
                    (width, height),
                    wgpu::TextureFormat::Rgba32Float,
                    wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                ),
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(rgba),
            )
            .create_view(&wgpu::TextureViewDescriptor::default())
    }

    /// A bind group of `layout` with `entries`.
    pub fn bind_group(
        &self,
        label: &str,
        layout: &BindGroupLayout,
        entries: &[wgpu::BindGroupEntry],
    ) -> wgpu::BindGroup {
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries,
        })
    }
}

fn texture_2d_descriptor(
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::TextureDescriptor<'_> {
    wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    }
}

/// The whole texture as one view.
pub(crate) fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor::default())
}

pub(crate) fn buffer_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

pub(crate) fn texture_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    }
}

/// A colour attachment that is cleared to `clear`, or loaded where `None`, and stored.
pub(crate) fn color_attachment(
    view: &wgpu::TextureView,
    clear: Option<wgpu::Color>,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: match clear {
                Some(c) => wgpu::LoadOp::Clear(c),
                None => wgpu::LoadOp::Load,
            },
            store: wgpu::StoreOp::Store,
        },
    })
}

/// Workgroups (x, y) of 64 threads covering `slots` threads; y spills over the 65535 x limit.
pub(crate) fn dispatch_size(slots: u32) -> (u32, u32) {
    let groups = slots.div_ceil(64).max(1);
    let x = groups.min(65535);
    (x, groups.div_ceil(x))
}

pub(crate) fn uniform(binding: u32, visibility: ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn storage(
    binding: u32,
    visibility: ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn texture(
    binding: u32,
    visibility: ShaderStages,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// A write-only 2D storage texture of the compute stage.
pub(crate) fn written_texture(
    binding: u32,
    format: wgpu::TextureFormat,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format,
            view_dimension: D2,
        },
        count: None,
    }
}

pub(crate) const FLOAT: wgpu::TextureSampleType =
    wgpu::TextureSampleType::Float { filterable: false };
pub(crate) const D2: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2;

pub(crate) fn layout(
    device: &Device,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries,
    })
}

/// A WGSL module from source `parts` concatenated (shared files first, the role's file last).
pub(crate) fn module(device: &Device, label: &str, parts: &[&str]) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(parts.concat().into()),
    })
}

pub(crate) fn pipeline_layout(
    device: &Device,
    label: &str,
    groups: &[&BindGroupLayout],
) -> wgpu::PipelineLayout {
    let groups: Vec<Option<&BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    })
}

pub(crate) fn compute(
    device: &Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> ComputePipeline {
    specialised_compute(device, label, layout, module, entry, &[])
}

/// A compute pipeline with WGSL `override` constants set.
pub(crate) fn specialised_compute(
    device: &Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
    constants: &[(&str, f64)],
) -> ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    })
}

/// A render pipeline of triangle lists without vertex buffers or face culling, and with
/// reversed-Z depth (nearer is larger) where `depth` names the depth format.
pub(crate) struct RenderSpec<'a> {
    pub label: &'a str,
    pub layout: &'a wgpu::PipelineLayout,
    pub module: &'a wgpu::ShaderModule,
    pub vertex: &'a str,
    pub fragment: &'a str,
    pub targets: &'a [Option<wgpu::ColorTargetState>],
    pub depth: Option<wgpu::TextureFormat>,
}

pub(crate) fn render_pipeline(device: &Device, spec: RenderSpec) -> RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(spec.label),
        layout: Some(spec.layout),
        vertex: wgpu::VertexState {
            module: spec.module,
            entry_point: Some(spec.vertex),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: spec.depth.map(|format| wgpu::DepthStencilState {
            format,
            depth_write_enabled: Some(true),
            // Reversed-Z: nearer is larger.
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: spec.module,
            entry_point: Some(spec.fragment),
            compilation_options: Default::default(),
            targets: spec.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A colour target written whole, without blending.
pub(crate) fn target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

//! Small constructors the crate's passes share: bind-group entries, colour attachments and the
//! workgroup grid of a one-thread-per-slot compute dispatch.

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
pub(super) fn color_attachment(
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

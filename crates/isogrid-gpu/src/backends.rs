//! Which wgpu backends to open: `WGPU_BACKEND` when set; otherwise Vulkan, Metal or DX12 when any
//! of them has an adapter, and GL only as the fallback.
//!
//! Asking for GL next to Vulkan is not free: wgpu initialises EGL when the instance is created,
//! which loads Mesa's `swrast_dri.so` on machines with lavapipe, and that driver's exit handler
//! crashed the viewer at exit about once in seven runs (SIGSEGV after main returned). Probing the
//! primary backends first keeps GL out of processes that never use it.

/// See the module docs. Blocks while the primary backends enumerate their adapters.
pub fn preferred_backends() -> wgpu::Backends {
    if let Some(chosen) = wgpu::Backends::from_env() {
        return chosen;
    }
    let primary = wgpu::Backends::PRIMARY;
    let probe = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: primary,
        ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
    });
    if pollster::block_on(probe.enumerate_adapters(primary)).is_empty() {
        primary | wgpu::Backends::GL
    } else {
        primary
    }
}

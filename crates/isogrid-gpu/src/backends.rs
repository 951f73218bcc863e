//! Which wgpu backends to open (`WGPU_BACKEND` when set; otherwise Vulkan, Metal or DX12 when any
//! of them has an adapter, and GL only as the fallback), and which adapter they give.
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

/// The adapter [`crate::Renderer::new`] opens, described without opening a device (no pipelines
/// are built): enough to decide whether rendering on it is worth its start-up.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Name and API, as [`crate::Renderer::adapter_info`] prints them.
    pub name: String,
    /// A software rasteriser on the CPU (lavapipe, llvmpipe, WARP: wgpu's `DeviceType::Cpu`).
    pub software: bool,
}

/// The adapter [`crate::Renderer::new`] would pick (same backends and power preference), or
/// `None` where there is none.
pub fn default_adapter() -> Option<AdapterSummary> {
    let adapter = request_adapter().ok()?;
    let info = adapter.get_info();
    Some(AdapterSummary {
        name: format!("{} ({:?})", info.name, info.backend),
        software: info.device_type == wgpu::DeviceType::Cpu,
    })
}

/// The adapter of [`preferred_backends`] that the renderer opens: headless, high performance,
/// with the adapter's own limits (not bucketed), so that big structures need as few pages as
/// possible.
pub(crate) fn request_adapter() -> Result<wgpu::Adapter, wgpu::RequestAdapterError> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: preferred_backends(),
        ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
    });
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        apply_limit_buckets: false,
    }))
}

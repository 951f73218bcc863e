//! [`RenderContext`]: the GPU adapter and renderer of a process, looked up and opened only when a
//! request is placed on the GPU, and then kept for the next request (opening a device and building
//! its pipelines is the slow part of a first GPU render).

use crate::policy::{decide, Decision};
use crate::request::RenderRequest;
use isogrid::{Error, Result};
use isogrid_gpu::{AdapterSummary, GpuErrorKind, Renderer};
use std::sync::OnceLock;

/// Holds what the GPU side found and opened; share one per process (the Python package keeps a
/// static one) or one per command (the CLI).
#[derive(Default)]
pub struct RenderContext {
    adapter: OnceLock<Option<AdapterSummary>>,
    renderer: OnceLock<Renderer>,
}

impl RenderContext {
    pub fn new() -> Self {
        Self::default()
    }

    /// The adapter the GPU renderer would open, found once (no device is created).
    pub fn adapter(&self) -> Option<&AdapterSummary> {
        self.adapter
            .get_or_init(isogrid_gpu::default_adapter)
            .as_ref()
    }

    /// Places `request` by [`crate::policy::decide`] with this context's adapter.
    pub fn decide(&self, request: &RenderRequest) -> Result<Decision> {
        decide(request, || self.adapter().cloned())
    }

    /// The GPU renderer, opened on first use.
    pub fn renderer(&self) -> Result<&Renderer> {
        if let Some(r) = self.renderer.get() {
            return Ok(r);
        }
        let renderer = Renderer::new().map_err(|e| match e.kind() {
            GpuErrorKind::NoAdapter => Error::unsupported(format!(
                "{e} (for a CPU Vulkan driver install mesa-vulkan-drivers)"
            )),
            _ => Error::from(e),
        })?;
        Ok(self.renderer.get_or_init(|| renderer))
    }
}

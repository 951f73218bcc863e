//! [`GpuError`]: what can go wrong on the GPU side, with a kind callers can branch on (e.g. fall
//! back to the CPU tracer on [`GpuErrorKind::NoAdapter`]).

use std::fmt;

/// Why a GPU operation failed.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GpuErrorKind {
    /// No usable adapter (no Vulkan/GL driver, or `WGPU_BACKEND` names one that is not there).
    NoAdapter,
    /// A structure, image or volume exceeds the device's limits even when split into pages.
    TooLarge,
    /// The device failed or reported a validation error.
    Device,
    /// The request does not make sense (mode without its scene data, bad camera, ...).
    InvalidInput,
    /// The caller cancelled the work through its [`isogrid::Progress`].
    Cancelled,
}

/// A one-line GPU error.
#[derive(Debug, Clone)]
pub struct GpuError {
    kind: GpuErrorKind,
    message: String,
}

impl GpuError {
    pub fn new(kind: GpuErrorKind, message: impl Into<String>) -> Self {
        let message: String = message.into();
        // One line: wgpu's validation messages span several.
        let message = message.split_whitespace().collect::<Vec<_>>().join(" ");
        GpuError { kind, message }
    }
    pub fn kind(&self) -> GpuErrorKind {
        self.kind
    }
    pub(crate) fn too_large(message: impl Into<String>) -> Self {
        Self::new(GpuErrorKind::TooLarge, message)
    }
    pub(crate) fn device(message: impl Into<String>) -> Self {
        Self::new(GpuErrorKind::Device, message)
    }
    pub(crate) fn invalid(message: impl Into<String>) -> Self {
        Self::new(GpuErrorKind::InvalidInput, message)
    }
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for GpuError {}

impl From<GpuError> for isogrid::Error {
    fn from(e: GpuError) -> Self {
        match e.kind {
            GpuErrorKind::TooLarge => isogrid::Error::too_large(e.message),
            GpuErrorKind::InvalidInput => isogrid::Error::invalid(e.message),
            GpuErrorKind::Cancelled => isogrid::Error::cancelled(e.message),
            _ => isogrid::Error::unsupported(format!("GPU: {}", e.message)),
        }
    }
}

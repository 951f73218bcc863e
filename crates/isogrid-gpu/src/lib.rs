//! GPU renderer for clustered grid cells (paper §3.2–3.4), built on wgpu.

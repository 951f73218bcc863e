//! The backend policy: which renderer runs a request, decided from the request and the adapter
//! the GPU renderer would open, before any device is created.
//!
//! - `cpu`: the CPU tracer; GPU-only modes are refused when the request is built.
//! - `gpu`: the GPU renderer on any adapter, lavapipe included; an error where there is none.
//! - `auto`: a hardware adapter when there is one. Where the only adapter is a software one
//!   (lavapipe, llvmpipe: wgpu's `DeviceType::Cpu`), the backend measured faster for the mode
//!   ([`software_adapter_wins`]). The CPU where there is no adapter. GPU-only modes and requests
//!   naming the primary rays need an adapter either way.

use crate::mode::{cpu_draws, Backend, Mode};
use crate::request::RenderRequest;
use isogrid::{Error, Result};
use isogrid_gpu::AdapterSummary;

/// The renderer a request runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// The CPU tracer (isogrid-trace).
    Cpu,
    /// The GPU renderer (isogrid-gpu).
    Gpu,
}

/// A placement and, when `auto` passed over an adapter or found none, why (one line for people).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decision {
    pub placement: Placement,
    pub note: Option<String>,
}

/// Places `request`. `adapter` tells which adapter the GPU renderer would open (see
/// [`isogrid_gpu::default_adapter`]); it is asked at most once, and only when the answer matters.
pub fn decide(
    request: &RenderRequest,
    adapter: impl FnOnce() -> Option<AdapterSummary>,
) -> Result<Decision> {
    let mode = request.mode();
    let gpu = |note: Option<String>| {
        Ok(Decision {
            placement: Placement::Gpu,
            note,
        })
    };
    let cpu = |note: Option<String>| {
        Ok(Decision {
            placement: Placement::Cpu,
            note,
        })
    };
    let no_adapter = || {
        Error::unsupported(format!(
            "mode {mode}{} needs a GPU adapter and none was found (for a CPU Vulkan driver \
             install mesa-vulkan-drivers)",
            match request.parts().primary {
                Some(p) => format!(" with {} primary rays", p.name()),
                None => String::new(),
            }
        ))
    };
    match request.backend() {
        Backend::Cpu => cpu(None),
        Backend::Gpu => match adapter() {
            Some(_) => gpu(None),
            None => Err(no_adapter()),
        },
        Backend::Auto => {
            // Naming the primary rays asks for the GPU path tracer; the CPU would ignore them.
            let gpu_only = !cpu_draws(mode) || request.parts().primary.is_some();
            match adapter() {
                None if gpu_only => Err(no_adapter()),
                None => cpu(Some("no GPU adapter, rendering on the CPU".into())),
                Some(_) if gpu_only => gpu(None),
                Some(a) if !a.software => gpu(None),
                Some(a) => {
                    if software_adapter_wins(mode) {
                        gpu(None)
                    } else {
                        cpu(Some(format!(
                            "{} is a software adapter; the CPU tracer is faster for {mode}",
                            a.name
                        )))
                    }
                }
            }
        }
    }
}

/// Whether a software adapter (lavapipe, llvmpipe) renders `mode` faster than the CPU tracer on
/// the same machine, device start-up included.
///
/// Measured (`scripts/bench_render_policy.py`, table in `docs/benchmarks-render-policy.md`): for
/// `cgc` and `pathtrace`, at 320×240 and at 1920×1080, the CPU tracer wins both a first render
/// (lavapipe spends seconds opening the device and compiling its pipelines) and a repeated one
/// (lavapipe's frames are slower than the tracer on the same cores: 1.6 s against 0.10 s for
/// `cgc` at 320×240, 12 s against 3.7 s at 1920×1080). The other modes exist on the GPU only.
pub fn software_adapter_wins(mode: Mode) -> bool {
    match mode {
        Mode::Cgc | Mode::PathTrace => false,
        Mode::CgcNoEwa | Mode::Mc | Mode::Cr => true,
    }
}

//! [`Mode`], [`Backend`], [`Primary`] and [`Aov`]: the choices of a render, with the names every front end
//! (CLI flags, Python keywords, the viewer's mode switch) spells them with.

use isogrid::{Error, Result};
use std::str::FromStr;

/// What to draw: the GPU renderer's modes, by the names every front end uses ([`Mode::name`]).
pub use isogrid_gpu::Mode;

/// Whether the CPU tracer draws `mode` too (`cgc` ray traced, `pathtrace`); the others are GPU
/// baselines.
pub fn cpu_draws(mode: Mode) -> bool {
    matches!(mode, Mode::Cgc | Mode::PathTrace)
}

/// Where to render; [`crate::policy`] turns `Auto` into one of the others.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Backend {
    /// A hardware GPU adapter when there is one; on a software adapter only (lavapipe) the faster
    /// of the two for the mode; the CPU when there is no adapter.
    #[default]
    Auto,
    /// The CPU tracer (isogrid-trace).
    Cpu,
    /// The GPU renderer (isogrid-gpu) on any wgpu adapter, lavapipe included.
    Gpu,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        }
    }
}

impl FromStr for Backend {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        [Backend::Auto, Backend::Cpu, Backend::Gpu]
            .into_iter()
            .find(|b| b.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| Error::invalid(format!("backend must be auto, cpu or gpu, not {s:?}")))
    }
}

/// Where GPU path tracing gets its primary hits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Primary {
    /// The paper's hybrid: rasterised (cell raster, EWA normals, deferred shading).
    #[default]
    Raster,
    /// Traced from the eye like the secondary rays, in the same compute pass, with no raster pass.
    Traced,
}

impl Primary {
    pub fn name(self) -> &'static str {
        match self {
            Primary::Raster => "raster",
            Primary::Traced => "traced",
        }
    }

    pub(crate) fn gpu(self) -> isogrid_gpu::PrimaryRays {
        match self {
            Primary::Raster => isogrid_gpu::PrimaryRays::Raster,
            Primary::Traced => isogrid_gpu::PrimaryRays::Traced,
        }
    }
}

impl FromStr for Primary {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        [Primary::Raster, Primary::Traced]
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| Error::invalid(format!("primary must be raster or traced, not {s:?}")))
    }
}

/// A per-pixel output besides the image (arbitrary output variable).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Aov {
    /// f32 world distance from the eye along the pixel-centre ray, +∞ on a miss.
    Depth,
    /// f32 × 3 unit world normal out of the solid, NaN on a miss.
    Normal,
    /// u32 cluster of the hit cell, `u32::MAX` on a miss.
    Cluster,
    /// f32 value of the grid's attribute at the hit cell, NaN on a miss (grids with an attribute).
    Value,
    /// u64 value of the hit cell's label, `u64::MAX` (all ones) on a miss (label grids).
    Label,
}

impl Aov {
    pub const ALL: [Aov; 5] = [
        Aov::Depth,
        Aov::Normal,
        Aov::Cluster,
        Aov::Value,
        Aov::Label,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Aov::Depth => "depth",
            Aov::Normal => "normal",
            Aov::Cluster => "cluster",
            Aov::Value => "value",
            Aov::Label => "label",
        }
    }
}

impl FromStr for Aov {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Aov::ALL
            .into_iter()
            .find(|a| a.name() == s.trim())
            .ok_or_else(|| {
                Error::invalid(format!(
                    "unknown AOV {s:?} (depth, normal, cluster, value or label)"
                ))
            })
    }
}

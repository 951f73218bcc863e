//! [`Mode`], [`Backend`] and [`Primary`]: the choices of a render, with the names every front end
//! (CLI flags, Python keywords, the viewer's mode switch) spells them with.

use isogrid::{Error, Result};
use std::fmt;
use std::str::FromStr;

/// What to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// The clustered grid cell isosurface (paper §3.2–3.4), Blinn–Phong shaded: cell
    /// rasterisation with EWA normals on the GPU, ray traced on the CPU (§3.6).
    Cgc,
    /// GPU only: cell rasterisation with trilinear-gradient normals, no EWA pass.
    CgcNoEwa,
    /// GPU only: the Marching Cubes mesh baseline (needs the volume).
    Mc,
    /// GPU only: cell rasterisation sampling the original volume (the CR baseline; needs the
    /// volume).
    Cr,
    /// Path tracing under an environment (§3.6): on the GPU one sample per pixel per frame,
    /// with raster (the paper's hybrid) or traced primary rays; on the CPU fully traced.
    PathTrace,
}

impl Mode {
    /// Every mode, in the order front ends list them.
    pub const ALL: [Mode; 5] = [
        Mode::Cgc,
        Mode::CgcNoEwa,
        Mode::Mc,
        Mode::Cr,
        Mode::PathTrace,
    ];

    /// The name front ends use: `cgc`, `cgc-noewa`, `mc`, `cr` or `pathtrace`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Cgc => "cgc",
            Mode::CgcNoEwa => "cgc-noewa",
            Mode::Mc => "mc",
            Mode::Cr => "cr",
            Mode::PathTrace => "pathtrace",
        }
    }

    /// The GPU renderer's mode.
    pub fn gpu_mode(self) -> isogrid_gpu::Mode {
        match self {
            Mode::Cgc => isogrid_gpu::Mode::Cgc,
            Mode::CgcNoEwa => isogrid_gpu::Mode::CgcNoEwa,
            Mode::Mc => isogrid_gpu::Mode::Mc,
            Mode::Cr => isogrid_gpu::Mode::Cr,
            Mode::PathTrace => isogrid_gpu::Mode::PathTrace,
        }
    }

    /// Whether the CPU tracer draws this mode (the others are GPU baselines).
    pub fn on_cpu(self) -> bool {
        matches!(self, Mode::Cgc | Mode::PathTrace)
    }

    /// Needs the original volume, so is unavailable for `.cgc` inputs.
    pub fn needs_volume(self) -> bool {
        matches!(self, Mode::Mc | Mode::Cr)
    }
}

impl FromStr for Mode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Mode::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                Error::invalid(format!(
                    "mode must be cgc, cgc-noewa, mc, cr or pathtrace, not {s:?}"
                ))
            })
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
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
}

impl Aov {
    pub const ALL: [Aov; 3] = [Aov::Depth, Aov::Normal, Aov::Cluster];

    pub fn name(self) -> &'static str {
        match self {
            Aov::Depth => "depth",
            Aov::Normal => "normal",
            Aov::Cluster => "cluster",
        }
    }
}

impl FromStr for Aov {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Aov::ALL
            .into_iter()
            .find(|a| a.name() == s.trim())
            .ok_or_else(|| Error::invalid(format!("unknown AOV {s:?} (depth, normal or cluster)")))
    }
}

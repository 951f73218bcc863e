//! The path tracers' environment as a request names it, loaded once into the core's
//! [`isogrid::EnvMap`] that both tracers read (orientation: `docs/design/tracing.md`).

use isogrid::Result;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where escaping path-tracer rays get their radiance.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum EnvSource {
    /// The built-in sky (gradient and sun).
    #[default]
    Sky,
    /// An equirectangular `.hdr` or `.exr` map (+y up).
    Map(PathBuf),
}

impl EnvSource {
    /// `sky` (any case) or a path.
    pub fn parse(text: &str) -> EnvSource {
        if text.eq_ignore_ascii_case("sky") {
            EnvSource::Sky
        } else {
            EnvSource::Map(PathBuf::from(text))
        }
    }

    pub fn path(&self) -> Option<&Path> {
        match self {
            EnvSource::Sky => None,
            EnvSource::Map(p) => Some(p),
        }
    }
}

/// A loaded environment: `None` is the built-in sky.
#[derive(Debug, Clone, Default)]
pub(crate) struct LoadedEnv(Option<Arc<isogrid::EnvMap>>);

impl LoadedEnv {
    /// Reads the map of `source` (errors name the file).
    pub fn load(source: &EnvSource) -> Result<LoadedEnv> {
        Ok(LoadedEnv(match source.path() {
            Some(path) => Some(Arc::new(isogrid_io::image::read_env_map(path)?)),
            None => None,
        }))
    }

    /// The CPU path tracer's environment.
    pub fn for_cpu(&self) -> isogrid_trace::Environment {
        match &self.0 {
            Some(map) => isogrid_trace::Environment::Map((**map).clone()),
            None => isogrid_trace::Environment::Sky,
        }
    }

    /// The GPU path tracer's environment, uploaded to `renderer`; `None` is its built-in sky.
    pub fn upload(
        &self,
        renderer: &isogrid_gpu::Renderer,
    ) -> Result<Option<isogrid_gpu::GpuEnvMap>> {
        let Some(map) = &self.0 else {
            return Ok(None);
        };
        Ok(Some(renderer.upload_env(map)?))
    }
}

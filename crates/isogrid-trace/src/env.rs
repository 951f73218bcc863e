//! Where the CPU path tracer's escaping rays get their radiance (paper §3.6): a constant colour,
//! the built-in sky, or an equirectangular map. The sky and the map are the core's
//! ([`isogrid::env_map`]), shared with the GPU path tracer, so both see the same environment in
//! the same orientation.

use isogrid::env_map::{sky, EnvMap};

/// Where escaping path-tracer rays get their radiance.
#[derive(Debug, Clone, PartialEq)]
pub enum Environment {
    /// The built-in sky ([`isogrid::env_map::sky`]): blue zenith, pale horizon, grey ground and
    /// a bright sun.
    Sky,
    /// The same radiance in every direction (a white furnace with `[1.0; 3]`).
    Uniform([f32; 3]),
    /// An equirectangular map, oriented as [`EnvMap`] documents.
    Map(EnvMap),
}

impl Environment {
    /// Radiance arriving from direction `d` (unit, world, pointing away from the scene).
    pub fn radiance(&self, d: [f64; 3]) -> [f32; 3] {
        match self {
            Environment::Uniform(c) => *c,
            Environment::Map(map) => map.radiance(d.map(|v| v as f32)),
            Environment::Sky => sky(d.map(|v| v as f32)),
        }
    }
}

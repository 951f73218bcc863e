//! GPU renderer tests, run on whatever adapter wgpu finds (Mesa lavapipe in CI). Every test skips
//! with a message when, and only when, there is no adapter at all.

mod accuracy;
mod culling;
mod edges;
mod empty_space;
mod paged_trace;
mod pathtrace;
mod reference;

use isogrid::generate::{generate, Field};
use isogrid::{extract, CellGrid, ExtractOptions, Iso, Precision, Volume};
use isogrid_gpu::{GpuErrorKind, Renderer};
use std::sync::OnceLock;

/// The shared renderer, or `None` (with a message) when the machine has no adapter.
pub fn renderer() -> Option<&'static Renderer> {
    static RENDERER: OnceLock<Option<Renderer>> = OnceLock::new();
    RENDERER.get_or_init(new_renderer).as_ref()
}

pub fn new_renderer() -> Option<Renderer> {
    match Renderer::new() {
        Ok(r) => Some(r),
        Err(e) if e.kind() == GpuErrorKind::NoAdapter => {
            eprintln!("skipping GPU test: {e}");
            None
        }
        Err(e) => panic!("GPU renderer failed to start: {e}"),
    }
}

/// A generated u8 volume and its grid at the paper's normalised isovalue 0.5.
pub fn scene(field: Field, size: usize, precision: Option<Precision>) -> (Volume, CellGrid) {
    let volume = generate(field, size, 7);
    let mut options = ExtractOptions::new(Iso::Normalized(0.5));
    options.precision = precision;
    let grid = extract(&volume.view(), &options).unwrap();
    (volume, grid)
}

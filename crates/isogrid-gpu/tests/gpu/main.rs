//! GPU renderer tests, run on whatever adapter wgpu finds (Mesa lavapipe in CI). Every test skips
//! with a message when, and only when, there is no adapter at all.

mod accuracy;
mod attribute_pages;
mod colour;
mod culling;
mod edges;
mod empty_space;
mod env_orientation;
mod metacell_walk;
mod paged_trace;
mod pathtrace;
mod rasters;
mod reference;
mod traced_primary;
mod views;

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

/// `grid` seen by `camera`, path traced under `env` with `samples` per pixel and `bounces` on
/// the GPU (hybrid primaries) and on the CPU tracer (random stream `seed`).
pub fn path_trace_on_both(
    r: &Renderer,
    grid: &CellGrid,
    camera: &isogrid::Camera,
    env: &isogrid::EnvMap,
    (samples, bounces, seed): (u32, u32, u64),
) -> (isogrid_gpu::Frame, isogrid_trace::Image) {
    use isogrid_trace::{Environment, PathTraceOptions, RenderOptions, Shading};
    let gpu_env = r.upload_env(env).unwrap();
    let gpu_grid = r.upload_grid(grid).unwrap();
    let gpu = r
        .path_trace(
            &gpu_grid,
            camera,
            &isogrid_gpu::PathTraceOptions {
                frames: samples,
                bounces,
                env: Some(&gpu_env),
                ..Default::default()
            },
        )
        .unwrap();
    let options = RenderOptions {
        shading: Shading::PathTrace(PathTraceOptions {
            samples_per_pixel: samples,
            bounces,
            environment: Environment::Map(env.clone()),
            seed,
            ..PathTraceOptions::default()
        }),
        ..RenderOptions::default()
    };
    let cpu = isogrid_trace::render(grid, camera, &options).unwrap();
    (gpu, cpu)
}

/// Pixels of a `width`-wide image where the pixel and its 4 neighbours are all `hit`: interior
/// surface pixels. Path tracers are compared there because at silhouettes the CPU's jittered
/// primaries mix in the environment and the GPU's pixel-centre primaries do not.
pub fn interior_pixels(width: usize, pixels: usize, hit: impl Fn(usize) -> bool) -> Vec<usize> {
    let height = pixels / width;
    (0..pixels)
        .filter(|&i| {
            let (x, y) = (i % width, i / width);
            x > 0
                && y > 0
                && x + 1 < width
                && y + 1 < height
                && [i, i - 1, i + 1, i - width, i + width]
                    .into_iter()
                    .all(&hit)
        })
        .collect()
}

/// The mean of independent samples and its standard error.
pub struct MeanEstimate {
    pub mean: f64,
    pub standard_error: f64,
}

impl MeanEstimate {
    pub fn of(values: impl Iterator<Item = f64>) -> Self {
        let values: Vec<f64> = values.collect();
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        MeanEstimate {
            mean,
            standard_error: (var / n).sqrt(),
        }
    }
}

/// How the GPU tracer's hits agree with the CPU tracer's on the same rays.
pub struct HitAgreement {
    pub rays: usize,
    /// Rays both call a hit or both a miss.
    pub agree: usize,
    /// Rays both call a hit.
    pub both: usize,
    /// Rays both call a hit, at distances within 0.05 world units.
    pub close: usize,
}

impl HitAgreement {
    pub fn of(
        cpu: &isogrid_trace::Tracer,
        rays: &[isogrid::Ray],
        gpu: &[Option<isogrid_gpu::RayHit>],
    ) -> Self {
        let mut a = HitAgreement {
            rays: rays.len(),
            agree: 0,
            both: 0,
            close: 0,
        };
        for (ray, got) in rays.iter().zip(gpu) {
            let want = cpu.closest_hit(ray, 0.0, f64::INFINITY);
            a.agree += (want.is_some() == got.is_some()) as usize;
            if let (Some(want), Some(got)) = (want, got) {
                a.both += 1;
                a.close += ((got.t as f64 - want.t).abs() <= 0.05) as usize;
            }
        }
        a
    }

    /// At least `min_hits` common hits; hit/miss agreement on 99 % of rays (the two differ only
    /// where a ray grazes a sliver within f32 rounding); 99 % of common hits within 0.05.
    pub fn assert_close(&self, label: &str, min_hits: usize) {
        let (rays, agree, both, close) = (self.rays, self.agree, self.both, self.close);
        eprintln!(
            "{label}: {rays} rays, hit/miss agree {agree}, both hit {both}, within 0.05 {close}"
        );
        assert!(both >= min_hits, "{label}: too few hits ({both})");
        assert!(
            agree as f64 >= 0.99 * rays as f64,
            "{label}: {agree} of {rays}"
        );
        assert!(
            close as f64 >= 0.99 * both as f64,
            "{label}: {close} of {both}"
        );
    }
}

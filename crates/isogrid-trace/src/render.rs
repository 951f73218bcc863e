//! CPU renderer of a clustered grid cell isosurface: one traced primary ray per pixel centre,
//! shaded with the shared deferred Blinn–Phong model ([`isogrid::shading`]) like the GPU renderer, or
//! a progressive Monte Carlo path tracer lit by an [`Environment`] (paper §3.6).
//!
//! Path tracing: Lambertian surfaces of a single albedo (or, coloured by the grid's attribute, the
//! colour of the value at each hit cell), cosine-weighted bounces, no light sources
//! but the environment (no shadow rays: light arrives only when a path escapes); a path that is
//! still on the surface after `bounces` scatterings contributes nothing. Every (pixel, sample) has
//! its own random stream, so images do not depend on the thread count. Samples are accumulated in
//! passes of one sample per pixel, each in tiles of whole rows (progress is counted and
//! cancellation checked per tile).

use crate::cluster_search::Hit;
use crate::crossing::Crossing;
use crate::env::Environment;
use crate::grid_tracer::{GridTracer, Traversal};
use crate::sample::{cosine_hemisphere, Rng};
use isogrid::camera::{dot, Camera, Ray};
use isogrid::colormap::Coloring;
use isogrid::error::{Error, Result};
use isogrid::grid::CellGrid;
use isogrid::progress::Progress;
use isogrid::shading::{shade_albedo, to_srgb8, ALBEDO, BACKGROUND_SRGB};
use rayon::prelude::*;

/// How pixels get their colour.
#[derive(Debug, Clone, PartialEq)]
pub enum Shading {
    /// Deferred normalised Blinn–Phong with camera-space lights, as every renderer of the project.
    Phong,
    /// Monte Carlo path tracing (see the module docs).
    PathTrace(PathTraceOptions),
}

#[derive(Debug, Clone, PartialEq)]
pub struct PathTraceOptions {
    /// Samples per pixel (≥ 1), each through a random point of the pixel.
    pub samples_per_pixel: u32,
    /// Scatterings per path.
    pub bounces: u32,
    pub environment: Environment,
    /// Linear diffuse reflectance.
    pub albedo: [f32; 3],
    pub seed: u64,
}

impl Default for PathTraceOptions {
    fn default() -> Self {
        PathTraceOptions {
            samples_per_pixel: 16,
            bounces: 3,
            environment: Environment::Sky,
            albedo: ALBEDO,
            seed: 0,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    pub crossing: Crossing,
    /// How rays find candidate metacells; the hits are the same either way.
    pub traversal: Traversal,
    pub shading: Shading,
    /// Colour the surface by the grid's attribute (its value at the hit cell, through the map) as
    /// the diffuse albedo, in Phong shading and path tracing alike; `None`: the constant albedo.
    pub coloring: Option<Coloring>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            crossing: Crossing::Samples3,
            traversal: Traversal::default(),
            shading: Shading::Phong,
            coloring: None,
        }
    }
}

/// The diffuse albedo of each hit cell: the attribute's colour, the colour of its cluster's label
/// in a label grid, or one albedo for all.
struct Albedo<'a> {
    colored: Option<(&'a isogrid::CellAttribute, &'a Coloring)>,
    labels: Option<&'a isogrid::labels::GridLabels>,
    constant: [f32; 3],
}

impl Albedo<'_> {
    fn of(&self, hit: &Hit) -> [f32; 3] {
        match (self.colored, self.labels) {
            (Some((attribute, coloring)), _) => coloring.albedo(attribute.value(hit.cell as usize)),
            (None, Some(labels)) => {
                let label = labels.cluster_labels()[hit.cluster as usize] as usize;
                labels.table()[label].albedo()
            }
            (None, None) => self.constant,
        }
    }
}

/// A rendered image and its per-pixel buffers (arbitrary output variables), row-major from the
/// top-left pixel, `width × height` entries each.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// sRGB 8-bit, 3 bytes per pixel.
    pub rgb8: Vec<u8>,
    /// Linear RGB before encoding (unclamped; the background's linear value on Phong misses).
    pub radiance: Vec<[f32; 3]>,
    /// World distance from the eye to the surface along the pixel-centre ray; +∞ on a miss.
    pub depth: Vec<f32>,
    /// Unit world-space normal −∇f/|∇f| (out of the solid); NaN on a miss.
    pub normal: Vec<[f32; 3]>,
    /// Cluster index of the hit cell; `u32::MAX` on a miss.
    pub cluster: Vec<u32>,
    /// The grid's attribute at the hit cell (the value stored for it), NaN on a miss; `None` when
    /// the grid has no attribute.
    pub value: Option<Vec<f32>>,
    /// Closest-hit queries made (primary rays plus every path segment).
    pub rays_traced: u64,
    /// Wall-clock seconds spent building the tracer (its traversal's structures) before the
    /// first ray.
    pub build_seconds: f64,
}

impl Image {
    /// Pixels whose centre ray hit the surface.
    pub fn hits(&self) -> usize {
        self.cluster.iter().filter(|&&c| c != u32::MAX).count()
    }
}

/// Pixels an image may have (a 16K × 16K image).
pub const MAX_PIXELS: u64 = 1 << 28;

/// Renders `grid` seen by `camera`.
pub fn render(grid: &CellGrid, camera: &Camera, options: &RenderOptions) -> Result<Image> {
    render_with_progress(grid, camera, options, &Progress::new())
}

/// Pixels of one tile: the unit of work between progress updates and cancel checks, whole rows
/// of at least this many pixels.
const TILE_PIXELS: usize = 4096;

/// [`render`], counting finished image rows in `progress` (one pass over the image for Phong,
/// one plus the sample count for path tracing, so `total` is passes × height) and stopping
/// with [`isogrid::ErrorKind::Cancelled`] within one tile of [`Progress::cancel`].
pub fn render_with_progress(
    grid: &CellGrid,
    camera: &Camera,
    options: &RenderOptions,
    progress: &Progress,
) -> Result<Image> {
    camera.validate()?;
    let (w, h) = (camera.width, camera.height);
    let n = w as u64 * h as u64;
    if n > MAX_PIXELS {
        return Err(Error::too_large(format!(
            "image {w}x{h} has more than {MAX_PIXELS} pixels"
        )));
    }
    let passes = match &options.shading {
        Shading::Phong => 1,
        Shading::PathTrace(p) => {
            if p.samples_per_pixel == 0 {
                return Err(Error::invalid("samples per pixel must be at least 1"));
            }
            1 + p.samples_per_pixel as u64
        }
    };
    let constant = match &options.shading {
        Shading::PathTrace(p) => p.albedo,
        Shading::Phong => ALBEDO,
    };
    let albedo = Albedo {
        colored: match (&options.coloring, grid.attribute()) {
            (Some(coloring), Some(attribute)) => Some((attribute, coloring)),
            (Some(_), None) => {
                return Err(Error::invalid(
                    "colouring asks for the grid's attribute, and the grid has none",
                ))
            }
            (None, _) => None,
        },
        labels: grid.labels(),
        constant,
    };
    progress.start(passes * h as u64);
    let build = std::time::Instant::now();
    let tracer = GridTracer::new(grid, options.crossing, options.traversal);
    let build_seconds = build.elapsed().as_secs_f64();
    progress.check()?;
    let pixel = |i: usize| ((i % w as usize) as u32, (i / w as usize) as u32);
    let tile_rows = TILE_PIXELS.div_ceil(w as usize);
    let tile = tile_rows * w as usize;
    // Each tile skips its work once cancelled; the pass then ends with the cancel error.
    let tile_rows_of = |len: usize| (len / w as usize) as u64;
    let mut primary: Vec<Option<Hit>> = vec![None; n as usize];
    primary
        .par_chunks_mut(tile)
        .enumerate()
        .for_each(|(t, hits)| {
            if progress.is_cancelled() {
                return;
            }
            for (k, hit) in hits.iter_mut().enumerate() {
                let (x, y) = pixel(t * tile + k);
                *hit = tracer.closest_hit(&camera.ray(x, y), 0.0, f64::INFINITY);
            }
            progress.advance(tile_rows_of(hits.len()));
        });
    progress.check()?;
    let mut rays_traced = n;

    let radiance: Vec<[f32; 3]> = match &options.shading {
        Shading::Phong => {
            let (right, up, forward) = camera.basis();
            let to_camera = |v: [f64; 3]| [dot(v, right), dot(v, up), -dot(v, forward)];
            let background = BACKGROUND_SRGB.map(srgb8_to_linear);
            primary
                .par_iter()
                .enumerate()
                .with_min_len(64)
                .map(|(i, hit)| match hit {
                    None => background,
                    Some(hit) => {
                        let (x, y) = pixel(i);
                        let d = to_camera(camera.ray(x, y).direction);
                        let n = to_camera(hit.normal);
                        shade_albedo(n.map(|v| v as f32), d.map(|v| -v as f32), albedo.of(hit))
                    }
                })
                .collect()
        }
        Shading::PathTrace(p) => {
            let mut sum = vec![[0.0f64; 3]; n as usize];
            let world = grid.info().spacing;
            let offset = 1e-3 * world.iter().cloned().fold(f64::INFINITY, f64::min);
            for s in 0..p.samples_per_pixel {
                rays_traced += sum
                    .par_chunks_mut(tile)
                    .enumerate()
                    .map(|(t, accs)| {
                        if progress.is_cancelled() {
                            return 0;
                        }
                        let mut rays = 0;
                        for (k, acc) in accs.iter_mut().enumerate() {
                            let i = t * tile + k;
                            let mut rng = Rng::for_sample(p.seed, i as u64, s as u64);
                            let (x, y) = pixel(i);
                            let ray = camera.ray_at(x as f64 + rng.unit(), y as f64 + rng.unit());
                            let (l, path_rays) =
                                trace_path(&tracer, ray, p, &albedo, offset, &mut rng);
                            for c in 0..3 {
                                acc[c] += l[c] as f64;
                            }
                            rays += path_rays;
                        }
                        progress.advance(tile_rows_of(accs.len()));
                        rays
                    })
                    .sum::<u64>();
                progress.check()?;
            }
            let inv = 1.0 / p.samples_per_pixel as f64;
            sum.iter().map(|v| v.map(|c| (c * inv) as f32)).collect()
        }
    };

    let rgb8 = radiance.iter().flat_map(|c| c.map(to_srgb8)).collect();
    let depth = primary
        .iter()
        .map(|h| h.map_or(f32::INFINITY, |h| h.t as f32))
        .collect();
    let normal = primary
        .iter()
        .map(|h| h.map_or([f32::NAN; 3], |h| h.normal.map(|v| v as f32)))
        .collect();
    let cluster = primary
        .iter()
        .map(|h| h.map_or(u32::MAX, |h| h.cluster))
        .collect();
    let value = grid.attribute().map(|attribute| {
        primary
            .iter()
            .map(|h| h.map_or(f32::NAN, |h| attribute.value(h.cell as usize)))
            .collect()
    });
    Ok(Image {
        width: w,
        height: h,
        rgb8,
        radiance,
        depth,
        normal,
        cluster,
        value,
        rays_traced,
        build_seconds,
    })
}

/// Radiance carried back along `ray` (one path, see the module docs) and the rays it took.
fn trace_path(
    tracer: &GridTracer,
    mut ray: Ray,
    p: &PathTraceOptions,
    albedo: &Albedo,
    offset: f64,
    rng: &mut Rng,
) -> ([f32; 3], u64) {
    let mut throughput = [1.0f32; 3];
    for depth in 0..=p.bounces {
        let Some(hit) = tracer.closest_hit(&ray, 0.0, f64::INFINITY) else {
            let env = p.environment.radiance(ray.direction);
            let l = std::array::from_fn(|c| throughput[c] * env[c]);
            return (l, depth as u64 + 1);
        };
        if depth == p.bounces {
            break;
        }
        // Scatter on the side the ray came from.
        let n = if dot(hit.normal, ray.direction) > 0.0 {
            hit.normal.map(|v| -v)
        } else {
            hit.normal
        };
        let point = [0, 1, 2].map(|a| ray.origin[a] + hit.t * ray.direction[a] + offset * n[a]);
        ray = Ray {
            origin: point,
            direction: cosine_hemisphere(n, rng),
        };
        // Cosine-weighted sampling cancels cos θ / π of the Lambertian BRDF: only albedo remains.
        for (t, a) in throughput.iter_mut().zip(albedo.of(&hit)) {
            *t *= a;
        }
    }
    ([0.0; 3], p.bounces as u64 + 1)
}

use isogrid::colormap::srgb8_to_linear;

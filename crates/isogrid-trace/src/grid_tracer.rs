//! Either traversal of one grid behind one type, for callers that let the user choose: the
//! paper's block walk ([`Tracer`], §3.6) or the hierarchy over regrouped metacells
//! ([`BvhTracer`], the paper's future work). Both run the same search inside a cluster, so they
//! find the same crossings (`t` equal to rounding; `tests/it/trace_bvh.rs`); they differ in speed
//! and in what they build before the first ray.
//!
//! ```
//! use isogrid_trace::{Crossing, GridTracer, Traversal};
//! use isogrid::{extract, generate::{generate, Field}, ExtractOptions, Iso, Ray};
//! let volume = generate(Field::Sphere, 24, 0);
//! let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
//! let ray = Ray { origin: [11.5, 11.5, -10.0], direction: [0.0, 0.0, 1.0] };
//! let [blocks, bvh] = [Traversal::Blocks, Traversal::Bvh]
//!     .map(|t| GridTracer::new(&grid, Crossing::Samples3, t).closest_hit(&ray, 0.0, f64::INFINITY));
//! assert!((blocks.unwrap().t - bvh.unwrap().t).abs() < 1e-9);
//! assert_eq!(Traversal::from_name("bvh"), Some(Traversal::Bvh));
//! assert_eq!(Traversal::from_name("octree"), None);
//! ```

use crate::block_traverse::{closest_hits, Tracer};
use crate::bvh_traverse::BvhTracer;
use crate::cluster_search::{Hit, Occlusion};
use crate::crossing::Crossing;
use isogrid::camera::Ray;
use isogrid::grid::CellGrid;

/// How rays find the metacells they may cross.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Traversal {
    /// 3D DDA over the 16³-cell blocks, leaping across empty space, then each block's cluster
    /// bounds (the paper's §3.6). Builds little (8 bytes per block, 68 per cluster) in next to no
    /// time. The default: over five runs of `scripts/bench_render_cpu.py` (1080p Phong and
    /// 960×540 path-traced frames of MNI and the dragon, `docs/benchmarks-render-cpu.md`) the
    /// hierarchy's frames took 0.82–1.21× the block walk's time, neither side winning
    /// throughout.
    #[default]
    Blocks,
    /// An 8-wide bounding volume hierarchy over the metacells regrouped by space into leaf
    /// clusters. Faster per ray: random rays from inside the grid's box 1.4–1.6×
    /// (`docs/benchmarks-rays.md`); a rendered frame's camera rays and path bounces in
    /// 0.76–1.04× the block walk's time (tracing only, three runs). It builds, on one core, in
    /// about 0.04 (MNI) to 0.10 s (the 512³ dragon), which a frame pays for, and adds about 0.45× the
    /// grid's bytes.
    Bvh,
}

impl Traversal {
    pub const ALL: [Traversal; 2] = [Traversal::Blocks, Traversal::Bvh];

    /// The traversal [`Self::name`] spells `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// `"blocks"` or `"bvh"`, as the CLI and JSON reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            Traversal::Blocks => "blocks",
            Traversal::Bvh => "bvh",
        }
    }
}

/// A [`Tracer`] or a [`BvhTracer`] of one grid; `Sync`.
// One per render, never in a collection: the larger variant's size costs nothing, while a box
// would add a load to every ray.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum GridTracer<'g> {
    Blocks(Tracer<'g>),
    Bvh(BvhTracer<'g>),
}

impl<'g> GridTracer<'g> {
    /// Builds what `traversal` needs (the BVH's build runs on the current rayon pool).
    pub fn new(grid: &'g CellGrid, crossing: Crossing, traversal: Traversal) -> Self {
        match traversal {
            Traversal::Blocks => GridTracer::Blocks(Tracer::new(grid, crossing)),
            Traversal::Bvh => GridTracer::Bvh(BvhTracer::new(grid, crossing)),
        }
    }

    pub fn traversal(&self) -> Traversal {
        match self {
            GridTracer::Blocks(_) => Traversal::Blocks,
            GridTracer::Bvh(_) => Traversal::Bvh,
        }
    }

    /// The closest crossing with `t ∈ [tmin, tmax]`, as [`Tracer::closest_hit`].
    #[inline]
    pub fn closest_hit(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        match self {
            GridTracer::Blocks(t) => t.closest_hit(ray, tmin, tmax),
            GridTracer::Bvh(t) => t.closest_hit(ray, tmin, tmax),
        }
    }

    /// Whether anything blocks the ray within `[tmin, tmax]`, as [`Tracer::any_hit`].
    pub fn any_hit(&self, ray: &Ray, tmin: f64, tmax: f64, occlusion: Occlusion) -> bool {
        match self {
            GridTracer::Blocks(t) => t.any_hit(ray, tmin, tmax, occlusion),
            GridTracer::Bvh(t) => t.any_hit(ray, tmin, tmax, occlusion),
        }
    }

    /// Closest hits of many rays in parallel (`t ∈ [0, ∞)`); `out[i]` answers `rays[i]`.
    ///
    /// # Panics
    /// When `out` and `rays` differ in length.
    pub fn closest_hits(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        match self {
            GridTracer::Blocks(t) => closest_hits(t, rays, out),
            GridTracer::Bvh(t) => t.closest_hits(rays, out),
        }
    }

    /// Bytes the traversal adds to the grid's own buffers.
    pub fn extra_bytes(&self) -> usize {
        match self {
            GridTracer::Blocks(t) => t.extra_bytes(),
            GridTracer::Bvh(t) => t.extra_bytes(),
        }
    }

    /// The SIMD set of the box tests ("avx2" or "baseline").
    pub fn simd(&self) -> &'static str {
        match self {
            GridTracer::Blocks(t) => t.simd(),
            GridTracer::Bvh(t) => t.simd(),
        }
    }
}

//! Ray tracing (paper §3.6) against a brute-force reference: every active cell of the grid is
//! tested for every ray (no hierarchy), the trilinear field of its stored corners is fine-stepped
//! along the ray and bisected, and the closest crossing kept. Also normals, any-hit, the renderer's
//! conventions and a white furnace for the path tracer.

use crate::common::{blobs_u8, field, random_u8, Rng};
use isogrid::generate::{generate, Field};
use isogrid::layout::{read_corners, BOUND_SLOT, CLUSTER_SLOTS};
use isogrid::{extract, Camera, CellGrid, ExtractOptions, Iso, Precision, Ray, Volume, VolumeData};
use isogrid_trace::{
    render, Crossing, Environment, GridTracer, Occlusion, PathTraceOptions, RenderOptions, Shading,
    Tracer, Traversal,
};

/// One active cell as the reference sees it.
struct RefCell {
    position: [u32; 3],
    corners: [f64; 8],
}

/// All active cells, read straight from the metacell slots.
fn reference_cells(grid: &CellGrid) -> Vec<RefCell> {
    let precision = grid.info().precision;
    let mut out = Vec::new();
    for (slot, m) in grid.metacells().iter().enumerate() {
        if slot % CLUSTER_SLOTS == BOUND_SLOT {
            continue;
        }
        let mut k = 0;
        for bit in 0..8 {
            if m.cell_mask >> bit & 1 == 1 {
                let c = read_corners(grid.cell_record((m.cell_pointer + k) as usize), precision);
                k += 1;
                out.push(RefCell {
                    position: m.cell_position(bit),
                    corners: c.map(|v| v as f64),
                });
            }
        }
    }
    out
}

/// Trilinear interpolation by nested lerps (independent of the library's polynomial form).
fn trilinear(c: &[f64; 8], u: [f64; 3]) -> f64 {
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(c[0], c[1], u[0]);
    let x10 = lerp(c[2], c[3], u[0]);
    let x01 = lerp(c[4], c[5], u[0]);
    let x11 = lerp(c[6], c[7], u[0]);
    lerp(lerp(x00, x10, u[1]), lerp(x01, x11, u[1]), u[2])
}

/// Gradient by central differences of [`trilinear`] (cell units).
fn gradient(c: &[f64; 8], u: [f64; 3]) -> [f64; 3] {
    let h = 1e-6;
    [0, 1, 2].map(|a| {
        let mut p = u;
        let mut m = u;
        p[a] += h;
        m[a] -= h;
        (trilinear(c, p) - trilinear(c, m)) / (2.0 * h)
    })
}

struct RefHit {
    t: f64,
    position: [u32; 3],
    /// World gradient of the field at the hit.
    gradient: [f64; 3],
}

const STEPS: usize = 200;

/// Closest crossing in `[tmin, tmax]` over all active cells: per cell, the ray's segment in the
/// world box, fine-stepped from its start for the first change of side, then bisected.
fn reference_hit(
    cells: &[RefCell],
    spacing: [f64; 3],
    iso: f64,
    ray: &Ray,
    tmin: f64,
    tmax: f64,
) -> Option<RefHit> {
    let mut best: Option<RefHit> = None;
    for cell in cells {
        let lo: [f64; 3] = [0, 1, 2].map(|a| cell.position[a] as f64 * spacing[a]);
        let hi: [f64; 3] = [0, 1, 2].map(|a| (cell.position[a] + 1) as f64 * spacing[a]);
        let (mut t0, mut t1) = (tmin, tmax.min(best.as_ref().map_or(f64::INFINITY, |b| b.t)));
        for a in 0..3 {
            let d = ray.direction[a];
            if d == 0.0 {
                if ray.origin[a] < lo[a] || ray.origin[a] > hi[a] {
                    t0 = f64::INFINITY;
                }
                continue;
            }
            let (ta, tb) = ((lo[a] - ray.origin[a]) / d, (hi[a] - ray.origin[a]) / d);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if t0 >= t1 || t0.is_nan() || t1.is_nan() {
            continue;
        }
        let local =
            |t: f64| [0, 1, 2].map(|a| (ray.origin[a] + t * ray.direction[a] - lo[a]) / spacing[a]);
        let inside = |t: f64| trilinear(&cell.corners, local(t)) >= iso;
        let start = inside(t0);
        let mut prev = t0;
        for k in 1..=STEPS {
            let t = t0 + (t1 - t0) * k as f64 / STEPS as f64;
            if inside(t) != start {
                let (mut a, mut b) = (prev, t);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if inside(m) == start {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let g = gradient(&cell.corners, local(b).map(|v| v.clamp(0.0, 1.0)));
                best = Some(RefHit {
                    t: b,
                    position: cell.position,
                    gradient: [0, 1, 2].map(|a| g[a] / spacing[a]),
                });
                break;
            }
            prev = t;
        }
    }
    best
}

/// Rays with origins in the world box grown by half its size on every side, half of them aimed at
/// a random point of the box (to hit often), half in uniform random directions.
fn random_rays(lo: [f64; 3], hi: [f64; 3], count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|i| {
            let origin = rng.point_in(lo, hi, 0.5);
            let d = if i % 2 == 0 {
                let target = rng.point_in(lo, hi, 0.0);
                [0, 1, 2].map(|a| target[a] - origin[a])
            } else {
                let z = 2.0 * rng.unit() - 1.0;
                let phi = std::f64::consts::TAU * rng.unit();
                let r = (1.0 - z * z).sqrt();
                [r * phi.cos(), r * phi.sin(), z]
            };
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            Ray {
                origin,
                direction: d.map(|v| v / n),
            }
        })
        .collect()
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    reference_hits: usize,
    samples3_misses: usize,
    exact_extra: usize,
}

/// Compares `Exact` (tightly) and `Samples3` (misses counted) with the reference on `rays`.
fn check_against_reference(grid: &CellGrid, rays: &[Ray], what: &str) -> Tally {
    let info = grid.info();
    let spacing = info.spacing;
    let iso = info.mapping.iso_code as f64;
    let cells = reference_cells(grid);
    let exact = Tracer::new(grid, Crossing::Exact);
    let samples3 = Tracer::new(grid, Crossing::Samples3);
    let tol = 1e-4 * spacing.iter().cloned().fold(0.0, f64::max);
    let mut tally = Tally::default();
    for (i, ray) in rays.iter().enumerate() {
        tally.rays += 1;
        let reference = reference_hit(&cells, spacing, iso, ray, 0.0, f64::INFINITY);
        let e = exact.closest_hit(ray, 0.0, f64::INFINITY);
        let s = samples3.closest_hit(ray, 0.0, f64::INFINITY);
        match (&reference, &e) {
            (Some(r), Some(h)) if (r.t - h.t).abs() <= tol => {
                tally.reference_hits += 1;
                let n = h.normal;
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                assert!((len - 1.0).abs() < 1e-9, "{what} ray {i}: |n| = {len}");
                let g = r.gradient;
                let gl = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                if gl > 1e-3 && r.position == h.position {
                    let cos = -(n[0] * g[0] + n[1] * g[1] + n[2] * g[2]) / gl;
                    assert!(
                        cos > 1.0 - 1e-6,
                        "{what} ray {i}: normal off by acos({cos})"
                    );
                }
                let cell = &cells
                    .iter()
                    .find(|c| c.position == h.position)
                    .expect("hit cell is active");
                assert!(cell.position == h.position);
                assert!(h.cluster < grid.clusters() as u32);
            }
            (reference, Some(h)) if reference.as_ref().is_none_or(|r| h.t < r.t) => {
                // Exact found an earlier crossing than the reference's fine steps: it must be a
                // genuine, very thin double crossing of its cell (checked just around it).
                tally.exact_extra += 1;
                let cell = cells.iter().find(|c| c.position == h.position).unwrap();
                let lo: [f64; 3] = [0, 1, 2].map(|a| h.position[a] as f64 * spacing[a]);
                let at = |t: f64| {
                    let u = [0, 1, 2]
                        .map(|a| (ray.origin[a] + t * ray.direction[a] - lo[a]) / spacing[a]);
                    trilinear(&cell.corners, u) >= iso
                };
                assert!(
                    at(h.t - 1e-7) != at(h.t + 1e-9) || at(h.t - 1e-7) != at(h.t),
                    "{what} ray {i}: exact hit at {} is not a crossing (reference {:?})",
                    h.t,
                    reference.as_ref().map(|r| r.t)
                );
                if let Some(r) = reference {
                    tally.reference_hits += 1;
                    let _ = r;
                }
            }
            (None, None) => {}
            (r, h) => panic!(
                "{what} ray {i} {ray:?}: exact {:?} vs reference {:?}",
                h.map(|h| (h.t, h.position)),
                r.as_ref().map(|r| (r.t, r.position))
            ),
        }
        // Samples3 finds the same crossing or a later one (a missed thin double crossing).
        if let Some(r) = &reference {
            match s {
                Some(h) if (h.t - r.t).abs() <= tol => {}
                Some(h) if h.t > r.t => tally.samples3_misses += 1,
                None => tally.samples3_misses += 1,
                Some(h) => {
                    // Earlier than the reference: must agree with exact.
                    let e = e.expect("exact hits where samples3 does");
                    assert!(
                        (h.t - e.t).abs() <= tol,
                        "{what} ray {i}: samples3 {} exact {}",
                        h.t,
                        e.t
                    );
                }
            }
        } else if let Some(h) = s {
            let e = e.expect("samples3 hit must be a real crossing that exact finds");
            assert!(h.t >= e.t - tol, "{what} ray {i}");
        }
    }
    tally
}

fn grid_of(volume: &Volume, iso: Iso, precision: Precision) -> CellGrid {
    extract(
        &volume.view(),
        &ExtractOptions::new(iso).with_precision(precision),
    )
    .unwrap()
}

fn world_box(grid: &CellGrid) -> ([f64; 3], [f64; 3]) {
    grid.info().world_bounds()
}

#[test]
fn exact_matches_brute_force_on_blobs_at_every_precision() {
    let volume = blobs_u8([30, 26, 34]);
    for (k, precision) in Precision::ALL.into_iter().enumerate() {
        let grid = grid_of(&volume, Iso::Value(127.5), precision);
        let (lo, hi) = world_box(&grid);
        let rays = random_rays(lo, hi, 300, 11 + k as u64);
        let t = check_against_reference(&grid, &rays, &format!("blobs {precision:?}"));
        eprintln!("blobs {precision:?}: {t:?}");
        assert!(t.reference_hits > 50, "{t:?}");
        // Smooth field: Samples3 misses only thin grazing double crossings.
        assert!(t.samples3_misses * 50 <= t.reference_hits, "{t:?}");
    }
}

/// Two small balls in opposite corners of a mostly empty, anisotropic grid: rays leap across
/// cubes of empty blocks (the tracer's octant empty-space map) before they meet a ball, and must find the
/// reference's crossings all the same, whichever side they come from.
#[test]
fn exact_matches_brute_force_after_long_leaps_across_empty_space() {
    const SPACING: [f64; 3] = [0.8, 1.25, 1.0];
    let dims = [120, 100, 130];
    let centres = [[16.0, 20.0, 18.0], [100.0, 80.0, 110.0]];
    let values = field(dims, |x, y, z| {
        let d = centres
            .iter()
            .map(|c| ((x - c[0]).powi(2) + (y - c[1]).powi(2) + (z - c[2]).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min);
        (255.0 * (7.0 - d).clamp(0.0, 1.0)).round()
    });
    let mut geometry = isogrid::Geometry::new(dims);
    geometry.spacing = SPACING;
    let data = VolumeData::U8(values.iter().map(|&v| v as u8).collect());
    let volume = Volume::with_geometry(geometry, data).unwrap();
    let grid = grid_of(&volume, Iso::Value(127.5), Precision::Bits8);
    let block_dims = grid.info().block_dims().map(|b| b as usize);
    let map = isogrid::skip::empty_space::EmptySpaceMap::new(grid.blocks(), block_dims);
    let longest = (0..grid.blocks().len()).map(|i| map.distance(i)).max();
    assert!(longest >= Some(4), "longest leap {longest:?} blocks");
    // The CPU tracer leaps across cubes that grow towards the ray's octant only: from blocks
    // beside a ball too (symmetric distance 1), when the ray moves away from it.
    let octants = isogrid::skip::octant_space::OctantSpaceMap::new(grid.blocks(), block_dims);
    let beside = (0..grid.blocks().len())
        .filter(|&i| map.distance(i) == 1 && (0..8).any(|o| octants.octant(o)[i] >= 4))
        .count();
    assert!(beside > 0, "no long octant leap beside a ball");

    // From anywhere around the box towards a point near either ball's centre.
    let (lo, hi) = world_box(&grid);
    let mut rng = Rng::new(77);
    let rays: Vec<Ray> = (0..240)
        .map(|i| {
            let origin: [f64; 3] = std::array::from_fn(|a| {
                let size = hi[a] - lo[a];
                lo[a] - 0.2 * size + 1.4 * size * rng.unit()
            });
            let c = centres[i % 2];
            let target: [f64; 3] =
                std::array::from_fn(|a| (c[a] + 8.0 * (rng.unit() - 0.5)) * SPACING[a]);
            let d: [f64; 3] = std::array::from_fn(|a| target[a] - origin[a]);
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            Ray {
                origin,
                direction: d.map(|v| v / n),
            }
        })
        .collect();
    let t = check_against_reference(&grid, &rays, "two balls");
    eprintln!("two balls, longest leap {longest:?} blocks: {t:?}");
    assert!(t.reference_hits >= 120, "{t:?}");
}

/// Rays along exact diagonals cross two or three of a metacell's mid-planes at the same `t`: the
/// walk through its cells must neither stop nor skip a cell there.
#[test]
fn diagonal_rays_through_metacell_centres_match_brute_force() {
    let volume = blobs_u8([30, 26, 34]);
    let grid = grid_of(&volume, Iso::Value(127.5), Precision::Bits8);
    let s2 = std::f64::consts::FRAC_1_SQRT_2;
    let s3 = 1.0 / 3f64.sqrt();
    let mut rays = Vec::new();
    for i in 0..24 {
        for j in 0..12 {
            // Origins on even (metacell-corner) coordinates, so the mid-planes line up.
            let (u, v) = (2.0 * i as f64 - 10.0, 2.0 * j as f64);
            rays.push(Ray {
                origin: [u, u - 2.0 * (j % 3) as f64, v + 1.0],
                direction: [s2, s2, 0.0],
            });
            rays.push(Ray {
                origin: [v + 1.0, u, u],
                direction: [0.0, s2, s2],
            });
            rays.push(Ray {
                origin: [u, u, u + v - 12.0],
                direction: [s3, s3, s3],
            });
        }
    }
    let t = check_against_reference(&grid, &rays, "diagonals");
    eprintln!("diagonals: {t:?}");
    assert!(t.reference_hits > 200, "{t:?}");
}

#[test]
fn exact_matches_brute_force_on_an_anisotropic_sphere() {
    let dims = [21, 17, 13];
    let spacing = [0.7, 1.3, 2.0];
    let c = [10.0 * 0.7, 8.0 * 1.3, 6.0 * 2.0];
    let values = field(dims, |x, y, z| {
        let p = [
            x * spacing[0] - c[0],
            y * spacing[1] - c[1],
            z * spacing[2] - c[2],
        ];
        9.0 - (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
    });
    let volume = Volume::new(
        dims,
        VolumeData::F32(values.iter().map(|&v| v as f32).collect()),
    )
    .unwrap()
    .with_spacing(spacing)
    .unwrap();
    for precision in [Precision::Float32, Precision::Bits16] {
        let grid = grid_of(&volume, Iso::Value(0.0), precision);
        let (lo, hi) = world_box(&grid);
        let rays = random_rays(lo, hi, 300, 5);
        let t = check_against_reference(&grid, &rays, &format!("sphere {precision:?}"));
        eprintln!("anisotropic sphere {precision:?}: {t:?}");
        assert!(t.reference_hits > 100, "{t:?}");
        assert!(t.samples3_misses * 50 <= t.reference_hits, "{t:?}");
        // The traced surface is the analytic sphere to within the trilinear error.
        let tracer = Tracer::new(&grid, Crossing::Exact);
        for ray in &rays {
            if let Some(h) = tracer.closest_hit(ray, 0.0, f64::INFINITY) {
                let p = [0, 1, 2].map(|a| ray.origin[a] + h.t * ray.direction[a] - c[a]);
                let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                assert!((r - 9.0).abs() < 0.1, "radius {r}");
                let radial = p.map(|v| v / r);
                let cos =
                    radial[0] * h.normal[0] + radial[1] * h.normal[1] + radial[2] * h.normal[2];
                assert!(cos > 0.97, "normal points out of the solid: {cos}");
            }
        }
    }
}

#[test]
fn exact_never_misses_on_random_noise_at_several_isovalues() {
    let volume = random_u8([14, 11, 17], 3, 256);
    let mut total_misses = 0;
    let mut total_hits = 0;
    for (k, (iso, precision)) in [
        (64.0, Precision::Bits8),
        (127.5, Precision::Bits8),
        (200.0, Precision::Bits4),
        (100.0, Precision::Bits16),
    ]
    .into_iter()
    .enumerate()
    {
        let grid = grid_of(&volume, Iso::Value(iso), precision);
        let (lo, hi) = world_box(&grid);
        let rays = random_rays(lo, hi, 200, 40 + k as u64);
        let t = check_against_reference(&grid, &rays, &format!("noise {iso} {precision:?}"));
        eprintln!("noise iso {iso} {precision:?}: {t:?}");
        assert!(t.reference_hits > 50, "{t:?}");
        total_misses += t.samples3_misses;
        total_hits += t.reference_hits;
    }
    // Noise has many thin features, so Samples3 misses more than on smooth fields; still bounded.
    assert!(
        total_misses * 10 <= total_hits,
        "{total_misses} of {total_hits}"
    );
}

#[test]
fn rays_starting_inside_the_solid_find_the_way_out() {
    // Gyroid: open, fills the cube, so many origins lie inside the solid.
    let volume = generate(Field::Gyroid, 26, 0);
    let grid = grid_of(&volume, Iso::Normalized(0.5), Precision::Bits8);
    let (lo, hi) = world_box(&grid);
    let mut rng = Rng::new(99);
    let rays: Vec<Ray> = random_rays(lo, hi, 250, 8)
        .into_iter()
        .map(|mut r| {
            r.origin = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * rng.unit());
            r
        })
        .collect();
    let t = check_against_reference(&grid, &rays, "gyroid");
    eprintln!("gyroid: {t:?}");
    assert!(t.reference_hits > 150, "{t:?}");
}

#[test]
fn any_hit_agrees_with_closest_hit_on_occlusion() {
    let volume = blobs_u8([26, 30, 22]);
    let grid = grid_of(&volume, Iso::Value(127.5), Precision::Bits8);
    let (lo, hi) = world_box(&grid);
    let cells = reference_cells(&grid);
    let mut rng = Rng::new(7);
    let mut occluded = 0;
    for crossing in [Crossing::Exact, Crossing::Samples3] {
        let tracer = Tracer::new(&grid, crossing);
        for ray in random_rays(lo, hi, 400, 21) {
            let tmin = 5.0 * rng.unit();
            let tmax = tmin + 40.0 * rng.unit();
            let closest = tracer.closest_hit(&ray, tmin, tmax);
            let surface = tracer.any_hit(&ray, tmin, tmax, Occlusion::Surface);
            assert_eq!(surface, closest.is_some());
            if let Some(h) = closest {
                assert!(h.t >= tmin && h.t <= tmax);
                occluded += 1;
            }
            // Cell boxes: exactly "some active cell box overlaps [tmin, tmax] of the ray".
            let boxes = tracer.any_hit(&ray, tmin, tmax, Occlusion::CellBoxes);
            let brute = cells.iter().any(|c| {
                let (mut t0, mut t1) = (tmin, tmax);
                for a in 0..3 {
                    let l = c.position[a] as f64 - ray.origin[a];
                    let (ta, tb) = (l / ray.direction[a], (l + 1.0) / ray.direction[a]);
                    t0 = t0.max(ta.min(tb));
                    t1 = t1.min(ta.max(tb));
                }
                t0 < t1
            });
            assert_eq!(boxes, brute);
            assert!(boxes || !surface, "cell boxes must be conservative");
        }
    }
    assert!(occluded > 100);
}

#[test]
fn renderer_empty_grid_shows_background_and_miss_conventions() {
    let volume = Volume::new([20, 20, 20], VolumeData::U8(vec![0; 8000])).unwrap();
    let grid = grid_of(&volume, Iso::Value(100.0), Precision::Bits8);
    assert_eq!(grid.active_cells(), 0);
    let (lo, hi) = world_box(&grid);
    let camera = Camera::preset(2, lo, hi, 16, 9).unwrap();
    let image = render(&grid, &camera, &RenderOptions::default()).unwrap();
    assert_eq!(image.rgb8.len(), 16 * 9 * 3);
    assert!(image
        .rgb8
        .chunks(3)
        .all(|p| p == isogrid::shading::BACKGROUND_SRGB));
    assert!(image.depth.iter().all(|d| *d == f32::INFINITY));
    assert!(image.normal.iter().flatten().all(|v| v.is_nan()));
    assert!(image.cluster.iter().all(|&c| c == u32::MAX));
    assert_eq!(image.hits(), 0);
}

#[test]
fn renderer_aovs_match_the_tracer_and_the_analytic_sphere() {
    for traversal in [Traversal::Blocks, Traversal::Bvh] {
        renderer_aovs_match(traversal);
    }
}

/// The renderer with `traversal` against closest hits of that traversal's own tracer.
fn renderer_aovs_match(traversal: Traversal) {
    let size = 32;
    let volume = generate(Field::Sphere, size, 0);
    let grid = grid_of(&volume, Iso::Normalized(0.5), Precision::Bits8);
    let (lo, hi) = world_box(&grid);
    let camera = Camera::preset(1, lo, hi, 40, 30).unwrap();
    let options = RenderOptions {
        crossing: Crossing::Exact,
        traversal,
        shading: Shading::Phong,
        coloring: None,
    };
    let image = render(&grid, &camera, &options).unwrap();
    let tracer = GridTracer::new(&grid, Crossing::Exact, traversal);
    assert_eq!(tracer.traversal(), traversal);
    let centre = (size as f64 - 1.0) / 2.0;
    let radius = 0.4 * (size as f64 - 1.0);
    let mut hits = 0;
    for y in 0..30 {
        for x in 0..40 {
            let i = (x + 40 * y) as usize;
            let ray = camera.ray(x, y);
            match tracer.closest_hit(&ray, 0.0, f64::INFINITY) {
                None => {
                    assert_eq!(image.depth[i], f32::INFINITY);
                    assert_eq!(image.cluster[i], u32::MAX);
                    assert_eq!(
                        &image.rgb8[3 * i..3 * i + 3],
                        isogrid::shading::BACKGROUND_SRGB
                    );
                }
                Some(h) => {
                    hits += 1;
                    assert_eq!(image.depth[i], h.t as f32);
                    assert_eq!(image.cluster[i], h.cluster);
                    let p = [0, 1, 2].map(|a| ray.origin[a] + h.t * ray.direction[a] - centre);
                    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    assert!((r - radius).abs() < 0.3, "radius {r} vs {radius}");
                    let n = image.normal[i];
                    let cos = (0..3).map(|a| n[a] as f64 * p[a] / r).sum::<f64>();
                    assert!(cos > 0.95, "normal {n:?} at {p:?}");
                    // Lit from the front: brighter than the background.
                    assert!(image.rgb8[3 * i] > isogrid::shading::BACKGROUND_SRGB[0]);
                }
            }
        }
    }
    assert_eq!(image.hits(), hits);
    assert!(hits > 100, "{traversal:?}: {hits}");
}

fn furnace(albedo: f32) -> (isogrid_trace::Image, f64) {
    let volume = generate(Field::Sphere, 24, 0);
    let grid = grid_of(&volume, Iso::Normalized(0.5), Precision::Bits8);
    let (lo, hi) = world_box(&grid);
    let camera = Camera::preset(2, lo, hi, 32, 24).unwrap();
    let options = RenderOptions {
        crossing: Crossing::Samples3,
        traversal: Traversal::default(),
        shading: Shading::PathTrace(PathTraceOptions {
            samples_per_pixel: 8,
            bounces: 3,
            environment: Environment::Uniform([1.0; 3]),
            albedo: [albedo; 3],
            seed: 1,
        }),
        coloring: None,
    };
    let image = render(&grid, &camera, &options).unwrap();
    let mean =
        image.radiance.iter().map(|c| c[1] as f64).sum::<f64>() / image.radiance.len() as f64;
    (image, mean)
}

#[test]
fn white_furnace_every_pixel_is_one() {
    // Albedo 1 under a white sky: a path that escapes carries exactly 1; from the outside of a
    // (nearly) convex sphere nearly every bounce escapes at once.
    let (image, mean) = furnace(1.0);
    assert!(image.hits() > 60, "{}", image.hits());
    for c in image.radiance.iter().flatten() {
        assert!(*c <= 1.0 + 1e-6 && *c >= 0.95, "{c}");
    }
    assert!((mean - 1.0).abs() < 0.01, "mean {mean}");
    // Albedo ½: pixels well inside the silhouette ≈ ½ (one bounce, then escape), misses 1.
    let (image, _) = furnace(0.5);
    let (w, h) = (image.width as i64, image.height as i64);
    let hit = |x: i64, y: i64| {
        x >= 0 && y >= 0 && x < w && y < h && image.cluster[(x + w * y) as usize] != u32::MAX
    };
    let mut interior = 0;
    for y in 0..h {
        for x in 0..w {
            let c = image.radiance[(x + w * y) as usize][0];
            if (-1..=1).all(|dy| (-1..=1).all(|dx| hit(x + dx, y + dy))) {
                interior += 1;
                assert!((0.45..=0.5 + 1e-6).contains(&c), "({x}, {y}): {c}");
            } else if (-1..=1).all(|dy| (-1..=1).all(|dx| !hit(x + dx, y + dy))) {
                assert!((c - 1.0).abs() < 1e-6, "({x}, {y}): {c}");
            }
        }
    }
    assert!(interior > 30, "{interior}");
    let hit_mean: f64 = image
        .radiance
        .iter()
        .zip(&image.cluster)
        .filter(|(_, &c)| c != u32::MAX)
        .map(|(r, _)| r[0] as f64)
        .sum::<f64>()
        / image.hits() as f64;
    assert!((hit_mean - 0.5).abs() < 0.05, "hit mean {hit_mean}");
}

/// A label volume's grid (one cluster per label, boundary cells stored once per label) traces as
/// the union of its label surfaces: the closest crossing over all its cells, as the brute force
/// finds it.
#[test]
fn a_labelled_grid_traces_as_the_union_of_its_label_surfaces() {
    let volume = blobs_u8([30, 26, 34]);
    let VolumeData::U8(samples) = volume.data() else {
        unreachable!("blobs are u8")
    };
    // Four bands of the blobs' values: background 0 and three nested, touching labels.
    let labels: Vec<u8> = samples.iter().map(|v| v / 64).collect();
    let labelled = Volume::new(volume.dims(), VolumeData::U8(labels)).unwrap();
    let grid = isogrid::extract_labels(
        &labelled.view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap();
    assert!(grid.labels().unwrap().table().len() >= 2);
    let cells = reference_cells(&grid);
    let spacing = grid.info().spacing;
    let iso = grid.info().mapping.iso_code as f64;
    let (lo, hi) = world_box(&grid);
    let tracer = Tracer::new(&grid, Crossing::Exact);
    let mut hits = 0;
    for (i, ray) in random_rays(lo, hi, 300, 29).iter().enumerate() {
        let reference = reference_hit(&cells, spacing, iso, ray, 0.0, f64::INFINITY);
        let hit = tracer.closest_hit(ray, 0.0, f64::INFINITY);
        match (reference, hit) {
            (Some(r), Some(h)) => {
                assert!((r.t - h.t).abs() <= 1e-4, "ray {i}: {} vs {}", h.t, r.t);
                hits += 1;
            }
            (None, None) => {}
            (r, h) => panic!("ray {i}: {:?} vs {:?}", h.map(|h| h.t), r.map(|r| r.t)),
        }
    }
    assert!(hits > 50, "{hits}");
}

/// A label grid is drawn in its labels' colours: path traced under a white furnace (radiance 1
/// everywhere, one bounce: a path that meets a second surface adds nothing), a pixel's radiance
/// is its surface's albedo times the share of its bounces that escape, so over the pixels of each label the mean colour has the direction of that label's
/// albedo, and labels of different colours give different directions.
#[test]
fn a_labelled_grid_is_drawn_in_its_label_colours() {
    // A ball cut into three labels side by side along x; the oblique view sees at least two.
    let labelled = isogrid::generate::labelled_ball(40);
    let grid = isogrid::extract_labels(
        &labelled.view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap();
    let table = grid.labels().unwrap().table().to_vec();
    assert_eq!(table.len(), 3);
    let (lo, hi) = world_box(&grid);
    let (w, h) = (128usize, 96usize);
    let camera = Camera::preset(2, lo, hi, w as u32, h as u32).unwrap();
    let options = RenderOptions {
        shading: Shading::PathTrace(PathTraceOptions {
            samples_per_pixel: 16,
            bounces: 1,
            environment: Environment::Uniform([1.0; 3]),
            ..Default::default()
        }),
        ..Default::default()
    };
    let image = render(&grid, &camera, &options).unwrap();
    let cluster_labels = grid.labels().unwrap().cluster_labels();
    let label_at = |i: usize| match image.cluster[i] {
        u32::MAX => None,
        c => Some(cluster_labels[c as usize]),
    };
    let mut sums = vec![([0.0f64; 3], 0u32); table.len()];
    // Pixels whose four neighbours show the same label: no sample of theirs sees another.
    for i in 0..w * h {
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            continue;
        }
        let Some(l) = label_at(i) else { continue };
        if [i - 1, i + 1, i - w, i + w]
            .iter()
            .any(|&j| label_at(j) != Some(l))
        {
            continue;
        }
        let l = l as usize;
        for c in 0..3 {
            sums[l].0[c] += image.radiance[i][c] as f64;
        }
        sums[l].1 += 1;
    }
    let unit = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    };
    let mut seen = 0;
    for (l, (sum, n)) in sums.iter().enumerate() {
        if *n < 30 {
            continue;
        }
        seen += 1;
        let got = unit(*sum);
        let cos = |k: usize| -> f64 {
            let want = unit(table[k].albedo().map(|a| a as f64));
            (0..3).map(|c| got[c] * want[c]).sum()
        };
        // Near its own colour (jittered samples at a pixel's edge may see a neighbour's), and
        // nearer to it than to any other label's.
        assert!(
            cos(l) > 0.99,
            "label {}: colour {got:?}, cos {}",
            table[l].value,
            cos(l)
        );
        for k in (0..table.len()).filter(|&k| k != l && table[k].rgba != table[l].rgba) {
            assert!(
                cos(l) > cos(k),
                "label {}: nearer label {}'s colour",
                table[l].value,
                table[k].value
            );
        }
    }
    assert!(seen >= 2, "{seen} labels seen");
}

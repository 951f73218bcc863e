//! The cluster hierarchy's traversal against independent answers: a search of every cluster,
//! single rays for batches, the root test for the root gate, the baseline lanes for AVX2.

use super::*;
use crate::block_traverse::Tracer;
use crate::cell_ray::{widen_f32, xyz};
use crate::cluster_search::{Best, ClusterSearch};
use crate::crossing::Crossing;
use isogrid::camera::Ray;
use isogrid::generate::{generate, Field};
use isogrid::{extract, ExtractOptions, Iso};

/// Brute force: every cluster of the grid searched with the cluster search over the grid's
/// clusters (the block walk's), in index order; the closest hit's `t`, and whether any cell box
/// is passed.
fn every_cluster(grid: &CellGrid, ray: &Ray) -> (Option<f64>, bool) {
    let tracer = ClusterSearch::new(grid, Crossing::Exact, grid.metacells());
    let r = tracer.cell_ray(ray);
    let mut best = Best::new(f64::INFINITY);
    let mut any = false;
    for (c, cluster) in grid.metacells().chunks_exact(CLUSTER_SLOTS).enumerate() {
        tracer.closest_in_cluster(Baseline, &r, cluster, c as u32, 0.0, &mut best);
        any |= tracer.any_box_in_cluster(Baseline, &r, cluster, c as u32, 0.0, f64::INFINITY);
    }
    (tracer.hit_of(ray, &best, |c, _| c).map(|h| h.t), any)
}

#[test]
fn finds_what_searching_every_cluster_finds() {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut hits = 0;
    for (field, size) in [(Field::Hairball, 40), (Field::MarschnerLobb, 33)] {
        let volume = generate(field, size, 1);
        let options = ExtractOptions::new(Iso::Normalized(0.5));
        let grid = extract(&volume.view(), &options).unwrap();
        let bvh = BvhTracer::new(&grid, Crossing::Exact);
        assert!(bvh.bvh().depth() >= 3, "{:?}", bvh.bvh());
        let n = size as f64;
        for _ in 0..250 {
            let origin: [f64; 3] = std::array::from_fn(|_| -0.3 * n + 1.6 * n * unit());
            let target: [f64; 3] = std::array::from_fn(|_| n * unit());
            let d = xyz(|a| target[a] - origin[a]);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let ray = Ray {
                origin,
                direction: d.map(|v| v / len),
            };
            let (t, any) = every_cluster(&grid, &ray);
            let got = bvh.closest_hit(&ray, 0.0, f64::INFINITY).map(|h| h.t);
            match (t, got) {
                (None, None) => {}
                (Some(a), Some(b)) if (a - b).abs() <= 1e-9 * a.max(1.0) => hits += 1,
                _ => panic!("{field} {ray:?}: every cluster {t:?}, hierarchy {got:?}"),
            }
            assert_eq!(
                bvh.any_hit(&ray, 0.0, f64::INFINITY, Occlusion::CellBoxes),
                any,
                "{field} {ray:?}"
            );
        }
    }
    assert!(hits > 150, "{hits} hits");
}

/// The batched search (every ray's root gate first) gives each ray exactly the hit that
/// `closest_hit` gives it alone: rays inside and outside the grid's box, a count that is not a
/// multiple of the batch, and one thread or several.
#[test]
fn closest_hits_match_closest_hit_ray_by_ray() {
    let volume = generate(Field::Hairball, 40, 1)
        .with_spacing([0.5, 1.0, 1.5])
        .unwrap();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let bvh = BvhTracer::new(&grid, Crossing::Samples3);
    let mut rng = crate::sample::Rng::for_sample(29, 0, 0);
    let extent = xyz(|a| 40.0 * [0.5, 1.0, 1.5][a]);
    let rays: Vec<Ray> = (0..3 * GATE_BATCH + 17)
        .map(|i| {
            // Most rays start inside the box, as the benchmark's do; one in four outside it.
            let spread = if i % 4 == 0 { 1.6 } else { 1.0 };
            let origin: [f64; 3] =
                std::array::from_fn(|a| extent[a] * (spread * rng.unit() - (spread - 1.0) / 2.0));
            let direction = crate::sample::uniform_sphere(&mut rng);
            Ray { origin, direction }
        })
        .collect();
    let alone: Vec<Option<Hit>> = rays
        .iter()
        .map(|r| bvh.closest_hit(r, 0.0, f64::INFINITY))
        .collect();
    let hits = alone.iter().filter(|h| h.is_some()).count();
    assert!(
        hits > rays.len() / 10 && hits < rays.len() * 9 / 10,
        "{hits} of {} rays hit: too few of one kind to test both",
        rays.len()
    );
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut batched = vec![None; rays.len()];
        pool.install(|| bvh.closest_hits(&rays, &mut batched));
        for (i, (a, b)) in alone.iter().zip(&batched).enumerate() {
            let key = |h: &Option<Hit>| {
                h.as_ref().map(|h| {
                    let normal = h.normal.map(f64::to_bits);
                    (h.t.to_bits(), h.cell, h.position, h.cluster, normal)
                })
            };
            assert_eq!(key(a), key(b), "ray {i} ({threads} threads)");
        }
    }
}

/// The gate stops a ray only where the traversal's own test of the root (same set) passes
/// no child, and stops exactly those among rays whose window starts in the grid's box.
#[test]
fn the_root_gate_stops_only_rays_the_root_test_stops() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx2) = crate::lanes::Avx2::detect() else {
            eprintln!("skipped: this CPU lacks AVX2, FMA or the bit instructions");
            return;
        };
        let mut rng = crate::sample::Rng::for_sample(13, 0, 0);
        let (mut stopped, mut passed, mut outside) = (0, 0, 0);
        for (field, size, spacing) in [
            (Field::Hairball, 48, [1.0; 3]),
            (Field::MarschnerLobb, 41, [0.3, 1.0, 2.5]),
        ] {
            let volume = generate(field, size, 1).with_spacing(spacing).unwrap();
            let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
            let bvh = BvhTracer::new(&grid, Crossing::Samples3);
            let root = &bvh.bvh.nodes[0];
            let extent = xyz(|a| size as f64 * spacing[a]);
            for i in 0..20_000 {
                let origin: [f64; 3] =
                    std::array::from_fn(|a| extent[a] * (1.4 * rng.unit() - 0.2));
                let mut direction = crate::sample::uniform_sphere(&mut rng);
                // Rays parallel to one or two axes take the reciprocal's special case.
                match i % 7 {
                    1 => direction[0] = 0.0,
                    2 => (direction[1], direction[2]) = (0.0, 0.0),
                    _ => {}
                }
                let ray = Ray { origin, direction };
                let tmin = if i % 3 == 0 {
                    0.0
                } else {
                    rng.unit() * extent[0]
                };
                let tmax = match i % 5 {
                    0 => f64::INFINITY,
                    1 => tmin - 1.0,
                    _ => tmin + rng.unit() * extent[0],
                };
                // SAFETY: `avx2` was detected, and it includes AVX2 and FMA.
                let (gate, passes) = unsafe {
                    (
                        bvh.gate.root_test_avx2(&ray, root, tmin, tmax),
                        bvh.gate.passes_avx2(&ray, root, tmin, tmax),
                    )
                };
                let test = bvh
                    .node_ray(&ray, tmin, tmax)
                    .map(|(_, nr)| avx2.node_test(&nr, root, nr.window(tmin, tmax)));
                assert!(passes || test.is_none_or(|(mask, _)| mask == 0), "{ray:?}");
                let units = cell_units(&ray, spacing, bvh.to_cells);
                let starts_inside = tmin <= tmax
                    && (0..3).all(|a| {
                        let start = units.0[a] + tmin * units.1[a];
                        start >= -1.0 && start <= bvh.cell_dims[a] + 1.0
                    });
                assert_eq!(gate.is_some(), starts_inside, "{ray:?} {tmin} {tmax}");
                if let Some((mask, entries)) = gate {
                    // The same constants and operations: the same mask and entry times,
                    // to the bit.
                    let (test_mask, test_entries) = test.unwrap();
                    assert_eq!(mask, test_mask, "{field} {ray:?} {tmin} {tmax}");
                    assert_eq!(entries.map(f32::to_bits), test_entries.map(f32::to_bits));
                    assert_eq!(passes, mask != 0);
                    stopped += (mask == 0) as usize;
                    passed += (mask != 0) as usize;
                } else {
                    outside += 1;
                }
            }
        }
        assert!(
            stopped > 2000 && passed > 2000 && outside > 2000,
            "{stopped} stopped, {passed} passed, {outside} outside"
        );
    }
}

/// The AVX2 and the baseline box tests find the same hits (they differ only in f32 rounding,
/// inside the boxes' margins), with the hierarchy and with the block walk.
#[test]
fn both_sets_find_the_same_hits() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx2) = crate::lanes::Avx2::detect() else {
            eprintln!("skipped: this CPU lacks AVX2, FMA or the bit instructions");
            return;
        };
        let mut rng = crate::sample::Rng::for_sample(11, 0, 0);
        let mut hits = 0;
        for (field, size) in [(Field::Hairball, 48), (Field::MarschnerLobb, 41)] {
            let volume = generate(field, size, 1);
            let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
            let bvh = BvhTracer::new(&grid, Crossing::Samples3);
            let blocks = Tracer::new(&grid, Crossing::Samples3);
            let n = size as f64;
            for _ in 0..2000 {
                let origin: [f64; 3] = std::array::from_fn(|_| -0.2 * n + 1.4 * n * rng.unit());
                let direction = crate::sample::uniform_sphere(&mut rng);
                let ray = Ray { origin, direction };
                let base = bvh.closest_hit_with(Baseline, &ray, 0.0, f64::INFINITY);
                // SAFETY: `avx2` was detected above.
                let wide = unsafe { bvh.closest_hit_avx2(avx2, &ray, 0.0, f64::INFINITY) };
                assert_eq!(base, wide, "{field} {ray:?}");
                let base = blocks.closest_hit_with(Baseline, &ray, 0.0, f64::INFINITY);
                // SAFETY: as above.
                let walk = unsafe { blocks.closest_hit_avx2(avx2, &ray, 0.0, f64::INFINITY) };
                assert_eq!(base, walk, "block walk, {field} {ray:?}");
                assert_eq!(base.map(|h| h.t), wide.map(|h| h.t), "{field} {ray:?}");
                hits += wide.is_some() as usize;
            }
        }
        assert!(hits > 500, "{hits} hits");
    }
}

/// The reported memory holds the nodes, the leaf clusters (16 slots of 12 bytes and a 4-byte
/// grid cluster per slot) and one 64-byte metacell record per leaf; the block walk's own
/// structures are not built for the hierarchy.
#[test]
fn extra_bytes_count_nodes_leaves_and_records() {
    let volume = generate(Field::Hairball, 40, 1);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let bvh = BvhTracer::new(&grid, Crossing::Samples3);
    let (nodes, leaves) = (bvh.bvh().nodes(), bvh.bvh().leaves());
    assert!(leaves > 10 && nodes > 2, "{leaves} leaves, {nodes} nodes");
    assert_eq!(bvh.bvh().bytes(), 128 * nodes + 16 * (12 + 4) * leaves);
    assert_eq!(bvh.extra_bytes(), bvh.bvh().bytes() + 64 * leaves);
}

#[test]
fn widened_windows_hold_the_exact_window() {
    let values = [
        0.0,
        0.1,
        -0.1,
        1e-3,
        16777217.0,
        -3.3e7,
        2.0,
        1e-40,
        -1e-40,
        1e-300,
        3.0e38,
        1e39,
        f64::INFINITY,
    ];
    for &lo in &values {
        for &hi in &values {
            let (a, b) = widen_f32(-lo, hi);
            // Clamped to the finite f32 range, where every node box's `t` lies.
            let finite = f32::MAX as f64;
            assert!(a as f64 <= (-lo).max(-finite), "{lo} {hi}");
            assert!(b as f64 >= hi.min(finite), "{lo} {hi}");
            assert!(a.is_finite() && b.is_finite());
        }
    }
}

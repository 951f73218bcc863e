//! The hierarchy over re-clustered metacells ([`BvhTracer`], the paper's §3.6 future work)
//! against the block walk ([`Tracer`], itself checked against brute force in `trace.rs`): same
//! hits (same cells and grid clusters) on random rays through several generated fields, same
//! occlusion, a hierarchy that holds every metacell, and proof that these comparisons notice a
//! dropped leaf or a leaf box one cell too small.

use crate::common::{blobs_u8, random_u8, Rng};
use isogrid::generate::{generate, Field};
use isogrid::layout::{Metacell, BOUND_SLOT};
use isogrid::{extract, CellGrid, ExtractOptions, Iso, Precision, Ray, Volume, VolumeData};
use isogrid_trace::{BvhTracer, ClusterBvh, Crossing, Occlusion, Tracer};

fn grid_of(volume: &Volume, iso: Iso, precision: Precision) -> CellGrid {
    extract(
        &volume.view(),
        &ExtractOptions::new(iso).with_precision(precision),
    )
    .unwrap()
}

fn unit(d: [f64; 3]) -> [f64; 3] {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / n)
}

/// Origins in the world box grown by a third on every side; half aimed at a point of the box,
/// a quarter uniform on the sphere, a quarter along an axis (zero direction components).
fn random_rays(grid: &CellGrid, count: usize, seed: u64) -> Vec<Ray> {
    let (lo, hi) = grid.info().world_bounds();
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|i| {
            let origin = rng.point_in(lo, hi, 0.33);
            let direction = match i % 4 {
                0 | 1 => {
                    let target = rng.point_in(lo, hi, 0.0);
                    unit([0, 1, 2].map(|a| target[a] - origin[a]))
                }
                2 => unit([0, 1, 2].map(|_| 2.0 * rng.unit() - 1.0)),
                _ => {
                    let mut d = [0.0; 3];
                    d[rng.below(3) as usize] = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                    d
                }
            };
            Ray { origin, direction }
        })
        .collect()
}

/// Compares the two tracers on `rays` with random `[tmin, tmax]` windows on every third ray;
/// returns (hits, hits whose `t` differs in any bit). Hit/miss must agree, `t` within rounding
/// (the two visit cells in different orders, and a cell searched after a farther hit was found
/// searches a shorter segment), and the hit cell, its position and its grid cluster exactly but
/// for rays that meet the surface where two cells share a face (`t` then agrees, the cell may not).
fn compare(grid: &CellGrid, crossing: Crossing, rays: &[Ray], what: &str) -> (usize, usize) {
    let blocks = Tracer::new(grid, crossing);
    let bvh = BvhTracer::new(grid, crossing);
    bvh.bvh().validate(grid).unwrap();
    let mut rng = Rng::new(5);
    let (mut hits, mut inexact, mut same_cell) = (0, 0, 0);
    for (i, ray) in rays.iter().enumerate() {
        let (tmin, tmax) = if i % 3 == 2 {
            let tmin = 30.0 * rng.unit();
            (tmin, tmin + 30.0 * rng.unit())
        } else {
            (0.0, f64::INFINITY)
        };
        let a = blocks.closest_hit(ray, tmin, tmax);
        let b = bvh.closest_hit(ray, tmin, tmax);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!(
                    (a.t - b.t).abs() <= 1e-9 * a.t.abs().max(1.0),
                    "{what} ray {i} {ray:?}: blocks t {} bvh t {}",
                    a.t,
                    b.t
                );
                inexact += (a.t != b.t) as usize;
                if a.cell == b.cell {
                    assert_eq!(
                        (a.position, a.cluster),
                        (b.position, b.cluster),
                        "{what} ray {i} {ray:?}"
                    );
                    same_cell += 1;
                }
            }
            (a, b) => panic!(
                "{what} ray {i} {ray:?} in [{tmin}, {tmax}]: blocks {:?} bvh {:?}",
                a.map(|h| (h.t, h.position)),
                b.map(|h| (h.t, h.position))
            ),
        }
        for occlusion in [Occlusion::CellBoxes, Occlusion::Surface] {
            assert_eq!(
                blocks.any_hit(ray, tmin, tmax, occlusion),
                bvh.any_hit(ray, tmin, tmax, occlusion),
                "{what} ray {i} {ray:?}: any hit {occlusion:?} in [{tmin}, {tmax}]"
            );
        }
    }
    assert!(
        same_cell * 100 >= hits * 99,
        "{what}: same cell in {same_cell} of {hits} hits"
    );
    (hits, inexact)
}

#[test]
fn bvh_hits_equal_the_block_walk_on_generated_fields() {
    let mut total = 0;
    for (k, (field, size)) in [
        (Field::Sphere, 40),
        (Field::Torus, 44),
        (Field::Gyroid, 36),
        (Field::MarschnerLobb, 41),
        (Field::Hairball, 56),
    ]
    .into_iter()
    .enumerate()
    {
        let volume = generate(field, size, 3);
        let grid = grid_of(&volume, Iso::Normalized(0.5), Precision::Bits8);
        let rays = random_rays(&grid, 400, 100 + k as u64);
        let crossing = if k % 2 == 0 {
            Crossing::Exact
        } else {
            Crossing::Samples3
        };
        let (hits, inexact) = compare(&grid, crossing, &rays, &format!("{field}"));
        eprintln!("{field} {size}: {hits} hits, {inexact} differ in rounding");
        assert!(hits > 60, "{field}: {hits} hits");
        total += hits;
    }
    assert!(total > 600);
}

#[test]
fn bvh_hits_equal_the_block_walk_on_anisotropic_blobs_and_noise() {
    // Anisotropic spacing: node boxes are in cell units, rays in world units.
    let blobs = blobs_u8([34, 22, 40]);
    let mut geometry = isogrid::Geometry::new([34, 22, 40]);
    geometry.spacing = [0.7, 1.6, 1.1];
    let VolumeData::U8(data) = blobs.data().clone() else {
        unreachable!("blobs are u8")
    };
    let blobs = Volume::with_geometry(geometry, VolumeData::U8(data)).unwrap();
    for precision in [Precision::Bits4, Precision::Bits16] {
        let grid = grid_of(&blobs, Iso::Value(127.5), precision);
        let rays = random_rays(&grid, 300, 7);
        let (hits, _) = compare(&grid, Crossing::Exact, &rays, "blobs");
        assert!(hits > 60, "blobs {precision:?}: {hits} hits");
    }
    // Noise: many small clusters in every block.
    let noise = random_u8([29, 23, 31], 9, 256);
    let grid = grid_of(&noise, Iso::Value(127.5), Precision::Bits8);
    let rays = random_rays(&grid, 300, 8);
    let (hits, _) = compare(&grid, Crossing::Samples3, &rays, "noise");
    assert!(hits > 100, "noise: {hits} hits");
}

#[test]
fn empty_grid_has_an_empty_hierarchy_and_no_hits() {
    let volume = Volume::new([20, 20, 20], VolumeData::U8(vec![10; 8000])).unwrap();
    let grid = grid_of(&volume, Iso::Value(127.5), Precision::Bits8);
    let tracer = BvhTracer::new(&grid, Crossing::Exact);
    assert_eq!(tracer.bvh().metacells(), 0);
    assert_eq!(tracer.bvh().leaves(), 0);
    assert_eq!(tracer.bvh().nodes(), 0);
    tracer.bvh().validate(&grid).unwrap();
    for ray in random_rays(&grid, 50, 1) {
        assert!(tracer.closest_hit(&ray, 0.0, f64::INFINITY).is_none());
        assert!(!tracer.any_hit(&ray, 0.0, f64::INFINITY, Occlusion::CellBoxes));
    }
}

/// Rays through the centre of every active cell of `slots` (a leaf cluster), along each axis
/// both ways from outside the grid: they pass through the leaf's box only in that cell's row.
fn rays_through_leaf(grid: &CellGrid, slots: &[Metacell]) -> Vec<Ray> {
    let spacing = grid.info().spacing;
    let (lo, hi) = grid.info().world_bounds();
    let mut rays = Vec::new();
    for m in &slots[..BOUND_SLOT] {
        for bit in 0..8 {
            if m.cell_mask >> bit & 1 == 0 {
                continue;
            }
            let p = m.cell_position(bit);
            let centre: [f64; 3] = std::array::from_fn(|a| (p[a] as f64 + 0.5) * spacing[a]);
            for a in 0..3 {
                for sign in [1.0, -1.0] {
                    let mut origin = centre;
                    origin[a] = if sign > 0.0 { lo[a] - 5.0 } else { hi[a] + 5.0 };
                    let mut direction = [0.0; 3];
                    direction[a] = sign;
                    rays.push(Ray { origin, direction });
                }
            }
        }
    }
    rays
}

/// A dropped leaf or a leaf box one cell short on its upper x face: `validate` reports it, and
/// rays through the leaf's cells find different hits than the block walk for most leaves.
#[test]
fn a_dropped_leaf_or_a_box_one_cell_short_is_caught() {
    let volume = generate(Field::Torus, 40, 0);
    let grid = grid_of(&volume, Iso::Normalized(0.5), Precision::Bits8);
    let bvh = ClusterBvh::new(&grid);
    bvh.validate(&grid).unwrap();
    let blocks = Tracer::new(&grid, Crossing::Exact);
    let leaves = bvh.leaves();
    assert!(leaves > 40, "{leaves} leaves");
    for shrink in [false, true] {
        let mut caught = 0;
        let mut tried = 0;
        for leaf in (0..leaves).step_by(leaves / 20) {
            let broken = bvh
                .mutated(leaf as u32, shrink)
                .expect("every leaf sits under a node");
            assert!(
                broken.validate(&grid).is_err(),
                "leaf {leaf} shrink {shrink}"
            );
            let slots = bvh.leaf(leaf);
            let tracer = BvhTracer::with_bvh(&grid, Crossing::Exact, broken);
            tried += 1;
            // Shrunk: only rays inside the lost layer (upper x cells of the box) can notice.
            let top = 2 * slots[BOUND_SLOT].as_bound().hi[0] as u32 + 1;
            let differs = rays_through_leaf(&grid, slots).iter().any(|ray| {
                let x = (ray.origin[0] / grid.info().spacing[0]).floor() as u32;
                if shrink && (ray.direction[0] != 0.0 || x != top) {
                    return false;
                }
                let a = blocks.closest_hit(ray, 0.0, f64::INFINITY).map(|h| h.t);
                let b = tracer.closest_hit(ray, 0.0, f64::INFINITY).map(|h| h.t);
                a != b
            });
            caught += differs as usize;
        }
        eprintln!("shrink {shrink}: rays notice {caught} of {tried} broken leaves");
        assert!(caught * 2 > tried, "shrink {shrink}: {caught} of {tried}");
    }
}

/// A label grid with more clusters per block than one isosurface can have (a run per label, up
/// to 11 labels in a block, beyond the block walk's 35 clusters per pass): both traversals find
/// every cluster, the same hits.
#[test]
fn bvh_hits_equal_the_block_walk_on_a_label_grid_of_many_labels_per_block() {
    let volume = isogrid::generate::labelled_cubes(32);
    let grid = isogrid::extract_labels(
        &volume.view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap();
    let busiest = grid.blocks().iter().map(|b| b.cluster_count()).max();
    assert!(busiest > Some(35), "busiest block: {busiest:?} clusters");
    let rays = random_rays(&grid, 400, 11);
    let (hits, _) = compare(&grid, Crossing::Samples3, &rays, "label cubes");
    assert!(hits > 200, "label cubes: {hits} hits");
}

//! Inside a block the GPU tracer walks the occupied metacells front to back with a DDA
//! (`trace.wgsl`, `isogrid::skip::occupancy`) and stops at the first one with a crossing. A walk
//! that started one metacell late, or found a metacell at the wrong slot, would lose crossings
//! near where rays start, which is where a path tracer's secondary rays start. So the rays here
//! start on and just off metacell faces, edges and corners, and just off the surface itself, in
//! dense fields whose blocks hold many clusters; their hits must be the CPU tracer's (which tests
//! cluster bounds and metacell boxes instead, checked against brute force in the core).

use crate::pathtrace::Rng;
use crate::{renderer, scene, HitAgreement};
use isogrid::camera::Ray;
use isogrid::generate::Field;
use isogrid::Precision;
use isogrid_trace::{Crossing, Tracer};

/// Offsets (cells) of ray origins from even grid coordinates, i.e. metacell faces: on the face,
/// and just below and above it by less than the walk's start nudge.
const FACE_OFFSETS: [f64; 5] = [0.0, -1e-4, 1e-4, -0.03, 0.03];

fn unit(d: [f64; 3]) -> [f64; 3] {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / n)
}

/// Rays from points near metacell faces (on one, two or three axes at once) inside the grid, in
/// random, axis-aligned and diagonal directions.
fn rays_from_metacell_faces(cells: usize, count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    let fixed = [
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, -1.0],
        [1.0, -2.0, 0.0],
    ];
    (0..count)
        .map(|i| {
            let mut origin = [0.0; 3];
            for (a, o) in origin.iter_mut().enumerate() {
                let metacell = 1 + (rng.next() * (cells / 2 - 2) as f64) as usize;
                // Axis a sits near a face on rays i % 3 ≥ a: one, two or three axes at once.
                *o = if a <= i % 3 {
                    2.0 * metacell as f64 + FACE_OFFSETS[(i / 3 + a) % FACE_OFFSETS.len()]
                } else {
                    2.0 * metacell as f64 + 2.0 * rng.next()
                };
            }
            let direction = if i % 4 == 0 {
                let d = fixed[(i / 4) % fixed.len()];
                unit(d.map(|v| if rng.next() < 0.5 { -v } else { v }))
            } else {
                rng.direction()
            };
            Ray { origin, direction }
        })
        .collect()
}

/// Secondary rays as the path tracer spawns them: from each CPU hit of `primary`, offset by
/// `offset` along the normal on the ray's side, into the hemisphere on that side.
fn rays_off_the_surface(tracer: &Tracer, primary: &[Ray], offset: f64, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    let mut rays = Vec::new();
    for ray in primary {
        let Some(hit) = tracer.closest_hit(ray, 0.0, f64::INFINITY) else {
            continue;
        };
        let facing = hit
            .normal
            .iter()
            .zip(ray.direction)
            .map(|(n, d)| n * d)
            .sum::<f64>();
        let n = hit.normal.map(|v| if facing > 0.0 { -v } else { v });
        let p: [f64; 3] = std::array::from_fn(|a| ray.origin[a] + hit.t * ray.direction[a]);
        for _ in 0..2 {
            let mut d = rng.direction();
            if d.iter().zip(n).map(|(d, n)| d * n).sum::<f64>() < 0.0 {
                d = d.map(|v| -v);
            }
            rays.push(Ray {
                origin: std::array::from_fn(|a| p[a] + offset * n[a]),
                direction: d,
            });
        }
    }
    rays
}

#[test]
fn rays_starting_near_metacell_faces_and_surfaces_hit_like_the_cpu_tracer() {
    let Some(r) = renderer() else { return };
    for (field, size, precision) in [
        (Field::Hairball, 64, Some(Precision::Float32)),
        (Field::Gyroid, 48, None),
    ] {
        let (_, grid) = scene(field, size, precision);
        let busiest = grid.blocks().iter().map(|b| b.metacell_count).max();
        // Several clusters per block, so that slots past the first cluster (rank ≥ 15) are used.
        assert!(busiest >= Some(64), "{field}: busiest block {busiest:?}");
        let cpu = Tracer::new(&grid, Crossing::Samples3);
        let gpu_grid = r.upload_grid(&grid).unwrap();
        let cells = size - 1;
        let from_faces = rays_from_metacell_faces(cells, 4000, 3);
        let primary = crate::pathtrace::random_rays(grid.info().world_bounds().1, 1500, 9);
        let from_surface = rays_off_the_surface(&cpu, &primary, 1e-3, 11);
        for (label, rays) in [
            ("near metacell faces", from_faces),
            ("off the surface", from_surface),
        ] {
            let gpu = r.trace_rays(&gpu_grid, &rays).unwrap();
            let agreement = HitAgreement::of(&cpu, &rays, &gpu);
            agreement.assert_close(&format!("{field} {size}, rays {label}"), rays.len() / 4);
        }
    }
}

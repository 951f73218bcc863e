//! The GPU tracer leaps across empty blocks with the octant empty-space map uploaded after the
//! block records (`isogrid::skip::octant_space`): two small balls in opposite corners of a mostly empty
//! grid, so that rays cross cubes of several empty blocks before they meet one. The hits must be
//! the CPU tracer's, whose leaps are tested against brute force in the core.

use crate::pathtrace::random_rays;
use crate::{renderer, HitAgreement};
use isogrid::camera::Ray;
use isogrid::layout::BLOCK_CELLS;
use isogrid::skip::octant_space::OctantSpaceMap;
use isogrid::{extract, ExtractOptions, Iso, Volume, VolumeData};
use isogrid_trace::{Crossing, Tracer};

/// 112³ samples (7³ blocks) with balls of radius 6 around `CENTRES`; inside is 200, outside 0.
const SIZE: usize = 112;
const CENTRES: [[f64; 3]; 2] = [[18.0, 22.0, 20.0], [92.0, 88.0, 95.0]];

fn two_balls() -> Volume {
    let mut data = vec![0u8; SIZE * SIZE * SIZE];
    for (i, v) in data.iter_mut().enumerate() {
        let p = [i % SIZE, i / SIZE % SIZE, i / (SIZE * SIZE)].map(|c| c as f64);
        let inside = CENTRES.iter().any(|c| {
            let d2: f64 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
            d2 <= 36.0
        });
        *v = if inside { 200 } else { 0 };
    }
    Volume::new([SIZE; 3], VolumeData::U8(data)).unwrap()
}

#[test]
fn secondary_rays_leap_across_empty_blocks_like_the_cpu_tracer() {
    let Some(r) = renderer() else { return };
    let volume = two_balls();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(100.0))).unwrap();
    let blocks = (SIZE - 1).div_ceil(BLOCK_CELLS);
    let map = OctantSpaceMap::new(grid.blocks(), grid.info().block_dims().map(|b| b as usize));
    let longest = (0..8).flat_map(|o| map.octant(o).iter().copied()).max();
    assert!(
        longest >= Some(4),
        "{blocks}³ blocks, longest leap {longest:?}"
    );

    // Random rays through the box, and rays from the far corners aimed at each ball, which cross
    // the empty middle of the grid and must hit.
    let (_, hi) = grid.info().world_bounds();
    let mut rays = random_rays(hi, 1500, 5);
    let corners = [
        [0.5, 0.5, 0.5],
        [110.5, 110.5, 110.5],
        [0.5, 110.5, 0.5],
        [110.5, 0.5, 110.5],
    ];
    for (k, corner) in corners.iter().enumerate() {
        for target in CENTRES {
            for j in 0..50 {
                // Spread the aim over the ball's central disc.
                let jitter = [(j % 7) as f64 - 3.0, (j / 7) as f64 - 3.0, (k as f64) - 1.5];
                let aim: [f64; 3] = std::array::from_fn(|a| target[a] + 0.6 * jitter[a]);
                let d: [f64; 3] = std::array::from_fn(|a| aim[a] - corner[a]);
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                rays.push(Ray {
                    origin: *corner,
                    direction: d.map(|c| c / n),
                });
            }
        }
    }
    let gpu_grid = r.upload_grid(&grid).unwrap();
    let gpu = r.trace_rays(&gpu_grid, &rays).unwrap();
    let cpu = Tracer::new(&grid, Crossing::Samples3);
    let label = format!("two balls, longest leap {longest:?} blocks");
    HitAgreement::of(&cpu, &rays, &gpu).assert_close(&label, 350);
}

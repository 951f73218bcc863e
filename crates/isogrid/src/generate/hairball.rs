//! A synthetic "hairball": many random smooth tubes packed in a ball.
//!
//! Stands in for the paper's Hairball dataset (§4, Table 2: 1024³, the one with by far the most
//! active cells and the highest depth complexity). Each of [`CURVES`] curves is a random walk
//! whose direction turns smoothly and is steered back when it nears the ball's edge; the tube is
//! the union of capsules of radius `r` around its segments (round joints make it smooth).
//!
//! The value is an 8-bit coverage estimate from the distance `d` to the nearest segment:
//! `clamp(0.5 + r − d, 0, 1)`, a one-voxel ramp centred on the tube wall, so the 0.5 isosurface is
//! exactly the tube surface.
//!
//! Speed: samples are computed one row (fixed j, k) at a time. Rows are bucketed by a 2D grid of
//! tiles over (y, z) holding the segments whose padded bounding box touches the tile; a segment
//! then only updates the x-range of the row its bounding box covers. On two cores 256³ takes
//! about 0.15 s and 1024³ about 6.5 s.

use super::rng::SplitMix64;
use rayon::prelude::*;

const CURVES: usize = 300;
const SEGMENTS_PER_CURVE: usize = 40;
/// Segment length in units of the ball radius.
const STEP: f64 = 0.07;
/// How much the direction may turn per step (a random vector of at most this length is added).
const WIGGLE: f64 = 0.35;
/// Beyond this fraction of the ball radius the walk is pulled back towards the centre.
const SOFT_EDGE: f64 = 0.8;
/// Tube radius as a fraction of the cube's edge (the paper's hairs are thin but not sub-voxel).
const RADIUS_FRACTION: f64 = 0.015;
/// Edge of the (y, z) tiles that bucket segments, in voxels.
const TILE: usize = 8;

struct Segment {
    a: [f64; 3],
    dir: [f64; 3],
    inv_len2: f64,
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Segment {
    fn new(a: [f64; 3], b: [f64; 3], pad: f64) -> Self {
        let dir = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let len2 = dot(dir, dir);
        Segment {
            a,
            dir,
            inv_len2: if len2 > 0.0 { 1.0 / len2 } else { 0.0 },
            lo: [0, 1, 2].map(|i| a[i].min(b[i]) - pad),
            hi: [0, 1, 2].map(|i| a[i].max(b[i]) + pad),
        }
    }

    fn distance2(&self, q: [f64; 3]) -> f64 {
        let aq = [q[0] - self.a[0], q[1] - self.a[1], q[2] - self.a[2]];
        let t = (dot(aq, self.dir) * self.inv_len2).clamp(0.0, 1.0);
        let d = [0, 1, 2].map(|i| aq[i] - t * self.dir[i]);
        dot(d, d)
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Curve polylines in the unit ball, independent of the volume size so a seed gives the same
/// shape at every resolution.
fn random_curves(seed: u64) -> Vec<Vec<[f64; 3]>> {
    let mut rng = SplitMix64::new(seed);
    (0..CURVES)
        .map(|_| {
            let mut p = rng.in_unit_ball().map(|c| c * SOFT_EDGE);
            let mut dir = rng.unit_vector();
            let mut points = vec![p];
            for _ in 0..SEGMENTS_PER_CURVE {
                let turn = rng.in_unit_ball();
                let dist = dot(p, p).sqrt();
                let pull = if dist > SOFT_EDGE {
                    (dist - SOFT_EDGE) * 4.0 / dist
                } else {
                    0.0
                };
                let d = [0, 1, 2].map(|i| dir[i] + WIGGLE * turn[i] - pull * p[i]);
                let len = dot(d, d).sqrt();
                if len > 1e-9 {
                    dir = d.map(|c| c / len);
                }
                p = [0, 1, 2].map(|i| p[i] + STEP * dir[i]);
                let dist = dot(p, p).sqrt();
                if dist > 1.0 {
                    p = p.map(|c| c / dist);
                }
                points.push(p);
            }
            points
        })
        .collect()
}

/// Segment lists per (y, z) tile in compressed form: tile t owns `ids[start[t]..start[t+1]]`.
struct TileGrid {
    tiles_per_axis: usize,
    start: Vec<usize>,
    ids: Vec<u32>,
}

impl TileGrid {
    fn new(size: usize, segments: &[Segment]) -> Self {
        let tiles_per_axis = size.div_ceil(TILE);
        let tile_range = |lo: f64, hi: f64| {
            let first = (lo.max(0.0) / TILE as f64) as usize;
            let last = ((hi.max(0.0) / TILE as f64) as usize).min(tiles_per_axis - 1);
            first..=last
        };
        let mut count = vec![0usize; tiles_per_axis * tiles_per_axis + 1];
        for pass in 0..2 {
            let mut ids = Vec::new();
            if pass == 1 {
                // Exclusive prefix sum: count[t] becomes the start of tile t.
                let mut sum = 0;
                for c in count.iter_mut() {
                    let n = *c;
                    *c = sum;
                    sum += n;
                }
                ids = vec![0u32; sum];
            }
            let mut fill = count.clone();
            for (id, s) in segments.iter().enumerate() {
                for tz in tile_range(s.lo[2], s.hi[2]) {
                    for ty in tile_range(s.lo[1], s.hi[1]) {
                        let t = ty + tiles_per_axis * tz;
                        if pass == 0 {
                            count[t] += 1;
                        } else {
                            ids[fill[t]] = id as u32;
                            fill[t] += 1;
                        }
                    }
                }
            }
            if pass == 1 {
                return TileGrid {
                    tiles_per_axis,
                    start: count,
                    ids,
                };
            }
        }
        unreachable!("the loop returns in its second pass")
    }

    fn segments_near_row(&self, j: usize, k: usize) -> &[u32] {
        let t = j / TILE + self.tiles_per_axis * (k / TILE);
        &self.ids[self.start[t]..self.start[t + 1]]
    }
}

pub(super) fn generate(size: usize, seed: u64) -> Vec<u8> {
    let extent = (size.max(2) - 1) as f64;
    let radius = (RADIUS_FRACTION * extent).max(1.0);
    // Coverage reaches zero half a voxel outside the wall.
    let reach = radius + 0.5;
    let centre = (size as f64 - 1.0) / 2.0;
    // Keep every tube, ramp included, off the border so the surface is closed.
    let ball = (extent / 2.0 - reach - 0.5).max(0.0);

    let segments: Vec<Segment> = random_curves(seed)
        .iter()
        .flat_map(|curve| curve.windows(2))
        .map(|w| {
            let to_voxels = |p: [f64; 3]| p.map(|c| centre + ball * c);
            Segment::new(to_voxels(w[0]), to_voxels(w[1]), reach)
        })
        .collect();
    let grid = TileGrid::new(size, &segments);

    let mut data = vec![0u8; size * size * size];
    data.par_chunks_mut(size).enumerate().for_each_init(
        || vec![f64::INFINITY; size],
        |nearest2, (row, out)| {
            let (j, k) = (row % size, row / size);
            let (y, z) = (j as f64, k as f64);
            nearest2.fill(f64::INFINITY);
            for &id in grid.segments_near_row(j, k) {
                let s = &segments[id as usize];
                if y < s.lo[1] || y > s.hi[1] || z < s.lo[2] || z > s.hi[2] {
                    continue;
                }
                let first = s.lo[0].max(0.0).ceil() as usize;
                let last = (s.hi[0].floor().max(-1.0) as isize).min(size as isize - 1);
                for i in first as isize..=last {
                    let i = i as usize;
                    let d2 = s.distance2([i as f64, y, z]);
                    if d2 < nearest2[i] {
                        nearest2[i] = d2;
                    }
                }
            }
            for (v, &d2) in out.iter_mut().zip(nearest2.iter()) {
                *v = if d2.is_finite() {
                    super::unit_to_u8(0.5 + radius - d2.sqrt())
                } else {
                    0
                };
            }
        },
    );
    data
}

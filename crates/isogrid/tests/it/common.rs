//! Shared helpers for the integration tests: deterministic random volumes and simple fields.

use isogrid::{Volume, VolumeData};

/// xorshift64*: small, deterministic, good enough for test data.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in the box `[lo, hi]` grown by `grow` times its size on every side.
    pub fn point_in(&mut self, lo: [f64; 3], hi: [f64; 3], grow: f64) -> [f64; 3] {
        [0, 1, 2].map(|a| {
            let size = hi[a] - lo[a];
            lo[a] - grow * size + (1.0 + 2.0 * grow) * size * self.unit()
        })
    }
}

pub fn random_u8(dims: [usize; 3], seed: u64, levels: u64) -> Volume {
    let mut rng = Rng::new(seed);
    let n = dims.iter().product();
    let data = (0..n)
        .map(|_| (rng.below(levels) * 255 / (levels - 1).max(1)) as u8)
        .collect();
    Volume::new(dims, VolumeData::U8(data)).unwrap()
}

/// A field of `f(x, y, z)` in sample coordinates, converted by `make`.
pub fn field(dims: [usize; 3], f: impl Fn(f64, f64, f64) -> f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                out.push(f(x as f64, y as f64, z as f64));
            }
        }
    }
    out
}

/// Union of a few spheres, 255 deep inside, 0 far outside, as u8.
pub fn blobs_u8(dims: [usize; 3]) -> Volume {
    let c = dims.map(|d| d as f64 / 2.0);
    let values = field(dims, |x, y, z| {
        let d1 = ((x - c[0]).powi(2) + (y - c[1]).powi(2) + (z - c[2]).powi(2)).sqrt() - c[0] * 0.6;
        let d2 = ((x - c[0] * 0.5).powi(2) + (y - c[1] * 1.3).powi(2) + (z - c[2]).powi(2)).sqrt()
            - c[0] * 0.3;
        (127.5 - 40.0 * d1.min(d2)).clamp(0.0, 255.0)
    });
    Volume::new(
        dims,
        VolumeData::U8(values.into_iter().map(|v| v.round() as u8).collect()),
    )
    .unwrap()
}

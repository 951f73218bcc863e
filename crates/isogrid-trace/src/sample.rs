//! Random numbers and direction sampling for the path tracer, deterministic per pixel and sample.

/// SplitMix64 (Steele et al. 2014): a counter-based generator whose streams for different seeds
/// are independent enough for Monte Carlo rendering.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A stream for one (pixel, sample) of an image with a global `seed`.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        let mut r = Rng(seed ^ 0x5851_F42D_4C95_7F2D);
        let a = r.next_u64() ^ pixel.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let mut r = Rng(a);
        let b = r.next_u64() ^ sample.wrapping_mul(0xD1B5_4A32_D192_ED03);
        Rng(b)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// A cosine-weighted direction on the hemisphere around unit `n` (pdf cos θ / π).
pub fn cosine_hemisphere(n: [f64; 3], rng: &mut Rng) -> [f64; 3] {
    let u1 = rng.unit();
    let u2 = rng.unit();
    let r = u1.sqrt();
    let phi = std::f64::consts::TAU * u2;
    let (x, y, z) = (r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt());
    let (t, b) = orthonormal_basis(n);
    [0, 1, 2].map(|a| x * t[a] + y * b[a] + z * n[a])
}

/// A uniformly random unit vector.
pub fn uniform_sphere(rng: &mut Rng) -> [f64; 3] {
    let z = 2.0 * rng.unit() - 1.0;
    let phi = std::f64::consts::TAU * rng.unit();
    let r = (1.0 - z * z).max(0.0).sqrt();
    [r * phi.cos(), r * phi.sin(), z]
}

/// Two unit vectors completing unit `n` to an orthonormal basis (Duff et al. 2017).
fn orthonormal_basis(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
        [b, sign + n[1] * n[1] * a, -n[1]],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_samples_have_the_right_mean_cosine() {
        // E[cos θ] under pdf cos θ/π is 2/3.
        let n = [0.3f64, -0.5, 0.81];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = n.map(|v| v / len);
        let mut rng = Rng::for_sample(1, 2, 3);
        let count = 20000;
        let mut sum = 0.0;
        for _ in 0..count {
            let d = cosine_hemisphere(n, &mut rng);
            let c = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            assert!(c >= -1e-12 && ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - 1.0).abs() < 1e-9);
            sum += c;
        }
        assert!((sum / count as f64 - 2.0 / 3.0).abs() < 0.01);
    }
}

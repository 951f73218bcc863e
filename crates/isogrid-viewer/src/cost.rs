//! Render cost model for picking image sizes: time ≈ fixed + per_pixel · pixels, fitted by least
//! squares to the last few frames of the same scene and mode.
//!
//! Both terms matter: cell rasterisation has a per-cell cost (vertex work, culling, probes) that no
//! image size removes, and a per-pixel cost (ray–cell intersection in each covered fragment,
//! shading). On a CPU adapter the fixed part alone can be seconds, and shrinking the image below
//! the size where the pixel part equals it only blurs the picture without making it faster.

/// Frames kept for the fit.
const SAMPLES: usize = 8;
/// Sides are scaled in steps of 1/8 of the full size, so that consecutive frames share a size.
const STEPS: f64 = 8.0;

#[derive(Debug, Clone, Default)]
pub struct CostModel {
    /// (pixels, milliseconds) of recent frames, oldest first.
    samples: Vec<(f64, f64)>,
}

impl CostModel {
    /// Forgets all frames (the scene or mode changed, so the costs did).
    pub fn reset(&mut self) {
        self.samples.clear();
    }

    pub fn record(&mut self, pixels: u64, ms: f64) {
        if !(ms.is_finite() && ms >= 0.0) || pixels == 0 {
            return;
        }
        if self.samples.len() == SAMPLES {
            self.samples.remove(0);
        }
        self.samples.push((pixels as f64, ms));
    }

    /// (fixed ms, ms per pixel), both ≥ 0; `None` before the first frame.
    pub fn fit(&self) -> Option<(f64, f64)> {
        let n = self.samples.len() as f64;
        if n == 0.0 {
            return None;
        }
        let mean_p = self.samples.iter().map(|s| s.0).sum::<f64>() / n;
        let mean_t = self.samples.iter().map(|s| s.1).sum::<f64>() / n;
        let var_p: f64 = self.samples.iter().map(|s| (s.0 - mean_p).powi(2)).sum();
        let cov: f64 = self
            .samples
            .iter()
            .map(|s| (s.0 - mean_p) * (s.1 - mean_t))
            .sum();
        // One image size seen so far: all of the time is charged to pixels, the cautious choice
        // (it predicts the largest saving from smaller images, so the first move goes small).
        if var_p <= 1e-6 * mean_p * mean_p {
            return Some((0.0, mean_t / mean_p));
        }
        let per_pixel = (cov / var_p).max(0.0);
        let fixed = (mean_t - per_pixel * mean_p).max(0.0);
        if per_pixel == 0.0 {
            // Time does not grow with size (noise): keep some per-pixel cost so sizes still
            // order by cost.
            return Some((fixed, mean_t / mean_p * 1e-3));
        }
        Some((fixed, per_pixel))
    }

    /// The size, at most `full`, expected to render in about `budget_ms`; where the fixed cost
    /// alone exceeds the budget, the size whose pixel cost equals the fixed cost. Without any
    /// frame yet, `full`.
    pub fn size_for(&self, full: [u32; 2], budget_ms: f64) -> [u32; 2] {
        let Some((fixed, per_pixel)) = self.fit() else {
            return full;
        };
        let full_pixels = full[0] as f64 * full[1] as f64;
        let pixel_ms = if budget_ms > 2.0 * fixed {
            budget_ms - fixed
        } else {
            fixed
        };
        let scale = (pixel_ms / (per_pixel * full_pixels).max(1e-12))
            .sqrt()
            .clamp(1.0 / STEPS, 1.0);
        let scale = (scale * STEPS).floor().max(1.0) / STEPS;
        if scale >= 1.0 {
            return full;
        }
        full.map(|n| ((n as f64 * scale).round() as u32).max(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_linear_cost() {
        let mut m = CostModel::default();
        for px in [10_000u64, 40_000, 160_000, 640_000] {
            m.record(px, 300.0 + 0.002 * px as f64);
        }
        let (fixed, per_pixel) = m.fit().unwrap();
        assert!((fixed - 300.0).abs() < 1e-6, "{fixed}");
        assert!((per_pixel - 0.002).abs() < 1e-12, "{per_pixel}");
    }

    #[test]
    fn sizes_meet_the_budget_or_stop_where_pixels_stop_paying() {
        let full = [640, 480];
        let mut pixel_bound = CostModel::default();
        pixel_bound.record(640 * 480, 3072.0); // 10 µs per pixel, nothing fixed
        assert_eq!(pixel_bound.size_for(full, 70.0), [80, 60]);
        let mut cheap = CostModel::default();
        cheap.record(640 * 480, 5.0);
        assert_eq!(cheap.size_for(full, 70.0), full);
        // 2 s fixed + 1 s for the full image: a 70 ms budget is out of reach, and the image
        // only shrinks until its pixel cost equals the fixed cost — here never below full.
        let mut fixed_bound = CostModel::default();
        fixed_bound.record(640 * 480, 3000.0);
        fixed_bound.record(320 * 240, 2250.0);
        assert_eq!(fixed_bound.size_for(full, 70.0), full);
        assert_eq!(CostModel::default().size_for(full, 70.0), full);
    }
}

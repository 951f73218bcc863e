//! The first test of a [`super::BvhTracer`] ray, its hierarchy's root, in AVX2 registers alone:
//! the exit for rays that pass through none of the root's children, where three in four of the
//! dragon's missing rays end and half of MNI's.
//!
//! The full traversal starts with the same test, but its setup (the ray in cell units, the
//! [`super::cell_ray::BoxFaces`] constants, the window) is scalar f64 code that LLVM interleaves
//! with the leaf searches' hoisted constants and the stack frame of the whole inlined traversal:
//! about 280 instructions before the root's test, against about 100 for the whole gate
//! (callgrind, the dragon's rays that miss). The gate computes the same values with the same
//! IEEE operations, four f64 lanes per step, so where it says "no child" the traversal would
//! have said so too; rays whose window starts outside the grid's box go to the traversal
//! untested (its re-basing needs a slab test the gate does not make).

use crate::cell_ray::widen_f32;
use crate::cluster_bvh::{Node, WIDTH};
use isogrid::camera::Ray;

/// The tracer's constants of the gate, one f64 lane per axis and a fourth lane that never fails
/// the box test.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
pub(super) struct RootGate {
    to_cells: [f64; 4],
    spacing: [f64; 4],
    /// The grid's box grown by one cell, as `NodeRay::new` tests it.
    box_hi: [f64; 4],
    margin: f64,
}

impl RootGate {
    /// `to_cells = 1 / spacing`, `cell_dims` the grid's cells per axis, `margin` the node boxes'
    /// (as the traversal holds them).
    pub(super) fn new(
        spacing: [f64; 3],
        to_cells: [f64; 3],
        cell_dims: [f64; 3],
        margin: f64,
    ) -> Self {
        RootGate {
            to_cells: [to_cells[0], to_cells[1], to_cells[2], 0.0],
            spacing: [spacing[0], spacing[1], spacing[2], 1.0],
            box_hi: [
                cell_dims[0] + 1.0,
                cell_dims[1] + 1.0,
                cell_dims[2] + 1.0,
                f64::INFINITY,
            ],
            margin,
        }
    }

    /// `false` only where the traversal's test of `root` within `[tmin, tmax]` passes no child;
    /// `true` for every ray whose window starts outside the grid's box (untested).
    ///
    /// # Safety
    /// The CPU must run AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) unsafe fn passes_avx2(&self, ray: &Ray, root: &Node, tmin: f64, tmax: f64) -> bool {
        // SAFETY: as this function's.
        unsafe { self.root_test_avx2(ray, root, tmin, tmax) }.is_none_or(|(mask, _)| mask != 0)
    }

    /// The traversal's test of `root` (`NodeRay::test_avx2`: which children the ray may pass
    /// through, and their entry times from `tmin`), or `None` where the window starts outside
    /// the grid's box.
    ///
    /// # Safety
    /// The CPU must run AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) unsafe fn root_test_avx2(
        &self,
        ray: &Ray,
        root: &Node,
        tmin: f64,
        tmax: f64,
    ) -> Option<(u32, [f32; WIDTH])> {
        use std::arch::x86_64::*;
        let xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
        // SAFETY: the masked loads read the three f64 of each array (lane 3 is zero, unread);
        // the tracer's arrays hold four; each row of `root.mc` holds eight u16.
        let (origin, direction, to_cells, spacing, box_hi, rows) = unsafe {
            (
                _mm256_maskload_pd(ray.origin.as_ptr(), xyz),
                _mm256_maskload_pd(ray.direction.as_ptr(), xyz),
                _mm256_load_pd(self.to_cells.as_ptr()),
                _mm256_load_pd(self.spacing.as_ptr()),
                _mm256_load_pd(self.box_hi.as_ptr()),
                root.mc.map(|row| {
                    let row = _mm_loadu_si128(row.as_ptr().cast());
                    _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(row))
                }),
            )
        };
        // `cell_units`: direction and origin in cells, `spacing / direction` (1e300 where 0).
        let zero = _mm256_setzero_pd();
        let inv = _mm256_blendv_pd(
            _mm256_div_pd(spacing, direction),
            _mm256_set1_pd(1e300),
            _mm256_cmp_pd::<_CMP_EQ_OQ>(direction, zero),
        );
        let direction = _mm256_mul_pd(direction, to_cells);
        let origin = _mm256_mul_pd(origin, to_cells);
        // `NodeRay::new`'s fast path: the ray re-based to `tmin`, which lies in the grown box.
        let start = _mm256_add_pd(origin, _mm256_mul_pd(_mm256_set1_pd(tmin), direction));
        let inside = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(start, _mm256_set1_pd(-1.0)),
            _mm256_cmp_pd::<_CMP_LE_OQ>(start, box_hi),
        );
        if _mm256_movemask_pd(inside) != 0b1111 || !(tmin <= tmax) {
            return None;
        }
        // `BoxFaces::new(start, inv, margin)`.
        let inv = _mm256_max_pd(
            _mm256_min_pd(inv, _mm256_set1_pd(1e30)),
            _mm256_set1_pd(-1e30),
        );
        let lower = _mm256_cvtpd_ps(_mm256_mul_pd(
            _mm256_sub_pd(_mm256_set1_pd(-self.margin), start),
            inv,
        ));
        let upper = _mm256_cvtpd_ps(_mm256_mul_pd(
            _mm256_sub_pd(_mm256_set1_pd(2.0 + self.margin), start),
            inv,
        ));
        let scale = _mm256_cvtpd_ps(_mm256_add_pd(inv, inv));
        let near = _mm_min_ps(lower, upper);
        let far = _mm_max_ps(lower, upper);
        // `NodeRay::window(tmin, tmax)` with `t_base = tmin`, then `test_avx2`. A row's face met
        // first is its upper one where the ray runs towards −axis: the sign of `scale`.
        let (lo_t, hi_t) = widen_f32(0.0, tmax - tmin);
        let mut entry = _mm256_set1_ps(lo_t);
        let mut exit = _mm256_set1_ps(hi_t);
        let lane = |v: __m128, a: usize| -> __m256 {
            let v = match a {
                0 => v,
                1 => _mm_permute_ps::<0b01_01_01_01>(v),
                _ => _mm_permute_ps::<0b10_10_10_10>(v),
            };
            _mm256_broadcastss_ps(v)
        };
        for a in 0..3 {
            let s = lane(scale, a);
            let first = _mm256_blendv_ps(rows[a], rows[3 + a], s);
            let last = _mm256_blendv_ps(rows[3 + a], rows[a], s);
            entry = _mm256_max_ps(entry, _mm256_fmadd_ps(first, s, lane(near, a)));
            exit = _mm256_min_ps(exit, _mm256_fmadd_ps(last, s, lane(far, a)));
        }
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(entry, exit)) as u32;
        let mut entries = [0f32; WIDTH];
        // SAFETY: `entries` holds eight f32.
        unsafe { _mm256_storeu_ps(entries.as_mut_ptr(), entry) };
        Some((mask, entries))
    }
}

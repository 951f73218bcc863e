//! One ray's constants for the cluster hierarchy's node tests, and the 8-wide node slab test in
//! SSE2 (two halves) and AVX2: the ray re-based to where it enters the grid's box, so that f32
//! `t` values stay small, and each axis's near and far face rows of a node chosen once per ray.
//!
//! Units: as [`crate::cluster_bvh`]: node boxes in cell units, stored as u16 metacell positions,
//! grown by the node margin.

use crate::cell_ray::{max, min, widen_f32, xyz, BoxFaces, CellRay, CellUnits};
use crate::cluster_bvh::{Node, WIDTH};

/// What one ray's node tests need, for the ray re-based to `t_base`: the faces of boxes made of
/// metacells ([`BoxFaces`], grown by the node margin), and `near_row[a]`, the row of `Node::mc`
/// holding the face met first on axis `a`. The leaf searches test metacell boxes with the same
/// faces, in the same window.
pub(crate) struct NodeRay {
    pub(crate) faces: BoxFaces,
    near_row: [usize; 3],
    far_row: [usize; 3],
    t_base: f64,
}

impl NodeRay {
    /// The ray re-based to where it enters the grid's box (grown by one cell) within `[tmin, tmax]`;
    /// `None` when it never does, or when that point is not finite. Boxes grown by `margin`.
    ///
    /// `units` are the ray's origin, direction and reciprocals ([`crate::cell_ray::cell_units`]);
    /// the whole [`CellRay`] (`cell_ray`) is built only where the window starts outside the
    /// grid's box.
    #[inline(always)]
    pub(crate) fn new(
        cell_ray: impl FnOnce() -> CellRay,
        units: CellUnits,
        cell_dims: [f64; 3],
        margin: f64,
        tmin: f64,
        tmax: f64,
    ) -> Option<Self> {
        let (origin, direction, inv) = units;
        // Where the window starts inside the grid's box (every ray of `bench rays`, and every
        // secondary ray of the renderers), that is where the ray is re-based, without waiting on
        // the slab test's divisions and products: the point at `tmin` lies in the box exactly
        // when `tmin` lies between the box's entry and exit.
        let start = xyz(|a| origin[a] + tmin * direction[a]);
        let inside = (0..3).fold(tmin <= tmax, |inside, a| {
            inside & (start[a] >= -1.0) & (start[a] <= cell_dims[a] + 1.0)
        });
        let (t_base, origin) = if inside {
            (tmin, start)
        } else {
            let r = cell_ray();
            let (near, far) = r.slab([-1.0; 3], xyz(|a| cell_dims[a] + 1.0));
            let t_base = max(near, tmin);
            if !(t_base <= min(far, tmax)) || !t_base.is_finite() {
                return None;
            }
            (t_base, r.at(t_base))
        };
        Some(NodeRay {
            faces: BoxFaces::new(origin, inv, margin),
            near_row: xyz(|a| if inv[a] < 0.0 { 3 + a } else { a }),
            far_row: xyz(|a| if inv[a] < 0.0 { a } else { 3 + a }),
            t_base,
        })
    }

    /// The window `[tmin, tmax]` relative to `t_base` in f32, widened so that it holds the exact
    /// window after rounding (the slab times' own rounding is covered by the boxes' margin).
    #[inline(always)]
    pub(crate) fn window(&self, tmin: f64, tmax: f64) -> (f32, f32) {
        widen_f32(tmin - self.t_base, tmax - self.t_base)
    }

    /// Slab tests of a node's child boxes within `(lo, hi)`: bit `k` set when the ray may pass
    /// through child `k`, and each child's entry `t` (relative to `t_base`). SSE2, four lanes at
    /// a time (scalar off x86-64).
    #[inline(always)]
    pub(crate) fn test_baseline(&self, node: &Node, (lo, hi): (f32, f32)) -> (u32, [f32; WIDTH]) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of the x86-64 baseline; each 8-byte load reads one row of
            // four u16 in `node.mc`.
            unsafe {
                let zero = _mm_setzero_si128();
                let mut entry = [0f32; WIDTH];
                let mut mask = 0;
                for h in 0..WIDTH / 4 {
                    let row = |r: usize| {
                        let v = _mm_loadl_epi64(node.mc[r].as_ptr().add(4 * h).cast());
                        _mm_cvtepi32_ps(_mm_unpacklo_epi16(v, zero))
                    };
                    let mut near = _mm_set1_ps(lo);
                    let mut far = _mm_set1_ps(hi);
                    for a in 0..3 {
                        let scale = _mm_set1_ps(self.faces.scale[a]);
                        let n = _mm_add_ps(
                            _mm_mul_ps(row(self.near_row[a]), scale),
                            _mm_set1_ps(self.faces.near[a]),
                        );
                        let f = _mm_add_ps(
                            _mm_mul_ps(row(self.far_row[a]), scale),
                            _mm_set1_ps(self.faces.far[a]),
                        );
                        near = _mm_max_ps(near, n);
                        far = _mm_min_ps(far, f);
                    }
                    _mm_storeu_ps(entry.as_mut_ptr().add(4 * h), near);
                    mask |= (_mm_movemask_ps(_mm_cmple_ps(near, far)) as u32) << (4 * h);
                }
                (mask, entry)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut near = [lo; WIDTH];
            let mut far = [hi; WIDTH];
            for a in 0..3 {
                for k in 0..WIDTH {
                    let n = node.mc[self.near_row[a]][k] as f32 * self.faces.scale[a]
                        + self.faces.near[a];
                    let f = node.mc[self.far_row[a]][k] as f32 * self.faces.scale[a]
                        + self.faces.far[a];
                    near[k] = max(near[k], n);
                    far[k] = min(far[k], f);
                }
            }
            let mask = (0..WIDTH).fold(0, |m, k| m | ((near[k] <= far[k]) as u32) << k);
            (mask, near)
        }
    }

    /// As [`Self::test_baseline`], all eight lanes in one AVX2 test.
    ///
    /// # Safety
    /// The CPU must run what `Avx2::detect` checks (AVX2, FMA and bit instructions).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    #[inline]
    pub(crate) unsafe fn test_avx2(
        &self,
        node: &Node,
        (lo, hi): (f32, f32),
    ) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        const _: () = assert!(WIDTH == 8);
        let mut near = _mm256_set1_ps(lo);
        let mut far = _mm256_set1_ps(hi);
        for a in 0..3 {
            // SAFETY: each 16-byte load reads one row of eight u16 in `node.mc`.
            let (first, last) = unsafe {
                (
                    _mm_loadu_si128(node.mc[self.near_row[a]].as_ptr().cast()),
                    _mm_loadu_si128(node.mc[self.far_row[a]].as_ptr().cast()),
                )
            };
            let first = _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(first));
            let last = _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(last));
            let scale = _mm256_set1_ps(self.faces.scale[a]);
            let n = _mm256_fmadd_ps(first, scale, _mm256_set1_ps(self.faces.near[a]));
            let f = _mm256_fmadd_ps(last, scale, _mm256_set1_ps(self.faces.far[a]));
            near = _mm256_max_ps(near, n);
            far = _mm256_min_ps(far, f);
        }
        let mut entry = [0f32; WIDTH];
        // SAFETY: `entry` holds eight f32.
        unsafe { _mm256_storeu_ps(entry.as_mut_ptr(), near) };
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
        (mask, entry)
    }
}

//! A copy of every cluster's metacell positions laid out for the tracer's metacell box test
//! (paper §3.6: per cluster, the metacells' boxes): one 64-byte record per cluster, the positions
//! of its 15 metacell slots as bytes per axis relative to the cluster's lowest metacell, so that
//! the 15 slab tests read one cache line, need no transpose of the 12-byte slots, and never touch
//! the slots of a cluster in which the ray meets no metacell (about half of the clusters a hit
//! ray enters on the dragon and the MNI head).
//!
//! | offset | size | field |
//! |---:|---:|---|
//! | 0 | 48 | `local[a][k]`: slot `k`'s metacell position minus `origin` on axis `a` (slot 15: 0) |
//! | 48 | 12 | `origin`: the lowest metacell position per axis over the occupied slots, f32 |
//! | 60 | 2 | `occupied`: bit `k` set when slot `k` (0–14) holds active cells |
//! | 62 | 2 | `far_apart`: 1 when some slot lies 256 or more metacells from `origin` (only a damaged file) |

use super::cell_ray::BoxFaces;
use isogrid::layout::{Metacell, BOUND_SLOT, CLUSTER_SLOTS};

/// See the module docs.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy)]
pub(super) struct ClusterBoxes {
    local: [[u8; CLUSTER_SLOTS]; 3],
    origin: [f32; 3],
    occupied: u16,
    far_apart: u16,
}
const _: () = assert!(std::mem::size_of::<ClusterBoxes>() == 64);

/// One [`ClusterBoxes`] per cluster, indexed by global cluster index (first slot / 16).
#[derive(Debug, Clone, Default)]
pub(super) struct AllClusterBoxes {
    records: Vec<ClusterBoxes>,
}

impl AllClusterBoxes {
    pub(super) fn new(metacells: &[Metacell]) -> Self {
        let records = metacells
            .chunks_exact(CLUSTER_SLOTS)
            .map(|cluster| {
                let slots = &cluster[..BOUND_SLOT];
                let mut occupied = 0u16;
                let mut origin = [u16::MAX; 3];
                for (k, m) in slots.iter().enumerate() {
                    if m.cell_mask & 0xff != 0 {
                        occupied |= 1 << k;
                        for (o, &p) in origin.iter_mut().zip(&m.position) {
                            *o = (*o).min(p);
                        }
                    }
                }
                let mut local = [[0u8; CLUSTER_SLOTS]; 3];
                let mut far_apart = 0;
                for (k, m) in slots.iter().enumerate() {
                    if occupied >> k & 1 == 0 {
                        continue;
                    }
                    for a in 0..3 {
                        let d = m.position[a] - origin[a];
                        far_apart |= (d > u8::MAX as u16) as u16;
                        local[a][k] = d.min(u8::MAX as u16) as u8;
                    }
                }
                ClusterBoxes {
                    local,
                    origin: origin.map(|o| if occupied == 0 { 0.0 } else { o as f32 }),
                    occupied,
                    far_apart,
                }
            })
            .collect();
        AllClusterBoxes { records }
    }

    /// The record of global cluster `c`, if there is one.
    #[inline(always)]
    pub(super) fn get(&self, c: usize) -> Option<&ClusterBoxes> {
        self.records.get(c)
    }

    /// Where record `c` lies (dangling past the end; for prefetching only).
    #[inline(always)]
    pub(super) fn record_ptr(&self, c: usize) -> *const i8 {
        self.records.as_ptr().wrapping_add(c).cast()
    }

    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.records[..])
    }
}

impl ClusterBoxes {
    /// Per axis: the f32 scale and the `t` of the near and far faces of the cluster's origin
    /// metacell; slot `k`'s faces are `local·scale` further.
    #[inline(always)]
    fn origin_faces(&self, faces: &BoxFaces) -> ([f32; 3], [f32; 3], [f32; 3]) {
        let BoxFaces {
            scale, near, far, ..
        } = *faces;
        let near0 = std::array::from_fn(|a| self.origin[a] * scale[a] + near[a]);
        let far0 = std::array::from_fn(|a| self.origin[a] * scale[a] + far[a]);
        (scale, near0, far0)
    }

    /// As [`Self::hits_baseline`], eight slots per AVX2 test.
    ///
    /// # Safety
    /// The CPU must run what `Avx2::detect` checks (AVX2, FMA and bit instructions).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    #[inline]
    pub(super) unsafe fn hits_avx2(&self, faces: &BoxFaces, t: (f32, f32)) -> u32 {
        use std::arch::x86_64::*;
        let (scale, near0, far0) = self.origin_faces(faces);
        let mut near_t = [_mm256_set1_ps(t.0); 2];
        let mut far_t = [_mm256_set1_ps(t.1); 2];
        for a in 0..3 {
            let s = _mm256_set1_ps(scale[a]);
            let n = _mm256_set1_ps(near0[a]);
            let f = _mm256_set1_ps(far0[a]);
            for g in 0..2 {
                // SAFETY: each 8-byte load reads half of one axis row of `local`.
                let bytes = unsafe { _mm_loadl_epi64(self.local[a].as_ptr().add(8 * g).cast()) };
                let p = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(bytes));
                near_t[g] = _mm256_max_ps(near_t[g], _mm256_fmadd_ps(p, s, n));
                far_t[g] = _mm256_min_ps(far_t[g], _mm256_fmadd_ps(p, s, f));
            }
        }
        let mut mask = 0;
        for g in 0..2 {
            let inside = _mm256_cmp_ps::<_CMP_LE_OQ>(near_t[g], far_t[g]);
            mask |= (_mm256_movemask_ps(inside) as u32) << (8 * g);
        }
        mask & self.occupied as u32
    }

    /// Whether [`Self::hits_baseline`] and `hits_avx2` can answer for this cluster (false only for a damaged file's
    /// cluster spanning 256 metacells or more; test the slots themselves then).
    #[inline(always)]
    pub(super) fn usable(&self) -> bool {
        self.far_apart == 0
    }

    /// Bit `k` set when the ray may pass through the box of occupied metacell slot `k` within the
    /// widened `t` range; as [`BoxFaces::boxes4`] on the slots' positions, with the boxes
    /// grown by the same margin (the one extra f32 rounding, of the origin's face, is far inside
    /// it). SSE2, four slots at a time (scalar off x86-64).
    #[inline(always)]
    pub(super) fn hits_baseline(&self, faces: &BoxFaces, t: (f32, f32)) -> u32 {
        let (scale, near0, far0) = self.origin_faces(faces);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of the x86-64 baseline; each 16-byte load reads one axis row of
            // `local`, and the store writes four lanes.
            unsafe {
                let zero = _mm_setzero_si128();
                let mut near_t = [_mm_set1_ps(t.0); 4];
                let mut far_t = [_mm_set1_ps(t.1); 4];
                for a in 0..3 {
                    let bytes = _mm_loadu_si128(self.local[a].as_ptr().cast());
                    let low = _mm_unpacklo_epi8(bytes, zero);
                    let high = _mm_unpackhi_epi8(bytes, zero);
                    let lanes = [
                        _mm_unpacklo_epi16(low, zero),
                        _mm_unpackhi_epi16(low, zero),
                        _mm_unpacklo_epi16(high, zero),
                        _mm_unpackhi_epi16(high, zero),
                    ];
                    let s = _mm_set1_ps(scale[a]);
                    let n = _mm_set1_ps(near0[a]);
                    let f = _mm_set1_ps(far0[a]);
                    for g in 0..4 {
                        let p = _mm_mul_ps(_mm_cvtepi32_ps(lanes[g]), s);
                        near_t[g] = _mm_max_ps(near_t[g], _mm_add_ps(p, n));
                        far_t[g] = _mm_min_ps(far_t[g], _mm_add_ps(p, f));
                    }
                }
                let mut mask = 0;
                for g in 0..4 {
                    mask |= (_mm_movemask_ps(_mm_cmple_ps(near_t[g], far_t[g])) as u32) << (4 * g);
                }
                mask & self.occupied as u32
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut mask = 0;
            for k in 0..BOUND_SLOT {
                let mut lo = t.0;
                let mut hi = t.1;
                for a in 0..3 {
                    let p = self.local[a][k] as f32 * scale[a];
                    lo = super::cell_ray::max(lo, p + near0[a]);
                    hi = super::cell_ray::min(hi, p + far0[a]);
                }
                mask |= ((lo <= hi) as u32) << k;
            }
            mask & self.occupied as u32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell_ray::CellRay;
    use crate::sample::Rng;
    use isogrid::camera::Ray;

    /// Random clusters of a 128K³-cell grid (metacell positions up to 65535) and random rays: each
    /// packed test (the baseline, and AVX2 where the CPU has it) reports every occupied metacell
    /// box that the exact f64 slab test finds the ray passing through, and no box that the exact
    /// test, on the box grown by twice the margin, finds it missing; empty slots are never
    /// reported.
    #[test]
    fn agrees_with_the_exact_slab_test() {
        let mut rng = Rng::for_sample(7, 0, 0);
        let mut below = |n: u64| rng.next_u64() % n;
        let mut unit = Rng::for_sample(7, 1, 0);
        let largest = 131072.0f64;
        let margin = (1e-3f64).max(largest * 1e-5);
        #[cfg(target_arch = "x86_64")]
        let avx2 = crate::lanes::Avx2::detect();
        let (mut inside, mut outside) = (0, 0);
        for _ in 0..400 {
            // A cluster in one 8³-metacell block, some slots empty.
            let block = [0; 3].map(|_: i32| below(8192) as u16 * 8);
            let mut cluster = [<Metacell as bytemuck::Zeroable>::zeroed(); CLUSTER_SLOTS];
            for m in cluster.iter_mut().take(BOUND_SLOT) {
                m.position = std::array::from_fn(|a| block[a] + below(8) as u16);
                m.cell_mask = if below(4) == 0 {
                    0
                } else {
                    1 + below(255) as u16
                };
            }
            let boxes = AllClusterBoxes::new(&cluster);
            let record = boxes.get(0).unwrap();
            assert!(record.usable());
            for _ in 0..20 {
                // Rays from near the block, or from far away, towards a point of the block.
                let spread = if below(2) == 0 { 40.0 } else { 1e5 };
                let target: [f64; 3] =
                    std::array::from_fn(|a| 2.0 * block[a] as f64 + 16.0 * unit.unit());
                let origin: [f64; 3] =
                    std::array::from_fn(|a| target[a] + spread * (2.0 * unit.unit() - 1.0));
                let d: [f64; 3] = std::array::from_fn(|a| target[a] - origin[a]);
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let ray = Ray {
                    origin,
                    direction: d.map(|v| v / len),
                };
                let r = CellRay::new(&ray, [1.0; 3], margin);
                let (tmin, tmax) = (0.0, len * (0.5 + unit.unit()));
                let window = (tmin as f32, tmax as f32);
                let mut results = vec![("baseline", record.hits_baseline(r.faces(), window))];
                #[cfg(target_arch = "x86_64")]
                if avx2.is_some() {
                    // SAFETY: the CPU runs the `Avx2` set (detected above).
                    results.push(("AVX2", unsafe { record.hits_avx2(r.faces(), window) }));
                }
                for (k, m) in cluster.iter().enumerate().take(BOUND_SLOT) {
                    let lo = m.position.map(|p| 2.0 * p as f64);
                    let exact = |grow: f64| {
                        let (near, far) = r.slab(lo.map(|v| v - grow), lo.map(|v| v + 2.0 + grow));
                        near.max(tmin) <= far.min(tmax)
                    };
                    for &(set, hits) in &results {
                        let got = hits >> k & 1 == 1;
                        if m.cell_mask == 0 {
                            assert!(!got, "{set}: empty slot {k} reported");
                        } else if exact(0.0) {
                            assert!(got, "{set}: slot {k} at {:?} missed by {ray:?}", m.position);
                            inside += 1;
                        } else if !exact(2.0 * margin) {
                            assert!(
                                !got,
                                "{set}: slot {k} at {:?} reported for {ray:?}",
                                m.position
                            );
                            outside += 1;
                        }
                    }
                }
                for &(set, hits) in &results {
                    assert_eq!(
                        hits & !0x7fff,
                        0,
                        "{set}: slot 15 is the bound, not a metacell"
                    );
                }
            }
        }
        assert!(inside > 1000 && outside > 10000, "{inside} {outside}");
    }
}

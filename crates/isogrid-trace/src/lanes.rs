//! Which SIMD instructions the tracer's box tests run on, chosen once per tracer at run time, as
//! Embree does: AVX2 with FMA (one 8-lane test per hierarchy node, two per cluster's metacells)
//! where the CPU has them, else the x86-64 baseline SSE2 (4 lanes; scalar code off x86-64).
//!
//! The traversal functions are generic over [`Lanes`] and marked `#[inline(always)]`; each tracer
//! calls them through one `#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]` entry
//! point per query, so the whole traversal is compiled for AVX2 there and the kernels inline into
//! it. On the dragon and the MNI head this took about 14 % off the cluster hierarchy's time per
//! ray. The bit instructions come with every AVX2 CPU; with them a
//! cell's record index is one `popcnt` instead of a dozen instructions, and bit scans one `tzcnt`.
//! Both sets find the same hits: the tests differ only in f32 rounding, which the boxes' margins
//! absorb (`bvh_traverse::tests::both_sets_find_the_same_hits`).
//!
//! Any-hit queries stay on the baseline set: nothing traces them in bulk (the renderers and the
//! benchmark ask for closest hits).

use crate::cell_ray::BoxFaces;
use crate::cluster_boxes::ClusterBoxes;
use crate::cluster_bvh::{Node, WIDTH};
use crate::node_ray::NodeRay;

/// The two box tests the traversals need, in one instruction set. A value of the type is the
/// proof that the CPU can run it.
pub(super) trait Lanes: Copy {
    /// Slab tests of a node's child boxes within `window`: bit `k` set when the ray may pass
    /// through child `k`, and each child's entry `t` ([`NodeRay::test_baseline`]).
    fn node_test(self, ray: &NodeRay, node: &Node, window: (f32, f32)) -> (u32, [f32; WIDTH]);
    /// Bit `k` set when the ray may pass through occupied metacell slot `k` of a cluster
    /// ([`ClusterBoxes::hits_baseline`]).
    fn metacell_boxes(self, boxes: &ClusterBoxes, faces: &BoxFaces, t: (f32, f32)) -> u32;
}

/// SSE2 on x86-64 (part of its baseline), scalar elsewhere: always available.
#[derive(Debug, Clone, Copy)]
pub(super) struct Baseline;

impl Lanes for Baseline {
    #[inline(always)]
    fn node_test(self, ray: &NodeRay, node: &Node, window: (f32, f32)) -> (u32, [f32; WIDTH]) {
        ray.test_baseline(node, window)
    }
    #[inline(always)]
    fn metacell_boxes(self, boxes: &ClusterBoxes, faces: &BoxFaces, t: (f32, f32)) -> u32 {
        boxes.hits_baseline(faces, t)
    }
}

/// AVX2, FMA and the bit instructions (POPCNT, BMI1, BMI2, LZCNT); only [`Avx2::detect`] makes
/// one, and only on a CPU that has them all.
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
pub(super) struct Avx2 {
    _detected: (),
}

#[cfg(target_arch = "x86_64")]
impl Avx2 {
    /// `Some` when this CPU runs AVX2, FMA and the bit instructions, unless the environment
    /// variable `ISOGRID_NO_AVX2` is set (to compare the two sets in one run).
    pub(super) fn detect() -> Option<Self> {
        let forced_off = std::env::var_os("ISOGRID_NO_AVX2").is_some();
        // Every CPU with AVX2 has these too (Haswell, Excavator and later); the traversal's bit
        // counts and scans compile to single instructions with them.
        let all = is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
            && is_x86_feature_detected!("popcnt")
            && is_x86_feature_detected!("bmi1")
            && is_x86_feature_detected!("bmi2")
            && is_x86_feature_detected!("lzcnt");
        (!forced_off && all).then_some(Avx2 { _detected: () })
    }
}

#[cfg(target_arch = "x86_64")]
impl Lanes for Avx2 {
    #[inline(always)]
    fn node_test(self, ray: &NodeRay, node: &Node, window: (f32, f32)) -> (u32, [f32; WIDTH]) {
        // SAFETY: an `Avx2` exists only where the CPU runs all of its set (`Avx2::detect`).
        unsafe { ray.test_avx2(node, window) }
    }
    #[inline(always)]
    fn metacell_boxes(self, boxes: &ClusterBoxes, faces: &BoxFaces, t: (f32, f32)) -> u32 {
        // SAFETY: as above.
        unsafe { boxes.hits_avx2(faces, t) }
    }
}

/// The set a new tracer uses: AVX2 where available.
#[derive(Debug, Clone, Copy)]
pub(super) struct Chosen {
    #[cfg(target_arch = "x86_64")]
    pub(super) avx2: Option<Avx2>,
}

impl Chosen {
    pub(super) fn detect() -> Self {
        Chosen {
            #[cfg(target_arch = "x86_64")]
            avx2: Avx2::detect(),
        }
    }

    /// Name of the set, for reports.
    pub fn name(&self) -> &'static str {
        #[cfg(target_arch = "x86_64")]
        if self.avx2.is_some() {
            return "avx2";
        }
        "baseline"
    }
}

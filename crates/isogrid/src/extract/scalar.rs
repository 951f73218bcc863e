//! What the extraction needs of a sample type beyond [`Scalar`]: sentinels and the isovalue
//! translated into the type, so hot loops compare samples without converting them.

use crate::volume::Scalar;

pub(crate) trait ExtractScalar: Scalar {
    /// Starts a running minimum (every sample is `<=` it, NaN aside).
    const HIGHEST: Self;
    /// Starts a running maximum.
    const LOWEST: Self;
    /// The smallest value of this type that is `>= iso`, so `v >= iso ⇔ v >= threshold`;
    /// `None` when no value of the type reaches `iso`.
    fn threshold(iso: f64) -> Option<Self>;

    /// Whether samples can be NaN (which count as outside but escape min/max).
    const MAY_BE_NAN: bool = false;

    /// The integer code of an integer sample under an exact (`step = 1`) mapping with this offset.
    fn exact_code(self, offset: i64) -> u32;

    /// The sample as a u8, for u8 samples (whose codes are looked up).
    #[inline]
    fn as_u8(self) -> Option<u8> {
        None
    }

    /// Bit i set when `chunk[i] >= t`.
    #[inline]
    fn mask_chunk(chunk: &[Self; 16], t: Self) -> u16 {
        let mut m = 0u16;
        for (i, &v) in chunk.iter().enumerate() {
            m |= ((v >= t) as u16) << i;
        }
        m
    }

    /// One 16-sample chunk of a row: returns bit i set when `chunk[i] >= t`, and folds the chunk
    /// into the lane-wise running minima and maxima (NaN ignored). The hot loop of pass 1.
    #[inline]
    fn scan_chunk(chunk: &[Self; 16], t: Self, lo: &mut [Self; 16], hi: &mut [Self; 16]) -> u16 {
        let mut m = 0u16;
        for i in 0..16 {
            let v = chunk[i];
            m |= ((v >= t) as u16) << i;
            lo[i] = if v < lo[i] { v } else { lo[i] };
            hi[i] = if v > hi[i] { v } else { hi[i] };
        }
        m
    }
}

/// The smallest integer in `min..=max` that is `>= iso`, compared exactly (no rounding of either
/// side: `ceil` of an f64 is an integer-valued f64, which i128 holds exactly); `None` when none is
/// (or `iso` is NaN). For every integer `v` of the range, `v >= iso ⇔ v >= result`.
pub(crate) fn integer_at_or_above(iso: f64, min: i128, max: i128) -> Option<i128> {
    if iso.is_nan() {
        return None;
    }
    // `as` saturates ±∞ and magnitudes beyond i128, which the clamp below handles alike.
    let c = iso.ceil() as i128;
    (c <= max).then_some(c.max(min))
}

/// The smallest integer in `min..=max` that is `> iso`, exactly: floor(iso) + 1 in i128 (in f64
/// the + 1 would vanish beyond 2^53).
pub(crate) fn integer_above(iso: f64, min: i128, max: i128) -> Option<i128> {
    if iso.is_nan() {
        return None;
    }
    let c = (iso.floor() as i128).saturating_add(1);
    (c <= max).then_some(c.max(min))
}

macro_rules! integer_scalar {
    ($t:ty) => {
        impl ExtractScalar for $t {
            const HIGHEST: Self = <$t>::MAX;
            const LOWEST: Self = <$t>::MIN;
            fn threshold(iso: f64) -> Option<Self> {
                integer_at_or_above(iso, <$t>::MIN as i128, <$t>::MAX as i128).map(|c| c as $t)
            }
            #[inline]
            fn exact_code(self, offset: i64) -> u32 {
                // Exact mappings only exist for ranges within ±2^53 (see `Quantizer::new`), where
                // every sample fits an i64.
                (self as i64 - offset) as u32
            }
        }
    };
}

impl ExtractScalar for u8 {
    const HIGHEST: Self = u8::MAX;
    const LOWEST: Self = u8::MIN;
    fn threshold(iso: f64) -> Option<Self> {
        integer_at_or_above(iso, 0, 255).map(|c| c as u8)
    }

    #[inline]
    fn exact_code(self, offset: i64) -> u32 {
        (self as i64 - offset) as u32
    }

    #[inline]
    fn as_u8(self) -> Option<u8> {
        Some(self)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn mask_chunk(chunk: &[u8; 16], t: u8) -> u16 {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the load is unaligned and in bounds.
        unsafe {
            let v = _mm_loadu_si128(chunk.as_ptr().cast());
            _mm_movemask_epi8(_mm_cmpeq_epi8(_mm_max_epu8(v, _mm_set1_epi8(t as i8)), v)) as u16
        }
    }

    /// SSE2 (baseline on x86-64): 16 samples in one register; LLVM does not find this itself.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn scan_chunk(chunk: &[u8; 16], t: u8, lo: &mut [u8; 16], hi: &mut [u8; 16]) -> u16 {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; loads and stores are unaligned and in bounds.
        unsafe {
            let v = _mm_loadu_si128(chunk.as_ptr().cast());
            let at_least = _mm_cmpeq_epi8(_mm_max_epu8(v, _mm_set1_epi8(t as i8)), v);
            let l = _mm_loadu_si128(lo.as_ptr().cast());
            let h = _mm_loadu_si128(hi.as_ptr().cast());
            _mm_storeu_si128(lo.as_mut_ptr().cast(), _mm_min_epu8(l, v));
            _mm_storeu_si128(hi.as_mut_ptr().cast(), _mm_max_epu8(h, v));
            _mm_movemask_epi8(at_least) as u16
        }
    }
}
integer_scalar!(u16);
integer_scalar!(i16);
integer_scalar!(u32);
integer_scalar!(i32);
integer_scalar!(u64);
integer_scalar!(i64);

/// f64 samples compare with the (f64) isovalue itself: exact.
impl ExtractScalar for f64 {
    const MAY_BE_NAN: bool = true;
    const HIGHEST: Self = f64::INFINITY;
    const LOWEST: Self = f64::NEG_INFINITY;
    fn threshold(iso: f64) -> Option<Self> {
        Some(iso)
    }
    fn exact_code(self, _offset: i64) -> u32 {
        unreachable!("float samples are quantised through the affine path")
    }
}

impl ExtractScalar for f32 {
    const MAY_BE_NAN: bool = true;
    const HIGHEST: Self = f32::INFINITY;
    const LOWEST: Self = f32::NEG_INFINITY;
    fn threshold(iso: f64) -> Option<Self> {
        let r = iso as f32;
        Some(if (r as f64) < iso { r.next_up() } else { r })
    }

    /// Float data never gets an exact integer mapping.
    fn exact_code(self, _offset: i64) -> u32 {
        unreachable!("float samples are quantised through the affine path")
    }

    /// SSE (baseline on x86-64), four lanes at a time; `minps(v, lo)` keeps `lo` when `v` is NaN.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn scan_chunk(chunk: &[f32; 16], t: f32, lo: &mut [f32; 16], hi: &mut [f32; 16]) -> u16 {
        use std::arch::x86_64::*;
        let mut m = 0u16;
        // SAFETY: SSE is part of the x86-64 baseline; all accesses are in bounds of 16-element arrays.
        unsafe {
            let tv = _mm_set1_ps(t);
            for q in 0..4 {
                let v = _mm_loadu_ps(chunk.as_ptr().add(4 * q));
                m |= (_mm_movemask_ps(_mm_cmpge_ps(v, tv)) as u16) << (4 * q);
                let l = _mm_loadu_ps(lo.as_ptr().add(4 * q));
                let h = _mm_loadu_ps(hi.as_ptr().add(4 * q));
                _mm_storeu_ps(lo.as_mut_ptr().add(4 * q), _mm_min_ps(v, l));
                _mm_storeu_ps(hi.as_mut_ptr().add(4 * q), _mm_max_ps(v, h));
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thresholds against comparisons made in i128 with integer isovalues, which are exact
    /// (f64 integers up to 2^64 convert to i128 without rounding).
    #[test]
    fn integer_thresholds_are_exact_at_the_edges_of_64_bit_types() {
        let two63 = 2f64.powi(63);
        let two64 = 2f64.powi(64);
        for iso in [
            0.0,
            -1.0,
            two63,
            -two63,
            two64,
            2f64.powi(60),
            2f64.powi(53) + 2.0,
        ] {
            let i = iso as i128;
            for v in [
                0u64,
                1,
                u64::MAX,
                1 << 60,
                (1 << 60) - 1,
                (1 << 53) + 1,
                (1 << 53) + 2,
            ] {
                let t = u64::threshold(iso);
                assert_eq!(
                    t.is_some_and(|t| v >= t),
                    v as i128 >= i,
                    "u64 {v} >= {iso}"
                );
            }
            for v in [0i64, -1, i64::MIN, i64::MAX, (1 << 53) + 1, -(1 << 53) - 1] {
                let t = i64::threshold(iso);
                assert_eq!(
                    t.is_some_and(|t| v >= t),
                    v as i128 >= i,
                    "i64 {v} >= {iso}"
                );
                let above = integer_above(iso, i64::MIN as i128, i64::MAX as i128);
                assert_eq!(
                    above.is_some_and(|t| v as i128 >= t),
                    v as i128 > i,
                    "i64 {v} > {iso}"
                );
            }
        }
        // A fractional isovalue between two integers an f32 cannot tell apart.
        assert_eq!(u32::threshold(16_777_216.5), Some(16_777_217));
        assert_eq!(i32::threshold(-99_999_999.5), Some(-99_999_999));
        assert_eq!(u8::threshold(f64::NAN), None);
        assert_eq!(f64::threshold(0.1), Some(0.1));
    }
}

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

macro_rules! integer_scalar {
    ($t:ty) => {
        impl ExtractScalar for $t {
            const HIGHEST: Self = <$t>::MAX;
            const LOWEST: Self = <$t>::MIN;
            fn threshold(iso: f64) -> Option<Self> {
                let c = iso.ceil();
                if c > <$t>::MAX as f64 {
                    None
                } else {
                    Some(c.max(<$t>::MIN as f64) as $t)
                }
            }
            #[inline]
            fn exact_code(self, offset: i64) -> u32 {
                (self as i64 - offset) as u32
            }
        }
    };
}

impl ExtractScalar for u8 {
    const HIGHEST: Self = u8::MAX;
    const LOWEST: Self = u8::MIN;
    fn threshold(iso: f64) -> Option<Self> {
        let c = iso.ceil();
        if c > 255.0 {
            None
        } else {
            Some(c.max(0.0) as u8)
        }
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

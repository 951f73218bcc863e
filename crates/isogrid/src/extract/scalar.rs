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
        }
    };
}
integer_scalar!(u8);
integer_scalar!(u16);
integer_scalar!(i16);

impl ExtractScalar for f32 {
    const HIGHEST: Self = f32::INFINITY;
    const LOWEST: Self = f32::NEG_INFINITY;
    fn threshold(iso: f64) -> Option<Self> {
        let r = iso as f32;
        Some(if (r as f64) < iso { r.next_up() } else { r })
    }
}

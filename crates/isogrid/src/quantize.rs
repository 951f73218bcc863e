//! Corner-value quantisation that never moves a corner across the isovalue (paper §3.1, §3.5).
//!
//! Stored codes relate to data values by `value ≈ offset + code · step`. Integer volumes whose value
//! range fits the code range are stored exactly (`step = 1`): u8 at 8 bits, u16 and i16 at 16 bits.
//! Otherwise the value range `[min, max]` is spread over all codes and each value rounds to the
//! nearest code — except that a corner whose rounded code would land on the wrong side of the
//! threshold is pulled to the nearest code on its own side. Renderers compare interpolated codes
//! with [`ValueMapping::iso_code`]: `code >= iso_code` holds for a stored corner exactly when
//! `value >= iso` held for the original sample, so the set of active cells and every corner's side
//! survive quantisation. 32-bit precision stores the values themselves as f32; a wider sample
//! (u32, i32, 64-bit) whose f32 would cross the threshold is stored as the nearest f32 on its own
//! side instead. Integer data is stored exactly only where its range lies within ±2^53, where the
//! f64 range and every sample are exact.

use crate::layout::Precision;

/// How stored codes map to data values, and the isovalue in code units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueMapping {
    /// Data value of code 0.
    pub offset: f64,
    /// Data units per code step (1 for 32-bit floats, whose codes are the values).
    pub step: f64,
    /// Threshold in code units: a stored corner is inside when its code is `>= iso_code`.
    pub iso_code: f32,
}

impl ValueMapping {
    /// Data value of a code.
    pub fn value(&self, code: f32) -> f64 {
        self.offset + code as f64 * self.step
    }
    /// The isovalue normalised to the code range, as a renderer that reads codes as unorm values
    /// (code / max_code) compares them; for floats, the isovalue itself.
    pub fn iso_normalized(&self, precision: Precision) -> f32 {
        match precision.max_code() {
            Some(max) => self.iso_code / max as f32,
            None => self.iso_code,
        }
    }
}

/// Precomputed quantiser for one extraction.
#[derive(Debug, Clone, Copy)]
pub struct Quantizer {
    precision: Precision,
    mapping: ValueMapping,
    inv_step: f64,
    max_code: f64,
    /// Smallest code that counts as inside (integer precisions).
    first_inside: f64,
    exact: bool,
    /// The code of every u8 sample value, its side being `value >= iso` (integer precisions):
    /// u8 volumes at 4 bits and label indicators look their codes up instead of rounding.
    u8_codes: [u16; 256],
}

/// Smallest f32 that is `>= x`, so that `v >= x ⇔ v >= result` for every f32 `v`.
fn f32_at_or_above(x: f64) -> f32 {
    let r = x as f32;
    if (r as f64) < x {
        r.next_up()
    } else {
        r
    }
}

/// `x.round()` (halves away from zero) of a code `x` in `0..2⁵²`, in lane arithmetic: adding and
/// taking away 2⁵² rounds to the nearest integer with ties to even (the sum's unit is 1), and a
/// tie that went down (`x − r` = ½, exact since `r` is within ½ of `x`) goes up instead. No call
/// to libm's `round` (which baseline x86-64 makes), no branch, and eight corners at a time
/// vectorise.
#[inline(always)]
fn round_code(x: f64) -> f64 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    let r = (x + TWO_52) - TWO_52;
    r + if x - r == 0.5 { 1.0 } else { 0.0 }
}

impl Quantizer {
    /// Builds the mapping for values in `[min, max]` of an integer (`integer_data`) or float volume.
    pub fn new(precision: Precision, integer_data: bool, min: f64, max: f64, iso: f64) -> Self {
        let Some(max_code) = precision.max_code() else {
            return Quantizer {
                precision,
                mapping: ValueMapping {
                    offset: 0.0,
                    step: 1.0,
                    iso_code: f32_at_or_above(iso),
                },
                inv_step: 1.0,
                max_code: f64::MAX,
                first_inside: 0.0,
                exact: true,
                u8_codes: [0; 256],
            };
        };
        let max_code = max_code as f64;
        let span = max - min;
        // Beyond ±2^53 the range (and the offset below) would be a rounded 64-bit integer.
        let exactly_f64 = |x: f64| x.abs() < 9_007_199_254_740_992.0;
        let (offset, step, exact) =
            if integer_data && span <= max_code && exactly_f64(min) && exactly_f64(max) {
                // Keep raw codes when they already fit, e.g. u8 at 8 bits stores the samples themselves.
                let offset = if min >= 0.0 && max <= max_code {
                    0.0
                } else {
                    min
                };
                (offset, 1.0, true)
            } else if span > 0.0 {
                (min, span / max_code, false)
            } else {
                (min, 1.0, false)
            };
        let x = (iso - offset) / step;
        let first_inside = x.ceil();
        // iso_code must separate first_inside - 1 (outside) from first_inside (inside).
        let mut t = x as f32;
        if t as f64 > first_inside {
            t = first_inside as f32;
        }
        if t as f64 <= first_inside - 1.0 {
            t = ((first_inside - 1.0) as f32).next_up();
        }
        let mut q = Quantizer {
            precision,
            mapping: ValueMapping {
                offset,
                step,
                iso_code: t,
            },
            inv_step: 1.0 / step,
            max_code,
            first_inside,
            exact,
            u8_codes: [0; 256],
        };
        q.u8_codes = std::array::from_fn(|v| q.code(v as f64, v as f64 >= iso) as u16);
        q
    }

    /// The integer offset when codes are `sample − offset` exactly (integer data that fits).
    pub(crate) fn exact_integer_offset(&self) -> Option<i64> {
        (self.exact && self.precision != Precision::Float32).then_some(self.mapping.offset as i64)
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }
    pub fn mapping(&self) -> ValueMapping {
        self.mapping
    }

    /// Code of one sample; `inside` is the sample's side (`value >= iso`), which the code keeps.
    #[inline]
    pub fn code(&self, value: f64, inside: bool) -> u32 {
        if self.exact {
            return (value - self.mapping.offset) as u32;
        }
        self.scaled_code(value, inside) as u32
    }

    /// [`Quantizer::code`] of a mapping that is not exact, as an f64. Selects rather than
    /// branches (on NaN, on the side, which follows the surface and mispredicts), so that
    /// [`Quantizer::encode_cell`]'s eight corners vectorise.
    #[inline(always)]
    fn scaled_code(&self, value: f64, inside: bool) -> f64 {
        let x = (value - self.mapping.offset) * self.inv_step;
        // Clamped to the codes, NaN to 0 (integers, so before or after rounding is the same).
        let x = if x > 0.0 { x } else { 0.0 };
        let x = if x < self.max_code { x } else { self.max_code };
        let c = round_code(x);
        // Then to the codes of the sample's side.
        let lo = if inside { self.first_inside } else { 0.0 };
        let hi = if inside {
            self.max_code
        } else {
            self.first_inside - 1.0
        };
        let c = if c > lo { c } else { lo };
        if c < hi {
            c
        } else {
            hi
        }
    }

    /// Writes the corner record of one cell (`values` in corner order, `inside` bit c = corner c's side).
    #[inline]
    pub fn encode_cell(&self, values: &[f64; 8], inside: u8, out: &mut [u8]) {
        if self.precision == Precision::Float32 {
            let t = self.mapping.iso_code;
            for (c, v) in values.iter().enumerate() {
                // An f32 sample keeps its side as it is (t is the least f32 >= iso); a wider one
                // may round across t and is pulled back to the nearest f32 on its side.
                let mut code = *v as f32;
                if inside >> c & 1 != 0 {
                    if !(code >= t) {
                        code = t;
                    }
                } else if code >= t {
                    code = t.next_down();
                }
                out[4 * c..4 * c + 4].copy_from_slice(&code.to_le_bytes());
            }
            return;
        }
        let codes = if self.exact {
            std::array::from_fn(|c| self.code(values[c], inside >> c & 1 != 0) as u16)
        } else {
            let scaled: [f64; 8] =
                std::array::from_fn(|c| self.scaled_code(values[c], inside >> c & 1 != 0));
            scaled.map(|c| c as u16)
        };
        self.pack_codes(&codes, out);
    }

    /// [`Quantizer::encode_cell`] of u8 samples, whose codes are looked up (integer precisions).
    #[inline]
    pub(crate) fn encode_u8_cell(&self, values: &[u8; 8], out: &mut [u8]) {
        self.pack_codes(&values.map(|v| self.u8_codes[v as usize]), out);
    }

    /// Packs eight integer codes into a corner record at the precision's width.
    #[inline]
    fn pack_codes(&self, codes: &[u16; 8], out: &mut [u8]) {
        match self.precision {
            Precision::Bits16 => {
                for (c, code) in codes.iter().enumerate() {
                    out[2 * c..2 * c + 2].copy_from_slice(&code.to_le_bytes());
                }
            }
            Precision::Bits8 => {
                for (c, &code) in codes.iter().enumerate() {
                    out[c] = code as u8;
                }
            }
            Precision::Bits1 => {
                out[0] = codes
                    .iter()
                    .enumerate()
                    .fold(0u8, |byte, (c, &code)| byte | ((code as u8 & 1) << c));
            }
            Precision::Bits4 => {
                for pair in 0..4 {
                    out[pair] = (codes[2 * pair] | codes[2 * pair + 1] << 4) as u8;
                }
            }
            Precision::Float32 => unreachable!("32-bit records hold values, not codes"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::read_corner;

    #[test]
    fn code_rounding_is_f64_round() {
        let mut values = vec![
            0.0,
            0.5,
            1.5,
            2.5,
            254.5,
            255.0,
            65534.5,
            65535.0,
            4294967295.5,
        ];
        for base in [0.0f64, 1.0, 2.0, 127.0, 255.0, 65535.0] {
            for v in [base + 0.5, base + 0.25, base + 0.75] {
                values.extend([v, v.next_up(), v.next_down()]);
            }
            values.extend([base.next_up(), (base + 1.0).next_down()]);
        }
        let mut next = crate::test_rng::xorshift(7);
        values.extend((0..10_000).map(|_| (next() >> 11) as f64 / (1u64 << 53) as f64 * 70_000.0));
        for x in values {
            assert_eq!(round_code(x).to_bits(), x.round().to_bits(), "{x:?}");
        }
    }

    /// Every value of a dense sweep around the isovalue keeps its side after quantisation.
    fn assert_sides_kept(
        precision: Precision,
        integer: bool,
        min: f64,
        max: f64,
        iso: f64,
        values: &[f64],
    ) {
        let q = Quantizer::new(precision, integer, min, max, iso);
        let t = q.mapping().iso_code;
        for chunk in values.chunks(8) {
            let mut vals = [min; 8];
            vals[..chunk.len()].copy_from_slice(chunk);
            let inside = vals
                .iter()
                .enumerate()
                .fold(0u8, |m, (c, v)| m | ((*v >= iso) as u8) << c);
            let mut rec = [0u8; 32];
            q.encode_cell(&vals, inside, &mut rec[..precision.bytes_per_cell()]);
            for (c, v) in vals.iter().enumerate() {
                let code = read_corner(&rec, precision, c);
                assert_eq!(
                    code >= t,
                    *v >= iso,
                    "{precision:?} value {v} iso {iso} code {code} threshold {t} (range {min}..{max})"
                );
                if let Some(mc) = precision.max_code() {
                    assert!(code <= mc as f32);
                }
            }
        }
    }

    #[test]
    fn adversarial_values_within_one_step_of_the_isovalue_keep_their_side() {
        for precision in Precision::ALL {
            for &(min, max) in &[(0.0, 1.0), (-1000.0, 3000.0), (0.0, 255.0), (10.0, 10.5)] {
                let step = match precision.max_code() {
                    Some(mc) => (max - min) / mc as f64,
                    None => 1e-6,
                };
                for frac in [0.0, 0.13, 0.5, 0.5 + 1e-9, 0.77, 1.0 - 1e-12, 1.0] {
                    let iso = min + frac * (max - min);
                    let mut values = vec![min, max];
                    for k in -40..=40 {
                        let v = iso + k as f64 * step / 16.0;
                        if v >= min && v <= max {
                            values.push(v);
                        }
                    }
                    values.extend([iso, iso - 1e-9, iso + 1e-9, iso - step, iso + step]);
                    values.retain(|v| *v >= min && *v <= max);
                    // Float32 stores f32 values: feed it values that are f32 already.
                    if precision == Precision::Float32 {
                        values.iter_mut().for_each(|v| *v = *v as f32 as f64);
                    }
                    assert_sides_kept(precision, false, min, max, iso, &values);
                }
            }
        }
    }

    #[test]
    fn integer_data_is_exact_when_it_fits() {
        let q = Quantizer::new(Precision::Bits8, true, 3.0, 200.0, 100.0);
        assert_eq!(q.mapping().offset, 0.0);
        assert_eq!(q.code(137.0, true), 137);
        let q = Quantizer::new(Precision::Bits16, true, -1024.0, 3071.0, 300.5);
        assert_eq!(q.mapping().offset, -1024.0);
        assert_eq!(q.mapping().value(q.code(-5.0, false) as f32), -5.0);
        assert_eq!(q.mapping().iso_code, 1324.5);
        // Integer isovalues tie on samples: equal counts as inside.
        let values: Vec<f64> = (0..=255).map(f64::from).collect();
        assert_sides_kept(Precision::Bits8, true, 0.0, 255.0, 128.0, &values);
        assert_sides_kept(Precision::Bits4, true, 0.0, 255.0, 128.0, &values);
        assert_sides_kept(Precision::Bits4, true, 0.0, 255.0, 127.5, &values);
    }

    #[test]
    fn threshold_is_just_above_an_isovalue_that_is_not_an_f32() {
        let iso = 0.1f64; // 0.1 rounds down to f32
        let q = Quantizer::new(Precision::Float32, false, 0.0, 1.0, iso);
        let t = q.mapping().iso_code;
        assert!(t as f64 >= iso && (t.next_down() as f64) < iso);
    }
}

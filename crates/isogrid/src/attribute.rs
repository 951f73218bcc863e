//! Per-cell attributes (paper §3.4: cells carry "normals and other attributes"; §5: data "that
//! need storing additional attributes per voxel or cell"): a second quantity sampled for every
//! active cell, to colour the surface by.
//!
//! An attribute is stored as one `.cgc` section (kind [`crate::cgc::SectionKind::CellAttribute`]):
//! a 96-byte head, then the values, little-endian:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | values per cell, u32: 1 (the attribute at the cell's surface point) |
//! | 4 | 4 | bits per value, u32: 8 or 16 (codes, below) or 32 (IEEE f32 as it is) |
//! | 8 | 8 | `lo`, f64: the smallest finite value (data units of the attribute) |
//! | 16 | 8 | `hi`, f64: the largest finite value, `hi >= lo` (both 0 when no value is finite) |
//! | 24 | 8 | value count, u64 = active cells × values per cell |
//! | 32 | 64 | name, UTF-8, zero-padded (the attribute's source, for people) |
//! | 96 | count × bits/8 | the values, in the order of the corner records |
//!
//! Codes of `b` bits (8 or 16): code `c < 2^b − 1` stands for `lo + c·(hi − lo)/(2^b − 2)`, and
//! `2^b − 1` for NaN (no value). Rounding to the nearest code keeps the error within
//! `(hi − lo)/(2(2^b − 2))`: 0.2 % of the range at 8 bits.

use crate::error::{Error, Result};
use rayon::prelude::*;

/// Bytes of the head of an attribute section.
pub const ATTRIBUTE_HEAD_SIZE: usize = 96;
/// Bytes of the name field.
pub const ATTRIBUTE_NAME_SIZE: usize = 64;

/// Bits per stored attribute value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AttributePrecision {
    /// 8-bit codes over `[lo, hi]`.
    Code8,
    /// 16-bit codes over `[lo, hi]`.
    Code16,
    /// 32-bit floats, as they are.
    F32,
}

impl AttributePrecision {
    pub const ALL: [AttributePrecision; 3] = [
        AttributePrecision::Code8,
        AttributePrecision::Code16,
        AttributePrecision::F32,
    ];
    pub fn bits(self) -> u32 {
        match self {
            AttributePrecision::Code8 => 8,
            AttributePrecision::Code16 => 16,
            AttributePrecision::F32 => 32,
        }
    }
    pub fn from_bits(bits: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.bits() == bits)
    }
    pub fn bytes(self) -> usize {
        self.bits() as usize / 8
    }
    /// The code that stands for NaN (codes only).
    fn nan_code(self) -> u32 {
        match self {
            AttributePrecision::Code8 => 0xff,
            AttributePrecision::Code16 => 0xffff,
            AttributePrecision::F32 => unreachable!("f32 values are stored as they are"),
        }
    }
}

/// What an attribute is: its name, how its values are stored and their finite range.
#[derive(Debug, Clone, PartialEq)]
pub struct AttributeInfo {
    /// Where the values came from (a file name, a channel), at most 64 bytes of UTF-8.
    pub name: String,
    pub precision: AttributePrecision,
    /// Smallest and largest finite value, in the attribute's own units (`[0, 0]` when none is).
    pub range: [f64; 2],
}

impl AttributeInfo {
    /// The head of the attribute's section, for `count` values.
    pub fn head_bytes(&self, count: u64) -> [u8; ATTRIBUTE_HEAD_SIZE] {
        let mut h = [0u8; ATTRIBUTE_HEAD_SIZE];
        h[0..4].copy_from_slice(&1u32.to_le_bytes());
        h[4..8].copy_from_slice(&self.precision.bits().to_le_bytes());
        h[8..16].copy_from_slice(&self.range[0].to_le_bytes());
        h[16..24].copy_from_slice(&self.range[1].to_le_bytes());
        h[24..32].copy_from_slice(&count.to_le_bytes());
        let name = truncate_utf8(&self.name, ATTRIBUTE_NAME_SIZE);
        h[32..32 + name.len()].copy_from_slice(name.as_bytes());
        h
    }

    /// Parses and checks a section head; returns the info and the value count.
    pub fn from_head(h: &[u8]) -> Result<(AttributeInfo, u64)> {
        let h: &[u8; ATTRIBUTE_HEAD_SIZE] = h
            .get(..ATTRIBUTE_HEAD_SIZE)
            .and_then(|h| h.try_into().ok())
            .ok_or_else(|| Error::corrupt("cell attribute section is shorter than its head"))?;
        let u32_at = |o: usize| u32::from_le_bytes(h[o..o + 4].try_into().unwrap());
        let f64_at = |o: usize| f64::from_le_bytes(h[o..o + 8].try_into().unwrap());
        let per_cell = u32_at(0);
        if per_cell != 1 {
            return Err(Error::corrupt(format!(
                "cell attribute has {per_cell} values per cell; 1 is defined"
            )));
        }
        let bits = u32_at(4);
        let precision = AttributePrecision::from_bits(bits)
            .ok_or_else(|| Error::corrupt(format!("cell attribute of {bits} bits per value")))?;
        let range = [f64_at(8), f64_at(16)];
        if !(range[0].is_finite() && range[1].is_finite() && range[0] <= range[1]) {
            return Err(Error::corrupt(format!(
                "cell attribute range {range:?} is not finite and ordered"
            )));
        }
        let count = u64::from_le_bytes(h[24..32].try_into().unwrap());
        let name_field = &h[32..32 + ATTRIBUTE_NAME_SIZE];
        let name_len = name_field
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(ATTRIBUTE_NAME_SIZE);
        if name_field[name_len..].iter().any(|&b| b != 0) {
            return Err(Error::corrupt("cell attribute name is not zero-padded"));
        }
        let name = std::str::from_utf8(&name_field[..name_len])
            .map_err(|_| Error::corrupt("cell attribute name is not UTF-8"))?
            .to_string();
        Ok((
            AttributeInfo {
                name,
                precision,
                range,
            },
            count,
        ))
    }

    /// The stored value of `value` (little-endian, [`AttributePrecision::bytes`] long).
    pub fn encode(&self, value: f32, out: &mut [u8]) {
        self.encode_run(std::slice::from_ref(&value), out);
    }

    /// [`AttributeInfo::encode`] of each of `values` into consecutive runs of `out`, with the
    /// precision chosen once rather than per value.
    pub fn encode_all(&self, values: &[f32], out: &mut [u8]) {
        // Pieces of 64 Ki values are encoded in parallel: each value's code depends on it alone.
        const PIECE: usize = 1 << 16;
        let width = self.precision.bytes();
        if values.len() <= PIECE {
            return self.encode_run(values, out);
        }
        out.par_chunks_mut(PIECE * width)
            .zip(values.par_chunks(PIECE))
            .for_each(|(out, values)| self.encode_run(values, out));
    }

    /// [`AttributeInfo::encode_all`] on the calling thread.
    fn encode_run(&self, values: &[f32], out: &mut [u8]) {
        let [lo, hi] = self.range;
        // Loop-invariant choices are made once, and the NaN code is selected rather than
        // branched to, so the loop vectorises.
        let code = |value: f32, max_code: u32| -> u32 {
            if hi > lo {
                let t = ((value as f64 - lo) / (hi - lo)).clamp(0.0, 1.0);
                // `f64::round` of a non-negative value, without its libm call (no rounding
                // instruction in the x86-64 baseline): the fraction is exact below 2^52. A NaN
                // `t` gives 0 here and is replaced below.
                let scaled = t * max_code as f64;
                let whole = scaled as u32;
                let rounded = whole + (scaled - whole as f64 >= 0.5) as u32;
                if value.is_nan() {
                    max_code + 1
                } else {
                    rounded
                }
            } else if value.is_nan() {
                max_code + 1
            } else {
                0
            }
        };
        let runs = out.chunks_exact_mut(self.precision.bytes()).zip(values);
        match self.precision {
            AttributePrecision::Code8 => runs.for_each(|(o, &v)| o[0] = code(v, 0xfe) as u8),
            AttributePrecision::Code16 => {
                runs.for_each(|(o, &v)| o.copy_from_slice(&(code(v, 0xfffe) as u16).to_le_bytes()))
            }
            AttributePrecision::F32 => runs.for_each(|(o, &v)| o.copy_from_slice(&v.to_le_bytes())),
        }
    }

    /// How codes map to values, for renderers that decode them (the GPU's shading pass): value =
    /// `zero + code × step`, except `nan_code`. The rule [`AttributeInfo::decode`] applies;
    /// `None` for f32 values, which are stored as they are.
    pub fn code_mapping(&self) -> Option<CodeMapping> {
        if self.precision == AttributePrecision::F32 {
            return None;
        }
        let nan_code = self.precision.nan_code();
        let [lo, hi] = self.range;
        Some(CodeMapping {
            zero: lo,
            step: (hi - lo) / (nan_code - 1) as f64,
            nan_code,
        })
    }

    /// The value stored as `bytes` (NaN for the NaN code).
    pub fn decode(&self, bytes: &[u8]) -> f32 {
        let from_code = |code: u32| -> f32 {
            let m = self.code_mapping().expect("8- or 16-bit codes");
            if code == m.nan_code {
                f32::NAN
            } else {
                (m.zero + code as f64 * m.step) as f32
            }
        };
        match self.precision {
            AttributePrecision::Code8 => from_code(bytes[0] as u32),
            AttributePrecision::Code16 => {
                from_code(u16::from_le_bytes([bytes[0], bytes[1]]) as u32)
            }
            AttributePrecision::F32 => f32::from_le_bytes(bytes[..4].try_into().unwrap()),
        }
    }
}

/// How stored codes become values: `zero + code × step`, and `nan_code` is NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CodeMapping {
    pub zero: f64,
    pub step: f64,
    pub nan_code: u32,
}

/// The longest prefix of `s` of at most `max` bytes that ends on a character boundary.
fn truncate_utf8(s: &str, max: usize) -> &str {
    let mut end = s.len().min(max);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end.min(s.find('\0').unwrap_or(end))]
}

/// An attribute's values held by a grid: one per active cell, in corner-record order.
#[derive(Debug, Clone, PartialEq)]
pub struct CellAttribute {
    info: AttributeInfo,
    head: [u8; ATTRIBUTE_HEAD_SIZE],
    values: Vec<u8>,
}

/// The least and greatest finite values of `values`, `None` when none is finite. A zero bound is
/// +0 whichever sign the zeros had, so the range does not depend on the order values are met.
///
/// Pieces are folded in parallel, each in eight branch-free lanes so that the loop vectorises.
fn finite_range(values: &[f32]) -> Option<(f32, f32)> {
    const LANES: usize = 8;
    let fold = |piece: &[f32]| {
        let (mut lo, mut hi) = ([f32::INFINITY; LANES], [f32::NEG_INFINITY; LANES]);
        let mut take = |l: usize, v: f32| {
            let finite = v.is_finite();
            lo[l] = if finite && v < lo[l] { v } else { lo[l] };
            hi[l] = if finite && v > hi[l] { v } else { hi[l] };
        };
        let mut lanes = piece.chunks_exact(LANES);
        for chunk in &mut lanes {
            for (l, &v) in chunk.iter().enumerate() {
                take(l, v);
            }
        }
        for (l, &v) in lanes.remainder().iter().enumerate() {
            take(l, v);
        }
        let lo = lo
            .iter()
            .fold(f32::INFINITY, |a, &b| if b < a { b } else { a });
        let hi = hi
            .iter()
            .fold(f32::NEG_INFINITY, |a, &b| if b > a { b } else { a });
        (lo, hi)
    };
    let (lo, hi) = values.par_chunks(1 << 16).map(fold).reduce(
        || (f32::INFINITY, f32::NEG_INFINITY),
        |a, b| {
            (
                if b.0 < a.0 { b.0 } else { a.0 },
                if b.1 > a.1 { b.1 } else { a.1 },
            )
        },
    );
    // `+ 0.0` turns -0 into +0 and leaves every other value as it is.
    (lo <= hi).then_some((lo + 0.0, hi + 0.0))
}

impl CellAttribute {
    /// An attribute from values, one per active cell, stored at `precision` over their finite range.
    pub fn from_values(name: &str, precision: AttributePrecision, values: &[f32]) -> Self {
        let range = finite_range(values).map_or([0.0, 0.0], |(lo, hi)| [lo as f64, hi as f64]);
        let info = AttributeInfo {
            name: truncate_utf8(name, ATTRIBUTE_NAME_SIZE).to_string(),
            precision,
            range,
        };
        let mut bytes = vec![0u8; values.len() * precision.bytes()];
        info.encode_all(values, &mut bytes);
        Self::from_encoded(info, bytes)
    }

    /// An attribute from its info and its encoded value bytes.
    pub(crate) fn from_encoded(info: AttributeInfo, values: Vec<u8>) -> Self {
        let count = (values.len() / info.precision.bytes()) as u64;
        CellAttribute {
            head: info.head_bytes(count),
            info,
            values,
        }
    }

    pub fn info(&self) -> &AttributeInfo {
        &self.info
    }
    /// Values stored.
    pub fn len(&self) -> usize {
        self.values.len() / self.info.precision.bytes()
    }
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
    /// The value of active cell `i` (NaN where it has none).
    pub fn value(&self, i: usize) -> f32 {
        let w = self.info.precision.bytes();
        self.info.decode(&self.values[i * w..(i + 1) * w])
    }
    /// The section's head bytes.
    pub fn head_bytes(&self) -> &[u8] {
        &self.head
    }
    /// The stored values, as the section holds them after its head.
    pub fn value_bytes(&self) -> &[u8] {
        &self.values
    }

    /// The values as 16-bit codes and their mapping, for renderers that hold 2 bytes per cell:
    /// 8- and 16-bit codes as stored; f32 values coded at 16 bits over the attribute's range (an
    /// error of at most 1/131070 of the range).
    pub fn codes16(&self) -> (Vec<u16>, CodeMapping) {
        let info = match self.info.precision {
            AttributePrecision::F32 => AttributeInfo {
                precision: AttributePrecision::Code16,
                ..self.info.clone()
            },
            _ => self.info.clone(),
        };
        let mapping = info.code_mapping().expect("8- or 16-bit codes");
        let codes = match self.info.precision {
            AttributePrecision::Code8 => self.values.iter().map(|&c| c as u16).collect(),
            AttributePrecision::Code16 => self
                .values
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
                .collect(),
            AttributePrecision::F32 => self
                .values
                .chunks_exact(4)
                .map(|b| {
                    let mut code = [0u8; 2];
                    info.encode(f32::from_le_bytes(b.try_into().unwrap()), &mut code);
                    u16::from_le_bytes(code)
                })
                .collect(),
        };
        (codes, mapping)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel, lane-wise range and encoding equal a plain one-value-at-a-time reference,
    /// across piece boundaries, with NaN, infinities and zeros of both signs.
    #[test]
    fn range_and_codes_match_a_plain_reference() {
        let mut next = crate::test_rng::xorshift(0x2545_f491_4f6c_dd1d);
        for len in [0usize, 1, 7, 65_536, 65_537, 300_001] {
            let values: Vec<f32> = (0..len)
                .map(|_| match next() % 50 {
                    0 => f32::NAN,
                    1 => f32::INFINITY,
                    2 => f32::NEG_INFINITY,
                    3 => -0.0,
                    _ => (next() % 100_000) as f32 / 97.0 - 300.0,
                })
                .collect();
            let finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
            let expected = (!finite.is_empty()).then(|| {
                let lo = finite.iter().copied().fold(f32::INFINITY, f32::min);
                let hi = finite.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                (lo + 0.0, hi + 0.0)
            });
            let got = finite_range(&values);
            assert_eq!(
                got.map(|(a, b)| (a.to_bits(), b.to_bits())),
                expected.map(|(a, b)| (a.to_bits(), b.to_bits())),
                "length {len}"
            );
            for precision in [AttributePrecision::Code8, AttributePrecision::Code16] {
                let attribute = CellAttribute::from_values("v", precision, &values);
                let [lo, hi] = attribute.info().range;
                let max_code = precision.nan_code() - 1;
                for (i, &v) in values.iter().enumerate() {
                    let code = if v.is_nan() {
                        precision.nan_code()
                    } else if hi > lo {
                        let t = ((v as f64 - lo) / (hi - lo)).clamp(0.0, 1.0);
                        (t * max_code as f64).round() as u32
                    } else {
                        0
                    };
                    let w = precision.bytes();
                    let bytes = &attribute.values[i * w..(i + 1) * w];
                    let stored = if w == 1 {
                        bytes[0] as u32
                    } else {
                        u16::from_le_bytes([bytes[0], bytes[1]]) as u32
                    };
                    assert_eq!(stored, code, "value {v} of {len} at {precision:?}");
                }
            }
        }
    }
}

//! Decoding sample arrays stored in files into [`VolumeData`], shared by every reader.
//!
//! A [`Volume`](isogrid::Volume) keeps the file's element type (the rule, the same for every
//! format, is [`ElemType::kept`]):
//!
//! | file type                                  | kept as | note |
//! |--------------------------------------------|---------|------|
//! | u8, u16, i16, u32, i32, u64, i64, f32, f64 | same    | bit-exact |
//! | bool                                       | u8      | 0 / 1 |
//! | i8                                         | i16     | exact |
//!
//! Rescaled samples (NIfTI `scl_slope`/`scl_inter`, DICOM RescaleSlope/Intercept) follow
//! [`rescaled_type`].
//!
//! Reading never trusts a declared size: callers check it against the file first, and streams
//! (gzip) are read in bounded chunks so that a tiny file claiming a huge volume fails after
//! reading what it really holds, not after allocating what it claims.

use isogrid::{Error, Result, Samples, ScalarType, VolumeData, MAX_DIM};
use std::io::Read;

/// An element type as a file declares it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ElemType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F32,
    F64,
}

impl ElemType {
    /// The sample type a volume keeps this element type as: itself, i8 widened to i16.
    pub(crate) fn kept(self) -> ScalarType {
        match self {
            ElemType::U8 => ScalarType::U8,
            ElemType::I8 | ElemType::I16 => ScalarType::I16,
            ElemType::U16 => ScalarType::U16,
            ElemType::U32 => ScalarType::U32,
            ElemType::I32 => ScalarType::I32,
            ElemType::U64 => ScalarType::U64,
            ElemType::I64 => ScalarType::I64,
            ElemType::F32 => ScalarType::F32,
            ElemType::F64 => ScalarType::F64,
        }
    }
    /// The element type that stores `scalar` as it is.
    pub(crate) fn of(scalar: ScalarType) -> ElemType {
        match scalar {
            ScalarType::U8 => ElemType::U8,
            ScalarType::U16 => ElemType::U16,
            ScalarType::I16 => ElemType::I16,
            ScalarType::F32 => ElemType::F32,
            ScalarType::U32 => ElemType::U32,
            ScalarType::I32 => ElemType::I32,
            ScalarType::U64 => ElemType::U64,
            ScalarType::I64 => ElemType::I64,
            ScalarType::F64 => ElemType::F64,
        }
    }
    /// Smallest and largest value of an integer type (`None` for floats).
    fn integer_range(self) -> Option<(i128, i128)> {
        Some(match self {
            ElemType::U8 => (0, u8::MAX as i128),
            ElemType::I8 => (i8::MIN as i128, i8::MAX as i128),
            ElemType::U16 => (0, u16::MAX as i128),
            ElemType::I16 => (i16::MIN as i128, i16::MAX as i128),
            ElemType::U32 => (0, u32::MAX as i128),
            ElemType::I32 => (i32::MIN as i128, i32::MAX as i128),
            ElemType::U64 => (0, u64::MAX as i128),
            ElemType::I64 => (i64::MIN as i128, i64::MAX as i128),
            ElemType::F32 | ElemType::F64 => return None,
        })
    }
    pub(crate) fn size(self) -> usize {
        match self {
            ElemType::U8 | ElemType::I8 => 1,
            ElemType::U16 | ElemType::I16 => 2,
            ElemType::U32 | ElemType::I32 | ElemType::F32 => 4,
            ElemType::U64 | ElemType::I64 | ElemType::F64 => 8,
        }
    }
}

/// Checks that every dimension is in `1..=MAX_DIM` and returns the sample count.
pub(crate) fn sample_count(dims: [usize; 3]) -> Result<usize> {
    for (axis, &n) in dims.iter().enumerate() {
        if n == 0 {
            return Err(Error::corrupt(format!("size along axis {axis} is 0")));
        }
        if n > MAX_DIM {
            return Err(Error::too_large(format!(
                "size {n} along axis {axis} exceeds the limit of {MAX_DIM}"
            )));
        }
    }
    // Each factor is at most 2^17, so the product fits in u64; it may not fit in usize on 32-bit.
    let count = dims.iter().map(|&n| n as u64).product::<u64>();
    usize::try_from(count)
        .map_err(|_| Error::too_large(format!("{count} samples do not fit in memory")))
}

/// Bytes that `count` elements of `elem` take, or a TooLarge error.
pub(crate) fn byte_count(count: usize, elem: ElemType) -> Result<u64> {
    (count as u64)
        .checked_mul(elem.size() as u64)
        .ok_or_else(|| Error::too_large("sample data size overflows"))
}

/// Fails unless a file region of `available` bytes can hold `needed` bytes.
pub(crate) fn check_available(needed: u64, available: u64) -> Result<()> {
    if needed > available {
        return Err(Error::corrupt(format!(
            "file is truncated: sample data needs {needed} bytes but only {available} are there"
        )));
    }
    Ok(())
}

/// Fails when `compressed` bytes of deflate data could not possibly expand to `needed` bytes.
///
/// Deflate cannot expand more than about 1032:1; a looser 1100:1 plus 1 MiB keeps the check safe
/// while still rejecting a tiny file that claims gigabytes before anything is allocated.
pub(crate) fn check_deflate_budget(needed: u64, compressed: u64) -> Result<()> {
    let most = compressed.saturating_mul(1100).saturating_add(1 << 20);
    if needed > most {
        return Err(Error::corrupt(format!(
            "compressed data of {compressed} bytes cannot hold the {needed} bytes the header declares"
        )));
    }
    Ok(())
}

/// Fails with a `TooLarge` error naming the limit when decoding `count` elements of `elem` needs
/// more memory than the machine has ([`isogrid::memory`]): the file's element array plus, for a
/// widened type (i8), the kept array built from it.
pub(crate) fn ensure_memory(count: usize, elem: ElemType) -> Result<()> {
    let file_bytes = count as u64 * elem.size() as u64;
    let kept_bytes = match elem {
        ElemType::I8 => count as u64 * 2,
        _ => 0,
    };
    isogrid::memory::ensure_fits(
        &format!("a volume of {count} samples"),
        file_bytes + kept_bytes,
    )
}

/// Reads exactly `count` elements of `elem` (byte order `big_endian`) as [`ElemType::kept`]. The
/// memory this needs is checked first ([`ensure_memory`]); then it grows with the data actually
/// read (in chunks), so a short stream fails without the full allocation. A short read is a
/// `Corrupt` error naming expected and actual bytes.
pub(crate) fn read_samples<R: Read + ?Sized>(
    reader: &mut R,
    elem: ElemType,
    big_endian: bool,
    count: usize,
) -> Result<VolumeData> {
    ensure_memory(count, elem)?;
    let swap = big_endian != cfg!(target_endian = "big");
    Ok(match elem {
        ElemType::U8 => VolumeData::U8(read_vec::<u8, R>(reader, count, false)?),
        ElemType::U16 => VolumeData::U16(read_vec(reader, count, swap)?),
        ElemType::I16 => VolumeData::I16(read_vec(reader, count, swap)?),
        ElemType::F32 => VolumeData::F32(read_vec(reader, count, swap)?),
        ElemType::I8 => VolumeData::I16(convert(read_vec::<i8, R>(reader, count, false)?, |v| {
            v as i16
        })),
        ElemType::U32 => VolumeData::U32(read_vec(reader, count, swap)?),
        ElemType::I32 => VolumeData::I32(read_vec(reader, count, swap)?),
        ElemType::U64 => VolumeData::U64(read_vec(reader, count, swap)?),
        ElemType::I64 => VolumeData::I64(read_vec(reader, count, swap)?),
        ElemType::F64 => VolumeData::F64(read_vec(reader, count, swap)?),
    })
}

/// f64 samples as f32, refusing finite values beyond the f32 range (about ±3.4·10³⁸): they would
/// become infinite and every isovalue would then be measured against infinity. NaN and ±∞ stay.
fn f64_to_f32(values: &[f64]) -> Result<Vec<f32>> {
    if let Some(i) = values
        .iter()
        .position(|v| v.is_finite() && (*v as f32).is_infinite())
    {
        return Err(Error::unsupported(format!(
            "sample {i} is {:e}, beyond the f32 range (±{:e}) of the declared type",
            values[i],
            f32::MAX
        )));
    }
    Ok(values.iter().map(|&v| v as f32).collect())
}

/// Builds kept-type data from values given as f64 (text encodings), as [`read_samples`] keeps
/// them. A value an integer type cannot hold exactly (out of range, or with a fraction, or
/// beyond ±2^53 where the f64 it was parsed into is not that integer) is an error naming it, not
/// a silently saturated or rounded sample.
pub(crate) fn from_f64_values(values: &[f64], elem: ElemType) -> Result<VolumeData> {
    if let Some((lo, hi)) = elem.integer_range() {
        const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
        let (lo, hi) = ((lo as f64).max(-EXACT), (hi as f64).min(EXACT));
        if let Some(i) = values
            .iter()
            .position(|&v| !(v >= lo && v <= hi && v.fract() == 0.0))
        {
            return Err(Error::corrupt(format!(
                "value {} (number {i}) is not an integer in [{lo}, {hi}] as the type declares \
                 (text values are exact up to ±2^53)",
                values[i]
            )));
        }
    }
    Ok(match elem {
        ElemType::U8 => VolumeData::U8(values.iter().map(|&v| v as u8).collect()),
        ElemType::U16 => VolumeData::U16(values.iter().map(|&v| v as u16).collect()),
        ElemType::I16 => VolumeData::I16(values.iter().map(|&v| v as i16).collect()),
        ElemType::I8 => VolumeData::I16(values.iter().map(|&v| v as i8 as i16).collect()),
        ElemType::U32 => VolumeData::U32(values.iter().map(|&v| v as u32).collect()),
        ElemType::I32 => VolumeData::I32(values.iter().map(|&v| v as i32).collect()),
        ElemType::U64 => VolumeData::U64(values.iter().map(|&v| v as u64).collect()),
        ElemType::I64 => VolumeData::I64(values.iter().map(|&v| v as i64).collect()),
        ElemType::F32 => VolumeData::F32(f64_to_f32(values)?),
        ElemType::F64 => VolumeData::F64(values.to_vec()),
    })
}

/// The type samples of `elem` rescaled to `stored · slope + inter` are kept as, from the header
/// alone (so a streamed read agrees with a whole one):
/// - an integer type with slope 1 and an integral intercept: the narrowest of i16, i32 and i64
///   (or u8/u16 for the unsigned types they hold) that holds the type's whole shifted range,
///   exactly; beyond i64, f64;
/// - otherwise f32 where every rescaled value of a type of at most 16 bits stays below 2^24 in
///   magnitude (f32 then resolves it to better than one stored step: CT's −1024 intercepts),
///   and f64 for wider types or larger values (an intercept of 2e9, where f32 steps are 128).
pub(crate) fn rescaled_type(elem: ElemType, slope: f64, inter: f64) -> ScalarType {
    const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
    if let Some((lo, hi)) = elem.integer_range() {
        if slope == 1.0 && inter.fract() == 0.0 && inter.abs() < EXACT {
            let (lo, hi) = (lo + inter as i128, hi + inter as i128);
            let fits = |a: i128, b: i128| lo >= a && hi <= b;
            return if fits(0, u8::MAX as i128) {
                ScalarType::U8
            } else if fits(i16::MIN as i128, i16::MAX as i128) {
                ScalarType::I16
            } else if fits(0, u16::MAX as i128) {
                ScalarType::U16
            } else if fits(i32::MIN as i128, i32::MAX as i128) {
                ScalarType::I32
            } else if fits(i64::MIN as i128, i64::MAX as i128) {
                ScalarType::I64
            } else {
                ScalarType::F64
            };
        }
        let bound = (lo as f64 * slope + inter)
            .abs()
            .max((hi as f64 * slope + inter).abs());
        if elem.size() <= 2 && bound < 16_777_216.0 {
            return ScalarType::F32;
        }
    }
    ScalarType::F64
}

/// `data` rescaled to `stored · slope + inter`, computed in f64 (in i128 for integer shifts) and
/// kept as [`rescaled_type`] says.
pub(crate) fn rescaled(data: &VolumeData, elem: ElemType, slope: f64, inter: f64) -> VolumeData {
    let s = data.samples();
    let kept = rescaled_type(elem, slope, inter);
    fn map<U>(samples: Samples<'_>, f: impl Fn(f64) -> U) -> Vec<U> {
        (0..samples.len()).map(|i| f(samples.get_f64(i))).collect()
    }
    // Integer shifts are exact through i128 whatever the stored width (u64 beyond 2^53 included).
    let shifted = |i: usize| -> i128 { integer_at(s, i) + inter as i128 };
    let n = s.len();
    match kept {
        ScalarType::U8 => VolumeData::U8((0..n).map(|i| shifted(i) as u8).collect()),
        ScalarType::I16 => VolumeData::I16((0..n).map(|i| shifted(i) as i16).collect()),
        ScalarType::U16 => VolumeData::U16((0..n).map(|i| shifted(i) as u16).collect()),
        ScalarType::I32 => VolumeData::I32((0..n).map(|i| shifted(i) as i32).collect()),
        ScalarType::I64 => VolumeData::I64((0..n).map(|i| shifted(i) as i64).collect()),
        ScalarType::F32 => VolumeData::F32(map(s, |v| (v * slope + inter) as f32)),
        _ => VolumeData::F64(map(s, |v| v * slope + inter)),
    }
}

/// Sample `i` of integer samples, exactly.
fn integer_at(s: Samples<'_>, i: usize) -> i128 {
    match s {
        Samples::U8(v) => v[i] as i128,
        Samples::U16(v) => v[i] as i128,
        Samples::I16(v) => v[i] as i128,
        Samples::U32(v) => v[i] as i128,
        Samples::I32(v) => v[i] as i128,
        Samples::U64(v) => v[i] as i128,
        Samples::I64(v) => v[i] as i128,
        Samples::F32(v) => v[i] as i128,
        Samples::F64(v) => v[i] as i128,
    }
}

/// Reads `count` decimal values separated by whitespace or commas from the next `available` bytes
/// (NRRD ascii, MetaImage text data) and converts them like [`read_samples`]. `what` names the data
/// in errors.
pub(crate) fn read_text_samples<R: Read>(
    reader: R,
    available: u64,
    elem: ElemType,
    count: usize,
    what: &str,
) -> Result<VolumeData> {
    // Each value takes at least one character plus a separator.
    if count as u64 > available / 2 + 1 {
        return Err(Error::corrupt(format!(
            "{what} of {available} bytes cannot hold {count} values"
        )));
    }
    // The text, its values as f64, and the kept samples.
    isogrid::memory::ensure_fits(
        &format!("{what} of {count} values"),
        available + count as u64 * 12,
    )?;
    let mut text = String::new();
    reader
        .take(available)
        .read_to_string(&mut text)
        .map_err(|_| Error::corrupt(format!("{what} is not text")))?;
    let values = text
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<f64>().map_err(|_| {
                let shown: String = t.chars().filter(|c| !c.is_control()).take(60).collect();
                Error::corrupt(format!("{what}: value '{shown}' is not a number"))
            })
        })
        .collect::<Result<Vec<f64>>>()?;
    if values.len() != count {
        return Err(Error::corrupt(format!(
            "{what} holds {} values, the header declares {count}",
            values.len()
        )));
    }
    from_f64_values(&values, elem)
}

/// Fails if `reader` has any byte left: a stream longer than declared is inconsistent. A
/// decompressing reader is read on to its end first (up to 64 MiB): a damaged deflate stream
/// often decodes to too many bytes, and its checksum, at the end, says the data is corrupt rather
/// than long (the caller's `gzip_error` turns that I/O error into "gzip data is invalid").
pub(crate) fn expect_end<R: Read + ?Sized>(reader: &mut R) -> Result<()> {
    let mut byte = [0u8; 1];
    loop {
        match reader.read(&mut byte) {
            Ok(0) => return Ok(()),
            Ok(_) => {
                // At most 64 MiB more: a stream that inflates without end is read no further.
                std::io::copy(&mut reader.take(64 << 20), &mut std::io::sink())
                    .map_err(Error::io)?;
                return Err(Error::corrupt("data is longer than the header declares"));
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(e)),
        }
    }
}

/// Turns an OS-level error from a decompressing reader into what it means: invalid gzip data.
pub(crate) fn gzip_error(e: Error) -> Error {
    if e.kind() == isogrid::ErrorKind::Io {
        Error::corrupt(format!("gzip data is invalid: {}", e.message()))
    } else {
        e
    }
}

/// Skips exactly `n` bytes of a stream.
pub(crate) fn skip_bytes<R: Read + ?Sized>(reader: &mut R, n: u64) -> Result<()> {
    let skipped = std::io::copy(&mut reader.take(n), &mut std::io::sink())?;
    if skipped != n {
        return Err(Error::corrupt(format!(
            "file is truncated: expected to skip {n} bytes, only {skipped} were there"
        )));
    }
    Ok(())
}

fn convert<T: Copy, U>(values: Vec<T>, f: impl Fn(T) -> U) -> Vec<U> {
    values.into_iter().map(f).collect()
}

/// Largest chunk grown at once while reading: bounds the over-allocation for short streams.
const CHUNK_BYTES: usize = 64 << 20;

fn read_vec<T: bytemuck::Pod, R: Read + ?Sized>(
    reader: &mut R,
    count: usize,
    swap: bool,
) -> Result<Vec<T>> {
    let size = std::mem::size_of::<T>();
    let chunk = (CHUNK_BYTES / size).max(1);
    let mut values: Vec<T> = Vec::new();
    while values.len() < count {
        let start = values.len();
        let end = count.min(start + chunk);
        if end > values.capacity() {
            // Amortised growth (doubling) that never reserves past `count`, and fails cleanly.
            let want = count.min(end.max(values.capacity().saturating_mul(2)));
            values.try_reserve_exact(want - start).map_err(|_| {
                Error::too_large(format!(
                    "{} bytes of samples cannot be allocated",
                    count as u64 * size as u64
                ))
            })?;
        }
        values.resize(end, T::zeroed());
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut values[start..end]);
        let got = fill(reader, bytes)?;
        if got < bytes.len() {
            return Err(Error::corrupt(format!(
                "file is truncated: sample data needs {} bytes, only {} were there",
                count as u64 * size as u64,
                (start * size + got) as u64
            )));
        }
    }
    if swap && size > 1 {
        for element in bytemuck::cast_slice_mut::<T, u8>(&mut values).chunks_exact_mut(size) {
            element.reverse();
        }
    }
    Ok(values)
}

/// Reads until `buf` is full or the stream ends; returns the bytes read.
fn fill<R: Read + ?Sized>(reader: &mut R, buf: &mut [u8]) -> Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match reader.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(e)),
        }
    }
    Ok(filled)
}

/// `b`'s samples after `a`'s (slices of a stack, pieces of a file); both back when the types differ.
pub(crate) fn append(
    a: VolumeData,
    b: VolumeData,
) -> std::result::Result<VolumeData, (VolumeData, VolumeData)> {
    macro_rules! joined {
        ($($v:ident),*) => {
            match (a, b) {
                $((VolumeData::$v(mut a), VolumeData::$v(b)) => {
                    a.extend(b);
                    VolumeData::$v(a)
                })*
                (a, b) => return Err((a, b)),
            }
        };
    }
    Ok(joined!(U8, U16, I16, F32, U32, I32, U64, I64, F64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn big_endian_u16_is_swapped() {
        let bytes = [0x01u8, 0x02, 0x03, 0x04];
        let data = read_samples(&mut &bytes[..], ElemType::U16, true, 2).unwrap();
        assert_eq!(data, VolumeData::U16(vec![0x0102, 0x0304]));
        let data = read_samples(&mut &bytes[..], ElemType::U16, false, 2).unwrap();
        assert_eq!(data, VolumeData::U16(vec![0x0201, 0x0403]));
    }

    #[test]
    fn wide_types_are_kept_and_i8_becomes_i16() {
        let bytes = (-100_000_001i32).to_be_bytes();
        let data = read_samples(&mut &bytes[..], ElemType::I32, true, 1).unwrap();
        assert_eq!(data, VolumeData::I32(vec![-100_000_001]));
        let bytes = (u64::MAX - 1).to_le_bytes();
        let data = read_samples(&mut &bytes[..], ElemType::U64, false, 1).unwrap();
        assert_eq!(data, VolumeData::U64(vec![u64::MAX - 1]));
        let data = read_samples(&mut &[0xFFu8][..], ElemType::I8, false, 1).unwrap();
        assert_eq!(data, VolumeData::I16(vec![-1]));
    }

    #[test]
    fn rescaling_keeps_large_intercepts_exact() {
        // An intercept of 2e9 on i16: i32 holds every shifted value, exactly.
        let data = VolumeData::I16(vec![-5, 0, 1]);
        assert_eq!(rescaled_type(ElemType::I16, 1.0, 2e9), ScalarType::I32);
        assert_eq!(
            rescaled(&data, ElemType::I16, 1.0, 2e9),
            VolumeData::I32(vec![1_999_999_995, 2_000_000_000, 2_000_000_001])
        );
        // CT's −1024 on u16 fits i32 but not i16 from the header alone.
        assert_eq!(rescaled_type(ElemType::U16, 1.0, -1024.0), ScalarType::I32);
        assert_eq!(rescaled_type(ElemType::I16, 0.5, -1024.0), ScalarType::F32);
        assert_eq!(rescaled_type(ElemType::I16, 0.5, 2e9), ScalarType::F64);
        assert_eq!(rescaled_type(ElemType::U64, 1.0, 1.0), ScalarType::F64);
    }

    #[test]
    fn short_stream_reports_expected_and_actual_bytes() {
        let err = read_samples(&mut &[0u8; 5][..], ElemType::U16, false, 4).unwrap_err();
        assert_eq!(err.kind(), isogrid::ErrorKind::Corrupt);
        assert!(err.message().contains("needs 8 bytes, only 5"), "{err}");
    }

    #[test]
    fn absurd_dims_are_too_large() {
        let err = sample_count([200_000, 1, 1]).unwrap_err();
        assert_eq!(err.kind(), isogrid::ErrorKind::TooLarge);
        assert_eq!(sample_count([7, 5, 3]).unwrap(), 105);
    }
}

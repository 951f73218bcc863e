//! Decoding sample arrays stored in files into [`VolumeData`], shared by every reader.
//!
//! Files store many element types; a [`Volume`](isogrid::Volume) keeps four (u8, u16, i16, f32).
//! The conversion rule, the same for every format:
//!
//! | file type               | kept as | note |
//! |-------------------------|---------|------|
//! | u8, u16, i16, f32       | same    | bit-exact |
//! | bool                    | u8      | 0 / 1 |
//! | i8                      | i16     | exact |
//! | u32, i32, u64, i64, f64 | f32     | **lossy**: integers above 2²⁴ and f64 mantissas are rounded to f32 |
//!
//! Reading never trusts a declared size: callers check it against the file first, and streams
//! (gzip) are read in bounded chunks so that a tiny file claiming a huge volume fails after
//! reading what it really holds, not after allocating what it claims.

use isogrid::{Error, Result, VolumeData, MAX_DIM};
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
/// converted type, the kept array built from it.
pub(crate) fn ensure_memory(count: usize, elem: ElemType) -> Result<()> {
    let file_bytes = count as u64 * elem.size() as u64;
    let kept_bytes = match elem {
        ElemType::U8 | ElemType::U16 | ElemType::I16 | ElemType::F32 => 0,
        ElemType::I8 => count as u64 * 2,
        _ => count as u64 * 4,
    };
    isogrid::memory::ensure_fits(
        &format!("a volume of {count} samples"),
        file_bytes + kept_bytes,
    )
}

/// Reads exactly `count` elements of `elem` (byte order `big_endian`) and converts them to one of
/// the kept types. The memory this needs is checked first ([`ensure_memory`]); then it grows with
/// the data actually read (in chunks), so a short stream fails without the full allocation. A
/// short read is a `Corrupt` error naming expected and actual bytes.
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
        ElemType::U32 => VolumeData::F32(convert(read_vec::<u32, R>(reader, count, swap)?, |v| {
            v as f32
        })),
        ElemType::I32 => VolumeData::F32(convert(read_vec::<i32, R>(reader, count, swap)?, |v| {
            v as f32
        })),
        ElemType::U64 => VolumeData::F32(convert(read_vec::<u64, R>(reader, count, swap)?, |v| {
            v as f32
        })),
        ElemType::I64 => VolumeData::F32(convert(read_vec::<i64, R>(reader, count, swap)?, |v| {
            v as f32
        })),
        ElemType::F64 => VolumeData::F32(f64_to_f32(&read_vec::<f64, R>(reader, count, swap)?)?),
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
            "sample {i} is {:e}, beyond the f32 range (±{:e}) in which volumes are kept",
            values[i],
            f32::MAX
        )));
    }
    Ok(values.iter().map(|&v| v as f32).collect())
}

/// Builds kept-type data from values given as f64 (text encodings), converting like
/// [`read_samples`]. A value an integer type cannot hold exactly (out of range, or with a
/// fraction) is an error naming it, not a silently saturated sample.
pub(crate) fn from_f64_values(values: &[f64], elem: ElemType) -> Result<VolumeData> {
    let range = match elem {
        ElemType::U8 => Some((0.0, u8::MAX as f64)),
        ElemType::I8 => Some((i8::MIN as f64, i8::MAX as f64)),
        ElemType::U16 => Some((0.0, u16::MAX as f64)),
        ElemType::I16 => Some((i16::MIN as f64, i16::MAX as f64)),
        _ => None,
    };
    if let Some((lo, hi)) = range {
        if let Some(i) = values
            .iter()
            .position(|&v| !(v >= lo && v <= hi && v.fract() == 0.0))
        {
            return Err(Error::corrupt(format!(
                "value {} (number {i}) is not an integer in [{lo}, {hi}] as the type declares",
                values[i]
            )));
        }
    }
    Ok(match elem {
        ElemType::U8 => VolumeData::U8(values.iter().map(|&v| v as u8).collect()),
        ElemType::U16 => VolumeData::U16(values.iter().map(|&v| v as u16).collect()),
        ElemType::I16 => VolumeData::I16(values.iter().map(|&v| v as i16).collect()),
        ElemType::I8 => VolumeData::I16(values.iter().map(|&v| v as i8 as i16).collect()),
        _ => VolumeData::F32(f64_to_f32(values)?),
    })
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
    Ok(match (a, b) {
        (VolumeData::U8(mut a), VolumeData::U8(b)) => {
            a.extend(b);
            VolumeData::U8(a)
        }
        (VolumeData::U16(mut a), VolumeData::U16(b)) => {
            a.extend(b);
            VolumeData::U16(a)
        }
        (VolumeData::I16(mut a), VolumeData::I16(b)) => {
            a.extend(b);
            VolumeData::I16(a)
        }
        (VolumeData::F32(mut a), VolumeData::F32(b)) => {
            a.extend(b);
            VolumeData::F32(a)
        }
        (a, b) => return Err((a, b)),
    })
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
    fn wide_types_become_f32_and_i8_becomes_i16() {
        let bytes = (-3i32).to_be_bytes();
        let data = read_samples(&mut &bytes[..], ElemType::I32, true, 1).unwrap();
        assert_eq!(data, VolumeData::F32(vec![-3.0]));
        let data = read_samples(&mut &[0xFFu8][..], ElemType::I8, false, 1).unwrap();
        assert_eq!(data, VolumeData::I16(vec![-1]));
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

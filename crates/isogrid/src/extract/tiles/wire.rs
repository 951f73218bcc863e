//! The byte layout of the fragments that cross between the driver and the tasks: plain
//! little-endian fields, each fragment starting with a four-byte tag, checked by the receiver
//! before use.

use super::geometry::BlockBox;
use crate::cgc::scalar_code;
use crate::error::{Error, Result};
use crate::volume::ScalarType;

pub(super) const SCAN_TAG: &[u8; 4] = b"IGTS";
pub(super) const JOB_TAG: &[u8; 4] = b"IGTJ";
pub(super) const OUTPUT_TAG: &[u8; 4] = b"IGTO";
pub(super) const TASK_TAG: &[u8; 4] = b"IGTT";
pub(super) const TILE_TAG: &[u8; 4] = b"IGTX";

/// Bytes per block of a scan fragment: occupied metacells, active cells (u32), min, max (f64: exact
/// for every sample type up to 32 bits, nearest beyond 2^53 for 64-bit integers).
pub(super) const SCAN_RECORD: usize = 24;
/// Bytes per block of an emit job: metacell slots, active cells.
pub(super) const JOB_RECORD: usize = 8;

/// Writes a fragment's tag, sample type, volume dimensions and box of blocks.
pub(super) fn put_header(
    out: &mut Vec<u8>,
    tag: &[u8; 4],
    scalar_type: ScalarType,
    dims: [usize; 3],
    blocks: &BlockBox,
) {
    put_tag(out, tag);
    put_u32(out, scalar_code(scalar_type));
    dims.iter().for_each(|&d| put_u32(out, d as u32));
    blocks.iter().for_each(|b| put_u32(out, b.start as u32));
    blocks.iter().for_each(|b| put_u32(out, b.len() as u32));
}

/// Reads a box of blocks (first blocks, then counts), which must lie inside `block_dims`.
pub(super) fn read_box(r: &mut Reader, block_dims: [usize; 3], what: &str) -> Result<BlockBox> {
    let first = [r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    let count = [r.u32()?, r.u32()?, r.u32()?].map(|v| v as usize);
    if (0..3).any(|a| count[a] == 0 || first[a] + count[a] > block_dims[a]) {
        return Err(Error::corrupt(format!(
            "{what} of blocks outside the volume's {}x{}x{}",
            block_dims[0], block_dims[1], block_dims[2]
        )));
    }
    Ok([0, 1, 2].map(|a| first[a]..first[a] + count[a]))
}

pub(in crate::extract) fn put_tag(out: &mut Vec<u8>, tag: &[u8; 4]) {
    out.extend_from_slice(tag);
}

pub(in crate::extract) fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Reads a fragment's fields, checking its tag and length.
pub(in crate::extract) struct Reader<'a> {
    bytes: &'a [u8],
    pub(super) what: &'static str,
}

impl<'a> Reader<'a> {
    pub(in crate::extract) fn new(
        bytes: &'a [u8],
        tag: &[u8; 4],
        what: &'static str,
    ) -> Result<Self> {
        match bytes.split_first_chunk::<4>() {
            Some((t, rest)) if t == tag => Ok(Reader { bytes: rest, what }),
            _ => Err(Error::corrupt(format!("not a valid {what}"))),
        }
    }
    pub(in crate::extract) fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        let (head, rest) = self
            .bytes
            .split_first_chunk::<N>()
            .ok_or_else(|| Error::corrupt(format!("{} is truncated", self.what)))?;
        self.bytes = rest;
        Ok(*head)
    }
    pub(in crate::extract) fn u32(&mut self) -> Result<u32> {
        self.take().map(u32::from_le_bytes)
    }
    pub(in crate::extract) fn f64(&mut self) -> Result<f64> {
        self.take().map(f64::from_le_bytes)
    }
    /// The next `len` bytes.
    pub(in crate::extract) fn bytes(&mut self, len: usize) -> Result<&'a [u8]> {
        if self.bytes.len() < len {
            return Err(Error::corrupt(format!("{} is truncated", self.what)));
        }
        let (head, rest) = self.bytes.split_at(len);
        self.bytes = rest;
        Ok(head)
    }
    /// The rest, which must be exactly `len` bytes.
    pub(in crate::extract) fn rest(self, len: usize) -> Result<&'a [u8]> {
        if self.bytes.len() != len {
            return Err(Error::corrupt(format!(
                "{} holds {} bytes of records where {len} were expected",
                self.what,
                self.bytes.len()
            )));
        }
        Ok(self.bytes)
    }
}

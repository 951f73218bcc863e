//! Constants and small encodings of the `.cgc` header that the reader and the writer share.

pub(crate) const MAGIC: [u8; 8] = *b"\x89CGC\r\n\x1a\n";
pub(crate) const VERSION: u32 = 1;
pub(crate) const HEADER_SIZE: usize = 320;
pub(crate) const HEADER_CRC_AT: usize = 316;

pub(crate) fn align16(n: u64) -> u64 {
    n.div_ceil(16) * 16
}

pub(crate) fn scalar_code(t: crate::ScalarType) -> u32 {
    match t {
        crate::ScalarType::U8 => 0,
        crate::ScalarType::U16 => 1,
        crate::ScalarType::I16 => 2,
        crate::ScalarType::F32 => 3,
    }
}

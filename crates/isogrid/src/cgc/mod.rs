//! `.cgc` files: a clustered grid cell structure on disk, ready to memory-map.
//!
//! Layout (all little-endian). A 320-byte header, then three sections at 16-byte-aligned offsets,
//! zero bytes between them:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `\x89CGC\r\n\x1a\n` (detects text-mode mangling, like PNG's) |
//! | 8 | 4 | format version, u32 = 1 |
//! | 12 | 4 | header size, u32 = 320 |
//! | 16 | 12 | dims: samples per axis, 3×u32 |
//! | 28 | 4 | source scalar type, u32: 0 u8, 1 u16, 2 i16, 3 f32 |
//! | 32 | 24 | spacing, 3×f64 |
//! | 56 | 24 | origin, 3×f64 |
//! | 80 | 16 | value range (min, max) of the source, 2×f64 |
//! | 96 | 8 | isovalue in data units, f64 |
//! | 104 | 4 | precision in bits per corner, u32: 4, 8, 16 or 32 |
//! | 108 | 4 | `iso_code`, f32: threshold in code units ([`crate::ValueMapping`]) |
//! | 112 | 8 | mapping offset (data value of code 0), f64 |
//! | 120 | 8 | mapping step (data units per code), f64 |
//! | 128 | 8 | block count, u64 |
//! | 136 | 8 | metacell slot count, u64 |
//! | 144 | 8 | active cell count, u64 |
//! | 152 | 8 | occupied metacell count, u64 |
//! | 160 | 48 | sections: (offset u64, byte length u64) for blocks, metacells, cells |
//! | 208 | 72 | direction cosines, 3×3 f64, rows = world directions of the i, j, k axes |
//! | 280 | 12 | CRC-32 of each section's bytes, 3×u32 |
//! | 292 | 24 | reserved, zero |
//! | 316 | 4 | CRC-32 of header bytes 0..316 |
//!
//! Sections hold the records of [`crate::layout`] byte for byte. Readers check every size, offset,
//! checksum, pointer and position before handing out a grid, so renderers and tracers can index
//! the buffers without bounds surprises.

mod format;
mod read;
mod write;

pub(crate) use format::scalar_code;
pub use read::{open, open_with_progress, read, read_bytes};
pub(crate) use write::{header_bytes, sections_for_lengths, HeaderCounts};
pub use write::{to_bytes, write};

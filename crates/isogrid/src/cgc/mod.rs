//! `.cgc` files: a clustered grid cell structure on disk, ready to memory-map.
//!
//! Layout of version 2, which this build writes (all little-endian): a 320-byte header, a section
//! table of 32-byte entries ([`SectionKind`], offset, length, CRC-32 each), then the sections at
//! 16-byte-aligned offsets in table order, zero bytes between them; the file ends where its last
//! section ends.
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `\x89CGC\r\n\x1a\n` (detects text-mode mangling, like PNG's) |
//! | 8 | 4 | format version, u32 = 2 |
//! | 12 | 4 | header size, u32 = 320 |
//! | 16 | 12 | dims: samples per axis, 3×u32 |
//! | 28 | 4 | source scalar type, u32: 0 u8, 1 u16, 2 i16, 3 f32, 4 u32, 5 i32, 6 u64, 7 i64, 8 f64 (4–8 since the wide sample types; a reader that predates them refuses the file by its code) |
//! | 32 | 24 | spacing, 3×f64 |
//! | 56 | 24 | origin, 3×f64 |
//! | 80 | 16 | value range (min, max) of the source, 2×f64 |
//! | 96 | 8 | isovalue in data units, f64 |
//! | 104 | 4 | precision in bits per corner, u32: 1, 4, 8, 16 or 32 |
//! | 108 | 4 | `iso_code`, f32: threshold in code units ([`crate::ValueMapping`]) |
//! | 112 | 8 | mapping offset (data value of code 0), f64 |
//! | 120 | 8 | mapping step (data units per code), f64 |
//! | 128 | 8 | block count, u64 |
//! | 136 | 8 | metacell slot count, u64 |
//! | 144 | 8 | active cell count, u64 |
//! | 152 | 8 | occupied metacell count, u64 |
//! | 160 | 8 | section table offset, u64 = 320 |
//! | 168 | 4 | section count `n`, u32, 3..=64 |
//! | 172 | 4 | CRC-32 of the `n`×32 table bytes |
//! | 176 | 32 | reserved, zero |
//! | 208 | 72 | direction cosines, 3×3 f64, rows = world directions of the i, j, k axes |
//! | 280 | 36 | reserved, zero |
//! | 316 | 4 | CRC-32 of header bytes 0..316 |
//!
//! Table entries are laid out as `format::TableEntry` documents: kind, flags (bit 0: a reader
//! that does not know the kind must refuse the file), offset, length, CRC-32. Sections, by kind:
//!
//! | kind | section | flags | contents |
//! |---|---|---|---|
//! | 1 | blocks | required | [`crate::layout::Block`] records |
//! | 2 | metacells | required | [`crate::layout::Metacell`] slots |
//! | 3 | cells | required | corner records at the header's precision |
//! | 4 | cell attribute | optional | one value per active cell ([`crate::attribute`]) |
//! | 5 | cluster labels | optional | a u32 label per cluster ([`crate::labels`]) |
//! | 6 | label index | optional | per label: cells, bounds, runs of clusters ([`crate::labels`]) |
//! | 7 | label table | optional | per label: value, colour, name ([`crate::labels`]) |
//! | 8 | world frame | optional | the convention of the header's origin and directions: u32 1 LPS or 2 RAS, then 4 zero bytes ([`crate::WorldFrame`]); absent: unknown |
//!
//! A file holds the three label sections together or none of them; the reader checks them
//! against each other and against the metacells (every cluster's label in range, the index
//! consistent with the clusters, names UTF-8). In a file of a label volume the corner records
//! hold each label's indicator (header value range `[0, 1]`, isovalue ½).
//!
//! A reader skips optional sections of kinds it does not know (checking their CRC) and refuses
//! required ones. Version 1 files, still read, have no table: header bytes 160..208 hold
//! (offset u64, length u64) of the blocks, metacells and cells and 280..292 their CRC-32s.
//!
//! Sections hold the records of [`crate::layout`] byte for byte. Readers check every size, offset,
//! checksum, pointer and position before handing out a grid, so renderers and tracers can index
//! the buffers without bounds surprises. Every file is written by one writer, `CgcWriter`.

mod format;
pub mod pack;
mod range_coder;
mod read;
mod write;

pub(crate) use format::scalar_code;
pub use format::SectionKind;
pub use pack::{
    pack, pack_into, pack_into_with_progress, PackedSizes, PACKED_HEAD_SIZE, PACKED_MAGIC,
    PACKED_VERSION,
};
pub use read::{open, open_with_progress, read, read_bytes};
pub use write::{to_bytes, write};
pub(crate) use write::{CgcWriter, FilePlan, HeaderCounts};

/// Whether `head` (a file's first 8 bytes) is the magic of a `.cgc` file or of its packed form.
pub fn is_cgc_magic(head: &[u8; 8]) -> bool {
    *head == format::MAGIC || *head == PACKED_MAGIC
}

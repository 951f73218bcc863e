//! Constants, section kinds and small encodings of the `.cgc` header and section table that the
//! reader and the writer share.

pub(crate) const MAGIC: [u8; 8] = *b"\x89CGC\r\n\x1a\n";
/// The version this build writes.
pub(crate) const VERSION: u32 = 2;
/// The first version: three fixed sections described in the header, no section table.
pub(crate) const VERSION_1: u32 = 1;
pub(crate) const HEADER_SIZE: usize = 320;
pub(crate) const HEADER_CRC_AT: usize = 316;
/// Version 2: where the section table's offset, entry count and CRC-32 sit in the header.
pub(crate) const TABLE_FIELDS_AT: usize = 160;
/// Bytes of one section table entry.
pub(crate) const TABLE_ENTRY_SIZE: usize = 32;
/// Entries a section table may hold: the three grid sections and up to 61 optional ones.
pub(crate) const MAX_SECTIONS: usize = 64;
/// Flag bit of a section a reader must understand to use the file at all.
pub(crate) const FLAG_REQUIRED: u32 = 1;

/// What a section holds, as its table entry's `kind` field says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SectionKind {
    /// [`crate::layout::Block`] records, one per block (required).
    Blocks,
    /// [`crate::layout::Metacell`] slots (required).
    Metacells,
    /// Corner records, one per active cell (required).
    Cells,
    /// A per-cell attribute ([`super::attribute`]; optional: a reader without it still has the surface).
    CellAttribute,
    /// The label of every cluster ([`crate::labels`]; optional, with the two below).
    ClusterLabels,
    /// Per label: cells, bounds and runs of clusters ([`crate::labels`]).
    LabelIndex,
    /// Per label: value, name and colour ([`crate::labels`]).
    LabelTable,
    /// The convention of the header's origin and directions ([`WORLD_FRAME_SIZE`] bytes: the
    /// [`crate::WorldFrame`] code, u32, 1 LPS or 2 RAS, then 4 zero bytes; optional: absent, the
    /// frame is unknown).
    WorldFrame,
}

/// Bytes of a world frame section.
pub(crate) const WORLD_FRAME_SIZE: u64 = 8;

/// The world frame section's bytes for `frame` (none when it is unknown).
pub(crate) fn world_frame_bytes(frame: crate::WorldFrame) -> Option<[u8; 8]> {
    let code: u32 = match frame {
        crate::WorldFrame::Unknown => return None,
        crate::WorldFrame::Lps => 1,
        crate::WorldFrame::Ras => 2,
    };
    let mut bytes = [0u8; 8];
    bytes[..4].copy_from_slice(&code.to_le_bytes());
    Some(bytes)
}

/// The frame a world frame section's `bytes` name; an error for any other bytes.
pub(crate) fn world_frame_of(bytes: &[u8]) -> crate::Result<crate::WorldFrame> {
    [crate::WorldFrame::Lps, crate::WorldFrame::Ras]
        .into_iter()
        .find(|&f| world_frame_bytes(f).is_some_and(|b| b[..] == *bytes))
        .ok_or_else(|| {
            crate::Error::corrupt("world frame section is not an LPS (1) or RAS (2) code")
        })
}

impl SectionKind {
    pub const ALL: [SectionKind; 8] = [
        SectionKind::Blocks,
        SectionKind::Metacells,
        SectionKind::Cells,
        SectionKind::CellAttribute,
        SectionKind::ClusterLabels,
        SectionKind::LabelIndex,
        SectionKind::LabelTable,
        SectionKind::WorldFrame,
    ];
    /// The label sections, which a file holds all or none of, in this order.
    pub const LABELS: [SectionKind; 3] = [
        SectionKind::ClusterLabels,
        SectionKind::LabelIndex,
        SectionKind::LabelTable,
    ];
    /// The `kind` code in the section table.
    pub fn code(self) -> u32 {
        match self {
            SectionKind::Blocks => 1,
            SectionKind::Metacells => 2,
            SectionKind::Cells => 3,
            SectionKind::CellAttribute => 4,
            SectionKind::ClusterLabels => 5,
            SectionKind::LabelIndex => 6,
            SectionKind::LabelTable => 7,
            SectionKind::WorldFrame => 8,
        }
    }
    pub fn from_code(code: u32) -> Option<SectionKind> {
        SectionKind::ALL.into_iter().find(|k| k.code() == code)
    }
    /// Whether a reader must understand the section to use the file.
    pub fn required(self) -> bool {
        matches!(
            self,
            SectionKind::Blocks | SectionKind::Metacells | SectionKind::Cells
        )
    }
    /// Whether a file may hold more than one section of this kind.
    pub fn repeatable(self) -> bool {
        false
    }
    pub fn name(self) -> &'static str {
        match self {
            SectionKind::Blocks => "blocks",
            SectionKind::Metacells => "metacells",
            SectionKind::Cells => "cells",
            SectionKind::CellAttribute => "cell attribute",
            SectionKind::ClusterLabels => "cluster labels",
            SectionKind::LabelIndex => "label index",
            SectionKind::LabelTable => "label table",
            SectionKind::WorldFrame => "world frame",
        }
    }
}

/// One entry of the version 2 section table (32 bytes, little-endian):
///
/// | offset | size | field |
/// |---|---|---|
/// | 0 | 4 | `kind`, u32 ([`SectionKind::code`]; unknown codes are allowed, see `flags`) |
/// | 4 | 4 | `flags`, u32: bit 0 set when a reader that does not know `kind` must refuse the file; other bits zero |
/// | 8 | 8 | byte offset of the section in the file, u64, a multiple of 16 |
/// | 16 | 8 | byte length, u64 |
/// | 24 | 4 | CRC-32 (IEEE) of the section's bytes |
/// | 28 | 4 | reserved, zero |
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TableEntry {
    pub kind: u32,
    pub flags: u32,
    pub offset: u64,
    pub len: u64,
    pub crc: u32,
}

impl TableEntry {
    pub fn to_bytes(self) -> [u8; TABLE_ENTRY_SIZE] {
        let mut b = [0u8; TABLE_ENTRY_SIZE];
        b[0..4].copy_from_slice(&self.kind.to_le_bytes());
        b[4..8].copy_from_slice(&self.flags.to_le_bytes());
        b[8..16].copy_from_slice(&self.offset.to_le_bytes());
        b[16..24].copy_from_slice(&self.len.to_le_bytes());
        b[24..28].copy_from_slice(&self.crc.to_le_bytes());
        b
    }
    /// The entry in `b` and whether its reserved field is zero.
    pub fn from_bytes(b: &[u8; TABLE_ENTRY_SIZE]) -> (TableEntry, bool) {
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap());
        (
            TableEntry {
                kind: u32_at(0),
                flags: u32_at(4),
                offset: u64_at(8),
                len: u64_at(16),
                crc: u32_at(24),
            },
            u32_at(28) == 0,
        )
    }
}

pub(crate) fn align16(n: u64) -> u64 {
    n.div_ceil(16) * 16
}

/// The header's source sample type codes (docs/design/file-format.md), in code order.
const SCALAR_CODES: [crate::ScalarType; 9] = {
    use crate::ScalarType::*;
    [U8, U16, I16, F32, U32, I32, U64, I64, F64]
};

pub(crate) fn scalar_code(t: crate::ScalarType) -> u32 {
    SCALAR_CODES.iter().position(|&s| s == t).unwrap() as u32
}

/// The sample type of a header code; `None` for an unknown code.
pub(crate) fn scalar_of_code(code: u32) -> Option<crate::ScalarType> {
    SCALAR_CODES.get(code as usize).copied()
}

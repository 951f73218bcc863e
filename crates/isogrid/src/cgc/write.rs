//! The one `.cgc` writer (format in [`super`]): a file pre-sized for its sections, filled in pieces
//! in any order, then closed with its section table and header.
//!
//! Every path that makes a `.cgc` file writes through [`CgcWriter`]: the in-memory [`write`], the
//! streaming extraction (groups of blocks as they are emitted) and the tiled extraction (block rows
//! of emit jobs, in whatever order they arrive). Each piece is checksummed as it is written;
//! [`CgcWriter::finish`] checks that the pieces cover every section exactly once, combines their
//! checksums in file order and writes the table and header last, so a file that lacks a piece
//! never gets a valid header.

use super::format::{
    align16, scalar_code, world_frame_bytes, SectionKind, TableEntry, FLAG_REQUIRED, HEADER_CRC_AT,
    HEADER_SIZE, MAGIC, MAX_SECTIONS, TABLE_ENTRY_SIZE, VERSION, WORLD_FRAME_SIZE,
};
use crate::error::{Error, Result};
use crate::grid::{CellGrid, GridInfo};
use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

/// Counts a header records besides the grid's metadata.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct HeaderCounts {
    pub blocks: u64,
    pub metacell_slots: u64,
    pub active_cells: u64,
    pub occupied_metacells: u64,
}

impl HeaderCounts {
    fn of(grid: &CellGrid) -> Self {
        HeaderCounts {
            blocks: grid.blocks().len() as u64,
            metacell_slots: grid.metacell_slots() as u64,
            active_cells: grid.active_cells() as u64,
            occupied_metacells: grid.occupied_metacells() as u64,
        }
    }
}

/// Somewhere a file's bytes can be placed at offsets: the temporary file of an atomic write, or
/// memory.
pub(crate) trait WriteAt {
    /// Sets the length, filling with zero bytes.
    fn set_len(&mut self, len: u64) -> std::io::Result<()>;
    fn write_at(&mut self, offset: u64, bytes: &[u8]) -> std::io::Result<()>;
}

impl WriteAt for File {
    fn set_len(&mut self, len: u64) -> std::io::Result<()> {
        File::set_len(self, len)
    }
    fn write_at(&mut self, offset: u64, bytes: &[u8]) -> std::io::Result<()> {
        self.seek(SeekFrom::Start(offset))?;
        self.write_all(bytes)
    }
}

impl WriteAt for Vec<u8> {
    fn set_len(&mut self, len: u64) -> std::io::Result<()> {
        self.clear();
        self.resize(len as usize, 0);
        Ok(())
    }
    fn write_at(&mut self, offset: u64, bytes: &[u8]) -> std::io::Result<()> {
        self[offset as usize..offset as usize + bytes.len()].copy_from_slice(bytes);
        Ok(())
    }
}

/// Where each section of a file goes: 16-byte aligned, in the order given, after the header and
/// the section table. (Byte offsets in the file.)
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct FilePlan {
    /// (kind, offset, length) of each section, in file order.
    sections: Vec<(SectionKind, u64, u64)>,
    len: u64,
}

impl FilePlan {
    /// The plan of a file with sections of these kinds and byte lengths, in this order, then the
    /// world frame section when `frame` is known (its bytes written by [`CgcWriter::finish`]). The
    /// three grid sections must come first, in the order blocks, metacells, cells.
    pub(crate) fn new(sections: &[(SectionKind, u64)], frame: crate::WorldFrame) -> Self {
        let frame = world_frame_bytes(frame).map(|_| (SectionKind::WorldFrame, WORLD_FRAME_SIZE));
        let sections: Vec<(SectionKind, u64)> = sections.iter().copied().chain(frame).collect();
        assert!(
            sections.len() <= MAX_SECTIONS
                && sections.iter().map(|s| s.0).take(3).eq([
                    SectionKind::Blocks,
                    SectionKind::Metacells,
                    SectionKind::Cells
                ]),
            "a .cgc file starts with its blocks, metacells and cells"
        );
        let mut end = (HEADER_SIZE + TABLE_ENTRY_SIZE * sections.len()) as u64;
        let sections: Vec<_> = sections
            .iter()
            .map(|&(kind, len)| {
                let offset = align16(end);
                end = offset + len;
                (kind, offset, len)
            })
            .collect();
        FilePlan { sections, len: end }
    }
}

/// A piece of a section already written: where it starts in the section, its length and checksum.
struct Piece {
    at: u64,
    len: u64,
    crc: crc32fast::Hasher,
}

/// Writes a `.cgc` file into a target pre-sized by its [`FilePlan`]: sections are filled in pieces,
/// in any order, then [`Self::finish`] writes the table and header.
pub(crate) struct CgcWriter<'a> {
    target: &'a mut dyn WriteAt,
    plan: FilePlan,
    /// Pieces written, per section of the plan.
    pieces: Vec<Vec<Piece>>,
}

impl<'a> CgcWriter<'a> {
    /// Sizes `target` for `plan` (zero bytes everywhere).
    pub(crate) fn new(target: &'a mut dyn WriteAt, plan: FilePlan) -> Result<Self> {
        target.set_len(plan.len)?;
        let pieces = plan.sections.iter().map(|_| Vec::new()).collect();
        Ok(CgcWriter {
            target,
            plan,
            pieces,
        })
    }

    /// Writes `bytes` at byte `at` of the section of `kind`.
    pub(crate) fn put(&mut self, kind: SectionKind, at: u64, bytes: &[u8]) -> Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        let s = self
            .plan
            .sections
            .iter()
            .position(|&(k, _, _)| k == kind)
            .ok_or_else(|| Error::invalid(format!("no {} section planned", kind.name())))?;
        let (_, offset, len) = self.plan.sections[s];
        let end = at.checked_add(bytes.len() as u64);
        if end.is_none_or(|end| end > len) {
            return Err(Error::invalid(format!(
                "{} bytes at {at} run past the {len}-byte {} section",
                bytes.len(),
                kind.name()
            )));
        }
        self.target.write_at(offset + at, bytes)?;
        let mut crc = crc32fast::Hasher::new();
        crc.update(bytes);
        self.pieces[s].push(Piece {
            at,
            len: bytes.len() as u64,
            crc,
        });
        Ok(())
    }

    /// Writes the world frame section of `info`, checks that every section was written exactly
    /// once, then writes the section table and the header: the file is complete.
    pub(crate) fn finish(mut self, info: &GridInfo, counts: &HeaderCounts) -> Result<()> {
        if let Some(bytes) = world_frame_bytes(info.frame) {
            self.put(SectionKind::WorldFrame, 0, &bytes)?;
        }
        let mut table = Vec::with_capacity(TABLE_ENTRY_SIZE * self.plan.sections.len());
        for (&(kind, offset, len), mut pieces) in self.plan.sections.iter().zip(self.pieces) {
            pieces.sort_by_key(|p| p.at);
            let mut crc = crc32fast::Hasher::new();
            let mut end = 0;
            for piece in pieces {
                if piece.at != end {
                    break;
                }
                end += piece.len;
                crc.combine(&piece.crc);
            }
            if end != len {
                return Err(Error::invalid(format!(
                    "the {} section was not written exactly once (bytes {end}.. of {len})",
                    kind.name()
                )));
            }
            let entry = TableEntry {
                kind: kind.code(),
                flags: if kind.required() { FLAG_REQUIRED } else { 0 },
                offset,
                len,
                crc: crc.finalize(),
            };
            table.extend_from_slice(&entry.to_bytes());
        }
        self.target.write_at(HEADER_SIZE as u64, &table)?;
        let header = header_bytes(
            info,
            counts,
            self.plan.sections.len() as u32,
            crc32fast::hash(&table),
        );
        self.target.write_at(0, &header)?;
        Ok(())
    }
}

/// The header bytes (version 2) from their parts.
fn header_bytes(
    info: &GridInfo,
    counts: &HeaderCounts,
    section_count: u32,
    table_crc: u32,
) -> [u8; HEADER_SIZE] {
    let mut h = [0u8; HEADER_SIZE];
    let mut at = 0;
    let mut put = |bytes: &[u8]| {
        h[at..at + bytes.len()].copy_from_slice(bytes);
        at += bytes.len();
    };
    put(&MAGIC);
    put(&VERSION.to_le_bytes());
    put(&(HEADER_SIZE as u32).to_le_bytes());
    info.dims.iter().for_each(|d| put(&d.to_le_bytes()));
    put(&scalar_code(info.scalar_type).to_le_bytes());
    info.spacing.iter().for_each(|v| put(&v.to_le_bytes()));
    info.origin.iter().for_each(|v| put(&v.to_le_bytes()));
    info.value_range.iter().for_each(|v| put(&v.to_le_bytes()));
    put(&info.iso.to_le_bytes());
    put(&info.precision.bits().to_le_bytes());
    put(&info.mapping.iso_code.to_le_bytes());
    put(&info.mapping.offset.to_le_bytes());
    put(&info.mapping.step.to_le_bytes());
    put(&counts.blocks.to_le_bytes());
    put(&counts.metacell_slots.to_le_bytes());
    put(&counts.active_cells.to_le_bytes());
    put(&counts.occupied_metacells.to_le_bytes());
    put(&(HEADER_SIZE as u64).to_le_bytes()); // at TABLE_FIELDS_AT
    put(&section_count.to_le_bytes());
    put(&table_crc.to_le_bytes());
    put(&[0u8; 32]); // reserved
    info.direction
        .iter()
        .flatten()
        .for_each(|v| put(&v.to_le_bytes()));
    put(&[0u8; 36]); // reserved
    debug_assert_eq!(at, HEADER_CRC_AT);
    let crc = crc32fast::hash(&h[..HEADER_CRC_AT]);
    h[HEADER_CRC_AT..].copy_from_slice(&crc.to_le_bytes());
    h
}

/// The sections of an extracted grid, in file order, each as the pieces of its bytes.
fn grid_sections<'a>(
    grid: &'a CellGrid,
    labels: &'a Option<[Vec<u8>; 3]>,
) -> Vec<(SectionKind, Vec<&'a [u8]>)> {
    let mut sections = vec![
        (
            SectionKind::Blocks,
            vec![bytemuck::cast_slice(grid.blocks())],
        ),
        (
            SectionKind::Metacells,
            vec![bytemuck::cast_slice(grid.metacells())],
        ),
        (SectionKind::Cells, vec![grid.cells()]),
    ];
    if let Some(attribute) = grid.attribute() {
        sections.push((
            SectionKind::CellAttribute,
            vec![attribute.head_bytes(), attribute.value_bytes()],
        ));
    }
    if let Some(labels) = labels {
        for (kind, bytes) in SectionKind::LABELS.into_iter().zip(labels) {
            sections.push((kind, vec![bytes.as_slice()]));
        }
    }
    sections
}

fn write_to(grid: &CellGrid, target: &mut dyn WriteAt) -> Result<()> {
    let labels = grid.labels().map(|l| l.section_bytes());
    let sections = grid_sections(grid, &labels);
    let plan = FilePlan::new(
        &sections
            .iter()
            .map(|(kind, pieces)| (*kind, pieces.iter().map(|p| p.len() as u64).sum()))
            .collect::<Vec<_>>(),
        grid.info().frame,
    );
    let mut writer = CgcWriter::new(target, plan)?;
    for (kind, pieces) in &sections {
        let mut at = 0;
        for piece in pieces {
            writer.put(*kind, at, piece)?;
            at += piece.len() as u64;
        }
    }
    writer.finish(grid.info(), &HeaderCounts::of(grid))
}

/// Writes `grid` to `path` (temporary file + rename: an existing file survives a failed write).
pub fn write(path: &Path, grid: &CellGrid) -> Result<()> {
    crate::fs::write_atomic_file(path, |file| write_to(grid, file))
}

/// A target that keeps only the header and section table of what is written to it (the sections
/// are checksummed as they pass), and the file's length.
struct HeadOnly {
    head: Vec<u8>,
    len: u64,
}

impl WriteAt for HeadOnly {
    fn set_len(&mut self, len: u64) -> std::io::Result<()> {
        self.len = len;
        Ok(())
    }
    fn write_at(&mut self, offset: u64, bytes: &[u8]) -> std::io::Result<()> {
        let end = (offset as usize + bytes.len()).min(self.head.len());
        if (offset as usize) < end {
            self.head[offset as usize..end].copy_from_slice(&bytes[..end - offset as usize]);
        }
        Ok(())
    }
}

/// The header and section table of `grid`'s file (the first `320 + 32·sections` bytes of
/// [`to_bytes`]) and the file's length, without holding the file.
pub(crate) fn head_of(grid: &CellGrid) -> (Vec<u8>, u64) {
    let sections = 3
        + grid.attribute().is_some() as usize
        + grid.labels().map_or(0, |_| SectionKind::LABELS.len())
        + world_frame_bytes(grid.info().frame).is_some() as usize;
    let mut target = HeadOnly {
        head: vec![0; HEADER_SIZE + TABLE_ENTRY_SIZE * sections],
        len: 0,
    };
    write_to(grid, &mut target).expect("writing to memory cannot fail");
    (target.head, target.len)
}

/// The whole file as bytes.
pub fn to_bytes(grid: &CellGrid) -> Vec<u8> {
    let mut out = Vec::new();
    write_to(grid, &mut out).expect("writing to memory cannot fail");
    out
}

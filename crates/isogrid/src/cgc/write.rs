//! Writes a [`CellGrid`] as a `.cgc` file (format in [`super`]), atomically.

use super::format::{align16, scalar_code, HEADER_CRC_AT, HEADER_SIZE, MAGIC, VERSION};
use crate::error::Result;
use crate::grid::{CellGrid, GridInfo};
use std::io::Write;
use std::path::Path;

/// Counts a header records besides the grid's metadata.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct HeaderCounts {
    pub blocks: u64,
    pub metacell_slots: u64,
    pub active_cells: u64,
    pub occupied_metacells: u64,
}

/// The header bytes for `grid`.
fn header(grid: &CellGrid) -> [u8; HEADER_SIZE] {
    let counts = HeaderCounts {
        blocks: grid.blocks().len() as u64,
        metacell_slots: grid.metacell_slots() as u64,
        active_cells: grid.active_cells() as u64,
        occupied_metacells: grid.occupied_metacells() as u64,
    };
    let crcs = section_bytes(grid).map(crc32fast::hash);
    header_bytes(grid.info(), &counts, section_layout(grid), crcs)
}

/// The header bytes from their parts: shared by the in-memory writer and the streaming extraction,
/// which knows its sections' checksums only once they are written.
pub(crate) fn header_bytes(
    info: &GridInfo,
    counts: &HeaderCounts,
    sections: [(u64, u64); 3],
    crcs: [u32; 3],
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
    for (offset, len) in sections {
        put(&offset.to_le_bytes());
        put(&len.to_le_bytes());
    }
    info.direction
        .iter()
        .flatten()
        .for_each(|v| put(&v.to_le_bytes()));
    for crc in crcs {
        put(&crc.to_le_bytes());
    }
    debug_assert_eq!(at, 292);
    let crc = crc32fast::hash(&h[..HEADER_CRC_AT]);
    h[HEADER_CRC_AT..].copy_from_slice(&crc.to_le_bytes());
    h
}

fn section_bytes(grid: &CellGrid) -> [&[u8]; 3] {
    [
        bytemuck::cast_slice(grid.blocks()),
        bytemuck::cast_slice(grid.metacells()),
        grid.cells(),
    ]
}

/// (offset, length) of each section.
fn section_layout(grid: &CellGrid) -> [(u64, u64); 3] {
    sections_for_lengths(section_bytes(grid).map(|bytes| bytes.len() as u64))
}

/// (offset, length) of sections of the given byte lengths: 16-byte aligned, after the header.
pub(crate) fn sections_for_lengths(lengths: [u64; 3]) -> [(u64, u64); 3] {
    let mut offset = HEADER_SIZE as u64;
    lengths.map(|len| {
        let start = align16(offset);
        offset = start + len;
        (start, len)
    })
}

fn write_to(grid: &CellGrid, out: &mut dyn Write) -> Result<()> {
    out.write_all(&header(grid))?;
    let mut at = HEADER_SIZE as u64;
    for ((offset, _), bytes) in section_layout(grid).into_iter().zip(section_bytes(grid)) {
        out.write_all(&[0u8; 16][..(offset - at) as usize])?;
        out.write_all(bytes)?;
        at = offset + bytes.len() as u64;
    }
    Ok(())
}

/// Writes `grid` to `path` (temporary file + rename: an existing file survives a failed write).
pub fn write(path: &Path, grid: &CellGrid) -> Result<()> {
    crate::fs::write_atomic(path, |out| write_to(grid, out))
}

/// The whole file as bytes.
pub fn to_bytes(grid: &CellGrid) -> Vec<u8> {
    let mut out = Vec::new();
    write_to(grid, &mut out).expect("writing to memory cannot fail");
    out
}

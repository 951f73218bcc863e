//! Writes a [`CellGrid`] as a `.cgc` file (format in [`super`]), atomically.

use super::format::{align16, scalar_code, HEADER_CRC_AT, HEADER_SIZE, MAGIC, VERSION};
use crate::error::Result;
use crate::grid::CellGrid;
use std::io::Write;
use std::path::Path;

/// The header bytes for `grid`.
fn header(grid: &CellGrid) -> [u8; HEADER_SIZE] {
    let info = grid.info();
    let sections = section_layout(grid);
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
    put(&(grid.blocks().len() as u64).to_le_bytes());
    put(&(grid.metacell_slots() as u64).to_le_bytes());
    put(&(grid.active_cells() as u64).to_le_bytes());
    put(&(grid.occupied_metacells() as u64).to_le_bytes());
    for (offset, len) in sections {
        put(&offset.to_le_bytes());
        put(&len.to_le_bytes());
    }
    info.direction
        .iter()
        .flatten()
        .for_each(|v| put(&v.to_le_bytes()));
    for bytes in section_bytes(grid) {
        put(&crc32fast::hash(bytes).to_le_bytes());
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
    let mut offset = HEADER_SIZE as u64;
    section_bytes(grid).map(|bytes| {
        let start = align16(offset);
        offset = start + bytes.len() as u64;
        (start, bytes.len() as u64)
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

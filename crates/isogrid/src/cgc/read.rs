//! Reads and validates `.cgc` files (format in [`super`]): into memory or memory-mapped.
//!
//! Nothing is allocated from a header field before it has been checked against the file's length,
//! and no grid is returned before every checksum, pointer and position has been checked.

use super::format::{HEADER_CRC_AT, HEADER_SIZE, MAGIC, VERSION};
use crate::error::{Error, Result, ResultExt};
use crate::grid::{CellGrid, GridInfo, Storage};
use crate::layout::{Block, Metacell, Precision, BLOCK_METACELLS, BOUND_SLOT, CLUSTER_SLOTS};
use crate::progress::Progress;
use crate::quantize::ValueMapping;
use crate::volume::{ScalarType, MAX_DIM};
use std::io::{Read, Seek, SeekFrom};
use std::ops::Range;
use std::path::Path;

struct Header {
    info: GridInfo,
    sections: [Range<usize>; 3],
    crcs: [u32; 3],
    occupied: u64,
}

struct Cursor<'a>(&'a [u8]);

impl Cursor<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let (head, rest) = self.0.split_at(N);
        self.0 = rest;
        head.try_into().unwrap()
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
}

fn parse_header(h: &[u8], file_len: u64) -> Result<Header> {
    if h.len() < HEADER_SIZE {
        return Err(Error::corrupt(format!(
            "file is {file_len} bytes, shorter than the {HEADER_SIZE}-byte .cgc header"
        )));
    }
    let h = &h[..HEADER_SIZE];
    if h[..8] != MAGIC {
        return Err(Error::corrupt("not a .cgc file (bad magic bytes)"));
    }
    let mut c = Cursor(&h[8..]);
    let version = c.u32();
    if version != VERSION {
        return Err(Error::unsupported(format!(
            "format version {version}; this build reads version {VERSION}"
        )));
    }
    if c.u32() as usize != HEADER_SIZE {
        return Err(Error::corrupt("header size field is wrong"));
    }
    let stored_crc = u32::from_le_bytes(h[HEADER_CRC_AT..].try_into().unwrap());
    if crc32fast::hash(&h[..HEADER_CRC_AT]) != stored_crc {
        return Err(Error::corrupt(
            "header checksum mismatch (the header is damaged)",
        ));
    }
    let dims = [c.u32(), c.u32(), c.u32()];
    if dims.iter().any(|&d| d == 0 || d as usize > MAX_DIM) {
        return Err(Error::corrupt(format!(
            "dims {dims:?} outside 1..={MAX_DIM}"
        )));
    }
    let scalar_type = match c.u32() {
        0 => ScalarType::U8,
        1 => ScalarType::U16,
        2 => ScalarType::I16,
        3 => ScalarType::F32,
        t => return Err(Error::corrupt(format!("unknown scalar type code {t}"))),
    };
    let spacing = [c.f64(), c.f64(), c.f64()];
    if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(Error::corrupt(format!(
            "spacing {spacing:?} is not positive and finite"
        )));
    }
    let origin = [c.f64(), c.f64(), c.f64()];
    let value_range = [c.f64(), c.f64()];
    let iso = c.f64();
    let bits = c.u32();
    let precision = Precision::from_bits(bits)
        .ok_or_else(|| Error::corrupt(format!("unknown precision {bits} bits")))?;
    let mapping = ValueMapping {
        iso_code: c.f32(),
        offset: c.f64(),
        step: c.f64(),
    };
    if !(iso.is_finite()
        && mapping.offset.is_finite()
        && mapping.step.is_finite()
        && mapping.step > 0.0)
    {
        return Err(Error::corrupt("isovalue or value mapping is not finite"));
    }
    let counts = [c.u64(), c.u64(), c.u64()];
    let occupied = c.u64();
    let info = GridInfo {
        dims,
        spacing,
        origin,
        direction: [[0.0; 3]; 3],
        scalar_type,
        value_range,
        iso,
        precision,
        mapping,
    };
    let record_sizes = [16u64, 12, precision.bytes_per_cell() as u64];
    let mut sections: [Range<usize>; 3] = Default::default();
    let mut end = HEADER_SIZE as u64;
    let names = ["blocks", "metacells", "cells"];
    for s in 0..3 {
        let (offset, len) = (c.u64(), c.u64());
        if counts[s].checked_mul(record_sizes[s]) != Some(len) {
            return Err(Error::corrupt(format!(
                "{} section is {len} bytes but holds {} records of {} bytes",
                names[s], counts[s], record_sizes[s]
            )));
        }
        if offset % 16 != 0 || offset < end || offset.checked_add(len).is_none_or(|e| e > file_len)
        {
            return Err(Error::corrupt(format!(
                "{} section at {offset}+{len} does not fit the {file_len}-byte file (truncated?)",
                names[s]
            )));
        }
        end = offset + len;
        sections[s] = offset as usize..end as usize;
    }
    let mut info = info;
    for row in info.direction.iter_mut() {
        *row = [c.f64(), c.f64(), c.f64()];
    }
    let crcs = [c.u32(), c.u32(), c.u32()];
    if counts[0] as usize != info.block_count() {
        return Err(Error::corrupt(format!(
            "{} blocks stored but dims {:?} need {}",
            counts[0],
            dims,
            info.block_count()
        )));
    }
    Ok(Header {
        info,
        sections,
        crcs,
        occupied,
    })
}

/// Bytes checksummed between two progress steps: a step of a memory-mapped file is mostly page
/// faults, a few milliseconds at disk speed.
const CHECKSUM_STEP: usize = 8 << 20;

/// Checks every record against the header and the structure of §3.1. `progress` counts bytes
/// checksummed, then blocks walked: `done` reaches `total` when the grid is valid.
fn validate(
    header: &Header,
    blocks: &[Block],
    metacells: &[Metacell],
    cells: &[u8],
    progress: &Progress,
) -> Result<()> {
    let sections: [&[u8]; 3] = [
        bytemuck::cast_slice(blocks),
        bytemuck::cast_slice(metacells),
        cells,
    ];
    let bytes_total: usize = sections.iter().map(|s| s.len()).sum();
    progress.start((bytes_total + blocks.len()) as u64);
    for (s, bytes) in sections.into_iter().enumerate() {
        let mut crc = crc32fast::Hasher::new();
        for chunk in bytes.chunks(CHECKSUM_STEP) {
            crc.update(chunk);
            progress.advance(chunk.len() as u64);
        }
        if crc.finalize() != header.crcs[s] {
            let name = ["blocks", "metacells", "cells"][s];
            return Err(Error::corrupt(format!(
                "{name} section checksum mismatch (the data is damaged)"
            )));
        }
    }
    let info = &header.info;
    let block_dims = info.block_dims().map(|b| b as usize);
    let cell_dims = info.cell_dims();
    let record = info.precision.bytes_per_cell();
    let total_cells = cells.len() / record;
    let (mut next_slot, mut next_cell, mut occupied) = (0usize, 0usize, 0u64);
    for (b, block) in blocks.iter().enumerate() {
        progress.advance(1);
        let fail = |what: String| Error::corrupt(format!("block {b}: {what}"));
        if !(block.metacell_count as usize).is_multiple_of(CLUSTER_SLOTS)
            || block.metacell_pointer as usize != next_slot
        {
            return Err(fail(format!(
                "metacell range {}+{} is not the next whole clusters (expected start {next_slot})",
                block.metacell_pointer, block.metacell_count
            )));
        }
        let slots = metacells
            .get(block.slots())
            .ok_or_else(|| fail("metacell range runs past the metacell section".into()))?;
        next_slot += slots.len();
        let block_pos = [
            b % block_dims[0],
            b / block_dims[0] % block_dims[1],
            b / (block_dims[0] * block_dims[1]),
        ];
        for (k, cluster) in slots.chunks_exact(CLUSTER_SLOTS).enumerate() {
            let (mut lo, mut hi, mut last_code) = ([u16::MAX; 3], [0u16; 3], None);
            let mut padding = false;
            for (s, m) in cluster[..BOUND_SLOT].iter().enumerate() {
                let slot = block.metacell_pointer as usize + k * CLUSTER_SLOTS + s;
                let fail = |what: &str| Error::corrupt(format!("metacell slot {slot}: {what}"));
                if m.is_empty() {
                    if bytemuck::bytes_of(m).iter().any(|&x| x != 0) {
                        return Err(fail("empty slot with non-zero fields"));
                    }
                    padding = true;
                    continue;
                }
                if padding || m.cell_mask > 0xff {
                    return Err(fail("metacell after padding, or reserved mask bits set"));
                }
                let local = m.position.map(|p| p as usize);
                for a in 0..3 {
                    if local[a] / BLOCK_METACELLS != block_pos[a] {
                        return Err(fail("position outside its block"));
                    }
                }
                let code = crate::morton::metacell_code(
                    (local[0] % BLOCK_METACELLS) as u32,
                    (local[1] % BLOCK_METACELLS) as u32,
                    (local[2] % BLOCK_METACELLS) as u32,
                );
                if last_code.is_some_and(|c| c >= code) {
                    return Err(fail("metacells out of Morton order"));
                }
                last_code = Some(code);
                for bit in 0..8 {
                    if m.cell_mask >> bit & 1 == 1 {
                        let p = m.cell_position(bit);
                        if (0..3).any(|a| p[a] >= cell_dims[a]) {
                            return Err(fail("active cell outside the grid"));
                        }
                    }
                }
                if m.cell_pointer as usize != next_cell {
                    return Err(fail(&format!(
                        "cell pointer {} out of sequence (expected {next_cell})",
                        m.cell_pointer
                    )));
                }
                next_cell += m.active_cells() as usize;
                if next_cell > total_cells {
                    return Err(fail("cells run past the cell section"));
                }
                occupied += 1;
                for a in 0..3 {
                    lo[a] = lo[a].min(m.position[a]);
                    hi[a] = hi[a].max(m.position[a]);
                }
            }
            let bound = cluster[BOUND_SLOT].as_bound();
            if cluster[0].is_empty() || bound.lo != lo || bound.hi != hi {
                let slot = block.metacell_pointer as usize + k * CLUSTER_SLOTS + BOUND_SLOT;
                return Err(Error::corrupt(format!(
                    "cluster bound in slot {slot} does not match its metacells"
                )));
            }
        }
    }
    if next_slot != metacells.len() || next_cell != total_cells || occupied != header.occupied {
        return Err(Error::corrupt(
            "blocks, metacells and cells do not add up to the header's counts",
        ));
    }
    Ok(())
}

/// Parses and validates a whole `.cgc` file held in memory; the grid owns copies of the buffers.
pub fn read_bytes(bytes: &[u8]) -> Result<CellGrid> {
    let header = parse_header(bytes, bytes.len() as u64)?;
    let blocks: Vec<Block> = bytemuck::pod_collect_to_vec(&bytes[header.sections[0].clone()]);
    let metacells: Vec<Metacell> = bytemuck::pod_collect_to_vec(&bytes[header.sections[1].clone()]);
    let cells = bytes[header.sections[2].clone()].to_vec();
    validate(&header, &blocks, &metacells, &cells, &Progress::new())?;
    Ok(CellGrid::from_parts(header.info, blocks, metacells, cells))
}

/// Reads and validates a `.cgc` file into memory. Errors name the file.
pub fn read(path: &Path) -> Result<CellGrid> {
    (|| -> Result<CellGrid> {
        let mut file = crate::fs::open_regular(path)?;
        let file_len = file.metadata()?.len();
        let mut head = vec![0u8; HEADER_SIZE.min(file_len as usize)];
        file.read_exact(&mut head)?;
        let header = parse_header(&head, file_len)?;
        // Sizes are checked against the file length, so these allocations are bounded by it,
        // and by the memory there is (a sparse file can be long and hold nothing).
        crate::memory::ensure_fits(
            "reading the grid",
            header.sections.iter().map(|r| r.len() as u64).sum(),
        )?;
        let mut blocks = vec![bytemuck::Zeroable::zeroed(); header.sections[0].len() / 16];
        let mut metacells = vec![bytemuck::Zeroable::zeroed(); header.sections[1].len() / 12];
        let mut cells = vec![0u8; header.sections[2].len()];
        let targets: [&mut [u8]; 3] = [
            bytemuck::cast_slice_mut(&mut blocks),
            bytemuck::cast_slice_mut(&mut metacells),
            &mut cells,
        ];
        for (range, target) in header.sections.iter().zip(targets) {
            file.seek(SeekFrom::Start(range.start as u64))?;
            file.read_exact(target)?;
        }
        validate(&header, &blocks, &metacells, &cells, &Progress::new())?;
        Ok(CellGrid::from_parts(header.info, blocks, metacells, cells))
    })()
    .at_path(path)
}

/// Memory-maps and validates a `.cgc` file: the grid's buffers are views of the page cache.
pub fn open(path: &Path) -> Result<CellGrid> {
    open_with_progress(path, &Progress::new())
}

/// [`open`], counting in `progress` the bytes checksummed and then the blocks checked (a large
/// file is read from disk while its checksums are taken).
pub fn open_with_progress(path: &Path, progress: &Progress) -> Result<CellGrid> {
    (|| -> Result<CellGrid> {
        let file = crate::fs::open_regular(path)?;
        // SAFETY: the map is read-only; like every mmap user we rely on nobody truncating the
        // file while it is mapped. Validation below covers all contents we later index.
        let map = unsafe { memmap2::Mmap::map(&file)? };
        let header = parse_header(&map, map.len() as u64)?;
        let [b, m, c] = header.sections.clone();
        {
            let blocks: &[Block] = bytemuck::try_cast_slice(&map[b.clone()])
                .map_err(|_| Error::corrupt("misaligned blocks section"))?;
            let metacells: &[Metacell] = bytemuck::try_cast_slice(&map[m.clone()])
                .map_err(|_| Error::corrupt("misaligned metacell section"))?;
            validate(&header, blocks, metacells, &map[c.clone()], progress)?;
        }
        Ok(CellGrid::from_storage(
            header.info,
            Storage::Mapped {
                map,
                blocks: b,
                metacells: m,
                cells: c,
            },
        ))
    })()
    .at_path(path)
}

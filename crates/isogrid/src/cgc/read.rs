//! Reads and validates `.cgc` files (format in [`super`]): into memory or memory-mapped.
//!
//! Nothing is allocated from a header field before it has been checked against the file's length,
//! and no grid is returned before every checksum, pointer and position has been checked.

use super::format::{
    scalar_of_code, world_frame_of, SectionKind, TableEntry, FLAG_REQUIRED, HEADER_CRC_AT,
    HEADER_SIZE, MAGIC, MAX_SECTIONS, TABLE_ENTRY_SIZE, TABLE_FIELDS_AT, VERSION, VERSION_1,
    WORLD_FRAME_SIZE,
};
use crate::attribute::{AttributeInfo, AttributePrecision, CellAttribute, ATTRIBUTE_HEAD_SIZE};
use crate::error::{Error, Result, ResultExt};
use crate::grid::{CellGrid, GridInfo, Storage};
use crate::labels::GridLabels;
use crate::layout::{Block, Metacell, Precision, BLOCK_METACELLS, BOUND_SLOT, CLUSTER_SLOTS};
use crate::progress::Progress;
use crate::quantize::ValueMapping;
use crate::volume::MAX_DIM;
use std::io::{Read, Seek, SeekFrom};
use std::ops::Range;
use std::path::Path;

struct Header {
    info: GridInfo,
    /// Byte ranges of the blocks, metacells and cells in the file.
    sections: [Range<usize>; 3],
    /// Every section with its name and stored checksum, in file order (the grid's three included).
    checksummed: Vec<(String, Range<usize>, u32)>,
    /// The cell attribute section, when there is one.
    attribute: Option<Range<usize>>,
    /// The cluster labels, label index and label table, when the file has labels.
    labels: Option<[Range<usize>; 3]>,
    /// The world frame section, when there is one.
    frame: Option<Range<usize>>,
    /// Bytes between sections, which must be zero (version 2).
    gaps: Vec<Range<usize>>,
    occupied: u64,
}

/// Bytes a reader takes from the start of a file to parse its header and section table.
const HEAD_READ: usize = HEADER_SIZE + MAX_SECTIONS * TABLE_ENTRY_SIZE;

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

/// Parses the header (and, in version 2, the section table) from `h`, the first bytes of a file
/// of `file_len` bytes ([`HEAD_READ`] of them, or the whole file when shorter).
fn parse_header(h: &[u8], file_len: u64) -> Result<Header> {
    if h.len() < HEADER_SIZE {
        return Err(Error::corrupt(format!(
            "file is {file_len} bytes, shorter than the {HEADER_SIZE}-byte .cgc header"
        )));
    }
    let (h, after) = h.split_at(HEADER_SIZE);
    if h[..8] == super::pack::PACKED_MAGIC {
        return Err(Error::unsupported(
            "a packed .cgcz, the web viewer's transfer form (isogrid pack): open the .cgc it was packed from",
        ));
    }
    if h[..8] != MAGIC {
        return Err(Error::corrupt("not a .cgc file (bad magic bytes)"));
    }
    // The checksum first: a damaged version field is damage, not a version from the future.
    let stored_crc = u32::from_le_bytes(h[HEADER_CRC_AT..].try_into().unwrap());
    if crc32fast::hash(&h[..HEADER_CRC_AT]) != stored_crc {
        return Err(Error::corrupt(
            "header checksum mismatch (the header is damaged)",
        ));
    }
    let mut c = Cursor(&h[8..]);
    let version = c.u32();
    if version != VERSION && version != VERSION_1 {
        return Err(Error::unsupported(format!(
            "format version {version}; this build reads versions {VERSION_1} and {VERSION}"
        )));
    }
    if c.u32() as usize != HEADER_SIZE {
        return Err(Error::corrupt("header size field is wrong"));
    }
    let dims = [c.u32(), c.u32(), c.u32()];
    if dims.iter().any(|&d| d == 0 || d as usize > MAX_DIM) {
        return Err(Error::corrupt(format!(
            "dims {dims:?} outside 1..={MAX_DIM}"
        )));
    }
    let code = c.u32();
    let scalar_type = scalar_of_code(code)
        .ok_or_else(|| Error::corrupt(format!("unknown scalar type code {code}")))?;
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
    let mut direction = [[0.0; 3]; 3];
    let mut d = Cursor(&h[208..280]);
    for row in direction.iter_mut() {
        *row = [d.f64(), d.f64(), d.f64()];
    }
    let info = GridInfo {
        dims,
        spacing,
        origin,
        direction,
        frame: crate::volume::WorldFrame::Unknown,
        scalar_type,
        value_range,
        iso,
        precision,
        mapping,
    };
    if counts[0] as usize != info.block_count() {
        return Err(Error::corrupt(format!(
            "{} blocks stored but dims {:?} need {}",
            counts[0],
            dims,
            info.block_count()
        )));
    }
    let record_sizes = [16u64, 12, precision.bytes_per_cell() as u64];
    let grid_lengths = |s: usize, len: u64| -> Result<()> {
        let name = GRID_SECTIONS[s].name();
        if counts[s].checked_mul(record_sizes[s]) != Some(len) {
            return Err(Error::corrupt(format!(
                "{name} section is {len} bytes but holds {} records of {} bytes",
                counts[s], record_sizes[s]
            )));
        }
        Ok(())
    };
    let fits = |name: &str, offset: u64, len: u64, end: u64| -> Result<Range<usize>> {
        if !offset.is_multiple_of(16)
            || offset < end
            || offset.checked_add(len).is_none_or(|e| e > file_len)
        {
            return Err(Error::corrupt(format!(
                "{name} section at {offset}+{len} does not fit the {file_len}-byte file (truncated?)"
            )));
        }
        Ok(offset as usize..(offset + len) as usize)
    };
    let mut header = Header {
        info,
        sections: Default::default(),
        checksummed: Vec::new(),
        attribute: None,
        labels: None,
        frame: None,
        gaps: Vec::new(),
        occupied,
    };
    if version == VERSION_1 {
        let mut s160 = Cursor(&h[160..208]);
        let mut crcs = Cursor(&h[280..292]);
        let mut end = HEADER_SIZE as u64;
        for (s, kind) in GRID_SECTIONS.into_iter().enumerate() {
            let (offset, len) = (s160.u64(), s160.u64());
            grid_lengths(s, len)?;
            let range = fits(kind.name(), offset, len, end)?;
            end = range.end as u64;
            header.sections[s] = range.clone();
            header
                .checksummed
                .push((kind.name().to_string(), range, crcs.u32()));
        }
        return Ok(header);
    }

    // Version 2: the section table.
    let mut t = Cursor(&h[TABLE_FIELDS_AT..TABLE_FIELDS_AT + 16]);
    let (table_at, count, table_crc) = (t.u64(), t.u32() as usize, t.u32());
    if h[176..208]
        .iter()
        .chain(&h[280..HEADER_CRC_AT])
        .any(|&b| b != 0)
    {
        return Err(Error::corrupt("reserved header bytes are not zero"));
    }
    if table_at != HEADER_SIZE as u64 || !(3..=MAX_SECTIONS).contains(&count) {
        return Err(Error::corrupt(format!(
            "section table of {count} entries at {table_at} (expected 3..={MAX_SECTIONS} at {HEADER_SIZE})"
        )));
    }
    let table_len = count * TABLE_ENTRY_SIZE;
    let table = after.get(..table_len).ok_or_else(|| {
        Error::corrupt(format!(
            "the {table_len}-byte section table does not fit the {file_len}-byte file (truncated?)"
        ))
    })?;
    if crc32fast::hash(table) != table_crc {
        return Err(Error::corrupt(
            "section table checksum mismatch (the table is damaged)",
        ));
    }
    let mut end = (HEADER_SIZE + table_len) as u64;
    let mut seen = Vec::new();
    let mut labels: [Option<Range<usize>>; 3] = Default::default();
    for (i, raw) in table.chunks_exact(TABLE_ENTRY_SIZE).enumerate() {
        let (entry, reserved_zero) = TableEntry::from_bytes(raw.try_into().unwrap());
        let kind = SectionKind::from_code(entry.kind);
        let name = kind.map_or(format!("section {i} (kind {})", entry.kind), |k| {
            k.name().to_string()
        });
        if !reserved_zero || entry.flags & !FLAG_REQUIRED != 0 {
            return Err(Error::corrupt(format!(
                "{name}: reserved table bits are set"
            )));
        }
        let required = entry.flags & FLAG_REQUIRED != 0;
        let range = fits(&name, entry.offset, entry.len, end)?;
        header.gaps.push(end as usize..range.start);
        end = range.end as u64;
        match kind {
            None if required => {
                return Err(Error::unsupported(format!(
                    "{name} is required, and this build does not know its kind"
                )))
            }
            None => {}
            Some(kind) => {
                if kind.required() != required {
                    return Err(Error::corrupt(format!(
                        "{name} section has the wrong flags"
                    )));
                }
                if seen.contains(&kind) && !kind.repeatable() {
                    return Err(Error::corrupt(format!("two {name} sections")));
                }
                seen.push(kind);
                if let Some(s) = GRID_SECTIONS.iter().position(|&g| g == kind) {
                    grid_lengths(s, entry.len)?;
                    header.sections[s] = range.clone();
                } else if kind == SectionKind::CellAttribute {
                    header.attribute = Some(range.clone());
                } else if kind == SectionKind::WorldFrame {
                    if entry.len != WORLD_FRAME_SIZE {
                        return Err(Error::corrupt(format!(
                            "{name} section is {} bytes, not {WORLD_FRAME_SIZE}",
                            entry.len
                        )));
                    }
                    header.frame = Some(range.clone());
                } else if let Some(l) = SectionKind::LABELS.iter().position(|&k| k == kind) {
                    labels[l] = Some(range.clone());
                }
            }
        }
        header.checksummed.push((name, range, entry.crc));
    }
    if let Some(kind) = GRID_SECTIONS.iter().find(|k| !seen.contains(k)) {
        return Err(Error::corrupt(format!("no {} section", kind.name())));
    }
    if end != file_len {
        return Err(Error::corrupt(format!(
            "the file is {file_len} bytes but its sections end at {end} (truncated or appended to?)"
        )));
    }
    header.labels = match labels {
        [Some(c), Some(i), Some(t)] => Some([c, i, t]),
        [None, None, None] => None,
        _ => {
            return Err(Error::corrupt(
                "the file has some of the three label sections but not all",
            ))
        }
    };
    Ok(header)
}

const GRID_SECTIONS: [SectionKind; 3] = [
    SectionKind::Blocks,
    SectionKind::Metacells,
    SectionKind::Cells,
];

/// Checks the bytes that must be zero (gaps between sections).
fn check_gaps<'a>(gaps: impl IntoIterator<Item = &'a [u8]>) -> Result<()> {
    if gaps.into_iter().flatten().any(|&b| b != 0) {
        return Err(Error::corrupt("padding between sections is not zero"));
    }
    Ok(())
}

/// Checks the checksum of each section (`parts`: name, bytes, stored CRC), counting bytes in
/// `progress`.
fn check_sums(parts: &[(&str, &[u8], u32)], progress: &Progress) -> Result<()> {
    for (name, bytes, stored) in parts {
        let mut crc = crc32fast::Hasher::new();
        for chunk in bytes.chunks(CHECKSUM_STEP) {
            crc.update(chunk);
            progress.advance(chunk.len() as u64);
        }
        if crc.finalize() != *stored {
            return Err(Error::corrupt(format!(
                "{name} section checksum mismatch (the data is damaged)"
            )));
        }
    }
    Ok(())
}

/// The cell attribute in `bytes` (its whole section), checked against the grid's cell count.
fn parse_attribute(bytes: &[u8], active_cells: usize) -> Result<CellAttribute> {
    let (info, count) = AttributeInfo::from_head(bytes)?;
    let width = info.precision.bytes();
    let values = &bytes[ATTRIBUTE_HEAD_SIZE.min(bytes.len())..];
    if count != active_cells as u64 || values.len() as u64 != count * width as u64 {
        return Err(Error::corrupt(format!(
            "cell attribute section holds {} bytes of values, and {count} values for {active_cells} active cells",
            values.len()
        )));
    }
    if info.precision == AttributePrecision::F32 {
        let [lo, hi] = info.range;
        if let Some(v) = values
            .chunks_exact(4)
            .map(|v| f32::from_le_bytes(v.try_into().unwrap()) as f64)
            .find(|v| !v.is_nan() && !(lo..=hi).contains(v))
        {
            return Err(Error::corrupt(format!(
                "cell attribute value {v} lies outside its range [{lo}, {hi}]"
            )));
        }
    }
    Ok(CellAttribute::from_encoded(info, values.to_vec()))
}

/// Bytes checksummed between two progress steps: a step of a memory-mapped file is mostly page
/// faults, a few milliseconds at disk speed.
const CHECKSUM_STEP: usize = 8 << 20;

/// Checks every record against the header and the structure of §3.1. `progress` counts bytes
/// checksummed, then blocks walked: `done` reaches `total` when the grid is valid.
fn validate(
    header: &Header,
    section_bytes: &[&[u8]],
    blocks: &[Block],
    metacells: &[Metacell],
    cells: &[u8],
    progress: &Progress,
) -> Result<()> {
    let bytes_total: usize = section_bytes.iter().map(|s| s.len()).sum();
    progress.start((bytes_total + blocks.len()) as u64);
    let parts: Vec<(&str, &[u8], u32)> = header
        .checksummed
        .iter()
        .zip(section_bytes)
        .map(|((name, _, crc), bytes)| (name.as_str(), *bytes, *crc))
        .collect();
    check_sums(&parts, progress)?;
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
    let header = parse_header(&bytes[..HEAD_READ.min(bytes.len())], bytes.len() as u64)?;
    check_gaps(header.gaps.iter().map(|r| &bytes[r.clone()]))?;
    let blocks: Vec<Block> = bytemuck::pod_collect_to_vec(&bytes[header.sections[0].clone()]);
    let metacells: Vec<Metacell> = bytemuck::pod_collect_to_vec(&bytes[header.sections[1].clone()]);
    let cells = bytes[header.sections[2].clone()].to_vec();
    let sections: Vec<&[u8]> = header
        .checksummed
        .iter()
        .map(|(_, r, _)| &bytes[r.clone()])
        .collect();
    validate(
        &header,
        &sections,
        &blocks,
        &metacells,
        &cells,
        &Progress::new(),
    )?;
    let info = with_frame(&header.info, header.frame.clone().map(|r| &bytes[r]))?;
    let grid = CellGrid::from_parts(info, blocks, metacells, cells);
    with_optional(
        grid,
        header.attribute.map(|r| &bytes[r]),
        header.labels.map(|l| l.map(|r| &bytes[r])),
    )
}

/// `info` in the world frame its section's bytes name (`None`: the file has none, unknown).
fn with_frame(info: &GridInfo, section: Option<&[u8]>) -> Result<GridInfo> {
    let mut info = info.clone();
    if let Some(bytes) = section {
        info.frame = world_frame_of(bytes)?;
    }
    Ok(info)
}

/// `grid` with the attribute of section bytes `attribute` and the labels of the three label
/// sections' bytes, when it has them (checksums checked), validated against the grid.
fn with_optional(
    grid: CellGrid,
    attribute: Option<&[u8]>,
    labels: Option<[&[u8]; 3]>,
) -> Result<CellGrid> {
    let grid = match attribute {
        None => grid,
        Some(bytes) => {
            let attribute = parse_attribute(bytes, grid.active_cells())?;
            grid.with_attribute(attribute)?
        }
    };
    match labels {
        None => Ok(grid),
        Some([clusters, index, table]) => {
            let labels = GridLabels::from_sections(clusters, index, table, grid.metacells())?;
            grid.with_labels(labels)
        }
    }
}

/// Reads and validates a `.cgc` file into memory. Errors name the file.
pub fn read(path: &Path) -> Result<CellGrid> {
    (|| -> Result<CellGrid> {
        let mut file = crate::fs::open_regular(path)?;
        let file_len = file.metadata()?.len();
        let mut head = vec![0u8; HEAD_READ.min(file_len as usize)];
        file.read_exact(&mut head)?;
        let header = parse_header(&head, file_len)?;
        // Sizes are checked against the file length, so these allocations are bounded by it,
        // and by the memory there is (a sparse file can be long and hold nothing).
        crate::memory::ensure_fits(
            "reading the grid",
            header
                .checksummed
                .iter()
                .map(|(_, r, _)| r.len() as u64)
                .sum(),
        )?;
        let mut read_at = |range: &Range<usize>, target: &mut [u8]| -> Result<()> {
            file.seek(SeekFrom::Start(range.start as u64))?;
            file.read_exact(target)?;
            Ok(())
        };
        for gap in &header.gaps {
            let mut bytes = vec![0u8; gap.len()];
            read_at(gap, &mut bytes)?;
            check_gaps([bytes.as_slice()])?;
        }
        let mut blocks = vec![bytemuck::Zeroable::zeroed(); header.sections[0].len() / 16];
        let mut metacells = vec![bytemuck::Zeroable::zeroed(); header.sections[1].len() / 12];
        let mut cells = vec![0u8; header.sections[2].len()];
        let targets: [&mut [u8]; 3] = [
            bytemuck::cast_slice_mut(&mut blocks),
            bytemuck::cast_slice_mut(&mut metacells),
            &mut cells,
        ];
        for (range, target) in header.sections.iter().zip(targets) {
            read_at(range, target)?;
        }
        // The other sections, read whole (they are small beside the cells).
        let mut others: Vec<Vec<u8>> = Vec::new();
        for (_, range, _) in &header.checksummed {
            if !header.sections.contains(range) {
                let mut bytes = vec![0u8; range.len()];
                read_at(range, &mut bytes)?;
                others.push(bytes);
            }
        }
        let mut others_iter = others.iter();
        let grid_bytes: [&[u8]; 3] = [
            bytemuck::cast_slice(&blocks),
            bytemuck::cast_slice(&metacells),
            &cells,
        ];
        let sections: Vec<&[u8]> = header
            .checksummed
            .iter()
            .map(
                |(_, range, _)| match header.sections.iter().position(|r| r == range) {
                    Some(s) => grid_bytes[s],
                    None => others_iter.next().expect("read above").as_slice(),
                },
            )
            .collect();
        // An optional section's bytes, by its range.
        let optional: Vec<(&Range<usize>, &[u8])> = header
            .checksummed
            .iter()
            .map(|(_, r, _)| r)
            .filter(|r| !header.sections.contains(r))
            .zip(others.iter().map(|o| o.as_slice()))
            .collect();
        let bytes_of = |range: &Range<usize>| -> &[u8] {
            optional
                .iter()
                .find(|(r, _)| *r == range)
                .map_or(&[], |(_, bytes)| bytes)
        };
        let attribute = header.attribute.as_ref().map(bytes_of);
        let labels = header
            .labels
            .as_ref()
            .map(|l| [0, 1, 2].map(|i| bytes_of(&l[i])));
        validate(
            &header,
            &sections,
            &blocks,
            &metacells,
            &cells,
            &Progress::new(),
        )?;
        let info = with_frame(&header.info, header.frame.as_ref().map(bytes_of))?;
        let grid = CellGrid::from_parts(info, blocks, metacells, cells);
        with_optional(grid, attribute, labels)
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
        let header = parse_header(&map[..HEAD_READ.min(map.len())], map.len() as u64)?;
        check_gaps(header.gaps.iter().map(|r| &map[r.clone()]))?;
        let [b, m, c] = header.sections.clone();
        {
            let blocks: &[Block] = bytemuck::try_cast_slice(&map[b.clone()])
                .map_err(|_| Error::corrupt("misaligned blocks section"))?;
            let metacells: &[Metacell] = bytemuck::try_cast_slice(&map[m.clone()])
                .map_err(|_| Error::corrupt("misaligned metacell section"))?;
            let sections: Vec<&[u8]> = header
                .checksummed
                .iter()
                .map(|(_, r, _)| &map[r.clone()])
                .collect();
            validate(
                &header,
                &sections,
                blocks,
                metacells,
                &map[c.clone()],
                progress,
            )?;
        }
        let attribute = header
            .attribute
            .clone()
            .map(|r| parse_attribute(&map[r], c.len() / header.info.precision.bytes_per_cell()))
            .transpose()?;
        let labels = header
            .labels
            .as_ref()
            .map(|[l, i, t]| {
                let metacells: &[Metacell] = bytemuck::cast_slice(&map[m.clone()]);
                GridLabels::from_sections(
                    &map[l.clone()],
                    &map[i.clone()],
                    &map[t.clone()],
                    metacells,
                )
            })
            .transpose()?;
        let info = with_frame(&header.info, header.frame.clone().map(|r| &map[r]))?;
        let mut grid = CellGrid::from_storage(
            info,
            Storage::Mapped {
                map,
                blocks: b,
                metacells: m,
                cells: c,
            },
        );
        if let Some(attribute) = attribute {
            grid = grid.with_attribute(attribute)?;
        }
        match labels {
            Some(labels) => grid.with_labels(labels),
            None => Ok(grid),
        }
    })()
    .at_path(path)
}

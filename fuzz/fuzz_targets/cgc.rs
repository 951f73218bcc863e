//! `.cgc` clustered-grid-cell files from bytes: header, section table and the validation that
//! makes every later index into blocks, metacells and cells safe; a read grid is then walked.
//!
//! Every input is read twice: as it is (the checksum checks), and with its section and header
//! CRC-32s recomputed, so that mutations reach the structural checks behind the checksums
//! instead of stopping at the first mismatch.
#![no_main]

/// Header offsets of the `.cgc` layout (`isogrid::cgc`'s module table).
const V1_SECTIONS_AT: usize = 160;
const V1_SECTION_CRCS_AT: usize = 280;
const V2_TABLE_COUNT_AT: usize = 168;
const V2_TABLE_CRC_AT: usize = 172;
const TABLE_ENTRY_SIZE: usize = 32;
const HEADER_CRC_AT: usize = 316;
const HEADER_SIZE: usize = 320;

/// `data` with every checksum that can be found recomputed: each section's (version 1: in the
/// header; version 2: in its table entry), the table's and the header's.
fn with_checksums_fixed(data: &[u8]) -> Option<Vec<u8>> {
    if data.len() < HEADER_SIZE {
        return None;
    }
    let mut out = data.to_vec();
    let u32_at = |at: usize| u32::from_le_bytes(data[at..at + 4].try_into().unwrap());
    let u64_at = |at: usize| u64::from_le_bytes(data[at..at + 8].try_into().unwrap());
    let crc_of = |offset: u64, len: u64| -> Option<u32> {
        let end = offset
            .checked_add(len)
            .filter(|&e| e <= data.len() as u64)?;
        Some(crc32fast::hash(&data[offset as usize..end as usize]))
    };
    if u32_at(8) == 1 {
        for s in 0..3 {
            let at = V1_SECTIONS_AT + 16 * s;
            let crc = crc_of(u64_at(at), u64_at(at + 8))?;
            out[V1_SECTION_CRCS_AT + 4 * s..][..4].copy_from_slice(&crc.to_le_bytes());
        }
    } else {
        let count = (u32_at(V2_TABLE_COUNT_AT) as usize).min(64);
        let table_end = HEADER_SIZE + count * TABLE_ENTRY_SIZE;
        if table_end > data.len() {
            return None;
        }
        for e in 0..count {
            let at = HEADER_SIZE + e * TABLE_ENTRY_SIZE;
            if let Some(crc) = crc_of(u64_at(at + 8), u64_at(at + 16)) {
                out[at + 24..at + 28].copy_from_slice(&crc.to_le_bytes());
            }
        }
        let crc = crc32fast::hash(&out[HEADER_SIZE..table_end]);
        out[V2_TABLE_CRC_AT..V2_TABLE_CRC_AT + 4].copy_from_slice(&crc.to_le_bytes());
    }
    let crc = crc32fast::hash(&out[..HEADER_CRC_AT]);
    out[HEADER_CRC_AT..HEADER_SIZE].copy_from_slice(&crc.to_le_bytes());
    Some(out)
}

fn read_and_walk(bytes: &[u8]) {
    if let Ok(grid) = isogrid::cgc::read_bytes(bytes) {
        let stats = isogrid::GridStats::of(&grid);
        assert_eq!(stats.active_cells as usize, grid.active_cells());
        for c in 0..grid.clusters() {
            let _ = grid.cluster_bound(c);
        }
        for i in 0..grid.active_cells() {
            let _ = grid.cell_record(i);
        }
        let _ = grid.info().world_bounds();
        if let Some(attribute) = grid.attribute() {
            assert_eq!(attribute.len(), grid.active_cells());
            for i in 0..attribute.len() {
                let _ = attribute.value(i);
            }
        }
    }
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::init();
    read_and_walk(data);
    if let Some(fixed) = with_checksums_fixed(data) {
        read_and_walk(&fixed);
    }
});

//! `.cgc` clustered-grid-cell files from bytes: header, section ranges and the validation that
//! makes every later index into blocks, metacells and cells safe; a read grid is then walked.
//!
//! Every input is read twice: as it is (the checksum checks), and with its section and header
//! CRC-32s recomputed, so that mutations reach the structural checks behind the checksums
//! instead of stopping at the first mismatch.
#![no_main]

/// Header offsets of the `.cgc` layout (`isogrid::cgc`'s module table).
const SECTIONS_AT: usize = 160;
const SECTION_CRCS_AT: usize = 280;
const HEADER_CRC_AT: usize = 316;
const HEADER_SIZE: usize = 320;

fn with_checksums_fixed(data: &[u8]) -> Option<Vec<u8>> {
    if data.len() < HEADER_SIZE {
        return None;
    }
    let mut out = data.to_vec();
    let u64_at = |at: usize| u64::from_le_bytes(data[at..at + 8].try_into().unwrap());
    for s in 0..3 {
        let (offset, len) = (
            u64_at(SECTIONS_AT + 16 * s),
            u64_at(SECTIONS_AT + 16 * s + 8),
        );
        let end = offset
            .checked_add(len)
            .filter(|&e| e <= data.len() as u64)?;
        let crc = crc32fast::hash(&data[offset as usize..end as usize]);
        out[SECTION_CRCS_AT + 4 * s..][..4].copy_from_slice(&crc.to_le_bytes());
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
    }
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::init();
    read_and_walk(data);
    if let Some(fixed) = with_checksums_fixed(data) {
        read_and_walk(&fixed);
    }
});

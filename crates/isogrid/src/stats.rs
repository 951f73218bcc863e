//! Memory accounting as the paper reports it (§3.5, Table 3).
//!
//! Table 3's "Memory" column is metacell slots × 12 B + active cells × corner bytes, in decimal
//! megabytes; the block volume (16 B per block) is reported separately, and bytes per active cell
//! include it, as §3.5 does when it quotes 11 B/cell for 8-bit data.

use crate::grid::CellGrid;

/// Counts and sizes of an extracted grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridStats {
    pub dims: [u32; 3],
    pub iso: f64,
    pub precision_bits: u32,
    pub active_cells: u64,
    /// Metacells holding at least one active cell.
    pub metacells: u64,
    /// All metacell slots: metacells, padding and cluster bounds.
    pub metacell_slots: u64,
    pub clusters: u64,
    pub blocks: u64,
    pub nonempty_blocks: u64,
    pub bytes: MemoryBytes,
}

/// Bytes of each buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemoryBytes {
    pub blocks: u64,
    pub metacells: u64,
    pub cells: u64,
    /// Table 3's figure: metacells + cells.
    pub paper_total: u64,
}

impl GridStats {
    pub fn of(grid: &CellGrid) -> Self {
        let info = grid.info();
        let blocks = grid.blocks().len() as u64;
        let slots = grid.metacell_slots() as u64;
        let cells = grid.cells().len() as u64;
        GridStats {
            dims: info.dims,
            iso: info.iso,
            precision_bits: info.precision.bits(),
            active_cells: grid.active_cells() as u64,
            metacells: grid.occupied_metacells() as u64,
            metacell_slots: slots,
            clusters: grid.clusters() as u64,
            blocks,
            nonempty_blocks: grid.nonempty_blocks() as u64,
            bytes: MemoryBytes {
                blocks: blocks * 16,
                metacells: slots * 12,
                cells,
                paper_total: slots * 12 + cells,
            },
        }
    }

    /// All bytes (blocks, metacells, cells) per active cell; 0 when there is none.
    pub fn bytes_per_cell(&self) -> f64 {
        if self.active_cells == 0 {
            return 0.0;
        }
        (self.bytes.blocks + self.bytes.paper_total) as f64 / self.active_cells as f64
    }
}

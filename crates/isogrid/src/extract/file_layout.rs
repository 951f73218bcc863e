//! The `.cgc` header fields and section sizes of an extraction, from its block counts alone
//! (paper §3.1): what the streaming and the tiled extractions settle before they emit anything,
//! since they write files they never hold whole.

use super::Totals;
use crate::cgc::{FilePlan, HeaderCounts, SectionKind};
use crate::grid::GridInfo;
use crate::layout::{Block, Metacell, Precision, CLUSTER_SLOTS};
use crate::quantize::Quantizer;
use crate::stats::{GridStats, MemoryBytes};
use crate::volume::{Geometry, ScalarType};

/// Header, quantiser, section offsets and statistics of one output file.
pub(super) struct FileLayout {
    pub info: GridInfo,
    pub quantizer: Quantizer,
    pub counts: HeaderCounts,
    /// Byte lengths of the block, metacell and cell sections.
    pub lengths: [u64; 3],
    /// Sections after those three, with their byte lengths (a label grid's).
    pub more: Vec<(SectionKind, u64)>,
    pub stats: GridStats,
}

impl FileLayout {
    /// The layout of `block_count` blocks whose prefix sums ended at `totals`. `range` is the
    /// NaN-free value range of the samples (min > max when none is finite, stored as 0..0).
    pub(super) fn new(
        geometry: &Geometry,
        scalar_type: ScalarType,
        precision: Precision,
        iso: f64,
        range: (f64, f64),
        block_count: u64,
        totals: &Totals,
    ) -> Self {
        let (lo, hi) = if range.0 <= range.1 {
            range
        } else {
            (0.0, 0.0)
        };
        let quantizer = Quantizer::new(precision, scalar_type.is_integer(), lo, hi, iso);
        Self::with_quantizer(
            geometry,
            scalar_type,
            quantizer,
            [lo, hi],
            iso,
            block_count,
            totals,
        )
    }

    /// The layout of a grid whose corner values `quantizer` maps and whose header gives the
    /// value range `range` (a label grid's: its indicators', `[0, 1]`).
    pub(super) fn with_quantizer(
        geometry: &Geometry,
        scalar_type: ScalarType,
        quantizer: Quantizer,
        range: [f64; 2],
        iso: f64,
        block_count: u64,
        totals: &Totals,
    ) -> Self {
        let precision = quantizer.precision();
        let record = precision.bytes_per_cell() as u64;
        let info = GridInfo::new(geometry, scalar_type, range, iso, &quantizer);
        let counts = HeaderCounts {
            blocks: block_count,
            metacell_slots: totals.slots,
            active_cells: totals.cells,
            occupied_metacells: totals.occupied_metacells,
        };
        let lengths = [
            block_count * size_of::<Block>() as u64,
            totals.slots * size_of::<Metacell>() as u64,
            totals.cells * record,
        ];
        let stats = GridStats {
            dims: info.dims,
            iso,
            precision_bits: precision.bits(),
            active_cells: totals.cells,
            metacells: totals.occupied_metacells,
            metacell_slots: totals.slots,
            clusters: totals.slots / CLUSTER_SLOTS as u64,
            blocks: block_count,
            nonempty_blocks: totals.nonempty_blocks,
            bytes: MemoryBytes {
                blocks: block_count * size_of::<Block>() as u64,
                metacells: totals.slots * size_of::<Metacell>() as u64,
                cells: totals.cells * record,
                paper_total: totals.slots * size_of::<Metacell>() as u64 + totals.cells * record,
            },
        };
        FileLayout {
            info,
            quantizer,
            counts,
            lengths,
            more: Vec::new(),
            stats,
        }
    }

    /// Where the file's sections go.
    pub(super) fn plan(&self) -> FilePlan {
        let [blocks, metacells, cells] = self.lengths;
        let mut sections = vec![
            (SectionKind::Blocks, blocks),
            (SectionKind::Metacells, metacells),
            (SectionKind::Cells, cells),
        ];
        sections.extend_from_slice(&self.more);
        FilePlan::new(&sections, self.info.frame)
    }
}

//! One label grid from several label grids of the same volume grid, each with its own labels: the
//! layers of a segmentation whose segments overlap (a layered 3D Slicer `.seg.nrrd`), each layer
//! extracted on its own by [`crate::extract_labels`].
//!
//! Each block of the result holds the block's clusters of the first grid, then of the second, and
//! so on, with their cell pointers moved; the labels keep their cells, counts and bounds, and take
//! the values (and names and colours) the caller gives. The values must increase across the
//! grids, so a block's clusters stay sorted by label as the label sections require.

use crate::error::{Error, Result};
use crate::grid::CellGrid;
use crate::labels::{ClusterRun, GridLabels, Label, LabelEntry};
use crate::layout::{Block, Metacell, BOUND_SLOT, CLUSTER_SLOTS};

/// Joins label grids of one volume grid (same header: dims, spacing, precision, value mapping)
/// into one, the labels of `parts[i]` taking the table `parts[i].1` (same length as its own, in
/// the same order). The tables' values together must increase strictly.
pub fn merge_label_grids(parts: &[(&CellGrid, Vec<Label>)]) -> Result<CellGrid> {
    let Some((first, _)) = parts.first() else {
        return Err(Error::invalid("no label grids to merge"));
    };
    let info = first.info().clone();
    let mut table: Vec<Label> = Vec::new();
    let mut label_base = Vec::with_capacity(parts.len());
    for (grid, names) in parts {
        let labels = grid
            .labels()
            .ok_or_else(|| Error::invalid("a grid to merge has no labels"))?;
        if *grid.info() != info {
            return Err(Error::invalid(
                "label grids to merge differ in their header (dims, spacing, precision or values)",
            ));
        }
        if names.len() != labels.table().len() {
            return Err(Error::invalid("a merged grid's table must keep its labels"));
        }
        if let (Some(last), Some(next)) = (table.last(), names.first()) {
            if next.value <= last.value {
                return Err(Error::invalid(
                    "merged label values must increase across the grids",
                ));
            }
        }
        label_base.push(table.len() as u32);
        table.extend(names.iter().cloned());
    }
    if table.windows(2).any(|w| w[0].value >= w[1].value) {
        return Err(Error::invalid("merged label values must increase strictly"));
    }

    let record = info.precision.bytes_per_cell();
    let block_count = info.block_count();
    let mut blocks = Vec::with_capacity(block_count);
    let mut metacells: Vec<Metacell> = Vec::new();
    let mut cells: Vec<u8> = Vec::new();
    let mut cluster_labels: Vec<u32> = Vec::new();
    let mut runs: Vec<(u32, ClusterRun)> = Vec::new();
    let too_large = || {
        Error::too_large(
            "more than 2^32 metacell slots or active cells: beyond the 32-bit pointers of the format",
        )
    };
    for b in 0..block_count {
        let slot_start = metacells.len();
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        for ((grid, _), &base) in parts.iter().zip(&label_base) {
            let block = grid.blocks()[b];
            if block.metacell_count == 0 {
                continue;
            }
            min = min.min(block.min);
            max = max.max(block.max);
            let slots = &grid.metacells()[block.slots()];
            // The block's cells are consecutive, in slot order, from its first occupied slot's.
            let occupied =
                |s: &(usize, &Metacell)| s.0 % CLUSTER_SLOTS != BOUND_SLOT && !s.1.is_empty();
            let from = slots
                .iter()
                .enumerate()
                .find(|s| occupied(s))
                .map_or(0, |(_, m)| m.cell_pointer as usize);
            let to = u32::try_from(cells.len() / record).map_err(|_| too_large())?;
            let mut next = from;
            for (s, m) in slots.iter().enumerate() {
                let mut m = *m;
                if occupied(&(s, &m)) {
                    if m.cell_pointer as usize != next {
                        return Err(Error::corrupt(
                            "a block's cells are not consecutive in slot order",
                        ));
                    }
                    next += m.active_cells() as usize;
                    m.cell_pointer = m.cell_pointer - from as u32 + to;
                }
                metacells.push(m);
            }
            cells.extend_from_slice(&grid.cells()[from * record..next * record]);
            // Its clusters' labels, and its runs: consecutive clusters of one label.
            let labels = grid.labels().expect("checked above").cluster_labels();
            let first_cluster = block.metacell_pointer as usize / CLUSTER_SLOTS;
            for &l in &labels[first_cluster..first_cluster + block.cluster_count()] {
                let label = l + base;
                let cluster = cluster_labels.len() as u32;
                match runs.last_mut() {
                    Some((last, run))
                        if *last == label
                            && run.first_cluster + run.cluster_count == cluster
                            && run.first_cluster as usize * CLUSTER_SLOTS >= slot_start =>
                    {
                        run.cluster_count += 1
                    }
                    _ => runs.push((
                        label,
                        ClusterRun {
                            first_cluster: cluster,
                            cluster_count: 1,
                        },
                    )),
                }
                cluster_labels.push(label);
            }
        }
        let count = metacells.len() - slot_start;
        if metacells.len() > u32::MAX as usize || cells.len() / record > u32::MAX as usize {
            return Err(too_large());
        }
        blocks.push(Block {
            metacell_count: count as u32,
            metacell_pointer: slot_start as u32,
            min: if count == 0 { 0.0 } else { min },
            max: if count == 0 { 0.0 } else { max },
        });
    }

    // Each label's runs together, in cluster order (the sort is stable); counts and bounds as the
    // parts had them.
    runs.sort_by_key(|&(label, _)| label);
    let mut index = Vec::with_capacity(table.len());
    let mut next = 0u64;
    for (grid, _) in parts {
        for e in grid.labels().expect("checked above").index() {
            let label = index.len() as u32;
            let run_count = runs[next as usize..]
                .iter()
                .take_while(|(l, _)| *l == label)
                .count() as u64;
            index.push(LabelEntry {
                first_run: next,
                run_count,
                ..*e
            });
            next += run_count;
        }
    }
    let runs = runs.into_iter().map(|(_, r)| r).collect();
    CellGrid::from_parts(info, blocks, metacells, cells).with_labels(GridLabels::from_parts(
        table,
        cluster_labels,
        index,
        runs,
    ))
}

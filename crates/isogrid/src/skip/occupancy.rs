//! Which of a block's 8×8×8 metacells hold active cells, as a 512-bit mask in Morton order, and
//! where each one's slots lie: the index the GPU tracer's in-block metacell DDA (`trace.wgsl` in
//! `isogrid-gpu`) reads instead of testing cluster and metacell boxes, so that it meets a block's
//! metacells in ray order and stops at the first crossing.
//!
//! The extraction (paper §3.1, `extract/emit.rs`) stores a block's metacells in Morton order, 15
//! per cluster (slot 15 is the cluster's bound), with padding only after the block's last
//! metacell. So the metacell of rank `k` (the `k`-th set bit of the mask) lies in slot
//! `metacell_pointer + k + k / 15`, and its rank is a popcount of the mask below its bit: per-word
//! prefix counts make that one masked popcount.
//!
//! A label grid (`crate::labels`) stores one such *run* per label present in the block, each
//! starting at a cluster's first slot, so a position may hold a metacell of several labels. Such a
//! block is *listed*: its mask is the union of its runs' positions, and a list gives the slots at
//! each occupied position (rank `k`'s slots are `list[list[k]..list[k + 1]]`), which the walk tests
//! all before it stops. A block of one run keeps the rank rule and no list.
//!
//! Memory: 80 bytes per non-empty block and a 4-byte record index per block; a listed block adds
//! 4 bytes per occupied position and per metacell. The CPU tracer does not use it: on the CPU the
//! same walk measured no faster than the box tests on the 512³ dragon (each step ends in a
//! data-dependent branch, which costs about what the box tests it replaces).

use crate::layout::{Block, Metacell, BLOCK_METACELLS, CLUSTER_METACELLS, CLUSTER_SLOTS};
use crate::morton;

/// One non-empty block's occupancy. 80 bytes.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(16))]
pub struct BlockOccupancy {
    /// Bit `code` set when the metacell with Morton code `code` (within the block) is occupied.
    words: [u64; 8],
    /// Low 8 bits of the number of occupied metacells in the words before word `w`.
    prefix_low: [u8; 8],
    /// Bits 0–8: the smallest occupied metacell position on each axis (3 bits each); bits 9–17:
    /// the largest; bit 18 ([`LISTED`]): the block is listed; bits 24–31: bit `24 + w` is the 9th
    /// bit (256) of word `w`'s prefix count (at most 448 < 512).
    packed: u32,
    /// The block's first metacell slot; in a listed block, where its list starts in
    /// [`MetacellOccupancy::list`].
    pointer: u32,
}
const _: () = assert!(size_of::<BlockOccupancy>() == 80);

/// No occupancy record: the block is empty.
const NONE: u32 = u32::MAX;

/// Bit of [`BlockOccupancy`]'s packed word set when the block is listed (several runs).
pub const LISTED: u32 = 1 << 18;

/// Per-block occupancy masks, indexed like the block array (`x + nx·(y + ny·z)`).
#[derive(Debug, Clone)]
pub struct MetacellOccupancy {
    record_of_block: Vec<u32>,
    records: Vec<BlockOccupancy>,
    /// The lists of the listed blocks, one after another: a block's list at `pointer` holds
    /// `occupied + 1` offsets from `pointer` (rank `k`'s slots start at offset `list[k]`, the last
    /// one ends them), then the slots.
    lists: Vec<u32>,
}

impl BlockOccupancy {
    /// The record of a block whose first slot is `pointer` and whose occupied metacells have the
    /// Morton codes `codes` (each < 512).
    pub fn from_codes(pointer: u32, codes: impl IntoIterator<Item = u32>) -> Self {
        let mut record = BlockOccupancy {
            pointer,
            ..Default::default()
        };
        let (mut lo, mut hi) = ([7u32; 3], [0u32; 3]);
        for code in codes {
            record.words[code as usize >> 6 & 7] |= 1 << (code & 63);
            let local = morton::decode(code & 511);
            for a in 0..3 {
                lo[a] = lo[a].min(local[a]);
                hi[a] = hi[a].max(local[a]);
            }
        }
        for a in 0..3 {
            record.packed |= lo[a] << (3 * a) | hi[a] << (9 + 3 * a);
        }
        let mut before = 0u32;
        for w in 0..8 {
            record.prefix_low[w] = before as u8;
            record.packed |= (before >> 8 & 1) << (24 + w);
            before += record.words[w].count_ones();
        }
        record
    }

    /// Bit `code` (word `code / 64`, bit `code % 64`) is set when the metacell with Morton code
    /// `code` within the block holds active cells.
    pub fn mask(&self) -> [u64; 8] {
        self.words
    }

    /// The smallest and largest occupied metacell position (inclusive) on each axis, within the
    /// block; `lo > hi` when none is occupied.
    #[inline(always)]
    pub fn bounds(&self) -> ([i64; 3], [i64; 3]) {
        let field = |shift: usize| (self.packed >> shift & 7) as i64;
        (
            [field(0), field(3), field(6)],
            [field(9), field(12), field(15)],
        )
    }

    /// The packed word: the box (see [`Self::bounds`]) and the [`LISTED`] bit, as the GPU reads it.
    pub fn packed_bounds(&self) -> u32 {
        self.packed & ((1 << 24) - 1)
    }

    /// Whether the block holds several runs, its slots listed per position.
    pub fn is_listed(&self) -> bool {
        self.packed & LISTED != 0
    }

    /// The number of occupied positions.
    pub fn occupied(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The rank of Morton code `code` (< 512) among the block's occupied positions, or `None` when
    /// it is unoccupied.
    #[inline(always)]
    pub fn rank(&self, code: u32) -> Option<usize> {
        let w = (code >> 6) as usize & 7;
        let word = self.words[w];
        let bit = code & 63;
        if word >> bit & 1 == 0 {
            return None;
        }
        let before = self.prefix_low[w] as u32 | (self.packed >> (24 + w) & 1) << 8;
        Some((before + (word & ((1u64 << bit) - 1)).count_ones()) as usize)
    }

    /// The slot index of the metacell with Morton code `code` (< 512) in a block of one run, or
    /// `None` when it is unoccupied or the block is listed (see [`MetacellOccupancy::slots`]).
    #[inline(always)]
    pub fn slot(&self, code: u32) -> Option<usize> {
        if self.is_listed() {
            return None;
        }
        let rank = self.rank(code)?;
        Some(self.pointer as usize + rank + rank / CLUSTER_METACELLS)
    }
}

impl MetacellOccupancy {
    /// Builds the masks of `blocks` (laid out on `block_dims`, x fastest). Metacells are trusted
    /// only as far as they follow the layout (runs in Morton order, 15 per cluster, each starting
    /// at a cluster's first slot, inside their block): the first one that does not ends its
    /// block's mask, so a corrupt grid can misrender but never sends the walk to a slot that holds
    /// another metacell.
    pub fn new(blocks: &[Block], metacells: &[Metacell], block_dims: [usize; 3]) -> Self {
        let [nx, ny, _] = block_dims;
        let mut record_of_block = vec![NONE; blocks.len()];
        let mut records = Vec::new();
        let mut lists = Vec::new();
        for (index, block) in blocks.iter().enumerate() {
            if block.metacell_count == 0 {
                continue;
            }
            let origin = [index % nx, index / nx % ny, index / (nx * ny)]
                .map(|b| (b * BLOCK_METACELLS) as i64);
            let slots = metacells.get(block.slots()).unwrap_or(&[]);
            // (code, slot within the block) of every metacell kept, run after run.
            let mut found: Vec<(u32, u32)> = Vec::new();
            let mut runs = 0;
            let (mut run_start, mut rank) = (0usize, 0usize);
            for (s, m) in slots.iter().enumerate() {
                if s % CLUSTER_SLOTS == CLUSTER_METACELLS || m.is_empty() {
                    continue;
                }
                let local = [0, 1, 2].map(|a| m.position[a] as i64 - origin[a]);
                if local
                    .iter()
                    .any(|&v| !(0..BLOCK_METACELLS as i64).contains(&v))
                {
                    break;
                }
                let code = morton::metacell_code(local[0] as u32, local[1] as u32, local[2] as u32);
                // A run goes on while its metacells follow the rank rule in increasing codes (a
                // following label's run that happens to do so is one run to the walk: each of its
                // positions still has one slot in it); any other metacell starts a run, which
                // must begin a cluster.
                let goes_on = runs > 0
                    && s == run_start + rank + rank / CLUSTER_METACELLS
                    && found.last().is_some_and(|&(c, _)| c < code);
                if !goes_on {
                    if s % CLUSTER_SLOTS != 0 {
                        break;
                    }
                    runs += 1;
                    run_start = s;
                    rank = 0;
                }
                found.push((code, s as u32));
                rank += 1;
            }
            let pointer = block.metacell_pointer;
            let mut record = BlockOccupancy::from_codes(pointer, found.iter().map(|&(c, _)| c));
            if runs > 1 {
                found.sort_unstable();
                let start = lists.len();
                let occupied = record.occupied();
                lists.resize(start + occupied + 1, 0);
                let mut k = 0;
                for (i, &(code, slot)) in found.iter().enumerate() {
                    if i == 0 || found[i - 1].0 != code {
                        lists[start + k] = (lists.len() - start) as u32;
                        k += 1;
                    }
                    lists.push(pointer + slot);
                }
                debug_assert_eq!(k, occupied);
                lists[start + occupied] = (lists.len() - start) as u32;
                record.pointer = start as u32;
                record.packed |= LISTED;
            }
            record_of_block[index] = records.len() as u32;
            records.push(record);
        }
        MetacellOccupancy {
            record_of_block,
            records,
            lists,
        }
    }

    /// The list of a listed block (see [`MetacellOccupancy`]'s `lists`): `occupied + 1` offsets
    /// from its start, then the slots; `None` for a block of one run.
    pub fn list(&self, record: &BlockOccupancy) -> Option<&[u32]> {
        if !record.is_listed() {
            return None;
        }
        let start = record.pointer as usize;
        let end = start + *self.lists.get(start + record.occupied())? as usize;
        self.lists.get(start..end)
    }

    /// The slots of the metacells at Morton code `code` (< 512) of a block, in slot order (one in
    /// a block of one run; one per label there in a label grid); empty when unoccupied.
    pub fn slots(&self, record: &BlockOccupancy, code: u32) -> Vec<usize> {
        let Some(rank) = record.rank(code) else {
            return Vec::new();
        };
        match self.list(record) {
            None => vec![record.pointer as usize + rank + rank / CLUSTER_METACELLS],
            Some(list) => list[list[rank] as usize..list[rank + 1] as usize]
                .iter()
                .map(|&s| s as usize)
                .collect(),
        }
    }

    /// The occupancy of block `index`, `None` for an empty block.
    #[inline(always)]
    pub fn of_block(&self, index: usize) -> Option<&BlockOccupancy> {
        let record = *self.record_of_block.get(index)?;
        self.records.get(record as usize)
    }

    /// Bytes the masks, the lists and the per-block record index occupy.
    pub fn bytes(&self) -> usize {
        self.record_of_block.len() * 4
            + self.records.len() * size_of::<BlockOccupancy>()
            + self.lists.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{generate, Field};
    use crate::{extract, ExtractOptions, Iso};

    /// Every metacell the extraction wrote is found by its Morton code at its own slot, and no
    /// other code maps to a slot: checks the `k + k / 15` rule against `emit.rs`.
    #[test]
    fn every_metacell_is_found_at_its_slot_by_its_code() {
        let volume = generate(Field::Gyroid, 40, 0);
        let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
        let dims = grid.info().block_dims().map(|b| b as usize);
        let occupancy = MetacellOccupancy::new(grid.blocks(), grid.metacells(), dims);
        let mut found = 0;
        let mut full_clusters = 0;
        for (index, block) in grid.blocks().iter().enumerate() {
            let record = occupancy.of_block(index);
            assert_eq!(record.is_some(), block.metacell_count > 0);
            let Some(record) = record else { continue };
            assert!(
                !record.is_listed(),
                "one run per block in a grid without labels"
            );
            let origin = [
                index % dims[0],
                index / dims[0] % dims[1],
                index / (dims[0] * dims[1]),
            ]
            .map(|b| (b * BLOCK_METACELLS) as u32);
            let mut occupied = 0;
            for code in 0..512 {
                let local = morton::decode(code);
                let Some(slot) = record.slot(code) else {
                    continue;
                };
                assert!(block.slots().contains(&slot), "block {index} code {code}");
                assert_ne!(slot % CLUSTER_SLOTS, CLUSTER_METACELLS, "a bound slot");
                let m = grid.metacells()[slot];
                assert_eq!(
                    m.position.map(|p| p as u32),
                    [0, 1, 2].map(|a| origin[a] + local[a])
                );
                assert!(!m.is_empty());
                occupied += 1;
            }
            let in_slots = grid.metacells()[block.slots()]
                .iter()
                .enumerate()
                .filter(|(s, m)| s % CLUSTER_SLOTS != CLUSTER_METACELLS && !m.is_empty())
                .count();
            assert_eq!(occupied, in_slots, "block {index}");
            full_clusters += in_slots / CLUSTER_METACELLS;
            found += occupied;
        }
        // Enough metacells, and blocks with several clusters, that `k / 15` mattered.
        assert!(
            found > 1000 && full_clusters > 20,
            "{found} {full_clusters}"
        );
    }

    /// In a label grid every metacell is found at its position, among the slots listed there, and
    /// the lists hold nothing else: checked against a scan of every block's slots.
    #[test]
    fn every_label_metacell_is_listed_at_its_position() {
        for volume in [
            crate::generate::labelled_ball(40),
            crate::generate::labelled_cubes(32),
        ] {
            labels_are_listed(&volume);
        }
    }

    fn labels_are_listed(volume: &crate::Volume) {
        let grid = crate::extract_labels(
            &volume.view(),
            &crate::LabelOptions::new(crate::LabelSelection::All),
        )
        .unwrap();
        let dims = grid.info().block_dims().map(|b| b as usize);
        let occupancy = MetacellOccupancy::new(grid.blocks(), grid.metacells(), dims);
        let (mut listed, mut repeated) = (0, 0);
        for (index, block) in grid.blocks().iter().enumerate() {
            let Some(record) = occupancy.of_block(index) else {
                assert_eq!(block.metacell_count, 0);
                continue;
            };
            listed += record.is_listed() as usize;
            let origin = [
                index % dims[0],
                index / dims[0] % dims[1],
                index / (dims[0] * dims[1]),
            ]
            .map(|b| (b * BLOCK_METACELLS) as u32);
            let mut expected = vec![Vec::new(); 512];
            for s in block.slots() {
                let m = grid.metacells()[s];
                if (s - block.slots().start) % CLUSTER_SLOTS == CLUSTER_METACELLS || m.is_empty() {
                    continue;
                }
                let l = [0, 1, 2].map(|a| m.position[a] as u32 - origin[a]);
                expected[morton::metacell_code(l[0], l[1], l[2]) as usize].push(s);
            }
            for (code, slots) in expected.iter().enumerate() {
                assert_eq!(
                    &occupancy.slots(record, code as u32),
                    slots,
                    "block {index}"
                );
                repeated += (slots.len() > 1) as usize;
            }
        }
        // The ball's three labels touch: positions holding two labels' metacells exist.
        assert!(listed > 0 && repeated > 10, "{listed} {repeated}");
    }
}

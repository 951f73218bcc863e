//! A bounding volume hierarchy over the grid's metacells, re-clustered: the paper's future work
//! (§3.6 and the conclusion: "re-arranging the clusters of min-max blocks into bounding volume
//! hierarchies"), as an alternative to the block walk ([`crate::Tracer`]). This file builds
//! it; the traversal is in [`super::bvh_traverse`].
//!
//! Leaves are *leaf clusters*: up to 15 metacells that the build groups by space, stored as the
//! grid stores a cluster (16 slots of [`Metacell`], the bound in slot 15), so the tracer's own
//! cluster search runs inside each leaf (`cluster_search.rs`) and hits are those of the
//! block walk. A grid cluster holds 15 metacells consecutive in Morton order inside one block,
//! which can lie far apart; grouped by the build, the same metacells have boxes of about half the
//! surface area (the sum over leaves, relative to the grid's box: 11.7 → 6.6 on the MNI head,
//! 5.7 → 3.3 on the dragon), so a ray enters about half as many leaves that hold nothing it meets.
//! The copy costs 256 bytes per leaf (its slots, and the grid cluster of each for a hit's
//! report), about one and a half times the grid's own metacell slots.
//!
//! The hierarchy is built once, top down, with a binned surface-area heuristic on the metacells'
//! centroids, and stored as 8-wide nodes whose child boxes are lanes per face, so that one node
//! is one AVX2 slab test (Wald et al. 2008, "Getting rid of packets"; Dammertz et al. 2008,
//! "Shallow bounding volume hierarchies").
//!
//! Units: node boxes are in cell units (world / spacing), grown outward by a margin
//! ([`node_margin`]) that covers every rounding of the f32 test, so no metacell the ray really
//! passes through is culled. The ray is re-based to where it enters the grid's box, so that the
//! f32 `t` values stay small and their rounding stays within that margin.

use super::cell_ray::{max, min, xyz};
use bytemuck::Zeroable;
use isogrid::grid::CellGrid;
use isogrid::layout::{Block, ClusterBound, Metacell, BOUND_SLOT, CLUSTER_SLOTS};

/// Children per node.
pub(super) const WIDTH: usize = 8;
/// A child that is a leaf: the low 31 bits are a leaf cluster's index.
pub(super) const LEAF: u32 = 1 << 31;
/// An unused child lane (its box is empty).
pub(super) const NO_CHILD: u32 = u32::MAX;
/// Metacells per leaf cluster at most: the 15 metacell slots of a cluster.
pub(super) const LEAF_METACELLS: usize = BOUND_SLOT;
/// Traversal stack entries: at most `WIDTH − 1` per level plus one, and the build keeps the depth
/// at most [`MAX_DEPTH`].
pub(super) const STACK: usize = (WIDTH - 1) * MAX_DEPTH + 1;
/// Levels at most; past [`SAH_DEPTH`] the build splits at the median, which halves the metacells.
const MAX_DEPTH: usize = 64;
const SAH_DEPTH: usize = 40;
/// Bins of the surface-area heuristic per split.
const BINS: usize = 16;

/// One 8-wide node: 128 bytes, two cache lines. Boxes are whole metacells, as cluster bounds are,
/// so 16-bit positions hold them exactly and the node stays half the size of f32 faces.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    /// Child boxes in metacell units, inclusive as in [`isogrid::layout::ClusterBound`]: `mc[a]`
    /// the lowest metacell on axis `a` of the eight children, `mc[3 + a]` the highest. Empty lanes
    /// have lowest > highest.
    pub(super) mc: [[u16; WIDTH]; 6],
    /// Per lane: an inner node's index, `LEAF | leaf cluster`, or [`NO_CHILD`].
    pub(super) child: [u32; WIDTH],
}
const _: () = assert!(std::mem::size_of::<Node>() == 128);

const EMPTY_NODE: Node = Node {
    mc: [
        [u16::MAX; WIDTH],
        [u16::MAX; WIDTH],
        [u16::MAX; WIDTH],
        [0; WIDTH],
        [0; WIDTH],
        [0; WIDTH],
    ],
    child: [NO_CHILD; WIDTH],
};

/// One leaf cluster's slots. Aligned to a cache line, so that they fill exactly three: glibc
/// places a large allocation 16 bytes past a page, which spread every 192-byte leaf over four
/// lines, the last of which the traversal's prefetch of a leaf left out.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy, bytemuck::Pod, Zeroable)]
pub(super) struct LeafSlots(pub(super) [Metacell; CLUSTER_SLOTS]);
const _: () = assert!(std::mem::size_of::<LeafSlots>() == 3 * 64);

/// Margin (cells) by which the node test grows every box: more than the f32 rounding of the
/// re-based ray origin and of the slab test's products and sums, all of which are relative
/// errors (2⁻²⁴) of coordinates no larger than the grid.
pub fn node_margin(cell_dims: [u32; 3]) -> f64 {
    let largest = cell_dims.iter().copied().max().unwrap_or(0) as f64;
    (1e-3f64).max(largest * 4e-6)
}

/// A metacell as the build sees it: its box (cell units) and its slot in the grid.
#[derive(Debug, Clone, Copy)]
struct Item {
    lo: [f32; 3],
    hi: [f32; 3],
    slot: u32,
}

impl Item {
    fn centroid(&self, a: usize) -> f32 {
        0.5 * (self.lo[a] + self.hi[a])
    }
}

/// An axis-aligned box being accumulated (empty: lo > hi).
#[derive(Debug, Clone, Copy)]
struct Aabb {
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f32::MAX; 3],
        hi: [-f32::MAX; 3],
    };
    /// Boxes are finite, so `min`/`max` without `f32::min`'s NaN handling, which kept LLVM from
    /// using `minps`/`maxps` and was two fifths of the build's instructions (cachegrind).
    fn grow(&mut self, lo: [f32; 3], hi: [f32; 3]) {
        for a in 0..3 {
            self.lo[a] = min(self.lo[a], lo[a]);
            self.hi[a] = max(self.hi[a], hi[a]);
        }
    }
    fn of(items: &[Item]) -> Aabb {
        let mut b = Aabb::EMPTY;
        for item in items {
            b.grow(item.lo, item.hi);
        }
        b
    }
    /// Half the surface area (enough for comparing costs); 0 when empty.
    fn half_area(&self) -> f64 {
        let e = xyz(|a| (self.hi[a] as f64 - self.lo[a] as f64).max(0.0));
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }
}

/// See the module docs. Built by [`ClusterBvh::new`].
#[derive(Debug, Clone)]
pub struct ClusterBvh {
    /// Node 0 is the root (when there is any metacell).
    pub(super) nodes: Vec<Node>,
    /// The leaf clusters, [`CLUSTER_SLOTS`] slots each in the grid's own cluster format: copies
    /// of up to [`LEAF_METACELLS`] of the grid's metacells, then empty (all-zero) slots, and their
    /// bound in slot [`BOUND_SLOT`].
    pub(super) leaves: Vec<LeafSlots>,
    /// Per slot of `leaves`, the grid cluster its metacell came from, for a hit's
    /// [`crate::Hit::cluster`] (read once per hit ray; a binary search over the clusters'
    /// first cells instead cost about 40–75 ns per hit ray).
    grid_clusters: Vec<u32>,
    metacells: usize,
    depth: usize,
}

impl ClusterBvh {
    /// The hierarchy over every metacell of `grid`.
    pub fn new(grid: &CellGrid) -> Self {
        Self::build(grid.blocks(), grid.metacells())
    }

    /// The hierarchy over the occupied metacells of the clusters that `blocks` own in
    /// `metacells` (slots outside every block, bound slots and empty slots are left out: the
    /// block walk finds nothing in them either).
    fn build(blocks: &[Block], metacells: &[Metacell]) -> Self {
        let mut items = Vec::new();
        for block in blocks {
            let Some(slots) = metacells.get(block.slots()) else {
                continue;
            };
            for (k, m) in slots.iter().enumerate() {
                let slot = block.metacell_pointer as usize + k;
                if slot % CLUSTER_SLOTS == BOUND_SLOT || m.cell_mask & 0xff == 0 {
                    continue;
                }
                let Ok(slot) = u32::try_from(slot) else {
                    continue;
                };
                let lo = m.position.map(|p| 2.0 * p as f32);
                items.push(Item {
                    lo,
                    hi: lo.map(|v| v + 2.0),
                    slot,
                });
            }
        }
        let mut bvh = ClusterBvh {
            nodes: Vec::with_capacity(items.len() / 16 + 1),
            leaves: Vec::with_capacity(items.len() / 10 + 1),
            grid_clusters: Vec::with_capacity(items.len() * 3 / 2),
            metacells: items.len(),
            depth: 0,
        };
        if !items.is_empty() {
            let bounds = Aabb::of(&items);
            bvh.build_node(&mut items, bounds, 1, metacells);
        }
        bvh
    }

    /// Builds the node over `items` (at least one; `bounds` is their box) at `depth` (root: 1);
    /// returns its index.
    fn build_node(
        &mut self,
        items: &mut [Item],
        bounds: Aabb,
        depth: usize,
        metacells: &[Metacell],
    ) -> u32 {
        self.depth = self.depth.max(depth);
        let index = self.nodes.len();
        self.nodes.push(EMPTY_NODE);
        // Split into at most `WIDTH` groups, as collapsing a binary tree would: the group of
        // largest surface area (the likeliest to be entered) is split again; a group that fits
        // one leaf cluster stays whole. Each group's box is computed once, when the group is
        // made (splits permute items only inside the group they split), and handed down.
        let mut groups: Vec<(std::ops::Range<usize>, Aabb)> = Vec::with_capacity(WIDTH);
        groups.push((0..items.len(), bounds));
        while groups.len() < WIDTH {
            let Some((g, _)) = groups
                .iter()
                .enumerate()
                .filter(|(_, (r, _))| r.len() > LEAF_METACELLS)
                .map(|(g, (_, b))| (g, b.half_area()))
                .max_by(|a, b| a.1.total_cmp(&b.1))
            else {
                break;
            };
            let (range, _) = groups.swap_remove(g);
            let mid = range.start + split(&mut items[range.clone()], depth >= SAH_DEPTH);
            for half in [range.start..mid, mid..range.end] {
                let b = Aabb::of(&items[half.clone()]);
                groups.push((half, b));
            }
        }
        groups.sort_by_key(|(r, _)| r.start);
        let mut node = EMPTY_NODE;
        for (lane, (range, b)) in groups.into_iter().enumerate() {
            // Back to metacells: the box is [2·lo, 2·hi + 2] in cells, exact in f32.
            let lo = b.lo.map(|v| (v / 2.0) as u16);
            let hi = b.hi.map(|v| (v / 2.0 - 1.0) as u16);
            for a in 0..3 {
                node.mc[a][lane] = lo[a];
                node.mc[3 + a][lane] = hi[a];
            }
            node.child[lane] = if range.len() <= LEAF_METACELLS {
                self.push_leaf(&items[range], metacells, ClusterBound { lo, hi })
            } else {
                self.build_node(&mut items[range], b, depth + 1, metacells)
            };
        }
        self.nodes[index] = node;
        index as u32
    }

    /// Appends a leaf cluster of `items` (at most [`LEAF_METACELLS`]) with `bound`; its child id.
    fn push_leaf(&mut self, items: &[Item], metacells: &[Metacell], bound: ClusterBound) -> u32 {
        let leaf = self.leaves.len();
        let mut slots = LeafSlots::zeroed();
        for (slot, item) in slots.0.iter_mut().zip(items) {
            *slot = metacells[item.slot as usize];
        }
        slots.0[BOUND_SLOT] = bound.into_slot();
        self.leaves.push(slots);
        self.grid_clusters
            .extend(items.iter().map(|item| item.slot / CLUSTER_SLOTS as u32));
        self.grid_clusters
            .resize(self.leaves.len() * CLUSTER_SLOTS, u32::MAX);
        LEAF | leaf as u32
    }

    /// The grid cluster of the metacell in slot `slot` of leaf cluster `leaf`.
    #[inline]
    pub(super) fn grid_cluster(&self, leaf: u32, slot: u32) -> u32 {
        self.grid_clusters
            .get(leaf as usize * CLUSTER_SLOTS + slot as usize)
            .copied()
            .unwrap_or(u32::MAX)
    }

    /// Occupied metacells in the hierarchy's leaves.
    pub fn metacells(&self) -> usize {
        self.metacells
    }

    /// Leaf clusters.
    pub fn leaves(&self) -> usize {
        self.leaves.len()
    }

    /// The [`CLUSTER_SLOTS`] slots of leaf cluster `leaf` (empty when out of range).
    #[inline(always)]
    pub fn leaf(&self, leaf: usize) -> &[Metacell] {
        self.leaves.get(leaf).map_or(&[], |slots| &slots.0[..])
    }

    /// Every leaf cluster's slots, one leaf after another.
    pub(super) fn leaf_slots(&self) -> &[Metacell] {
        bytemuck::cast_slice(&self.leaves)
    }

    /// Nodes in the hierarchy.
    pub fn nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Levels of nodes (0 when empty).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Bytes the hierarchy occupies: nodes, leaf clusters and the grid cluster per leaf slot.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.nodes[..])
            + std::mem::size_of_val(&self.leaves[..])
            + std::mem::size_of_val(&self.grid_clusters[..])
    }

    /// Checks that every occupied metacell of `grid` is copied into exactly one leaf slot (with
    /// the grid cluster it came from), that each leaf's slot 15 bounds its metacells, that every
    /// node box holds the boxes below it, and that every leaf sits under one node. A one-line
    /// description of the first fault otherwise.
    pub fn validate(&self, grid: &CellGrid) -> Result<(), String> {
        let mut expected = std::collections::HashMap::new();
        for block in grid.blocks() {
            for slot in block.slots() {
                let m = grid.metacells()[slot];
                if slot % CLUSTER_SLOTS != BOUND_SLOT && m.cell_mask & 0xff != 0 {
                    // Keyed by records too: a label grid holds a position once per label there.
                    expected.insert((m.position, m.cell_pointer), (m, false));
                }
            }
        }
        for leaf in 0..self.leaves() {
            let slots = self.leaf(leaf);
            let (mut lo, mut hi) = ([u16::MAX; 3], [0u16; 3]);
            for (k, m) in slots[..BOUND_SLOT].iter().enumerate() {
                if m.is_empty() {
                    continue;
                }
                let Some((want, seen)) = expected.get_mut(&(m.position, m.cell_pointer)) else {
                    return Err(format!(
                        "leaf {leaf} slot {k}: no such metacell in the grid"
                    ));
                };
                if *want != *m || std::mem::replace(seen, true) {
                    return Err(format!("leaf {leaf} slot {k}: differs or repeats"));
                }
                let cluster = self.grid_cluster(leaf as u32, k as u32) as usize;
                let home = grid
                    .metacells()
                    .get(cluster * CLUSTER_SLOTS..cluster * CLUSTER_SLOTS + BOUND_SLOT);
                if !home.is_some_and(|slots| slots.contains(m)) {
                    return Err(format!(
                        "leaf {leaf} slot {k}: not from grid cluster {cluster}"
                    ));
                }
                for a in 0..3 {
                    lo[a] = lo[a].min(m.position[a]);
                    hi[a] = hi[a].max(m.position[a]);
                }
            }
            if slots[BOUND_SLOT].as_bound() != (ClusterBound { lo, hi }) {
                return Err(format!("leaf {leaf}: slot 15 does not bound its metacells"));
            }
        }
        if let Some((p, _)) = expected.iter().find(|(_, (_, seen))| !seen) {
            return Err(format!("metacell at {p:?} in no leaf"));
        }
        if self.nodes.is_empty() {
            return match self.leaves() {
                0 => Ok(()),
                n => Err(format!("{n} leaves without nodes")),
            };
        }
        let contains = |node: &Node, lane: usize, lo: [u16; 3], hi: [u16; 3]| {
            (0..3).all(|a| node.mc[a][lane] <= lo[a] && node.mc[3 + a][lane] >= hi[a])
        };
        let mut stack = vec![0u32];
        let mut reached = vec![false; self.leaves()];
        while let Some(n) = stack.pop() {
            let node = self
                .nodes
                .get(n as usize)
                .ok_or(format!("node {n} out of range"))?;
            for lane in 0..WIDTH {
                let id = node.child[lane];
                if id == NO_CHILD {
                    continue;
                }
                if id & LEAF != 0 {
                    let leaf = (id & !LEAF) as usize;
                    let bound = self
                        .leaf(leaf)
                        .get(BOUND_SLOT)
                        .ok_or(format!("leaf {leaf} out of range"))?
                        .as_bound();
                    if !contains(node, lane, bound.lo, bound.hi) {
                        return Err(format!("node {n} lane {lane} does not hold leaf {leaf}"));
                    }
                    if std::mem::replace(&mut reached[leaf], true) {
                        return Err(format!("leaf {leaf} under two lanes"));
                    }
                } else {
                    let child = self
                        .nodes
                        .get(id as usize)
                        .ok_or(format!("node {id} out of range"))?;
                    for k in 0..WIDTH {
                        if child.child[k] == NO_CHILD {
                            continue;
                        }
                        let lo = xyz(|a| child.mc[a][k]);
                        let hi = xyz(|a| child.mc[3 + a][k]);
                        if !contains(node, lane, lo, hi) {
                            return Err(format!("node {n} lane {lane} does not hold node {id}"));
                        }
                    }
                    stack.push(id);
                }
            }
        }
        match reached.iter().position(|&r| !r) {
            Some(leaf) => Err(format!("leaf {leaf} under no node")),
            None => Ok(()),
        }
    }

    /// Test support: a copy with leaf cluster `leaf` removed from its node, or (`shrink`) with its
    /// box one metacell (two cells, the finest step of a node box) smaller on the upper x face.
    /// `None` when no node holds the leaf.
    #[doc(hidden)]
    pub fn mutated(&self, leaf: u32, shrink: bool) -> Option<Self> {
        let mut copy = self.clone();
        for node in &mut copy.nodes {
            for lane in 0..WIDTH {
                if node.child[lane] == LEAF | leaf {
                    if shrink {
                        node.mc[3][lane] = node.mc[3][lane].wrapping_sub(1);
                    } else {
                        node.child[lane] = NO_CHILD;
                        for a in 0..3 {
                            node.mc[a][lane] = EMPTY_NODE.mc[a][lane];
                            node.mc[3 + a][lane] = EMPTY_NODE.mc[3 + a][lane];
                        }
                    }
                    return Some(copy);
                }
            }
        }
        None
    }
}

/// Reorders `items` (at least two) into two non-empty groups and returns the first group's
/// length: the cheapest binned surface-area split over the three axes of the centroids
/// (`median`: the median of the longest axis instead, which halves the items). A side's cost is
/// its area times the leaf clusters its metacells fill at least, so that splits leave fewer
/// part-empty leaves. Binning all three axes rather than only the longest one takes the build of
/// the dragon from about 0.065 to 0.11 s on one core (MNI: 0.025 to 0.04 s), for about 5 % fewer instructions on the
/// MNI head's missing rays and about 0.6 % fewer on hitting rays.
fn split(items: &mut [Item], median: bool) -> usize {
    let n = items.len();
    let mut lo = [f32::MAX; 3];
    let mut hi = [-f32::MAX; 3];
    for item in items.iter() {
        for a in 0..3 {
            lo[a] = min(lo[a], item.centroid(a));
            hi[a] = max(hi[a], item.centroid(a));
        }
    }
    let longest = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let median_split = |items: &mut [Item], axis: usize| {
        items.select_nth_unstable_by(n / 2, |x: &Item, y: &Item| {
            x.centroid(axis).total_cmp(&y.centroid(axis))
        });
        n / 2
    };
    if median || !(hi[longest] - lo[longest] > 0.0) {
        return median_split(items, longest);
    }
    let bins = |axis: usize| Bins {
        axis,
        lo: lo[axis],
        extent: hi[axis] - lo[axis],
    };
    let best = (0..3)
        .filter(|&a| hi[a] - lo[a] > 0.0)
        .filter_map(|a| {
            bins(a)
                .cheapest_split(items)
                .map(|(cost, last)| (cost, a, last))
        })
        .min_by(|x, y| x.0.total_cmp(&y.0));
    let Some((_, axis, last)) = best else {
        return median_split(items, longest);
    };
    let bins = bins(axis);
    let mut first = 0;
    for i in 0..n {
        if bins.of(&items[i]) <= last {
            items.swap(i, first);
            first += 1;
        }
    }
    first
}

/// [`BINS`] equal bins of the centroids along one axis, from `lo` over `extent` (positive).
struct Bins {
    axis: usize,
    lo: f32,
    extent: f32,
}

impl Bins {
    fn of(&self, item: &Item) -> usize {
        let b = ((item.centroid(self.axis) - self.lo) / self.extent * BINS as f32) as usize;
        b.min(BINS - 1)
    }

    /// The cheapest split between two bins, as (cost, last bin of the first side); `None` when
    /// every split leaves a side empty. Cost: area·leaf clusters on each side (the traversal's
    /// cost per node is the same for every split, so it is left out).
    fn cheapest_split(&self, items: &[Item]) -> Option<(f64, usize)> {
        let mut boxes = [Aabb::EMPTY; BINS];
        let mut counts = [0usize; BINS];
        for item in items {
            let b = self.of(item);
            boxes[b].grow(item.lo, item.hi);
            counts[b] += 1;
        }
        let mut right_cost = [0f64; BINS];
        let mut acc = Aabb::EMPTY;
        let mut count = 0;
        for k in (1..BINS).rev() {
            acc.grow(boxes[k].lo, boxes[k].hi);
            count += counts[k];
            right_cost[k] = acc.half_area() * count.div_ceil(LEAF_METACELLS) as f64;
        }
        let mut best: Option<(f64, usize)> = None;
        let mut acc = Aabb::EMPTY;
        let mut count = 0;
        for k in 0..BINS - 1 {
            acc.grow(boxes[k].lo, boxes[k].hi);
            count += counts[k];
            if count == 0 || count == items.len() {
                continue;
            }
            let cost = acc.half_area() * count.div_ceil(LEAF_METACELLS) as f64 + right_cost[k + 1];
            if best.is_none_or(|(b, _)| cost < b) {
                best = Some((cost, k));
            }
        }
        best.filter(|(cost, _)| cost.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isogrid::generate::{generate, Field};
    use isogrid::{extract, ExtractOptions, Iso};

    fn gyroid() -> CellGrid {
        let volume = generate(Field::Gyroid, 36, 0);
        extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap()
    }

    /// Leaves hold up to 15 metacells each, mostly near that many, from several grid clusters.
    #[test]
    fn leaves_are_full_and_regroup_the_grid_clusters() {
        let grid = gyroid();
        let bvh = ClusterBvh::new(&grid);
        bvh.validate(&grid).unwrap();
        assert_eq!(bvh.metacells(), grid.occupied_metacells());
        assert!(bvh.leaves() * LEAF_METACELLS >= bvh.metacells());
        // The surface-area split keeps most leaves at least two thirds full.
        assert!(
            bvh.leaves() * 10 <= bvh.metacells(),
            "{} leaves",
            bvh.leaves()
        );
        let mixed = (0..bvh.leaves())
            .filter(|&leaf| {
                let first = bvh.grid_cluster(leaf as u32, 0);
                (0..BOUND_SLOT).any(|k| {
                    let c = bvh.grid_cluster(leaf as u32, k as u32);
                    !bvh.leaf(leaf)[k].is_empty() && c != first
                })
            })
            .count();
        assert!(
            mixed * 2 > bvh.leaves(),
            "{mixed} of {} leaves",
            bvh.leaves()
        );
    }

    #[test]
    fn validate_notices_a_wrong_grid_cluster_or_leaf_bound() {
        let grid = gyroid();
        let bvh = ClusterBvh::new(&grid);
        let mut wrong_cluster = bvh.clone();
        wrong_cluster.grid_clusters[3] ^= 1;
        let err = wrong_cluster.validate(&grid).unwrap_err();
        assert!(err.contains("not from grid cluster"), "{err}");
        let mut wrong_bound = bvh.clone();
        wrong_bound.leaves[0].0[BOUND_SLOT].position[1] += 1;
        let err = wrong_bound.validate(&grid).unwrap_err();
        assert!(err.contains("does not bound"), "{err}");
        let mut lost = bvh.clone();
        lost.leaves[0].0[2] = Metacell::zeroed();
        let err = lost.validate(&grid).unwrap_err();
        assert!(
            err.contains("in no leaf") || err.contains("does not bound"),
            "{err}"
        );
    }
}

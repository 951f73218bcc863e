//! A bounding volume hierarchy over the grid's clusters, the paper's future work (§3.6 and the
//! conclusion: "re-arranging the clusters of min-max blocks into bounding volume hierarchies"),
//! as an alternative to the block walk of [`super::traverse`]. This file builds it; the traversal is
//! in [`super::bvh_traverse`].
//!
//! Leaves are single clusters, bounded by their slot 15 ([`crate::layout::ClusterBound`]); the hierarchy is built
//! once, top down, with a binned surface-area heuristic on the clusters' centroids, and stored as
//! 8-wide nodes whose child boxes are lanes per face, so that one node is one AVX2 slab test
//! (Wald et al. 2008, "Getting rid of packets"; Dammertz et al. 2008, "Shallow bounding volume
//! hierarchies"). Inside a leaf the tracer's own cluster search runs
//! (`Tracer::closest_in_cluster`), so hits are those of the block walk.
//!
//! Units: node boxes are in cell units (world / spacing), grown outward by a margin
//! ([`node_margin`]) that covers every rounding of the f32 test, so no cluster the ray really
//! passes through is culled. The ray is re-based to where it enters the grid's box, so that the
//! f32 `t` values stay small and their rounding stays within that margin.

use super::cell_ray::xyz;
use crate::grid::CellGrid;
use crate::layout::{Block, Metacell, BOUND_SLOT, CLUSTER_SLOTS};

/// Children per node.
pub(super) const WIDTH: usize = 8;
/// A child that is a leaf: the low 31 bits are a global cluster index.
pub(super) const LEAF: u32 = 1 << 31;
/// An unused child lane (its box is empty).
pub(super) const NO_CHILD: u32 = u32::MAX;
/// Traversal stack entries: at most `WIDTH − 1` per level plus one, and the build keeps the depth
/// at most [`MAX_DEPTH`].
pub(super) const STACK: usize = (WIDTH - 1) * MAX_DEPTH + 1;
/// Levels at most; past [`SAH_DEPTH`] the build splits at the median, which halves the clusters.
const MAX_DEPTH: usize = 64;
const SAH_DEPTH: usize = 40;
/// Bins of the surface-area heuristic per split.
const BINS: usize = 16;

/// One 8-wide node: 128 bytes, two cache lines. Boxes are whole metacells, as cluster bounds are,
/// so 16-bit positions hold them exactly and the node stays half the size of f32 faces.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    /// Child boxes in metacell units, inclusive as in [`crate::layout::ClusterBound`]: `mc[a]`
    /// the lowest metacell on axis `a` of the four children, `mc[3 + a]` the highest. Empty lanes
    /// have lowest > highest.
    pub(super) mc: [[u16; WIDTH]; 6],
    /// Per lane: an inner node's index, `LEAF | cluster`, or [`NO_CHILD`].
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

/// Margin (cells) by which the node test grows every box: more than the f32 rounding of the
/// re-based ray origin and of the slab test's products and sums, all of which are relative
/// errors (2⁻²⁴) of coordinates no larger than the grid.
pub fn node_margin(cell_dims: [u32; 3]) -> f64 {
    let largest = cell_dims.iter().copied().max().unwrap_or(0) as f64;
    (1e-3f64).max(largest * 4e-6)
}

/// A cluster as the build sees it: its box (cell units, whole metacells) and its global index.
#[derive(Debug, Clone, Copy)]
struct Item {
    lo: [f32; 3],
    hi: [f32; 3],
    cluster: u32,
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
    fn grow(&mut self, lo: [f32; 3], hi: [f32; 3]) {
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(lo[a]);
            self.hi[a] = self.hi[a].max(hi[a]);
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

/// See the module docs. Built by [`ClusterBvh::new`]; nodes only, no copy of the clusters.
#[derive(Debug, Clone)]
pub struct ClusterBvh {
    /// Node 0 is the root (when there is any cluster).
    pub(super) nodes: Vec<Node>,
    clusters: usize,
    depth: usize,
}

impl ClusterBvh {
    /// The hierarchy over every cluster of `grid`.
    pub fn new(grid: &CellGrid) -> Self {
        Self::build(grid.blocks(), grid.metacells())
    }

    /// The hierarchy over the clusters that `blocks` own in `metacells`. Clusters whose bound is
    /// empty (lo > hi on some axis) or out of range are left out: the block walk finds nothing
    /// in them either.
    fn build(blocks: &[Block], metacells: &[Metacell]) -> Self {
        let mut items = Vec::new();
        for block in blocks {
            let Some(slots) = metacells.get(block.slots()) else {
                continue;
            };
            let first = block.metacell_pointer as usize / CLUSTER_SLOTS;
            for (c, cluster) in slots.chunks_exact(CLUSTER_SLOTS).enumerate() {
                let bound = cluster[BOUND_SLOT].as_bound();
                if (0..3).any(|a| bound.lo[a] > bound.hi[a]) {
                    continue;
                }
                let Ok(index) = u32::try_from(first + c) else {
                    continue;
                };
                if index & LEAF != 0 {
                    continue;
                }
                let (lo, hi) = bound.cell_box();
                items.push(Item {
                    lo: lo.map(|v| v as f32),
                    hi: hi.map(|v| v as f32),
                    cluster: index,
                });
            }
        }
        let mut bvh = ClusterBvh {
            nodes: Vec::with_capacity(items.len() / 2 + 1),
            clusters: items.len(),
            depth: 0,
        };
        if !items.is_empty() {
            bvh.build_node(&mut items, 1);
        }
        bvh
    }

    /// Builds the node over `items` (at least one) at `depth` (root: 1); returns its index.
    fn build_node(&mut self, items: &mut [Item], depth: usize) -> u32 {
        self.depth = self.depth.max(depth);
        let index = self.nodes.len();
        self.nodes.push(EMPTY_NODE);
        // Split into at most `WIDTH` groups, as collapsing a binary tree would: the group of
        // largest surface area (the likeliest to be entered) is split again, so a node over
        // `WIDTH` or fewer clusters has them all as leaves.
        let mut groups: Vec<std::ops::Range<usize>> = Vec::with_capacity(WIDTH);
        groups.push(0..items.len());
        while groups.len() < WIDTH {
            let Some((g, _)) = groups
                .iter()
                .enumerate()
                .filter(|(_, r)| r.len() > 1)
                .map(|(g, r)| (g, Aabb::of(&items[r.clone()]).half_area()))
                .max_by(|a, b| a.1.total_cmp(&b.1))
            else {
                break;
            };
            let range = groups.swap_remove(g);
            let mid = range.start + split(&mut items[range.clone()], depth >= SAH_DEPTH);
            groups.push(range.start..mid);
            groups.push(mid..range.end);
        }
        groups.sort_by_key(|r| r.start);
        let mut node = EMPTY_NODE;
        for (lane, range) in groups.into_iter().enumerate() {
            let b = Aabb::of(&items[range.clone()]);
            // Back to metacells: the box is [2·lo, 2·hi + 2] in cells, exact in f32.
            for a in 0..3 {
                node.mc[a][lane] = (b.lo[a] / 2.0) as u16;
                node.mc[3 + a][lane] = (b.hi[a] / 2.0 - 1.0) as u16;
            }
            node.child[lane] = if range.len() == 1 {
                LEAF | items[range.start].cluster
            } else {
                self.build_node(&mut items[range], depth + 1)
            };
        }
        self.nodes[index] = node;
        index as u32
    }

    /// Clusters in the hierarchy.
    pub fn clusters(&self) -> usize {
        self.clusters
    }

    /// Nodes in the hierarchy.
    pub fn nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Levels of nodes (0 when empty).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Bytes the hierarchy occupies.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }

    /// Checks that every cluster of `grid` with a non-empty bound sits in exactly one leaf, and
    /// that every box holds the boxes below it and its clusters' bounds. A one-line description
    /// of the first fault otherwise.
    pub fn validate(&self, grid: &CellGrid) -> Result<(), String> {
        let metacells = grid.metacells();
        let mut seen = vec![false; metacells.len() / CLUSTER_SLOTS];
        let mut expected = 0;
        for block in grid.blocks() {
            for c in block.slots().step_by(CLUSTER_SLOTS) {
                let b = metacells[c + BOUND_SLOT].as_bound();
                expected += (0..3).all(|a| b.lo[a] <= b.hi[a]) as usize;
            }
        }
        if self.nodes.is_empty() {
            return if expected == 0 {
                Ok(())
            } else {
                Err(format!("no nodes for {expected} clusters"))
            };
        }
        let contains = |node: &Node, lane: usize, lo: [u16; 3], hi: [u16; 3]| {
            (0..3).all(|a| node.mc[a][lane] <= lo[a] && node.mc[3 + a][lane] >= hi[a])
        };
        let mut stack = vec![0u32];
        let mut found = 0;
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
                    let c = (id & !LEAF) as usize;
                    let slot = c * CLUSTER_SLOTS + BOUND_SLOT;
                    let bound = metacells
                        .get(slot)
                        .ok_or(format!("cluster {c} out of range"))?
                        .as_bound();
                    if !contains(node, lane, bound.lo, bound.hi) {
                        return Err(format!("node {n} lane {lane} does not hold cluster {c}"));
                    }
                    if std::mem::replace(&mut seen[c], true) {
                        return Err(format!("cluster {c} in two leaves"));
                    }
                    found += 1;
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
        if found != expected {
            return Err(format!("{found} of {expected} clusters in leaves"));
        }
        Ok(())
    }

    /// Test support: a copy with cluster `cluster` removed from its leaf, or (`shrink`) with its
    /// leaf box one metacell (two cells, the finest step of a node box) smaller on the upper x
    /// face. `None` when the cluster is in no leaf.
    #[doc(hidden)]
    pub fn mutated(&self, cluster: u32, shrink: bool) -> Option<Self> {
        let mut copy = self.clone();
        for node in &mut copy.nodes {
            for lane in 0..WIDTH {
                if node.child[lane] == LEAF | cluster {
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
/// length: a binned surface-area split on the longest axis of the centroids (`median`: split
/// there at the median instead, which halves the items).
fn split(items: &mut [Item], median: bool) -> usize {
    let n = items.len();
    let mut lo = [f32::MAX; 3];
    let mut hi = [-f32::MAX; 3];
    for item in items.iter() {
        for a in 0..3 {
            lo[a] = lo[a].min(item.centroid(a));
            hi[a] = hi[a].max(item.centroid(a));
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let extent = hi[axis] - lo[axis];
    let by_centroid = |x: &Item, y: &Item| x.centroid(axis).total_cmp(&y.centroid(axis));
    if median || !(extent > 0.0) {
        items.select_nth_unstable_by(n / 2, by_centroid);
        return n / 2;
    }
    let bin_of = |item: &Item| {
        let b = ((item.centroid(axis) - lo[axis]) / extent * BINS as f32) as usize;
        b.min(BINS - 1)
    };
    let mut boxes = [Aabb::EMPTY; BINS];
    let mut counts = [0usize; BINS];
    for item in items.iter() {
        let b = bin_of(item);
        boxes[b].grow(item.lo, item.hi);
        counts[b] += 1;
    }
    // Cost of splitting after bin k: area·count on each side (traversal cost is a constant).
    let mut right_area = [0f64; BINS];
    let mut acc = Aabb::EMPTY;
    let mut count = 0;
    for k in (1..BINS).rev() {
        acc.grow(boxes[k].lo, boxes[k].hi);
        count += counts[k];
        right_area[k] = acc.half_area() * count as f64;
    }
    let mut best = (f64::INFINITY, 0);
    let mut acc = Aabb::EMPTY;
    let mut count = 0;
    for k in 0..BINS - 1 {
        acc.grow(boxes[k].lo, boxes[k].hi);
        count += counts[k];
        if count == 0 || count == n {
            continue;
        }
        let cost = acc.half_area() * count as f64 + right_area[k + 1];
        if cost < best.0 {
            best = (cost, k);
        }
    }
    if !best.0.is_finite() {
        items.select_nth_unstable_by(n / 2, by_centroid);
        return n / 2;
    }
    let mut first = 0;
    for i in 0..n {
        if bin_of(&items[i]) <= best.1 {
            items.swap(i, first);
            first += 1;
        }
    }
    first
}

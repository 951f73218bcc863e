//! The attribute pass (paper §3.4: cells carry "normals and other attributes"): samples a second
//! volume — PET on CT, a second channel, pressure on a vorticity surface — at each active cell's
//! surface point, giving the grid a [`CellAttribute`] to colour it by.
//!
//! **Where a cell is sampled.** The surface point of a cell is the centroid of the points where
//! the isosurface crosses its edges, found by linear interpolation of the cell's *stored* corner
//! codes against the grid's `iso_code`, in the cell's own index coordinates (`[0, 1]³`). Reading
//! only the grid's records makes the pass independent of how the grid was made: a grid extracted
//! in memory, streamed within a memory budget or assembled from tiles gets the same values, byte
//! for byte.
//!
//! **Coordinates.** A surface point in grid index space `p` (sample `(i, j, k)` of the grid at
//! `p = (i, j, k)`) lies in world (patient) space at `origin + Σₐ pₐ·spacingₐ·directionₐ` (the
//! grid's [`crate::GridInfo`]); the attribute volume is sampled at the index of that world point
//! under its own [`Geometry`]. When both geometries are the same, the attribute's samples are the
//! grid's samples and a cell's value is the trilinear interpolation of its own eight attribute
//! corners ([`Alignment::SameGrid`]); otherwise the world point is resampled trilinearly in the
//! attribute volume ([`Alignment::Resampled`]), and a point outside it gets NaN.
//!
//! **NaN.** A NaN attribute sample with weight in the interpolation makes the value NaN, which is
//! stored as the NaN code and drawn in a NaN colour.
//!
//! **Memory.** The attribute volume is read slab by slab through a [`RegionSource`], one block
//! layer's planes at a time (17 planes on the same grid; the planes the layer's world box reaches
//! when resampled), plus 4 bytes per active cell for the values before they are encoded.

use super::stream::{RegionSource, SlabMut};
use crate::attribute::{AttributePrecision, CellAttribute};
use crate::error::{Error, Result};
use crate::grid::{CellGrid, GridInfo};
use crate::layout::{read_corners, BLOCK_CELLS, BOUND_SLOT, CLUSTER_SLOTS};
use crate::volume::{Geometry, Scalar, ScalarType, VolumeView};
use rayon::prelude::*;
use std::ops::Range;

/// How an attribute volume lines up with a grid's samples.
#[derive(Debug, Clone, PartialEq)]
pub enum Alignment {
    /// The same samples: dims, spacing, origin and direction agree.
    SameGrid,
    /// Another sampling of the same world space: `to_attribute` maps a grid index-space point
    /// `p` to the attribute's index space, `q = A·p + b` (rows of `[A | b]`).
    Resampled { to_attribute: [[f64; 4]; 3] },
}

/// World (patient) space of index space: `world = origin + Σₐ pₐ·spacingₐ·directionₐ`, as the
/// rows of `[M | origin]`.
fn index_to_world(g: &Geometry) -> [[f64; 4]; 3] {
    let mut m = [[0.0; 4]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        for a in 0..3 {
            row[a] = g.direction[a][r] * g.spacing[a];
        }
        row[3] = g.origin[r];
    }
    m
}

/// The inverse of an affine map given as rows `[M | t]`, or `None` when `M` is singular.
fn invert_affine(m: &[[f64; 4]; 3]) -> Option<[[f64; 4]; 3]> {
    let a = |r: usize, c: usize| m[r][c];
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    if !(det.is_finite() && det.abs() > 1e-300) {
        return None;
    }
    let cof = |r: usize, c: usize| {
        let (r0, r1) = ([1, 0, 0][r], [2, 2, 1][r]);
        let (c0, c1) = ([1, 0, 0][c], [2, 2, 1][c]);
        let minor = a(r0, c0) * a(r1, c1) - a(r0, c1) * a(r1, c0);
        if (r + c).is_multiple_of(2) {
            minor
        } else {
            -minor
        }
    };
    let mut inv = [[0.0; 4]; 3];
    for r in 0..3 {
        for c in 0..3 {
            inv[r][c] = cof(c, r) / det;
        }
    }
    for r in 0..3 {
        inv[r][3] = -(0..3).map(|c| inv[r][c] * m[c][3]).sum::<f64>();
    }
    Some(inv)
}

fn apply(m: &[[f64; 4]; 3], p: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

/// `a ∘ b` for affine maps as rows `[M | t]`.
fn compose(a: &[[f64; 4]; 3], b: &[[f64; 4]; 3]) -> [[f64; 4]; 3] {
    let mut out = [[0.0; 4]; 3];
    for r in 0..3 {
        for c in 0..4 {
            out[r][c] =
                (0..3).map(|k| a[r][k] * b[k][c]).sum::<f64>() + if c == 3 { a[r][3] } else { 0.0 };
        }
    }
    out
}

/// The geometry of a grid's source volume.
pub fn grid_geometry(info: &GridInfo) -> Geometry {
    Geometry {
        dims: info.dims.map(|d| d as usize),
        spacing: info.spacing,
        origin: info.origin,
        direction: info.direction,
        frame: info.frame,
    }
}

/// How `attribute` lines up with `grid`, once in the grid's world frame (an LPS attribute of a RAS
/// grid has the signs of its x and y turned: [`Geometry::in_frame`]). Fails when the attribute
/// volume does not overlap the grid's box in world space, or when either geometry has no inverse.
pub fn alignment(grid: &Geometry, attribute: &Geometry) -> Result<Alignment> {
    let attribute = &attribute.in_frame(grid.frame);
    if attribute.dims.iter().any(|&n| n < 2) {
        let [x, y, z] = attribute.dims;
        return Err(Error::invalid(format!(
            "the attribute volume of {x}x{y}x{z} samples is not 3-D: an attribute needs two or \
             more samples along every axis (an array of more axes needs --index)"
        )));
    }
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
    let same = grid.dims == attribute.dims
        && (0..3).all(|a| close(grid.spacing[a], attribute.spacing[a]))
        && (0..3).all(|a| close(grid.origin[a], attribute.origin[a]))
        && (0..3).all(|a| (0..3).all(|b| close(grid.direction[a][b], attribute.direction[a][b])));
    if same {
        return Ok(Alignment::SameGrid);
    }
    let world_to_attribute = invert_affine(&index_to_world(attribute))
        .ok_or_else(|| Error::invalid("the attribute volume's direction matrix has no inverse"))?;
    let to_attribute = compose(&world_to_attribute, &index_to_world(grid));
    // The grid's box, mapped into the attribute's index space, must meet the attribute's box.
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for corner in 0..8 {
        let p = [0, 1, 2].map(|a| {
            if corner >> a & 1 == 1 {
                grid.dims[a].saturating_sub(1) as f64
            } else {
                0.0
            }
        });
        let q = apply(&to_attribute, p);
        for a in 0..3 {
            lo[a] = lo[a].min(q[a]);
            hi[a] = hi[a].max(q[a]);
        }
    }
    let extent = attribute.dims.map(|d| d.saturating_sub(1) as f64);
    if (0..3).any(|a| !(hi[a] >= 0.0 && lo[a] <= extent[a])) || lo.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "the attribute volume does not overlap the surface's volume in world space",
        ));
    }
    Ok(Alignment::Resampled { to_attribute })
}

/// The 12 edges of a cell: (low corner, high corner, axis), corners numbered as in
/// [`crate::layout`] (bit 0 +x, bit 1 +y, bit 2 +z).
const EDGES: [(usize, usize, usize); 12] = {
    let mut edges = [(0, 0, 0); 12];
    let mut n = 0;
    let mut axis = 0;
    while axis < 3 {
        let mut c = 0;
        while c < 8 {
            if c >> axis & 1 == 0 {
                edges[n] = (c, c | 1 << axis, axis);
                n += 1;
            }
            c += 1;
        }
        axis += 1;
    }
    edges
};

/// The centroid of the points where the isosurface crosses a cell's edges, in the cell's own
/// coordinates `[0, 1]³`, from its eight stored corners (codes, or f32 values at 32 bits) and the
/// threshold in the same units. The cell's centre when no edge crosses.
pub fn surface_point(corners: &[f32; 8], iso_code: f32) -> [f64; 3] {
    cell_point(corners, iso_code).map(|t| t as f64)
}

/// [`surface_point`] in the f32 it is computed in. All twelve edges are computed, four per axis,
/// and the ones the surface does not cross are masked out rather than skipped: the number of
/// crossings varies from cell to cell, and a loop over them cost a mispredicted branch per cell.
/// Coordinate `k` sums the crossings' `t` along axis `k` (lanes in [`EDGES`] order, added as
/// `(t₀ + t₂) + (t₁ + t₃)`) and the count of the other crossings whose low corner lies on the
/// high side of axis `k`, an exact integer.
#[inline]
fn cell_point(corners: &[f32; 8], iso_code: f32) -> [f32; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        cell_point_sse(corners, iso_code)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        cell_point_portable(corners, iso_code)
    }
}

/// For each axis `k`, the lanes (bit `e`: edge `4·axis + e` of [`EDGES`]) of the edges along
/// each axis whose low corner has bit `k` set.
const HIGH_SIDE_LANES: [[u32; 3]; 3] = {
    let mut lanes = [[0u32; 3]; 3];
    let mut k = 0;
    while k < 3 {
        let mut e = 0;
        while e < 12 {
            if EDGES[e].0 >> k & 1 == 1 {
                lanes[k][e / 4] |= 1 << (e % 4);
            }
            e += 1;
        }
        k += 1;
    }
    lanes
};

/// Set bits of a 4-lane mask: a table, as `count_ones` without the POPCNT instruction (not in
/// the x86-64 baseline) vectorises into a long bit trick here.
const LANES_SET: [u8; 16] = [0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4];

/// The centroid from each axis's crossing mask (4 lanes) and sum of `t`.
#[inline]
fn centroid(masks: [u32; 3], t_sums: [f32; 3]) -> [f32; 3] {
    let set = |m: u32| LANES_SET[(m & 0xf) as usize] as u32;
    let n = set(masks[0]) + set(masks[1]) + set(masks[2]);
    if n == 0 {
        return [0.5; 3];
    }
    std::array::from_fn(|k| {
        let others: u32 = (0..3)
            .filter(|&axis| axis != k)
            .map(|axis| set(masks[axis] & HIGH_SIDE_LANES[k][axis]))
            .sum();
        (t_sums[k] + others as f32) / n as f32
    })
}

/// [`cell_point`] in plain Rust: what [`cell_point_sse`] computes, lane for lane.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn cell_point_portable(corners: &[f32; 8], iso_code: f32) -> [f32; 3] {
    let mut masks = [0u32; 3];
    let mut t_sums = [0.0f32; 3];
    for axis in 0..3 {
        let mut t = [0.0f32; 4];
        for e in 0..4 {
            let (c, d, _) = EDGES[4 * axis + e];
            let (a, b) = (corners[c], corners[d]);
            // A NaN corner is outside (as in the inside mask) and its edges carry no crossing.
            if (a >= iso_code) != (b >= iso_code) && !a.is_nan() && !b.is_nan() {
                masks[axis] |= 1 << e;
                t[e] = ((iso_code - a) / (b - a)).clamp(0.0, 1.0);
            }
        }
        t_sums[axis] = (t[0] + t[2]) + (t[1] + t[3]);
    }
    centroid(masks, t_sums)
}

/// [`cell_point`] four edges at a time (SSE is part of the x86-64 baseline).
#[cfg(target_arch = "x86_64")]
#[inline]
fn cell_point_sse(corners: &[f32; 8], iso_code: f32) -> [f32; 3] {
    use std::arch::x86_64::*;
    // SAFETY: SSE is part of the x86-64 baseline; the loads read the 8 lanes of `corners`.
    unsafe {
        let low = _mm_loadu_ps(corners.as_ptr());
        let high = _mm_loadu_ps(corners.as_ptr().add(4));
        // Each axis's edges as (low corners, high corners), lanes in `EDGES` order:
        // x (0,1) (2,3) (4,5) (6,7); y (0,2) (1,3) (4,6) (5,7); z (0,4) (1,5) (2,6) (3,7).
        let ends = [
            (
                _mm_shuffle_ps::<0b10_00_10_00>(low, high),
                _mm_shuffle_ps::<0b11_01_11_01>(low, high),
            ),
            (_mm_movelh_ps(low, high), _mm_movehl_ps(high, low)),
            (low, high),
        ];
        let iso = _mm_set1_ps(iso_code);
        let (zero, one) = (_mm_setzero_ps(), _mm_set1_ps(1.0));
        let mut masks = [0u32; 3];
        let mut t_sums = [0.0f32; 3];
        for (axis, &(a, b)) in ends.iter().enumerate() {
            // `>=` is false for NaN, and `ord` drops an edge with a NaN end.
            let crosses = _mm_and_ps(
                _mm_xor_ps(_mm_cmpge_ps(a, iso), _mm_cmpge_ps(b, iso)),
                _mm_cmpord_ps(a, b),
            );
            // max then min with t second, so a NaN t stays NaN as f32::clamp keeps it.
            let t = _mm_div_ps(_mm_sub_ps(iso, a), _mm_sub_ps(b, a));
            let t = _mm_and_ps(crosses, _mm_min_ps(one, _mm_max_ps(zero, t)));
            // (t₀ + t₂) + (t₁ + t₃)
            let pairs = _mm_add_ps(t, _mm_movehl_ps(t, t));
            t_sums[axis] = _mm_cvtss_f32(_mm_add_ss(pairs, _mm_shuffle_ps::<0b01>(pairs, pairs)));
            masks[axis] = _mm_movemask_ps(crosses) as u32;
        }
        centroid(masks, t_sums)
    }
}

/// The attribute samples an interpolation reads: planes `planes` (x-y planes, x fastest) of a
/// volume of `dims` — a slab read through a [`RegionSource`], or the whole volume in memory.
struct Lattice<'a, T> {
    samples: &'a [T],
    dims: [usize; 3],
    planes: Range<usize>,
}

/// `a` to `b` at `t`; the end itself at `t` = 0 or 1, so a NaN with no weight stays out.
///
/// Written as selects of values computed either way, not as branches: `t` is 0 or 1 on some axes
/// of many cells and not of others, a branch the processor cannot predict, and each miss would
/// also drop the attribute loads already issued for the cells ahead.
#[inline(always)]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    let between = a + (b - a) * t;
    let end = if t == 1.0 { b } else { between };
    if t == 0.0 {
        a
    } else {
        end
    }
}

impl<T: Scalar> Lattice<'_, T> {
    /// Trilinear interpolation inside the cell whose low corner is sample `origin`, at `t` in the
    /// cell's own coordinates: what [`Lattice::trilinear`] gives at `origin + t`, without its
    /// bounds work (the cell lies inside the lattice and its planes are held).
    #[inline]
    fn in_cell(&self, origin: [u32; 3], t: [f32; 3]) -> f32 {
        let at = self.cell_offset(origin);
        let (sy, sz) = (self.dims[0], self.dims[0] * self.dims[1]);
        let s = |o: usize| self.samples[at + o].to_f64() as f32;
        let x00 = lerp(s(0), s(1), t[0]);
        let x10 = lerp(s(sy), s(sy + 1), t[0]);
        let x01 = lerp(s(sz), s(sz + 1), t[0]);
        let x11 = lerp(s(sz + sy), s(sz + sy + 1), t[0]);
        lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2])
    }

    /// The index in `samples` of the sample at `origin`, a cell's low corner.
    #[inline]
    fn cell_offset(&self, origin: [u32; 3]) -> usize {
        let (nx, ny) = (self.dims[0], self.dims[1]);
        let [x, y, z] = origin.map(|c| c as usize);
        x + nx * (y + ny * (z - self.planes.start))
    }

    /// Asks the cache for the four sample rows [`Lattice::in_cell`] will read for the cell at
    /// `origin`.
    #[inline]
    fn prefetch_cell(&self, origin: [u32; 3]) {
        let at = self.cell_offset(origin);
        let (sy, sz) = (self.dims[0], self.dims[0] * self.dims[1]);
        for o in [0, sy, sz, sz + sy] {
            if let Some(row) = self.samples.get(at + o..at + o + 2) {
                super::prefetch_row(row);
            }
        }
    }

    /// Trilinear interpolation at attribute index point `q`; NaN outside the volume or outside
    /// the planes held.
    fn trilinear(&self, q: [f64; 3]) -> f32 {
        const EPS: f64 = 1e-9;
        let dims = self.dims;
        let mut base = [0usize; 3];
        let mut t = [0f32; 3];
        for a in 0..3 {
            let extent = dims[a].saturating_sub(1) as f64;
            if !(q[a] >= -EPS && q[a] <= extent + EPS) {
                return f32::NAN;
            }
            let v = q[a].clamp(0.0, extent);
            let i = (v as usize).min(dims[a].saturating_sub(2));
            base[a] = i;
            t[a] = (v - i as f64).clamp(0.0, 1.0) as f32;
        }
        let high_z = (base[2] + 1).min(dims[2] - 1);
        if !self.planes.contains(&base[2]) || (t[2] > 0.0 && !self.planes.contains(&high_z)) {
            return f32::NAN;
        }
        // Steps to the +1 neighbour along each axis (none on an axis of one sample).
        let (nx, ny) = (dims[0], dims[1]);
        let step = [
            (dims[0] > 1) as usize,
            if dims[1] > 1 { nx } else { 0 },
            if dims[2] > 1 { nx * ny } else { 0 },
        ];
        let at = base[0] + nx * (base[1] + ny * (base[2] - self.planes.start));
        let s = |o: usize| self.samples[at + o].to_f64() as f32;
        let x00 = lerp(s(0), s(step[0]), t[0]);
        let x10 = lerp(s(step[1]), s(step[1] + step[0]), t[0]);
        let x01 = lerp(s(step[2]), s(step[2] + step[0]), t[0]);
        let x11 = lerp(s(step[2] + step[1]), s(step[2] + step[1] + step[0]), t[0]);
        lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2])
    }
}

/// Reads attribute planes `z` of `source` as f32.
fn read_f32(source: &mut dyn RegionSource, z: Range<usize>, out: &mut Vec<f32>) -> Result<()> {
    let [nx, ny, _] = source.geometry().dims;
    let n = nx * ny * z.len();
    out.clear();
    macro_rules! via {
        ($t:ty, $variant:ident) => {{
            let mut typed = vec![<$t>::default(); n];
            source.read_planes(z, SlabMut::$variant(&mut typed))?;
            out.extend(typed.iter().map(|&v| v as f32));
        }};
    }
    match source.scalar_type() {
        ScalarType::U8 => via!(u8, U8),
        ScalarType::U16 => via!(u16, U16),
        ScalarType::I16 => via!(i16, I16),
        ScalarType::U32 => via!(u32, U32),
        ScalarType::I32 => via!(i32, I32),
        ScalarType::U64 => via!(u64, U64),
        ScalarType::I64 => via!(i64, I64),
        ScalarType::F64 => via!(f64, F64),
        ScalarType::F32 => {
            out.resize(n, 0.0);
            source.read_planes(z, SlabMut::F32(out))?;
        }
    }
    Ok(())
}

/// The values of the active cells of blocks `blocks` (block indices in grid order), sampled in
/// `lattice`, written to `values` (indexed by cell): blocks fill their own runs in parallel.
fn sample_blocks<T: Scalar>(
    grid: &CellGrid,
    blocks: Range<usize>,
    alignment: &Alignment,
    lattice: &Lattice<'_, T>,
    values: &mut [f32],
) {
    let info = grid.info();
    let (precision, iso_code) = (info.precision, info.mapping.iso_code);
    let mut runs = Vec::new();
    let mut rest: &mut [f32] = values;
    let mut next = 0usize;
    for b in blocks {
        let block = &grid.blocks()[b];
        if block.metacell_count == 0 {
            continue;
        }
        let slots = &grid.metacells()[block.slots()];
        // A block's first slot holds a metacell (padding only ends a cluster).
        let first = slots[0].cell_pointer as usize;
        let count: usize = slots
            .iter()
            .enumerate()
            .filter(|(s, _)| s % CLUSTER_SLOTS != BOUND_SLOT)
            .map(|(_, m)| m.active_cells() as usize)
            .sum();
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(first - next);
        let (run, tail) = tail.split_at_mut(count);
        rest = tail;
        next = first + count;
        runs.push((block.slots(), first, run));
    }
    // Each block first finds its cells' surface points (compute only), then interpolates the
    // attribute at them, asking for the rows of the cell `LOOKAHEAD` places ahead: the gathers
    // from the attribute volume are what the pass waits on, and they overlap only when issued
    // early.
    const LOOKAHEAD: usize = 32;
    runs.into_par_iter()
        .for_each_init(Vec::new, |points, (slots, first, run)| {
            points.clear();
            let record_bytes = precision.bytes_per_cell();
            let mut records = grid.cells()[first * record_bytes..].chunks_exact(record_bytes);
            for (s, m) in grid.metacells()[slots].iter().enumerate() {
                if s % CLUSTER_SLOTS == BOUND_SLOT {
                    continue;
                }
                // The active cells in bit order, the order of their records.
                let mut mask = m.cell_mask;
                while mask != 0 {
                    let bit = mask.trailing_zeros();
                    mask &= mask - 1;
                    let record = records.next().expect("a record per active cell");
                    let corners = read_corners(record, precision);
                    points.push((m.cell_position(bit), cell_point(&corners, iso_code)));
                }
            }
            match alignment {
                // The cell's own eight attribute samples, at the point inside it.
                Alignment::SameGrid => {
                    for (i, (value, &(origin, t))) in run.iter_mut().zip(points.iter()).enumerate()
                    {
                        if let Some(&(ahead, _)) = points.get(i + LOOKAHEAD) {
                            lattice.prefetch_cell(ahead);
                        }
                        *value = lattice.in_cell(origin, t);
                    }
                }
                Alignment::Resampled { to_attribute } => {
                    for (value, &(origin, t)) in run.iter_mut().zip(points.iter()) {
                        let p = [0, 1, 2].map(|a| origin[a] as f64 + t[a] as f64);
                        *value = lattice.trilinear(apply(to_attribute, p));
                    }
                }
            }
        });
}

/// Samples `source` at every active cell's surface point of `grid` and stores the values at
/// `precision` under `name`. Reads the source one block layer at a time.
pub fn sample_attribute(
    grid: &CellGrid,
    source: &mut dyn RegionSource,
    name: &str,
    precision: AttributePrecision,
) -> Result<CellAttribute> {
    let info = grid.info();
    let geometry = source.geometry();
    let alignment = alignment(&grid_geometry(info), &geometry)?;
    let dims = geometry.dims;
    crate::memory::ensure_fits("the attribute's values", grid.active_cells() as u64 * 4)?;
    let mut values = vec![f32::NAN; grid.active_cells()];
    let [nbx, nby, nbz] = info.block_dims().map(|b| b as usize);
    let mut slab = Vec::new();
    for bz in 0..nbz {
        let layer = bz * nbx * nby..(bz + 1) * nbx * nby;
        if grid.blocks()[layer.clone()]
            .iter()
            .all(|b| b.metacell_count == 0)
        {
            continue;
        }
        let planes = layer_planes(info, bz, &alignment, dims);
        if !planes.is_empty() {
            crate::memory::ensure_fits(
                "a slab of the attribute volume",
                (dims[0] * dims[1] * planes.len()) as u64 * 8,
            )?;
            read_f32(source, planes.clone(), &mut slab)?;
        }
        let lattice = Lattice {
            samples: &slab,
            dims,
            planes,
        };
        sample_blocks(grid, layer, &alignment, &lattice, &mut values);
    }
    Ok(CellAttribute::from_values(name, precision, &values))
}

/// [`sample_attribute`] from a volume in memory: its samples are read where they lie, with no
/// slab copied.
pub fn sample_attribute_in_memory(
    grid: &CellGrid,
    volume: &VolumeView<'_>,
    name: &str,
    precision: AttributePrecision,
) -> Result<CellAttribute> {
    let geometry = volume.geometry();
    let alignment = alignment(&grid_geometry(grid.info()), geometry)?;
    crate::memory::ensure_fits("the attribute's values", grid.active_cells() as u64 * 4)?;
    let mut values = vec![f32::NAN; grid.active_cells()];
    let all = 0..grid.blocks().len();
    let planes = 0..geometry.dims[2];
    macro_rules! with {
        ($samples:expr) => {
            sample_blocks(
                grid,
                all,
                &alignment,
                &Lattice {
                    samples: $samples,
                    dims: geometry.dims,
                    planes,
                },
                &mut values,
            )
        };
    }
    crate::volume::with_samples!(volume.samples(), s => with!(s));
    Ok(CellAttribute::from_values(name, precision, &values))
}

/// The attribute of a volume in memory at `points`, given in the index space of the volume of
/// `geometry` (a mesh's vertices: sample (i, j, k) at (i, j, k)); NaN outside the attribute.
pub fn sample_points_in_memory(
    geometry: &Geometry,
    points: &[[f64; 3]],
    volume: &VolumeView<'_>,
) -> Result<Vec<f32>> {
    let alignment = alignment(geometry, volume.geometry())?;
    let dims = volume.geometry().dims;
    macro_rules! with {
        ($samples:expr) => {{
            let lattice = Lattice {
                samples: $samples,
                dims,
                planes: 0..dims[2],
            };
            points
                .par_iter()
                .map(|&p| match &alignment {
                    Alignment::SameGrid => lattice.trilinear(p),
                    Alignment::Resampled { to_attribute } => {
                        lattice.trilinear(apply(to_attribute, p))
                    }
                })
                .collect()
        }};
    }
    Ok(crate::volume::with_samples!(volume.samples(), s => with!(s)))
}

/// Values at points on the surface of `grid` from its cell attribute, for meshes of the same
/// surface (the MC baseline drawn in colour): each point (index space) takes the mean of the
/// finite values of the active cells it touches (within 1e-4 of a cell, so a vertex on an edge
/// averages the up to four cells sharing the edge), NaN where they are all NaN or it touches
/// none. Fails when the grid has no attribute.
pub fn values_at_surface_points(grid: &CellGrid, points: &[[f64; 3]]) -> Result<Vec<f32>> {
    let attribute = grid
        .attribute()
        .ok_or_else(|| Error::invalid("the grid has no attribute to take values from"))?;
    let dims = grid.info().cell_dims().map(|d| d as u64);
    crate::memory::ensure_fits("the cell lookup", grid.active_cells() as u64 * 24)?;
    let mut record_of = std::collections::HashMap::with_capacity(grid.active_cells());
    let mut record = 0usize;
    for (s, m) in grid.metacells().iter().enumerate() {
        if s % CLUSTER_SLOTS == BOUND_SLOT || m.is_empty() {
            continue;
        }
        for bit in 0..8 {
            if m.cell_mask >> bit & 1 != 0 {
                let [i, j, k] = m.cell_position(bit).map(|c| c as u64);
                record_of.insert(i + dims[0] * (j + dims[1] * k), record);
                record += 1;
            }
        }
    }
    const TOUCH: f64 = 1e-4;
    Ok(points
        .iter()
        .map(|p| {
            let (mut sum, mut finite, mut touched) = (0.0f64, 0u32, [usize::MAX; 8]);
            for (n, corner) in (0..8u32).enumerate() {
                let cell: [f64; 3] = std::array::from_fn(|a| {
                    let side = if corner >> a & 1 == 0 { -TOUCH } else { TOUCH };
                    (p[a] + side).floor()
                });
                if (0..3).any(|a| cell[a] < 0.0 || cell[a] >= dims[a] as f64) {
                    continue;
                }
                let [i, j, k] = cell.map(|c| c as u64);
                let Some(&r) = record_of.get(&(i + dims[0] * (j + dims[1] * k))) else {
                    continue;
                };
                if touched[..n].contains(&r) {
                    continue;
                }
                touched[n] = r;
                let v = attribute.value(r);
                if v.is_finite() {
                    sum += v as f64;
                    finite += 1;
                }
            }
            if finite == 0 {
                f32::NAN
            } else {
                (sum / finite as f64) as f32
            }
        })
        .collect())
}

/// The attribute planes the surface points of block layer `bz` can reach.
fn layer_planes(
    info: &GridInfo,
    bz: usize,
    alignment: &Alignment,
    dims: [usize; 3],
) -> Range<usize> {
    let z_cells = [(bz * BLOCK_CELLS) as f64, ((bz + 1) * BLOCK_CELLS) as f64];
    match alignment {
        Alignment::SameGrid => bz * BLOCK_CELLS..((bz + 1) * BLOCK_CELLS + 1).min(dims[2]),
        Alignment::Resampled { to_attribute } => {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for corner in 0..8 {
                let p = [
                    if corner & 1 == 1 {
                        info.dims[0] as f64
                    } else {
                        0.0
                    },
                    if corner & 2 == 2 {
                        info.dims[1] as f64
                    } else {
                        0.0
                    },
                    z_cells[corner >> 2 & 1],
                ];
                let q = apply(to_attribute, p)[2];
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let start = lo.floor().max(0.0) as usize;
            let end = ((hi.ceil() + 1.0).max(0.0) as usize).min(dims[2]);
            start.min(end)..end
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SSE surface point equals the plain one bit for bit, NaN and infinite corners included,
    /// so files do not depend on the machine that wrote them.
    #[test]
    fn sse_and_portable_surface_points_agree_bit_for_bit() {
        let specials = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            1.0,
            2.0,
            2.5,
        ];
        let mut next = crate::test_rng::xorshift(0x2545_f491_4f6c_dd1d);
        for _ in 0..200_000 {
            let r = next();
            let corners: [f32; 8] = std::array::from_fn(|c| {
                let bits = (r >> (8 * c)) as u8;
                if bits < 24 {
                    specials[bits as usize % specials.len()]
                } else {
                    (next() % 5000) as f32 / 1000.0
                }
            });
            let iso = [2.5, 1.0, 0.001, 4.999][(r >> 62) as usize];
            let (a, b) = (
                cell_point(&corners, iso),
                cell_point_portable(&corners, iso),
            );
            assert_eq!(
                a.map(f32::to_bits),
                b.map(f32::to_bits),
                "{corners:?} at {iso}: {a:?} {b:?}"
            );
        }
    }
}

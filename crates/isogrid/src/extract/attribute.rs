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
use crate::volume::{Geometry, ScalarType};
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
        if (r + c) % 2 == 0 {
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
    }
}

/// How `attribute` lines up with `grid`. Fails when the attribute volume does not overlap the
/// grid's box in world space, or when either geometry has no inverse.
pub fn alignment(grid: &Geometry, attribute: &Geometry) -> Result<Alignment> {
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

/// The centroid of the points where the isosurface crosses a cell's edges, in the cell's own
/// coordinates `[0, 1]³`, from its eight stored corners (codes, or f32 values at 32 bits) and the
/// threshold in the same units. The cell's centre when no edge crosses.
pub fn surface_point(corners: &[f32; 8], iso_code: f32) -> [f64; 3] {
    let (mut sum, mut n) = ([0.0f64; 3], 0u32);
    for axis in 0..3 {
        for c in 0..8usize {
            if c >> axis & 1 == 1 {
                continue;
            }
            let d = c | 1 << axis;
            let (a, b) = (corners[c] as f64, corners[d] as f64);
            let (ia, ib) = (a >= iso_code as f64, b >= iso_code as f64);
            if ia == ib || a.is_nan() || b.is_nan() {
                continue;
            }
            let t = ((iso_code as f64 - a) / (b - a)).clamp(0.0, 1.0);
            for k in 0..3 {
                sum[k] += if k == axis { t } else { (c >> k & 1) as f64 };
            }
            n += 1;
        }
    }
    if n == 0 {
        [0.5; 3]
    } else {
        sum.map(|s| s / n as f64)
    }
}

/// Trilinear interpolation at `q` (index space of a slab whose first plane is `z0`), NaN outside
/// the volume's `dims` or outside the planes held.
fn trilinear(samples: &[f32], dims: [usize; 3], planes: &Range<usize>, q: [f64; 3]) -> f32 {
    const EPS: f64 = 1e-9;
    let mut base = [0usize; 3];
    let mut t = [0f64; 3];
    for a in 0..3 {
        let extent = dims[a].saturating_sub(1) as f64;
        if !(q[a] >= -EPS && q[a] <= extent + EPS) {
            return f32::NAN;
        }
        let v = q[a].clamp(0.0, extent);
        let i = (v.floor() as usize).min(dims[a].saturating_sub(2));
        base[a] = i;
        t[a] = (v - i as f64).clamp(0.0, 1.0);
    }
    let (nx, ny) = (dims[0], dims[1]);
    let mut value = 0.0f64;
    for c in 0..8usize {
        let o = [c & 1, c >> 1 & 1, c >> 2 & 1];
        let w: f64 = (0..3)
            .map(|a| if o[a] == 1 { t[a] } else { 1.0 - t[a] })
            .product();
        if w == 0.0 {
            continue;
        }
        let p = [0, 1, 2].map(|a| (base[a] + o[a]).min(dims[a] - 1));
        if !planes.contains(&p[2]) {
            return f32::NAN;
        }
        let s = samples[p[0] + nx * (p[1] + ny * (p[2] - planes.start))];
        value += w * s as f64;
    }
    value as f32
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
        ScalarType::F32 => {
            out.resize(n, 0.0);
            source.read_planes(z, SlabMut::F32(out))?;
        }
    }
    Ok(())
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
    let attribute_geometry = source.geometry();
    let alignment = alignment(&grid_geometry(info), &attribute_geometry)?;
    let dims = attribute_geometry.dims;
    crate::memory::ensure_fits("the attribute's values", grid.active_cells() as u64 * 4)?;
    let mut values = vec![f32::NAN; grid.active_cells()];
    let [nbx, nby, nbz] = info.block_dims().map(|b| b as usize);
    let mut slab = Vec::new();
    let blocks = grid.blocks();
    for bz in 0..nbz {
        let layer = bz * nbx * nby..(bz + 1) * nbx * nby;
        if blocks[layer.clone()].iter().all(|b| b.metacell_count == 0) {
            continue;
        }
        // The attribute planes this layer's surface points can reach.
        let z_cells = (bz * BLOCK_CELLS) as f64..=((bz + 1) * BLOCK_CELLS) as f64;
        let planes = match &alignment {
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
                        if corner & 4 == 4 {
                            *z_cells.end()
                        } else {
                            *z_cells.start()
                        },
                    ];
                    let q = apply(to_attribute, p)[2];
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                let start = lo.floor().max(0.0) as usize;
                let end = ((hi.ceil() + 1.0).max(0.0) as usize).min(dims[2]);
                start.min(end)..end
            }
        };
        if !planes.is_empty() {
            crate::memory::ensure_fits(
                "a slab of the attribute volume",
                (dims[0] * dims[1] * planes.len()) as u64 * 8,
            )?;
            read_f32(source, planes.clone(), &mut slab)?;
        }
        // Each block's cells are one run of the value array, so blocks fill their runs in parallel.
        let mut runs = Vec::new();
        let mut rest: &mut [f32] = &mut values;
        let mut next = 0usize;
        for b in layer {
            let block = &blocks[b];
            if block.metacell_count == 0 {
                continue;
            }
            let slots = &grid.metacells()[block.slots()];
            let first = slots
                .iter()
                .enumerate()
                .find(|(s, m)| s % CLUSTER_SLOTS != BOUND_SLOT && !m.is_empty())
                .map(|(_, m)| m.cell_pointer as usize)
                .unwrap_or(next);
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
        let precision_bits = info.precision;
        let iso_code = info.mapping.iso_code;
        runs.into_par_iter().for_each(|(slots, first, run)| {
            let mut cell = first;
            for (s, m) in grid.metacells()[slots].iter().enumerate() {
                if s % CLUSTER_SLOTS == BOUND_SLOT || m.is_empty() {
                    continue;
                }
                for bit in 0..8 {
                    if m.cell_mask >> bit & 1 == 0 {
                        continue;
                    }
                    let corners = read_corners(grid.cell_record(cell), precision_bits);
                    let t = surface_point(&corners, iso_code);
                    let origin = m.cell_position(bit).map(|c| c as f64);
                    let p = [0, 1, 2].map(|a| origin[a] + t[a]);
                    let q = match &alignment {
                        Alignment::SameGrid => p,
                        Alignment::Resampled { to_attribute } => apply(to_attribute, p),
                    };
                    run[cell - first] = if planes.is_empty() {
                        f32::NAN
                    } else {
                        trilinear(&slab, dims, &planes, q)
                    };
                    cell += 1;
                }
            }
        });
    }
    Ok(CellAttribute::from_values(name, precision, &values))
}

//! The block level of the tracer's traversal (paper §3.6): a 3D DDA (Amanatides & Woo, 1987) over
//! the dense grid of 16³-cell blocks, which leaps across empty space with the [`OctantSpaceMap`]
//! (distance-map skipping in the manner of Cohen & Sheffer 1994), kept as a state that the tracer
//! moves one block (or one leap) at a time.
//!
//! When the cube of `s ≥ 2` blocks per side that starts at the current block and extends towards
//! the ray's octant is empty, [`BlockWalk::leap`] takes the ray straight to where it leaves that
//! cube. Elsewhere [`BlockWalk::step`] moves one block.
//!
//! [`OctantSpaceMap`]: isogrid::skip::octant_space::OctantSpaceMap

use super::cell_ray::{max, min, xyz, CellRay};
use isogrid::layout::{BLOCK_CELLS, BLOCK_METACELLS};

/// Where one ray is in the block grid (block indices per axis) and what moving it needs.
#[derive(Debug, Clone)]
pub(super) struct BlockWalk {
    block: [i64; 3],
    /// `t` where the ray leaves the current block's slab on each axis.
    t_next: [f64; 3],
    /// `t` the ray takes to cross one block on each axis.
    t_delta: [f64; 3],
    t_exit: f64,
    forward: [bool; 3],
    dims: [i64; 3],
}

/// `floor(v / BLOCK_CELLS)` for the block index of a coordinate: a truncating cast, which agrees
/// with `floor` for `v ≥ 0` and the callers clamp negative results anyway (no libm `floor` call,
/// which the x86-64 baseline lacks an instruction for).
#[inline(always)]
fn block_of(v: f64) -> i64 {
    let b = v * (1.0 / BLOCK_CELLS as f64);
    if b < 0.0 {
        -1
    } else {
        b as i64
    }
}

/// The axis whose boundary the ray reaches first (the lowest axis on ties).
#[inline(always)]
fn first_to_leave(t: [f64; 3]) -> usize {
    let a01 = (t[1] < t[0]) as usize;
    if t[2] < min(t[0], t[1]) {
        2
    } else {
        a01
    }
}

/// `t` where `r` leaves the slab of blocks ending at block `last` along axis `a`.
#[inline(always)]
fn leave(r: &CellRay, forward: bool, a: usize, last: i64) -> f64 {
    let boundary = if forward { last + 1 } else { last } as f64 * BLOCK_CELLS as f64;
    (boundary - r.origin[a]) * r.inv[a]
}

impl BlockWalk {
    /// The walk of `r` over `block_dims` blocks covering `cell_dims` cells, from where the ray
    /// enters the grid within `[tmin, tmax]`; `None` when it never does.
    #[inline(always)]
    pub fn new(
        r: &CellRay,
        cell_dims: [f64; 3],
        block_dims: [i64; 3],
        tmin: f64,
        tmax: f64,
    ) -> Option<Self> {
        let (near, far) = r.slab([0.0; 3], cell_dims);
        let t_enter = max(near, tmin);
        let t_exit = min(far, tmax);
        if !(t_enter <= t_exit) || block_dims.contains(&0) {
            return None;
        }
        let p = r.at(t_enter);
        let block = xyz(|a| block_of(p[a]).clamp(0, block_dims[a] - 1));
        let forward = xyz(|a| r.direction[a] >= 0.0);
        Some(BlockWalk {
            block,
            t_next: xyz(|a| leave(r, forward[a], a, block[a])),
            t_delta: xyz(|a| BLOCK_CELLS as f64 * r.inv[a].abs()),
            t_exit,
            forward,
            dims: block_dims,
        })
    }

    /// Index of the current block in the block array (x fastest).
    #[inline(always)]
    pub fn index(&self) -> usize {
        let [x, y, z] = self.block;
        (x + self.dims[0] * (y + self.dims[1] * z)) as usize
    }

    /// The current block's first metacell (metacell units), as f32 lanes for the box tests.
    #[inline(always)]
    pub fn first_metacell(&self) -> [f32; 3] {
        xyz(|a| (self.block[a] * BLOCK_METACELLS as i64) as f32)
    }

    /// `t` where the ray leaves the current block.
    #[inline(always)]
    pub fn exit(&self) -> f64 {
        min(min(self.t_next[0], self.t_next[1]), self.t_next[2])
    }

    fn step_of(&self, a: usize) -> i64 {
        if self.forward[a] {
            1
        } else {
            -1
        }
    }

    /// Moves to the next block along the ray; false once the ray leaves the grid or `tmax`.
    #[inline(always)]
    pub fn step(&mut self) -> bool {
        if self.exit() >= self.t_exit {
            return false;
        }
        let a = first_to_leave(self.t_next);
        self.block[a] += self.step_of(a);
        if self.block[a] < 0 || self.block[a] >= self.dims[a] {
            return false;
        }
        self.t_next[a] += self.t_delta[a];
        true
    }

    /// Leaves the cube of `side³` blocks that starts at the current one and extends in the ray's
    /// direction on every axis, which the caller knows to be empty (`side ≥ 2`); false once the
    /// ray leaves the grid or `tmax`.
    #[inline(always)]
    pub fn leap(&mut self, r: &CellRay, side: u8) -> bool {
        let reach = side as i64 - 1;
        let far_side = xyz(|a| self.block[a] + self.step_of(a) * reach);
        let leaves = xyz(|a| leave(r, self.forward[a], a, far_side[a]));
        let axis = first_to_leave(leaves);
        let t = leaves[axis];
        if t >= self.t_exit {
            return false;
        }
        let p = r.at(t);
        for a in 0..3 {
            self.block[a] = if a == axis {
                far_side[a] + self.step_of(a)
            } else {
                // Inside the cube on this axis (up to rounding), and never backwards.
                let here = block_of(p[a]);
                let (lo, hi) = if self.forward[a] {
                    (self.block[a], far_side[a])
                } else {
                    (far_side[a], self.block[a])
                };
                here.clamp(lo, hi)
            };
            if self.block[a] < 0 || self.block[a] >= self.dims[a] {
                return false;
            }
            self.t_next[a] = leave(r, self.forward[a], a, self.block[a]);
        }
        true
    }
}

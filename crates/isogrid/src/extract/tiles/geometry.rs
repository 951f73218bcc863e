//! Tiles as boxes of whole blocks, and the samples each reads (its own plus the halo).

use crate::error::{Error, Result};
use crate::layout::BLOCK_CELLS;
use std::ops::Range;

/// A box of whole blocks: block ranges along x, y and z.
pub type BlockBox = [Range<usize>; 3];

/// Blocks per axis (x, y, z) of a volume of `dims` samples (none along an axis of one sample).
pub fn block_dims(dims: [usize; 3]) -> [usize; 3] {
    dims.map(|d| d.saturating_sub(1).div_ceil(BLOCK_CELLS))
}

/// The samples (x, y, z ranges) the blocks `blocks` read: their own and the halo sample after
/// them along each axis, clipped to the volume's `dims`.
pub fn tile_samples(blocks: &BlockBox, dims: [usize; 3]) -> [Range<usize>; 3] {
    [0, 1, 2].map(|a| BLOCK_CELLS * blocks[a].start..(BLOCK_CELLS * blocks[a].end + 1).min(dims[a]))
}

/// The tiles of `tile_blocks` blocks (x, y, z; the last along each axis may be smaller) that cover
/// a volume of `dims` samples, in block order (x fastest). None when the volume has no block.
pub fn tiles(dims: [usize; 3], tile_blocks: [usize; 3]) -> Result<Vec<BlockBox>> {
    if tile_blocks.contains(&0) {
        return Err(Error::invalid(
            "a tile must hold at least one block along each axis",
        ));
    }
    let nb = block_dims(dims);
    if nb.contains(&0) {
        return Ok(Vec::new());
    }
    let cuts = |a: usize| -> Vec<Range<usize>> {
        (0..nb[a])
            .step_by(tile_blocks[a])
            .map(|b| b..(b + tile_blocks[a]).min(nb[a]))
            .collect()
    };
    let (xs, ys, zs) = (cuts(0), cuts(1), cuts(2));
    let mut out = Vec::with_capacity(xs.len() * ys.len() * zs.len());
    for z in &zs {
        for y in &ys {
            for x in &xs {
                out.push([x.clone(), y.clone(), z.clone()]);
            }
        }
    }
    Ok(out)
}

/// The block rows (y, z) of a box, in block order.
pub(super) fn box_rows(blocks: &BlockBox) -> impl Iterator<Item = (usize, usize)> + '_ {
    blocks[2]
        .clone()
        .flat_map(move |z| blocks[1].clone().map(move |y| (y, z)))
}

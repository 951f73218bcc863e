//! Solid voxelisation of triangle meshes into 8-bit coverage volumes.
//!
//! Paper §4: the non-CT datasets were made by voxelising each mesh at three times the target
//! resolution (binary solid voxelisation) and downsampling to an 8-bit coverage volume, rendered at
//! the normalised isovalue 0.5. We do the same on the CPU, streaming.
//!
//! # Placement (mesh units)
//! Let `lo`/`hi` be the bounding box of all vertices and `L` its longest side. The output voxel
//! size is `h = L / (resolution − 2·padding)`, the same on every axis, so the box spans exactly
//! `resolution − 2·padding` voxels along its longest axis with `padding` empty voxels on each side.
//! Output sample `(i, j, k)` stands for the cube `lo + ([i, i+1] − padding)·h` (per axis) and sits
//! at its centre: volume spacing is `h`, origin `lo + (½ − padding)·h`. With `cube`, every axis
//! has `resolution` samples and the shorter axes get extra whole voxels of padding, split evenly,
//! so the mesh sits centred (the paper's datasets are cubes, e.g. the 512³ Dragon). Each such cube is split
//! into `supersample³` fine voxels; a fine voxel is solid when its *centre* is inside the mesh, and
//! the sample's value is `round(255 · solid / supersample³)` (255 = fully inside).
//!
//! # Inside test
//! Real scanned meshes are rarely closed, so "inside" is a vote of three ray-parity tests, along
//! x, y and z, through every fine-voxel centre (`parity.rs`); crossings come from an exact,
//! watertight rasterisation of every triangle onto the columns of the three planes (`raster.rs`).
//!
//! # Memory and time
//! The fine grid is never stored. Output slices are produced in z order, `supersample` fine slices
//! at a time, from the toggles of one chunk of slices at a time: memory is the output volume plus
//! O(surface crossings in one chunk + fine nx · fine ny / 8). Triangles are rasterised in parallel
//! and the toggles sorted, so the result does not depend on the thread count.

mod parity;
mod raster;

use crate::mesh::TriMesh;
use isogrid::{Error, Geometry, Result, Volume, VolumeData, MAX_DIM};
use parity::{coverage_row, CoverageScratch, SliceVoter};
use raster::{centre_span, rasterise, toggle_span, Fixed, RayAxis, ONE};
use rayon::prelude::*;
use std::ops::Range;

/// How finely to voxelise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VoxelizeOptions {
    /// Samples along the mesh's longest axis, padding included (the paper used 512–2048).
    pub resolution: usize,
    /// Fine voxels per output voxel along each axis (the paper used 3); 1 gives a binary volume.
    pub supersample: usize,
    /// Empty samples added around the mesh's bounding box on every side.
    pub padding: usize,
    /// Give every axis `resolution` samples, the mesh centred, as the paper's cubic datasets
    /// (its Dragon is 512³); otherwise the shorter axes fit the mesh's bounding box.
    pub cube: bool,
}

impl Default for VoxelizeOptions {
    fn default() -> Self {
        VoxelizeOptions {
            resolution: 256,
            supersample: 3,
            padding: 2,
            cube: false,
        }
    }
}

/// Largest supported supersampling factor.
pub const MAX_SUPERSAMPLE: usize = 16;

/// Toggles are packed as `z << 42 | y << 21 | x`, so fine coordinates (up to and including the
/// grid size) must stay below 2^21.
const KEY_BITS: u32 = 21;
const KEY_MASK: u64 = (1 << KEY_BITS) - 1;

/// Fine slices whose toggles are gathered at once: large enough that few triangles straddle
/// chunks, small enough that a chunk's toggles are a small part of memory.
const FINE_SLICES_PER_CHUNK: usize = 96;

/// Voxelises `mesh` into a u8 coverage volume (see the module documentation for placement and
/// the inside test). `progress(done, total)` is called from the calling thread after every output
/// z-slice, `total` being the number of slices.
pub fn voxelize(
    mesh: &TriMesh,
    opts: &VoxelizeOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Volume> {
    let placement = Placement::new(mesh, opts)?;
    let s = opts.supersample;
    let [nx, ny, nz] = placement.dims;
    let fine = placement.dims.map(|n| n * s);
    let fine_i64 = fine.map(|n| n as i64);
    let fixed: Vec<Fixed> = mesh
        .vertices
        .par_iter()
        .map(|&p| placement.to_fixed(p))
        .collect();
    let tris = &mesh.triangles;

    let slice_len = nx * ny;
    let mut data: Vec<u8> =
        isogrid::memory::try_vec(&format!("a {nx}x{ny}x{nz} u8 volume"), slice_len * nz)?;
    data.resize(slice_len * nz, 0);
    progress(0, nz as u64);

    let slices_per_chunk = (FINE_SLICES_PER_CHUNK / s).max(1);
    let chunks: Vec<Range<usize>> = (0..nz)
        .step_by(slices_per_chunk)
        .map(|k0| k0..(k0 + slices_per_chunk).min(nz))
        .collect();
    let fine_z = |ks: &Range<usize>| (ks.start * s) as i64..(ks.end * s) as i64;

    // Total z-ray parity per column, needed before the first slice to know which columns are
    // open. Crossings beyond the last centre (toggle index = fine nz) count too.
    let mut voter = SliceVoter::new(fine);
    for (c, ks) in chunks.iter().enumerate() {
        let mut range = fine_z(ks);
        if c + 1 == chunks.len() {
            range.end += 1;
        }
        for key in toggles(tris, &fixed, RayAxis::Z, fine_i64, range) {
            voter.add_z_total(
                (key & KEY_MASK) as usize,
                ((key >> KEY_BITS) & KEY_MASK) as usize,
            );
        }
    }

    let mut planes = vec![voter.new_plane(); s];
    for ks in &chunks {
        let events = RayAxis::ALL.map(|axis| toggles(tris, &fixed, axis, fine_i64, fine_z(ks)));
        let mut cursors = [0usize; 3];
        for k in ks.clone() {
            for (sub, plane) in planes.iter_mut().enumerate() {
                let fz = (k * s + sub) as u64;
                let [x, y, z] = [0, 1, 2].map(|a| {
                    let rest = &events[a][cursors[a]..];
                    let n = rest.partition_point(|&key| key >> (2 * KEY_BITS) <= fz);
                    cursors[a] += n;
                    rest[..n].iter().map(|&key| {
                        (
                            (key & KEY_MASK) as usize,
                            ((key >> KEY_BITS) & KEY_MASK) as usize,
                        )
                    })
                });
                voter.decide_slice(x, y, z, plane);
            }
            data[k * slice_len..(k + 1) * slice_len]
                .par_chunks_mut(nx)
                .enumerate()
                .for_each_init(
                    || CoverageScratch::new(voter.words_per_row()),
                    |scratch, (j, row)| coverage_row(&planes, j, scratch, row),
                );
            progress(k as u64 + 1, nz as u64);
        }
    }

    let geometry = Geometry {
        spacing: [placement.voxel_size; 3],
        origin: placement.origin(),
        ..Geometry::new(placement.dims)
    };
    Volume::with_geometry(geometry, VolumeData::U8(data))
}

/// Sorted toggle keys of every triangle for rays along `axis`, restricted to fine z-slices
/// `z_range`: for x and y rays the columns in those slices, for z rays the toggles landing in
/// them.
fn toggles(
    tris: &[[u32; 3]],
    fixed: &[Fixed],
    axis: RayAxis,
    fine: [i64; 3],
    z_range: Range<i64>,
) -> Vec<u64> {
    let (v_range, toggle_range) = match axis {
        RayAxis::X => (z_range.clone(), 0..fine[0] + 1),
        RayAxis::Y => (z_range.clone(), 0..fine[1] + 1),
        RayAxis::Z => (0..fine[1], z_range.clone()),
    };
    let overlaps = |r: Range<i64>| r.start < z_range.end && z_range.start < r.end;
    let mut keys = tris
        .par_iter()
        .with_min_len(1024)
        .fold(Vec::new, |mut keys, t| {
            let tri = t.map(|i| fixed[i as usize]);
            let span = match axis {
                RayAxis::Z => toggle_span(&tri, 2),
                _ => centre_span(&tri, 2),
            };
            if overlaps(span) {
                rasterise(
                    &tri,
                    axis,
                    fine,
                    v_range.clone(),
                    toggle_range.clone(),
                    &mut |[x, y, z]| {
                        keys.push((z as u64) << (2 * KEY_BITS) | (y as u64) << KEY_BITS | x as u64)
                    },
                );
            }
            keys
        })
        .reduce(Vec::new, |mut a, mut b| {
            if a.len() < b.len() {
                std::mem::swap(&mut a, &mut b);
            }
            a.extend_from_slice(&b);
            a
        });
    keys.par_sort_unstable();
    keys
}

/// Where the mesh lands in the output grid (see the module documentation).
struct Placement {
    dims: [usize; 3],
    /// Output voxel edge, mesh units.
    voxel_size: f64,
    lo: [f64; 3],
    /// Empty samples before the mesh's bounding box, per axis.
    padding: [usize; 3],
    supersample: usize,
}

impl Placement {
    fn new(mesh: &TriMesh, opts: &VoxelizeOptions) -> Result<Self> {
        let VoxelizeOptions {
            resolution,
            supersample,
            padding,
            cube,
        } = *opts;
        if !(1..=MAX_SUPERSAMPLE).contains(&supersample) {
            return Err(Error::invalid(format!(
                "supersample {supersample} is outside 1..={MAX_SUPERSAMPLE}"
            )));
        }
        let interior = resolution
            .checked_sub(padding.saturating_mul(2))
            .filter(|&n| n >= 1)
            .ok_or_else(|| {
                Error::invalid(format!(
                    "resolution {resolution} leaves no room inside a padding of {padding} on each side"
                ))
            })?;
        if resolution > MAX_DIM || resolution * supersample >= (1 << KEY_BITS) - 1 {
            return Err(Error::too_large(format!(
                "resolution {resolution} with supersample {supersample} exceeds the supported grid \
                 ({MAX_DIM} samples, {} fine voxels per axis)",
                (1usize << KEY_BITS) - 2
            )));
        }
        if mesh.triangles.is_empty() {
            return Err(Error::invalid("mesh has no triangles"));
        }
        let n = mesh.vertices.len();
        if let Some(t) = mesh
            .triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(Error::invalid(format!(
                "triangle {t} refers to a vertex beyond the {n} vertices"
            )));
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (i, v) in mesh.vertices.iter().enumerate() {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(Error::invalid(format!(
                    "vertex {i} has a non-finite coordinate"
                )));
            }
            for a in 0..3 {
                lo[a] = lo[a].min(v[a] as f64);
                hi[a] = hi[a].max(v[a] as f64);
            }
        }
        let extent = [0, 1, 2].map(|a| hi[a] - lo[a]);
        let longest = extent.iter().cloned().fold(0.0, f64::max);
        if longest <= 0.0 {
            return Err(Error::invalid(
                "mesh has zero extent (all vertices coincide)",
            ));
        }
        let voxel_size = longest / interior as f64;
        // The longest axis divides exactly; tolerate rounding so it does not gain a voxel.
        let cells =
            extent.map(|e| ((e / voxel_size - 1e-9).ceil().max(1.0) as usize).min(interior));
        let (dims, padding) = if cube {
            ([resolution; 3], cells.map(|c| padding + (interior - c) / 2))
        } else {
            (cells.map(|c| c + 2 * padding), [padding; 3])
        };
        Ok(Placement {
            dims,
            voxel_size,
            lo,
            padding,
            supersample,
        })
    }

    /// Position of sample (0, 0, 0): the centre of the first output voxel.
    fn origin(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| self.lo[a] + (0.5 - self.padding[a] as f64) * self.voxel_size)
    }

    /// Mesh units → fixed-point fine-voxel coordinates.
    fn to_fixed(&self, p: [f32; 3]) -> Fixed {
        let scale = self.supersample as f64 * ONE as f64;
        [0, 1, 2].map(|a| {
            let voxels = (p[a] as f64 - self.lo[a]) / self.voxel_size + self.padding[a] as f64;
            (voxels * scale).round() as i64
        })
    }
}

#[cfg(test)]
mod tests;

//! Marching Cubes extraction over bit-packed planes, in parallel z-slabs with a fixed output order.
//!
//! Each sample plane is reduced to one inside bit per sample (64 samples per word). Crossed edges
//! are then XORs of neighbouring bits and active cells a few bitwise operations per 64 cells, so
//! the empty bulk of a volume costs little more than reading it once.
//!
//! Vertex numbering is global and independent of how the work is split: vertices are sorted by
//! `(k, axis, j, i)` of the edge's lower sample, i.e. plane by plane, and within a plane first the
//! x-edges, then the y-edges, then the z-edges rising to the next plane, each in storage order. A
//! vertex's index is the rank of its edge among the crossed edges in that order, looked up with a
//! per-word prefix count and a popcount. A slab owns the edges of its planes; its last cell layer
//! refers to x/y-edges of the next slab's first plane, whose ranks it computes itself, numbering
//! them right after its own vertices. The next slab's vertices follow in the concatenation, so
//! every index only needs the slab's offset added: output is identical for any thread count.

use super::mesh::{Inside, McMesh};
use super::table::{cases, edge_corners};
use crate::error::{Error, Result};
use crate::extract::scalar::{integer_above, integer_at_or_above};
use crate::progress::Progress;
use crate::volume::{Scalar, VolumeView};
use rayon::prelude::*;
use std::collections::HashMap;

/// Planes per slab as a function of the volume alone (never of the thread count).
pub(crate) fn default_slab_planes(nz: usize) -> usize {
    nz.div_ceil(128).max(8)
}

/// The mesh of `volume`; `progress` counts sample planes whose slab is done.
pub(crate) fn extract(
    volume: &VolumeView,
    iso: f64,
    inside: Inside,
    slab_planes: usize,
    progress: &Progress,
) -> Result<McMesh> {
    progress.start(volume.dims()[2] as u64);
    crate::volume::with_samples!(volume.samples(), s => extract_typed(volume, s, iso, inside, slab_planes, progress))
}

/// The smallest sample value that counts as inside (`v as f64 >= iso`), so the hot loop compares
/// in the sample type. `None` when no value can be inside.
trait Threshold: Scalar {
    fn threshold(iso: f64) -> Option<Self>;
    /// The smallest value `v` of the type with `v as f64 > iso`.
    fn threshold_above(iso: f64) -> Option<Self>;
    fn inside_threshold(iso: f64, inside: Inside) -> Option<Self> {
        match inside {
            Inside::AtOrAbove => Self::threshold(iso),
            Inside::Above => Self::threshold_above(iso),
        }
    }
}

macro_rules! integer_threshold {
    ($($t:ty),*) => {$(
        impl Threshold for $t {
            fn threshold(iso: f64) -> Option<Self> {
                integer_at_or_above(iso, <$t>::MIN as i128, <$t>::MAX as i128).map(|c| c as $t)
            }
            fn threshold_above(iso: f64) -> Option<Self> {
                integer_above(iso, <$t>::MIN as i128, <$t>::MAX as i128).map(|c| c as $t)
            }
        }
    )*};
}
integer_threshold!(u8, u16, i16, u32, i32, u64, i64);

/// f64 samples compare with the isovalue itself.
impl Threshold for f64 {
    fn threshold(iso: f64) -> Option<Self> {
        (!iso.is_nan()).then_some(iso)
    }
    fn threshold_above(iso: f64) -> Option<Self> {
        (!iso.is_nan() && iso < f64::INFINITY).then(|| iso.next_up())
    }
}

impl Threshold for f32 {
    fn threshold(iso: f64) -> Option<Self> {
        if iso.is_nan() {
            return None;
        }
        // Round iso up to an f32: then `v >= t` in f32 is exactly `v as f64 >= iso`.
        let t = iso as f32;
        if (t as f64) >= iso {
            Some(t)
        } else if t == 0.0 {
            Some(f32::from_bits(1))
        } else if t > 0.0 {
            Some(f32::from_bits(t.to_bits() + 1))
        } else {
            Some(f32::from_bits(t.to_bits() - 1))
        }
    }
    fn threshold_above(iso: f64) -> Option<Self> {
        let t = Self::threshold(iso)?;
        if (t as f64) > iso {
            Some(t)
        } else if t == f32::INFINITY {
            None
        } else {
            // `t` equals iso: the next f32 up (the ordered successor; -0.0 and 0.0 are both 0).
            Some(next_up(t))
        }
    }
}

/// The smallest f32 greater than the finite or −∞ value `t`.
fn next_up(t: f32) -> f32 {
    if t == 0.0 {
        f32::from_bits(1)
    } else if t > 0.0 {
        f32::from_bits(t.to_bits() + 1)
    } else {
        f32::from_bits(t.to_bits() - 1)
    }
}

struct Grid<'a, T> {
    samples: &'a [T],
    dims: [usize; 3],
    spacing: [f64; 3],
    iso: f64,
    threshold: T,
    /// 64-bit words per row of a bit plane.
    words: usize,
}

/// Crossed edges of one family (one axis, one plane): a bit per edge and, per word, the index
/// of the word's first vertex.
struct EdgeRanks {
    bits: Vec<u64>,
    first: Vec<u32>,
}

impl EdgeRanks {
    fn new(len: usize) -> Self {
        EdgeRanks {
            bits: vec![0; len],
            first: vec![0; len],
        }
    }
    /// Vertex index of the edge at word-row `row`, column `i`.
    #[inline(always)]
    fn index(&self, row_start: usize, i: usize) -> u32 {
        let w = row_start + (i >> 6);
        let below = self.bits[w] & ((1u64 << (i & 63)) - 1);
        self.first[w] + below.count_ones()
    }
}

/// The bit planes and edge ranks of one sample plane.
struct Plane {
    inside: Vec<u64>,
    x: EdgeRanks,
    y: EdgeRanks,
}

impl Plane {
    fn new(len: usize) -> Self {
        Plane {
            inside: vec![0; len],
            x: EdgeRanks::new(len),
            y: EdgeRanks::new(len),
        }
    }
}

/// The vertices a slab creates, and which of them lie exactly on a sample.
#[derive(Default)]
struct Vertices {
    positions: Vec<[f32; 3]>,
    /// (vertex index local to the slab, linear sample index), in vertex order.
    on_sample: Vec<(u32, usize)>,
}

impl Vertices {
    #[inline]
    fn push(&mut self, (position, sample): ([f32; 3], Option<usize>)) {
        if let Some(s) = sample {
            self.on_sample.push((self.positions.len() as u32, s));
        }
        self.positions.push(position);
    }
}

struct Slab {
    vertices: Vertices,
    triangles: Vec<[u32; 3]>,
}

fn extract_typed<T: Threshold>(
    volume: &VolumeView,
    samples: &[T],
    iso: f64,
    inside: Inside,
    slab_planes: usize,
    progress: &Progress,
) -> Result<McMesh> {
    let geometry = volume.geometry();
    let Some(threshold) = T::inside_threshold(iso, inside) else {
        progress.advance(geometry.dims[2] as u64);
        return Ok(McMesh::default());
    };
    let dims = geometry.dims;
    let grid = Grid {
        samples,
        dims,
        spacing: geometry.spacing,
        iso,
        threshold,
        words: dims[0].div_ceil(64),
    };
    let slab_planes = slab_planes.max(1);
    let slab_count = dims[2].div_ceil(slab_planes);
    let slabs: Vec<Slab> = (0..slab_count)
        .into_par_iter()
        .map(|s| {
            // A cancelled run stops at the next slab.
            progress.check()?;
            let k0 = s * slab_planes;
            let k1 = (k0 + slab_planes).min(dims[2]);
            let slab = extract_slab(&grid, k0, k1);
            progress.advance((k1 - k0) as u64);
            slab
        })
        .collect::<Result<_>>()?;

    let vertex_count: usize = slabs.iter().map(|s| s.vertices.positions.len()).sum();
    if vertex_count > u32::MAX as usize {
        return Err(too_many_vertices());
    }
    let mut vertex_offsets = Vec::with_capacity(slabs.len());
    let mut triangle_offsets = Vec::with_capacity(slabs.len());
    let (mut v, mut t) = (0usize, 0usize);
    for slab in &slabs {
        vertex_offsets.push(v);
        triangle_offsets.push(t);
        v += slab.vertices.positions.len();
        t += slab.triangles.len();
    }
    let mut positions = vec![[0f32; 3]; v];
    let mut triangles = vec![[0u32; 3]; t];
    let mut position_parts = Vec::with_capacity(slabs.len());
    let mut triangle_parts = Vec::with_capacity(slabs.len());
    let (mut rest_p, mut rest_t) = (&mut positions[..], &mut triangles[..]);
    for slab in &slabs {
        let (p, rp) = rest_p.split_at_mut(slab.vertices.positions.len());
        let (q, rq) = rest_t.split_at_mut(slab.triangles.len());
        position_parts.push(p);
        triangle_parts.push(q);
        rest_p = rp;
        rest_t = rq;
    }
    let on_sample: Vec<(u32, usize)> = slabs
        .iter()
        .zip(&vertex_offsets)
        .flat_map(|(slab, &offset)| {
            slab.vertices
                .on_sample
                .iter()
                .map(move |&(v, s)| (v + offset as u32, s))
        })
        .collect();
    slabs
        .par_iter()
        .zip(position_parts)
        .zip(triangle_parts)
        .zip(vertex_offsets)
        .for_each(|(((slab, p), q), offset)| {
            p.copy_from_slice(&slab.vertices.positions);
            let offset = offset as u32;
            for (dst, src) in q.iter_mut().zip(&slab.triangles) {
                *dst = src.map(|i| i + offset);
            }
        });
    let mut mesh = McMesh {
        positions,
        triangles,
    };
    if !on_sample.is_empty() {
        merge_sample_vertices(&mut mesh, &on_sample);
    }
    Ok(mesh)
}

/// Makes the vertices that lie exactly on the same sample one vertex, and drops the triangles
/// that collapse.
///
/// A crossing lands on a sample when that sample's value equals the isovalue (or an endpoint is
/// infinite); every crossed edge at that sample then has its vertex there. The first of them in
/// vertex order is kept, so the result stays independent of the work split. Triangles of a cell
/// have their vertices on the cell's edges, and three distinct points on a cube's edges are
/// never collinear unless they share an edge (impossible here), so after merging a triangle has
/// zero area exactly when it repeats an index.
fn merge_sample_vertices(mesh: &mut McMesh, on_sample: &[(u32, usize)]) {
    // `target[v]`: the vertex's index after merging and compacting.
    let mut target: Vec<u32> = Vec::with_capacity(mesh.positions.len());
    let mut first_at_sample: HashMap<usize, u32> = HashMap::with_capacity(on_sample.len());
    let mut merged = on_sample.iter().peekable();
    let mut kept = 0u32;
    for v in 0..mesh.positions.len() {
        let mut duplicate_of = None;
        if let Some(&&(w, sample)) = merged.peek() {
            if w as usize == v {
                merged.next();
                match first_at_sample.get(&sample) {
                    Some(&first) => duplicate_of = Some(target[first as usize]),
                    None => {
                        first_at_sample.insert(sample, v as u32);
                    }
                }
            }
        }
        match duplicate_of {
            Some(t) => target.push(t),
            None => {
                mesh.positions[kept as usize] = mesh.positions[v];
                target.push(kept);
                kept += 1;
            }
        }
    }
    mesh.positions.truncate(kept as usize);
    mesh.triangles.retain_mut(|t| {
        *t = t.map(|i| target[i as usize]);
        t[0] != t[1] && t[1] != t[2] && t[0] != t[2]
    });
}

fn too_many_vertices() -> Error {
    Error::too_large("the mesh would have more than 2^32-1 vertices, beyond 32-bit indices")
}

/// Extracts the vertices of the edges owned by planes `k0..k1` and the triangles of the cell
/// layers `k0..min(k1, nz - 1)`, with indices local to the slab.
fn extract_slab<T: Threshold>(grid: &Grid<T>, k0: usize, k1: usize) -> Result<Slab> {
    let [_, ny, nz] = grid.dims;
    let len = ny * grid.words;
    let mut lo = Plane::new(len);
    let mut hi = Plane::new(len);
    let mut z = EdgeRanks::new(len);
    let mut slab = Slab {
        vertices: Vertices::default(),
        triangles: Vec::new(),
    };
    // Vertices numbered so far (including the next slab's, which are only ranked).
    let mut count = 0usize;

    pack_plane(grid, k0, &mut lo.inside);
    rank_xy(grid, k0, &mut lo, &mut count, Some(&mut slab.vertices));
    for k in k0..k1.min(nz - 1) {
        pack_plane(grid, k + 1, &mut hi.inside);
        rank_z(
            grid,
            k,
            &lo.inside,
            &hi.inside,
            &mut z,
            &mut count,
            &mut slab.vertices,
        );
        // The next slab emits plane k1's vertices; here they are only ranked.
        let emit = (k + 1 < k1).then_some(&mut slab.vertices);
        rank_xy(grid, k + 1, &mut hi, &mut count, emit);
        if count > u32::MAX as usize {
            return Err(too_many_vertices());
        }
        emit_cells(grid, &lo, &hi, &z, &mut slab.triangles);
        std::mem::swap(&mut lo, &mut hi);
    }
    Ok(slab)
}

/// Packs `v >= threshold` for plane `k` into bits, 64 samples per word, rows padded with zeros.
fn pack_plane<T: Threshold>(grid: &Grid<T>, k: usize, out: &mut [u64]) {
    let [nx, ny, _] = grid.dims;
    let plane = &grid.samples[nx * ny * k..nx * ny * (k + 1)];
    let threshold = grid.threshold;
    for (row, words) in plane.chunks_exact(nx).zip(out.chunks_exact_mut(grid.words)) {
        let mut bytes = [0u8; 64];
        let full = row.chunks_exact(64);
        let tail = full.remainder();
        for (chunk, word) in full.zip(words.iter_mut()) {
            for (b, &v) in bytes.iter_mut().zip(chunk) {
                *b = (v >= threshold) as u8;
            }
            *word = pack_bytes(&bytes);
        }
        if !tail.is_empty() {
            bytes = [0; 64];
            for (b, &v) in bytes.iter_mut().zip(tail) {
                *b = (v >= threshold) as u8;
            }
            words[words.len() - 1] = pack_bytes(&bytes);
        }
    }
}

/// Gathers 64 bytes that are each 0 or 1 into the bits of a word (byte `n` → bit `n`).
#[inline(always)]
fn pack_bytes(bytes: &[u8; 64]) -> u64 {
    // Multiplying eight 0/1 bytes by this constant sums byte n into bit 56 + n, without carries.
    const GATHER: u64 = 0x0102_0408_1020_4080;
    let mut word = 0;
    for (g, group) in bytes.chunks_exact(8).enumerate() {
        let x = u64::from_le_bytes(group.try_into().unwrap_or([0; 8]));
        word |= (x.wrapping_mul(GATHER) >> 56) << (8 * g);
    }
    word
}

/// Bits `i+1` of `words` moved to bit `i` (the right neighbour of each bit), across word borders.
#[inline(always)]
fn shift_next(words: &[u64], w: usize) -> u64 {
    let next = words.get(w + 1).map_or(0, |&n| n << 63);
    (words[w] >> 1) | next
}

/// Mask of the valid columns of word `w` when only columns `< limit` exist.
#[inline(always)]
fn column_mask(w: usize, limit: usize) -> u64 {
    let start = w * 64;
    if limit >= start + 64 {
        u64::MAX
    } else if limit <= start {
        0
    } else {
        (1u64 << (limit - start)) - 1
    }
}

/// Ranks (and, with `positions`, creates the vertices of) the x- then y-edges of plane `k`.
fn rank_xy<T: Threshold>(
    grid: &Grid<T>,
    k: usize,
    plane: &mut Plane,
    count: &mut usize,
    mut positions: Option<&mut Vertices>,
) {
    let [nx, ny, _] = grid.dims;
    let words = grid.words;
    let base = nx * ny * k;
    for j in 0..ny {
        let row = &plane.inside[j * words..(j + 1) * words];
        for w in 0..words {
            let bits = (row[w] ^ shift_next(row, w)) & column_mask(w, nx - 1);
            plane.x.bits[j * words + w] = bits;
            plane.x.first[j * words + w] = *count as u32;
            *count += bits.count_ones() as usize;
            if let Some(out) = positions.as_deref_mut() {
                for_each_bit(bits, w, |i| {
                    let s = base + nx * j + i;
                    out.push(grid.vertex(s, s + 1, [i, j, k], 0));
                });
            }
        }
    }
    for j in 0..ny {
        for w in 0..words {
            let bits = if j + 1 < ny {
                plane.inside[j * words + w] ^ plane.inside[(j + 1) * words + w]
            } else {
                0
            };
            plane.y.bits[j * words + w] = bits;
            plane.y.first[j * words + w] = *count as u32;
            *count += bits.count_ones() as usize;
            if let Some(out) = positions.as_deref_mut() {
                for_each_bit(bits, w, |i| {
                    let s = base + nx * j + i;
                    out.push(grid.vertex(s, s + nx, [i, j, k], 1));
                });
            }
        }
    }
}

/// Ranks and creates the vertices of the z-edges from plane `k` to `k + 1`.
fn rank_z<T: Threshold>(
    grid: &Grid<T>,
    k: usize,
    lo: &[u64],
    hi: &[u64],
    z: &mut EdgeRanks,
    count: &mut usize,
    positions: &mut Vertices,
) {
    let [nx, ny, _] = grid.dims;
    let words = grid.words;
    let base = nx * ny * k;
    for j in 0..ny {
        for w in 0..words {
            let at = j * words + w;
            let bits = lo[at] ^ hi[at];
            z.bits[at] = bits;
            z.first[at] = *count as u32;
            *count += bits.count_ones() as usize;
            for_each_bit(bits, w, |i| {
                let s = base + nx * j + i;
                positions.push(grid.vertex(s, s + nx * ny, [i, j, k], 2));
            });
        }
    }
}

#[inline(always)]
fn for_each_bit(mut bits: u64, w: usize, mut f: impl FnMut(usize)) {
    while bits != 0 {
        f(w * 64 + bits.trailing_zeros() as usize);
        bits &= bits - 1;
    }
}

impl<T: Threshold> Grid<'_, T> {
    /// The vertex on the edge from sample `s0` (grid position `at`) to `s1` one step along `axis`,
    /// and the sample it lies on when the crossing is exactly at an end of the edge.
    #[inline]
    fn vertex(
        &self,
        s0: usize,
        s1: usize,
        at: [usize; 3],
        axis: usize,
    ) -> ([f32; 3], Option<usize>) {
        let a = self.samples[s0].to_f64();
        let b = self.samples[s1].to_f64();
        let t = (self.iso - a) / (b - a);
        // NaN samples (outside) and infinities give no usable fraction: take the edge midpoint.
        let t = if t.is_nan() { 0.5 } else { t.clamp(0.0, 1.0) };
        let on_sample = if t == 0.0 {
            Some(s0)
        } else if t == 1.0 {
            Some(s1)
        } else {
            None
        };
        let mut p = at.map(|c| c as f64);
        p[axis] += t;
        let position = [
            (p[0] * self.spacing[0]) as f32,
            (p[1] * self.spacing[1]) as f32,
            (p[2] * self.spacing[2]) as f32,
        ];
        (position, on_sample)
    }
}

/// Emits the triangles of the cell layer between planes `lo` and `hi`.
fn emit_cells<T: Threshold>(
    grid: &Grid<T>,
    lo: &Plane,
    hi: &Plane,
    z: &EdgeRanks,
    triangles: &mut Vec<[u32; 3]>,
) {
    let [nx, ny, _] = grid.dims;
    let words = grid.words;
    let table = cases();
    for j in 0..ny.saturating_sub(1) {
        let r0 = j * words;
        let r1 = r0 + words;
        let rows = [
            &lo.inside[r0..r1],
            &lo.inside[r1..r1 + words],
            &hi.inside[r0..r1],
            &hi.inside[r1..r1 + words],
        ];
        for w in 0..words {
            let any = rows[0][w] | rows[1][w] | rows[2][w] | rows[3][w];
            let all = rows[0][w] & rows[1][w] & rows[2][w] & rows[3][w];
            let any_next = shift_next(rows[0], w)
                | shift_next(rows[1], w)
                | shift_next(rows[2], w)
                | shift_next(rows[3], w);
            let all_next = shift_next(rows[0], w)
                & shift_next(rows[1], w)
                & shift_next(rows[2], w)
                & shift_next(rows[3], w);
            let active = (any | any_next) & !(all & all_next) & column_mask(w, nx - 1);
            for_each_bit(active, w, |i| {
                let pattern = rows
                    .iter()
                    .enumerate()
                    .fold(0usize, |p, (r, row)| p | bit_pair(row, i) << (2 * r));
                let case = &table[pattern];
                let mut index = [0u32; 12];
                let mut mask = case.edge_mask;
                while mask != 0 {
                    let e = mask.trailing_zeros() as u8;
                    mask &= mask - 1;
                    index[e as usize] = edge_index(e, i, r0, r1, lo, hi, z);
                }
                for t in &case.triangles[..case.triangle_count as usize] {
                    triangles.push(t.map(|e| index[e as usize]));
                }
            });
        }
    }
}

/// Bits `i` and `i + 1` of a bit row, as a 2-bit number.
#[inline(always)]
fn bit_pair(row: &[u64], i: usize) -> usize {
    let (w, b) = (i >> 6, i & 63);
    let low = row[w] >> b;
    let high = if b == 63 { row[w + 1] << 1 } else { 0 };
    ((low | high) & 3) as usize
}

/// Vertex index of edge `e` of the cell at column `i` between rows starting at `r0` and `r1`.
#[inline(always)]
fn edge_index(e: u8, i: usize, r0: usize, r1: usize, lo: &Plane, hi: &Plane, z: &EdgeRanks) -> u32 {
    let (lower, _) = edge_corners(e);
    let column = i + (lower & 1) as usize;
    let row = if lower & 2 != 0 { r1 } else { r0 };
    let plane = if lower & 4 != 0 { hi } else { lo };
    match e / 4 {
        0 => plane.x.index(row, column),
        1 => plane.y.index(row, column),
        _ => z.index(row, column),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pack_bytes_puts_byte_n_at_bit_n() {
        for pattern in 0..=255u64 {
            for shift in [0, 8, 56] {
                let word = pattern << shift;
                let bytes: [u8; 64] = std::array::from_fn(|n| (word >> n & 1) as u8);
                assert_eq!(pack_bytes(&bytes), word);
            }
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..1000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let bytes: [u8; 64] = std::array::from_fn(|n| (seed >> n & 1) as u8);
            assert_eq!(pack_bytes(&bytes), seed);
        }
    }

    #[test]
    fn thresholds_match_f64_comparison() {
        let isos = [
            -1e9,
            -32768.5,
            -32768.0,
            -1.5,
            -0.0,
            0.0,
            1e-300,
            0.5,
            1.0,
            127.5,
            255.0,
            255.5,
            65535.0,
            65535.2,
            1e9,
            0.1,
            16_777_217.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for iso in isos {
            for v in 0..=255u8 {
                let t = u8::threshold(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 >= iso, "u8 {v} {iso}");
                let t = u8::threshold_above(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 > iso, "u8 > {v} {iso}");
            }
            for v in [i16::MIN, -2, -1, 0, 1, 127, 128, 255, 256, i16::MAX] {
                let t = i16::threshold(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 >= iso, "i16 {v} {iso}");
                let t = i16::threshold_above(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 > iso, "i16 > {v} {iso}");
            }
            for v in [0u16, 1, 255, 256, 65534, 65535] {
                let t = u16::threshold(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 >= iso, "u16 {v} {iso}");
                let t = u16::threshold_above(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 > iso, "u16 > {v} {iso}");
            }
            let floats = [
                f32::NEG_INFINITY,
                -1e9,
                -1.5,
                -0.0,
                0.0,
                f32::from_bits(1),
                0.1,
                0.5,
                127.5,
                255.5,
                16_777_216.0,
                16_777_218.0,
                f32::MAX,
                f32::INFINITY,
                f32::NAN,
            ];
            for v in floats {
                let t = f32::threshold(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 >= iso, "f32 {v} {iso}");
                let t = f32::threshold_above(iso);
                assert_eq!(t.is_some_and(|t| v >= t), v as f64 > iso, "f32 > {v} {iso}");
            }
        }
        assert!(u8::threshold(f64::NAN).is_none());
        assert!(f32::threshold(f64::NAN).is_none());
    }
}

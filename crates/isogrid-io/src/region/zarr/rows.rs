//! Slab reads of a Zarr array chunk by chunk, for arrays whose last three axes are z, y and x (the
//! C order of every OME-Zarr image and of numpy-written volumes).
//!
//! zarrs' `retrieve_array_subset` assembles a subset through an index iterator that walks every
//! contiguous run of a chunk (64 samples for 64³ chunks) and then copies the whole subset into
//! the typed `Vec` it returns; on a 2048³ volume that assembly, not zstd, was most of the read.
//! Here each chunk is decoded on its own (in parallel over the chunks of a *chunk row*, the
//! chunks that share one z range) and its x-runs are copied straight into the caller's slab,
//! converting the type on the way; the decoded bytes are read in place, and a chunk never written
//! (the fill value, as the specs say) is not decoded at all but filled in.
//!
//! A slab of `16·k + 1` planes rarely ends on a chunk boundary, so the chunk row holding its last
//! planes is also the first row of the next slab. That row's planes from the slab's halo plane on
//! are kept (one row's planes at most), and the next read takes them from there instead of
//! decoding the row again, so a whole stream decodes each chunk once per pass. The emit pass asks
//! only for the samples of active blocks, and then only the chunks holding some are decoded.

use isogrid::extract::stream::BlockMask;
use isogrid::{Error, Result};
use rayon::prelude::*;
use std::any::Any;
use std::borrow::Cow;
use std::ops::Range;
use zarrs::array::{
    Array, ArrayBytes, ArrayShardedExt, ArraySubset, CodecOptions, DataType, ElementOwned,
};
use zarrs::storage::ReadableStorageTraits;

/// Reads planes of an array whose axes are `[fixed…, z, y, x]`.
pub(super) struct ChunkRows {
    /// Array dimensionality, and the index picked on each leading (non-spatial) axis.
    fixed: Vec<u64>,
    /// Samples along x, y, z.
    dims: [usize; 3],
    /// z extent of the chunk rows (the first chunk's; a regular grid's for all).
    row_depth: usize,
    kept: Option<KeptRow>,
}

/// The planes `planes` of chunk row `row`, decoded by the previous read.
struct KeptRow {
    row: u64,
    planes: Range<usize>,
    /// A `Vec<K>` of the slab's sample type.
    samples: Box<dyn Any + Send + Sync>,
}

/// A slab that chunk copies on several threads write at once, each into places no other writes.
struct SharedSlab<K> {
    start: *mut K,
    len: usize,
}

// SAFETY: the pointer comes from a `&mut [K]` that outlives every use (the parallel loop of
// `ChunkRows::read` borrows it for its whole duration), and writers touch disjoint elements.
unsafe impl<K: Send> Send for SharedSlab<K> {}
unsafe impl<K: Send> Sync for SharedSlab<K> {}

impl<K> SharedSlab<K> {
    fn new(samples: &mut [K]) -> Self {
        SharedSlab {
            start: samples.as_mut_ptr(),
            len: samples.len(),
        }
    }

    /// `len` elements from `at`.
    ///
    /// # Safety
    /// No other live reference may cover any of these elements.
    #[allow(clippy::mut_from_ref)]
    unsafe fn run(&self, at: usize, len: usize) -> &mut [K] {
        assert!(
            at <= self.len && len <= self.len - at,
            "run outside the slab"
        );
        // SAFETY: in bounds (asserted); exclusive by the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.start.add(at), len) }
    }
}

/// Where one chunk row's samples go: planes `planes` of the volume, into `samples`, which holds
/// planes from `first_plane` on.
struct Destination<'a, K> {
    planes: Range<usize>,
    first_plane: usize,
    /// Samples along x and y of each plane.
    plane_dims: [usize; 2],
    samples: &'a SharedSlab<K>,
}

impl ChunkRows {
    /// A reader for `array` when its last three axes are z, y, x (`spatial` is x, y, z's axes),
    /// every other axis has a fixed index and it is not sharded; `None` otherwise. (A shard is
    /// one chunk of the outer grid, often hundreds of planes deep: zarrs' subset read decodes
    /// only the inner chunks a slab needs, and fetches only those over HTTP.)
    pub(super) fn new(
        array: &Array<dyn ReadableStorageTraits>,
        spatial: [usize; 3],
        fixed: &[(usize, u64)],
        dims: [usize; 3],
    ) -> Option<Self> {
        let n = array.dimensionality();
        if n < 3 || spatial != [n - 1, n - 2, n - 3] || fixed.len() != n - 3 || array.is_sharded() {
            return None;
        }
        let mut lead = vec![0u64; n - 3];
        for &(axis, index) in fixed {
            *lead.get_mut(axis)? = index;
        }
        let first = array.chunk_shape(&vec![0; n]).ok()?;
        let row_depth = usize::try_from(first[n - 3].get()).ok()?;
        Some(ChunkRows {
            fixed: lead,
            dims,
            row_depth,
            kept: None,
        })
    }

    /// z extent of a chunk row.
    pub(super) fn row_depth(&self) -> usize {
        self.row_depth
    }

    /// Planes of the row a slab of `planes` planes keeps for the next one (0 where a row is
    /// deeper than the slab: keeping it would cost more memory than decoding it twice).
    pub(super) fn kept_planes(&self, planes: usize) -> usize {
        if self.row_depth <= planes {
            self.row_depth
        } else {
            0
        }
    }

    /// Reads planes `z` into `out` (C order, x fastest), converting each sample with `convert`;
    /// with `wanted`, only the chunks that hold samples of the wanted blocks (and nothing is kept
    /// for the next read, as the rows are incomplete).
    pub(super) fn read<S, K>(
        &mut self,
        array: &Array<dyn ReadableStorageTraits>,
        location: &str,
        z: Range<usize>,
        out: &mut [K],
        wanted: Option<&BlockMask>,
        convert: impl Fn(S) -> K + Sync,
    ) -> Result<()>
    where
        S: ChunkElement,
        K: Copy + Default + Send + Sync + 'static,
    {
        let [nx, ny, nz] = self.dims;
        let fill = fill_value::<S>(array).map_err(|e| e.with_path(location))?;
        let plane = nx * ny;
        assert_eq!(out.len(), plane * z.len(), "slab buffer of the wrong size");
        if z.is_empty() {
            return Ok(());
        }
        let n = array.dimensionality();
        let mut ranges: Vec<Range<u64>> = self.fixed.iter().map(|&i| i..i + 1).collect();
        ranges.extend([z.start as u64..z.end as u64, 0..ny as u64, 0..nx as u64]);
        let subset = ArraySubset::new_with_ranges(&ranges);
        let chunks = match array.chunks_in_array_subset(&subset) {
            Ok(Some(chunks)) => chunks,
            _ => {
                return Err(Error::corrupt(format!(
                    "the Zarr chunk grid does not cover planes {}..{}",
                    z.start, z.end
                ))
                .with_path(location))
            }
        };
        let (first, end) = (chunks.start().to_vec(), chunks.end_exc());
        let keep_row = wanted.is_none() && self.kept_planes(z.len()) > 0;
        let shared_out = SharedSlab::new(out);
        for row in first[n - 3]..end[n - 3] {
            let mut indices = first.clone();
            indices[n - 3] = row;
            let row_planes = bounded(array, &indices, n - 3, nz, location)?;
            let needed = z.start.max(row_planes.start)..z.end.min(row_planes.end);
            let at = (needed.start - z.start) * plane;

            if let Some(kept) = &self.kept {
                if kept.row == row
                    && kept.planes.start <= needed.start
                    && needed.end <= kept.planes.end
                {
                    let samples = kept
                        .samples
                        .downcast_ref::<Vec<K>>()
                        .expect("a kept row has the slab's sample type");
                    let from = (needed.start - kept.planes.start) * plane;
                    // SAFETY: no chunk copy runs; this is the only reference into `out`.
                    let dst = unsafe { shared_out.run(at, needed.len() * plane) };
                    dst.copy_from_slice(&samples[from..from + needed.len() * plane]);
                    continue;
                }
            }

            // The last row goes on past the slab: keep its planes from the halo plane on (the
            // next slab starts there, or one plane later for reads that do not overlap).
            let keep = if keep_row && row + 1 == end[n - 3] && row_planes.end > z.end {
                row_planes.start.max(z.end - 1)..row_planes.end
            } else {
                0..0
            };
            let mut kept_samples: Vec<K> = match self.kept.take() {
                Some(kept) => *kept
                    .samples
                    .downcast::<Vec<K>>()
                    .expect("a kept row has the slab's sample type"),
                None => Vec::new(),
            };
            kept_samples.clear();
            kept_samples.resize(keep.len() * plane, K::default());
            let shared_kept = SharedSlab::new(&mut kept_samples);
            let destinations = [
                Destination {
                    planes: needed.clone(),
                    first_plane: z.start,
                    plane_dims: [nx, ny],
                    samples: &shared_out,
                },
                Destination {
                    planes: keep.clone(),
                    first_plane: keep.start,
                    plane_dims: [nx, ny],
                    samples: &shared_kept,
                },
            ];

            let mut row_chunks = Vec::new();
            for y in first[n - 2]..end[n - 2] {
                for x in first[n - 1]..end[n - 1] {
                    let mut chunk = indices.clone();
                    chunk[n - 2] = y;
                    chunk[n - 1] = x;
                    if let Some(mask) = wanted {
                        let (origin, shape) = chunk_box(array, &chunk, location)?;
                        let [x0, y0] = [origin[n - 1], origin[n - 2]].map(|o| o as usize);
                        let xs = x0..(x0 + shape[n - 1]).min(nx);
                        let ys = y0..(y0 + shape[n - 2]).min(ny);
                        if !mask.touches(xs, ys) {
                            continue;
                        }
                    }
                    row_chunks.push(chunk);
                }
            }
            row_chunks.par_iter().try_for_each(|chunk| {
                self.copy_chunk::<S, K>(array, location, chunk, &destinations, fill, &convert)
            })?;
            if !keep.is_empty() {
                self.kept = Some(KeptRow {
                    row,
                    planes: keep,
                    samples: Box::new(kept_samples),
                });
            }
        }
        Ok(())
    }

    /// Decodes one chunk and copies its x-runs into every destination that holds its planes.
    fn copy_chunk<S, K>(
        &self,
        array: &Array<dyn ReadableStorageTraits>,
        location: &str,
        chunk: &[u64],
        destinations: &[Destination<'_, K>],
        fill: S,
        convert: &(impl Fn(S) -> K + Sync),
    ) -> Result<()>
    where
        S: ChunkElement,
        K: Copy + Send,
    {
        let [nx, ny, _] = self.dims;
        let n = chunk.len();
        let (origin, shape) = chunk_box(array, chunk, location)?;
        // One chunk at a time per thread: the parallelism is over the chunks.
        let options = CodecOptions::default().with_concurrent_target(1);
        let fail = |e: &dyn std::fmt::Display| {
            let key = array.chunk_key(chunk);
            Error::corrupt(format!("chunk {key} (indices {chunk:?}): {e}")).with_path(location)
        };
        let decoded = array
            .retrieve_chunk_if_exists_opt::<ArrayBytes<'static>>(chunk, &options)
            .map_err(|e| fail(&e))?;
        let [cz0, cy0, cx0] = [origin[n - 3], origin[n - 2], origin[n - 1]].map(|o| o as usize);
        let ys = cy0..(cy0 + shape[n - 2]).min(ny);
        let xs = cx0..(cx0 + shape[n - 1]).min(nx);
        let chunk_planes = cz0..cz0 + shape[n - 3];
        let Some(decoded) = decoded else {
            // A chunk never written holds the fill value (the Zarr specs): no decode, no copy.
            let value = convert(fill);
            for_each_run(destinations, &chunk_planes, &ys, &xs, |_, _, dst| {
                dst.fill(value)
            });
            return Ok(());
        };
        let bytes = decoded.into_fixed().map_err(|e| fail(&e))?;
        let samples = S::view(&bytes, array.data_type()).map_err(|e| fail(&e))?;
        if samples.len() != shape.iter().product::<usize>() {
            let what = format!(
                "decoded to {} samples, not the {shape:?} of its chunk",
                samples.len()
            );
            return Err(fail(&what));
        }
        // Chunk-local C-order strides; the leading axes sit at their fixed index.
        let mut stride = vec![1usize; n];
        for a in (0..n - 1).rev() {
            stride[a] = stride[a + 1] * shape[a + 1];
        }
        let lead: usize = (0..n - 3)
            .map(|a| (self.fixed[a] - origin[a]) as usize * stride[a])
            .sum();
        for_each_run(destinations, &chunk_planes, &ys, &xs, |zz, y, dst| {
            let from = lead + (zz - cz0) * stride[n - 3] + (y - cy0) * stride[n - 2];
            for (o, &v) in dst.iter_mut().zip(&samples[from..from + xs.len()]) {
                *o = convert(v);
            }
        });
        Ok(())
    }
}

/// Calls `write(z, y, run)` with each x-run (columns `xs` of row `y` of plane `z`) of a chunk
/// spanning `planes`, `ys` and `xs` in every destination holding some of its planes.
fn for_each_run<K>(
    destinations: &[Destination<'_, K>],
    planes: &Range<usize>,
    ys: &Range<usize>,
    xs: &Range<usize>,
    mut write: impl FnMut(usize, usize, &mut [K]),
) {
    for destination in destinations {
        let [nx, ny] = destination.plane_dims;
        let overlap =
            destination.planes.start.max(planes.start)..destination.planes.end.min(planes.end);
        for z in overlap {
            for y in ys.clone() {
                let at = ((z - destination.first_plane) * ny + y) * nx + xs.start;
                // SAFETY: the chunks of one row cover disjoint (x, y) boxes, so this run of plane
                // `z`, row `y`, columns `xs` is written by this chunk alone.
                write(z, y, unsafe { destination.samples.run(at, xs.len()) });
            }
        }
    }
}

/// Stored element types, seen in a decoded chunk's native-order bytes without a copy where the
/// bytes are aligned for them (a fresh allocation always is).
pub(super) trait ChunkElement: ElementOwned + Copy + Send + Sync {
    fn view<'a>(bytes: &'a [u8], data_type: &DataType) -> Result<Cow<'a, [Self]>>;
}

macro_rules! chunk_element_pod {
    ($($t:ty),*) => {$(
        impl ChunkElement for $t {
            fn view<'a>(bytes: &'a [u8], _: &DataType) -> Result<Cow<'a, [Self]>> {
                Ok(match bytemuck::try_cast_slice(bytes) {
                    Ok(samples) => Cow::Borrowed(samples),
                    Err(_) => Cow::Owned(bytemuck::pod_collect_to_vec(bytes)),
                })
            }
        }
    )*};
}
chunk_element_pod!(u8, i8, u16, i16, u32, i32, u64, i64, f32, f64);

impl ChunkElement for bool {
    fn view<'a>(bytes: &'a [u8], data_type: &DataType) -> Result<Cow<'a, [Self]>> {
        // Not every byte is a bool: zarrs checks them.
        bool::from_array_bytes(data_type, ArrayBytes::new_flen(Cow::Borrowed(bytes)))
            .map(Cow::Owned)
            .map_err(|e| Error::corrupt(e.to_string()))
    }
}

/// The origin and shape of the chunk at `indices` (a whole chunk, also where the array ends).
fn chunk_box(
    array: &Array<dyn ReadableStorageTraits>,
    indices: &[u64],
    location: &str,
) -> Result<(Vec<u64>, Vec<usize>)> {
    let bad = |e: zarrs::array::ArrayError| Error::corrupt(e.to_string()).with_path(location);
    let origin = array.chunk_origin(indices).map_err(bad)?;
    let shape = array.chunk_shape(indices).map_err(bad)?;
    Ok((
        origin.to_vec(),
        shape.iter().map(|s| s.get() as usize).collect(),
    ))
}

/// The planes of chunk row `indices[axis]`, within the volume's `nz`.
fn bounded(
    array: &Array<dyn ReadableStorageTraits>,
    indices: &[u64],
    axis: usize,
    nz: usize,
    location: &str,
) -> Result<Range<usize>> {
    let (origin, shape) = chunk_box(array, indices, location)?;
    let start = (origin[axis] as usize).min(nz);
    Ok(start..(start + shape[axis]).min(nz))
}

/// The array's fill value as a stored element.
fn fill_value<S: ElementOwned>(array: &Array<dyn ReadableStorageTraits>) -> Result<S> {
    let bytes = ArrayBytes::new_fill_value(array.data_type(), 1, array.fill_value())
        .map_err(|e| Error::corrupt(format!("the fill value: {e}")))?;
    S::from_array_bytes(array.data_type(), bytes)
        .ok()
        .and_then(|v| v.into_iter().next())
        .ok_or_else(|| Error::corrupt("the fill value is not an element of the array's type"))
}

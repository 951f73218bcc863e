//! Uncompressed raw, NRRD and NIfTI-1 files read plane range by plane range.
//!
//! Samples stored as they are kept (u8, u16, i16, f32, unscaled) are read with one positioned
//! read straight into the slab, byte-swapped in place where the file's order is not the
//! machine's: one copy out of the page cache, with no page faults and no map to tear down.
//! Samples that must be converted are read a bounded chunk at a time into a reused buffer and
//! converted exactly as the in-memory readers convert them (the same `read_samples`), so both
//! paths see the same values. Nothing is memory-mapped: a file truncated by another process while
//! it is read ends in an error naming it, where a mapped page past the new end would kill the
//! process with SIGBUS.

use crate::mapped_layout::MappedLayout;
use crate::samples::{read_samples, rescaled, rescaled_type, ElemType};
use isogrid::extract::stream::{RegionSource, SlabMut};
use isogrid::{Error, Geometry, Result, ResultExt, ScalarType, VolumeData};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::ops::Range;
use std::path::Path;

/// Bytes converted at a time: bounds the temporary of the conversion.
const CONVERT_BYTES: usize = 4 << 20;

/// A file read plane range by plane range with positioned reads.
pub struct MappedSource {
    layout: MappedLayout,
    file: File,
    scalar: ScalarType,
    /// The stored bytes of one chunk of samples that are converted.
    chunk: Vec<u8>,
}

impl MappedSource {
    pub(crate) fn open(layout: MappedLayout) -> Result<Self> {
        let file = File::open(&layout.data_path).at_path(&layout.data_path)?;
        // The kept type: what `read_samples` (and rescaling) turns the stored type into.
        let scalar = match layout.scale {
            Some((slope, inter)) => rescaled_type(layout.elem, slope, inter),
            None => layout.elem.kept(),
        };
        Ok(MappedSource {
            layout,
            file,
            scalar,
            chunk: Vec::new(),
        })
    }

    fn read(&mut self, z: Range<usize>, mut out: SlabMut<'_>) -> Result<()> {
        let [nx, ny, _] = self.layout.geometry.dims;
        let size = self.layout.elem.size();
        let plane_bytes = (nx * ny * size) as u64;
        let offset = self.layout.data_offset + z.start as u64 * plane_bytes;
        let len = z.len() as u64 * plane_bytes;
        if len == 0 {
            return Ok(());
        }
        if self.stored_as_kept() {
            read_exact_at(&self.file, offset, out.as_bytes_mut())?;
            if self.layout.big_endian != cfg!(target_endian = "big") {
                out.swap_bytes();
            }
            return Ok(());
        }
        let per_chunk = (CONVERT_BYTES / size).max(1) as u64 * size as u64;
        let mut done = 0u64;
        while done < len {
            let chunk = per_chunk.min(len - done);
            self.chunk.resize(chunk as usize, 0);
            read_exact_at(&self.file, offset + done, &mut self.chunk)?;
            let count = chunk as usize / size;
            let data = read_samples(
                &mut &self.chunk[..],
                self.layout.elem,
                self.layout.big_endian,
                count,
            )?;
            let data = match self.layout.scale {
                Some((slope, inter)) => rescaled(&data, self.layout.elem, slope, inter),
                None => data,
            };
            copy_into(&data, &mut out, (done / size as u64) as usize)?;
            done += chunk;
        }
        Ok(())
    }
}

/// Fills `buf` from byte `offset` of `file`; a file that ends first (truncated since it was opened
/// and checked) is an error saying so.
fn read_exact_at(mut file: &File, offset: u64, buf: &mut [u8]) -> Result<()> {
    file.seek(SeekFrom::Start(offset))?;
    file.read_exact(buf).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => Error::invalid(format!(
            "the data ends before byte {}: the file is shorter than its header declares \
             (truncated while it was read?)",
            offset + buf.len() as u64
        )),
        _ => e.into(),
    })
}

/// Copies `data` into `out` from sample `at` on.
fn copy_into(data: &VolumeData, out: &mut SlabMut<'_>, at: usize) -> Result<()> {
    match (data, out) {
        (VolumeData::U8(d), SlabMut::U8(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::U16(d), SlabMut::U16(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::I16(d), SlabMut::I16(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::F32(d), SlabMut::F32(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::U32(d), SlabMut::U32(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::I32(d), SlabMut::I32(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::U64(d), SlabMut::U64(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::I64(d), SlabMut::I64(o)) => o[at..at + d.len()].copy_from_slice(d),
        (VolumeData::F64(d), SlabMut::F64(o)) => o[at..at + d.len()].copy_from_slice(d),
        _ => return Err(Error::invalid("slab buffer type differs from the file's")),
    }
    Ok(())
}

impl MappedSource {
    /// Whether the stored samples are the kept ones, byte order aside.
    fn stored_as_kept(&self) -> bool {
        self.layout.scale.is_none() && ElemType::of(self.scalar) == self.layout.elem
    }
}

impl RegionSource for MappedSource {
    fn geometry(&self) -> Geometry {
        self.layout.geometry
    }
    fn scalar_type(&self) -> ScalarType {
        self.scalar
    }
    fn read_planes(&mut self, z: Range<usize>, out: SlabMut<'_>) -> Result<()> {
        let path = self.layout.data_path.clone();
        self.read(z, out).at_path(&path)
    }
    fn read_overhead(&self, _planes: usize) -> u64 {
        if self.stored_as_kept() {
            return 0;
        }
        // One chunk of stored bytes, its converted samples and, for scaled data, their scaled copy.
        let samples = (CONVERT_BYTES / self.layout.elem.size()) as u64;
        let scaled = if self.layout.scale.is_some() { 8 } else { 0 };
        CONVERT_BYTES as u64 + samples * (self.scalar.size() as u64 + scaled)
    }
}

/// A raw file as described by its spec.
pub(crate) fn raw_layout(path: &Path, spec: &crate::RawSpec) -> Result<MappedLayout> {
    let count = crate::samples::sample_count(spec.dims).at_path(path)?;
    let elem = ElemType::of(spec.scalar);
    // A FIFO or a device has no length to check: name what it is.
    isogrid::fs::ensure_regular(path)?;
    let actual = std::fs::metadata(path).at_path(path)?.len();
    let expected = count as u64 * spec.scalar.size() as u64;
    if actual != expected {
        let [nx, ny, nz] = spec.dims;
        return Err(Error::invalid(format!(
            "raw size mismatch: {nx}x{ny}x{nz} {} needs {expected} bytes but the file has {actual}",
            spec.scalar.name()
        ))
        .with_path(path));
    }
    Ok(MappedLayout {
        data_path: path.to_path_buf(),
        data_offset: 0,
        elem,
        big_endian: spec.big_endian,
        geometry: Geometry::new(spec.dims),
        scale: None,
    })
}

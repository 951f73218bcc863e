//! Reading NRRD data: the header (see `header.rs`), then the samples from the attached data or
//! the detached data file(s), decoded as raw, gzip or ascii.
//!
//! Follows the Teem NRRD spec: `line skip` lines are skipped first, on the file as stored; then
//! `byte skip` bytes, on the raw bytes for raw encoding and on the *decompressed* stream for gzip;
//! `byte skip: -1` (raw only) means the data is the last bytes of the file. Every declared size is
//! checked against the file before allocating, and a gzip stream must decompress to exactly the
//! declared byte count.
//!
//! Geometry: spacing from `space directions` (vector lengths) or else `spacings` (`nan` = no
//! spacing for that axis, as the spec says, and becomes 1; 0 or a zero-length direction vector is
//! an error; a negative spacing flips the axis, see `geometry.rs`); origin from
//! `space origin`; directions (unit `space directions`) kept as metadata. Grid order is the file's
//! (first axis fastest). A 4-D file whose first axis has no space direction (a layered 3D Slicer
//! segmentation) holds one volume per entry of that axis: read as labels
//! ([`crate::labels`]), refused as one volume.

use super::header::{self, clip, DataFiles, Encoding, Header};
use crate::data_file::resolve;
use crate::geometry::geometry;
use crate::samples::{
    byte_count, check_available, check_deflate_budget, expect_end, gzip_error, read_samples,
    read_text_samples, sample_count, skip_bytes,
};
use isogrid::{Error, Result, ResultExt, Volume, VolumeData};
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Headers longer than this are not NRRD headers (they are garbage or binary data).
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Reads an attached `.nrrd` or a detached `.nhdr` (+ data files). Errors name the file at fault.
pub fn read_nrrd(path: &Path) -> Result<Volume> {
    let (mut layers, _) = read_nrrd_layers(path, false)?;
    Ok(layers.remove(0))
}

/// A NRRD file's `key:=value` pairs, in file order.
pub(crate) type KeyValues = Vec<(String, String)>;

/// A NRRD file's volumes along a leading non-spatial axis (one for a 3-D file; the layers of a
/// layered 3D Slicer segmentation), and its `key:=value` pairs. Without `layered`, a file with
/// more than one is refused.
pub(crate) fn read_nrrd_layers(path: &Path, layered: bool) -> Result<(Vec<Volume>, KeyValues)> {
    let file = isogrid::fs::open_regular(path)?;
    let mut reader = BufReader::new(file);
    let (lines, data_offset) = read_header_lines(&mut reader).at_path(path)?;
    let header = header::parse(&lines).at_path(path)?;
    if header.layers > 1 && !layered {
        return Err(layers_refused(header.layers).with_path(path));
    }
    let count = sample_count(header.dims)
        .and_then(|c| {
            c.checked_mul(header.layers)
                .ok_or_else(|| Error::too_large("the layers hold more samples than fit in memory"))
        })
        .at_path(path)?;
    // Before the data: a bad spacing fails without reading gigabytes.
    let g = geometry(
        header.dims,
        header.spacing,
        header.origin,
        header.direction,
        header.frame,
    )
    .at_path(path)?;
    let data = match &header.data {
        DataFiles::Attached => {
            let offset = data_offset.ok_or_else(|| {
                Error::corrupt("NRRD header names no data file and has no attached data")
                    .with_path(path)
            })?;
            read_part(reader.into_inner(), offset, &header, count).at_path(path)?
        }
        DataFiles::Detached(names) => {
            let base = path.parent().unwrap_or(Path::new("."));
            if count % names.len() != 0 {
                return Err(Error::corrupt(format!(
                    "{count} samples cannot be split evenly over {} data files",
                    names.len()
                ))
                .with_path(path));
            }
            let part = count / names.len();
            let mut data: Option<VolumeData> = None;
            for name in names {
                let data_path = resolve(base, name);
                let file = isogrid::fs::open_regular(&data_path)?;
                let piece = read_part(file, 0, &header, part).at_path(&data_path)?;
                data = Some(match data {
                    None => piece,
                    // Every piece is decoded with the same element type, so the variants always match.
                    Some(d) => crate::samples::append(d, piece).unwrap_or_else(|(a, _)| a),
                });
            }
            data.ok_or_else(|| Error::corrupt("no data files").with_path(path))?
        }
    };
    let volumes = if header.layers == 1 {
        vec![Volume::with_geometry(g, data).at_path(path)?]
    } else {
        let parts = split_layers(&data, header.layers);
        drop(data);
        parts
            .into_iter()
            .map(|d| Volume::with_geometry(g, d).at_path(path))
            .collect::<Result<_>>()?
    };
    Ok((volumes, header.key_values))
}

/// The refusal of a layered file where one volume is read.
fn layers_refused(layers: usize) -> Error {
    Error::unsupported(format!(
        "the NRRD file holds {layers} volumes along its first axis (a layered segmentation): \
         it is read as labels (`--labels`), one volume at a time is not read"
    ))
}

/// The volumes of interleaved samples, entry `l` of every `layers` consecutive samples being
/// volume `l`'s; one pass over the samples.
fn split_layers(data: &VolumeData, layers: usize) -> Vec<VolumeData> {
    fn split<T: Copy>(v: &[T], layers: usize) -> Vec<Vec<T>> {
        let mut out: Vec<Vec<T>> = (0..layers)
            .map(|_| Vec::with_capacity(v.len() / layers))
            .collect();
        for entries in v.chunks_exact(layers) {
            for (o, &e) in out.iter_mut().zip(entries) {
                o.push(e);
            }
        }
        out
    }
    macro_rules! each {
        ($($t:ident),*) => {
            match data {
                $(VolumeData::$t(v) => split(v, layers).into_iter().map(VolumeData::$t).collect(),)*
            }
        };
    }
    each!(U8, U16, I16, F32, U32, I32, U64, I64, F64)
}

/// The data files a detached NRRD header at `path` names (none for attached data), resolved
/// against its folder; `None` when the header does not parse (reading it fails anyway).
pub(crate) fn data_files(path: &Path) -> Option<Vec<std::path::PathBuf>> {
    let mut reader = BufReader::new(isogrid::fs::open_regular(path).ok()?);
    let (lines, _) = read_header_lines(&mut reader).ok()?;
    let header = header::parse(&lines).ok()?;
    let base = path.parent().unwrap_or(Path::new("."));
    Some(match &header.data {
        DataFiles::Attached => Vec::new(),
        DataFiles::Detached(names) => names.iter().map(|n| resolve(base, n)).collect(),
    })
}

/// The layer count and `key:=value` pairs of a NRRD's header, without its samples. Errors name
/// the file.
pub(crate) fn header_layers_and_keys(path: &Path) -> Result<(usize, KeyValues)> {
    let mut reader = BufReader::new(isogrid::fs::open_regular(path)?);
    let (lines, _) = read_header_lines(&mut reader).at_path(path)?;
    let header = header::parse(&lines).at_path(path)?;
    Ok((header.layers, header.key_values))
}

/// Where a raw-encoded NRRD (attached, or detached into one file, without line skips) keeps its
/// samples, for reading by region; `None` for other encodings and layouts, which are read whole.
/// Errors name the file at fault.
pub(crate) fn region_layout(path: &Path) -> Result<Option<crate::mapped_layout::MappedLayout>> {
    let file = isogrid::fs::open_regular(path)?;
    let mut reader = BufReader::new(file);
    let (lines, data_offset) = read_header_lines(&mut reader).at_path(path)?;
    let header = header::parse(&lines).at_path(path)?;
    if header.layers > 1 {
        return Err(layers_refused(header.layers).with_path(path));
    }
    if !matches!(header.encoding, Encoding::Raw) || header.line_skip != 0 {
        return Ok(None);
    }
    let count = sample_count(header.dims).at_path(path)?;
    let needed = byte_count(count, header.elem).at_path(path)?;
    let (data_path, start) = match &header.data {
        DataFiles::Attached => match data_offset {
            Some(offset) => (path.to_path_buf(), offset),
            None => {
                return Err(Error::corrupt(
                    "NRRD header names no data file and has no attached data",
                )
                .with_path(path))
            }
        },
        DataFiles::Detached(names) if names.len() == 1 => (
            resolve(path.parent().unwrap_or(Path::new(".")), &names[0]),
            0,
        ),
        DataFiles::Detached(_) => return Ok(None),
    };
    // A FIFO or a device has no length to check (and /dev/zero never ends): name what it is.
    isogrid::fs::ensure_regular(&data_path)?;
    let file_len = std::fs::metadata(&data_path).at_path(&data_path)?.len();
    let available = file_len.saturating_sub(start);
    let data_offset = if header.byte_skip == -1 {
        check_available(needed, available).at_path(&data_path)?;
        file_len - needed
    } else {
        let skip = header.byte_skip as u64;
        check_available(needed.saturating_add(skip), available).at_path(&data_path)?;
        start + skip
    };
    Ok(Some(crate::mapped_layout::MappedLayout {
        data_path,
        data_offset,
        elem: header.elem,
        big_endian: header.big_endian,
        geometry: geometry(
            header.dims,
            header.spacing,
            header.origin,
            header.direction,
            header.frame,
        )
        .at_path(path)?,
        scale: None,
    }))
}

/// Reads the magic line and the header lines. Returns the lines and, when a blank line ended the
/// header, the byte offset right after it (where attached data starts).
fn read_header_lines<R: BufRead>(reader: &mut R) -> Result<(Vec<String>, Option<u64>)> {
    let mut limited = reader.take(MAX_HEADER_BYTES);
    let mut offset = 0u64;
    let mut lines = Vec::new();
    let mut raw = Vec::new();
    let mut first = true;
    loop {
        raw.clear();
        let n = limited.read_until(b'\n', &mut raw)?;
        if n == 0 {
            if offset >= MAX_HEADER_BYTES {
                return Err(Error::corrupt("NRRD header is longer than 1 MiB"));
            }
            return Ok((lines, None));
        }
        offset += n as u64;
        let text = std::str::from_utf8(&raw)
            .map_err(|_| Error::corrupt("NRRD header is not text"))?
            .trim_end_matches(['\n', '\r']);
        if first {
            let version = text
                .strip_prefix("NRRD000")
                .and_then(|v| v.parse::<u8>().ok());
            if !matches!(version, Some(1..=5)) {
                return Err(Error::corrupt(format!(
                    "not a NRRD file: bad magic line '{}'",
                    clip(text)
                )));
            }
            first = false;
            continue;
        }
        if text.is_empty() {
            return Ok((lines, Some(offset)));
        }
        lines.push(text.to_string());
    }
}

/// Reads `count` samples from `file`, starting at `offset`, applying line and byte skips and the
/// header's encoding.
fn read_part(file: File, offset: u64, header: &Header, count: usize) -> Result<VolumeData> {
    let file_len = file.metadata()?.len();
    let mut reader = BufReader::new(file);
    reader.seek(SeekFrom::Start(offset))?;
    for _ in 0..header.line_skip {
        skip_line(&mut reader)?;
    }
    let position = reader.stream_position()?;
    let available = file_len.saturating_sub(position);
    let needed = byte_count(count, header.elem)?;
    match header.encoding {
        Encoding::Raw => {
            if header.byte_skip == -1 {
                check_available(needed, available)?;
                reader.seek(SeekFrom::Start(file_len - needed))?;
            } else {
                let skip = header.byte_skip as u64;
                check_available(needed.saturating_add(skip), available)?;
                skip_bytes(&mut reader, skip)?;
            }
            read_samples(&mut reader, header.elem, header.big_endian, count)
        }
        Encoding::Gzip => {
            let skip = header.byte_skip as u64;
            check_deflate_budget(needed.saturating_add(skip), available)?;
            let mut stream = flate2::read::MultiGzDecoder::new(reader);
            skip_bytes(&mut stream, skip).map_err(gzip_error)?;
            let data = read_samples(&mut stream, header.elem, header.big_endian, count)
                .map_err(gzip_error)?;
            expect_end(&mut stream).map_err(gzip_error)?;
            Ok(data)
        }
        Encoding::Ascii => {
            skip_bytes(&mut reader, header.byte_skip.max(0) as u64)?;
            read_text_samples(
                &mut reader,
                available,
                header.elem,
                count,
                "ascii NRRD data",
            )
        }
    }
}

fn skip_line<R: BufRead>(reader: &mut R) -> Result<()> {
    loop {
        let buf = reader.fill_buf()?;
        if buf.is_empty() {
            return Err(Error::corrupt(
                "file ends inside the lines to skip ('line skip')",
            ));
        }
        if let Some(p) = buf.iter().position(|&b| b == b'\n') {
            reader.consume(p + 1);
            return Ok(());
        }
        let n = buf.len();
        reader.consume(n);
    }
}

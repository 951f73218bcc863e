//! MetaImage volumes: `.mha` (header and data in one file) and `.mhd` + data file, as ITK,
//! SimpleITK, 3D Slicer and elastix write them.
//!
//! Spec: ITK's MetaIO documentation (<https://itk.org/Wiki/ITK/MetaIO/Documentation>); where it is
//! silent, the behaviour of MetaIO's own reader. The header is parsed in `header.rs`.
//!
//! - Grid: the file's order, first axis fastest. NDims 1 to 3 (a 2-D image is one slice); a 4th
//!   or later dimension of size 1 is accepted, a larger one is `Unsupported` rather than a silent
//!   pick of the first volume. `ElementNumberOfChannels` > 1 (vector, RGB) is `Unsupported`.
//! - Types: the scalar `MET_*` types, converted as the crate docs say (MET_CHAR becomes i16,
//!   MET_UINT/INT/ULONG/LONG/ULONG_LONG/LONG_LONG/DOUBLE become f32, rounding beyond f32's range).
//! - Data: `ElementDataFile = LOCAL` (after the header), one file (relative to the header's
//!   folder), `LIST [ND]` (file names follow the header, one per line) or a printf pattern
//!   `name%03d.raw first last step` (one file per slice). Raw, zlib (`CompressedData = True`,
//!   each file its own stream, read to its end marker whatever `CompressedDataSize` says; see
//!   `read_part`) or whitespace-separated
//!   decimal text (`BinaryData = False`). `HeaderSize = N` starts the data at byte N of its file
//!   and `-1` takes its last bytes, as MetaIO does. `BinaryDataByteOrderMSB` /
//!   `ElementByteOrderMSB` pick big-endian.
//! - Geometry: spacing from `ElementSpacing` (else `ElementSize`), origin from `Offset`
//!   (`Origin`, `Position`) and axis directions from `TransformMatrix` (`Rotation`,
//!   `Orientation`), whose row `a` is axis `a`'s world direction, as ITK's MetaImageIO reads it.
//! - Checks: every declared size is checked against the file before anything is allocated; a
//!   zlib stream must inflate to exactly the declared sample bytes and end there, its checksum
//!   checked. A `CompressedDataSize` that disagrees with the stream gives a notice, not an error
//!   (PyVista's `frogtissue.mhd` declares 260020 bytes for a 262087-byte stream; MetaIO reads
//!   the declared bytes only and fills the samples it could not inflate with zeros).

mod header;

use crate::data_file::{open_regular, resolve};
use crate::geometry::geometry;
use crate::nrrd::clip;
use crate::samples::{
    append, byte_count, check_available, check_deflate_budget, expect_end, read_samples,
    read_text_samples, sample_count,
};
use header::{DataFile, DataStart, Header};
use isogrid::{Error, ErrorKind, Result, ResultExt, Volume, VolumeData};
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Headers (with their LIST of file names) longer than this are not MetaImage headers.
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Reads a `.mha` or `.mhd` file and its data. Errors name the file at fault: the header, or the
/// data file that is missing or short.
pub fn read_metaimage(path: &Path) -> Result<Volume> {
    read_metaimage_noted(path).map(|(volume, _)| volume)
}

/// [`read_metaimage`], also returning notices for the user: a `CompressedDataSize` that differs
/// from the zlib stream it describes (the data, complete and checked, is read all the same).
pub fn read_metaimage_noted(path: &Path) -> Result<(Volume, Vec<String>)> {
    let mut notices = Vec::new();
    let mut reader = BufReader::new(open_regular(path)?);
    let mut budget = MAX_HEADER_BYTES;
    let (lines, data_offset) = read_header_lines(&mut reader, &mut budget).at_path(path)?;
    let header = header::parse(&lines).at_path(path)?;
    let count = sample_count(header.dims).at_path(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let data = match &header.data {
        DataFile::Local => {
            let file = reader.into_inner();
            read_part(
                file,
                data_offset,
                &header,
                count,
                header.compressed_size,
                &mut notices,
            )
            .at_path(path)?
        }
        DataFile::Single(name) => {
            let data_path = resolve(base, name);
            let file = open_regular(&data_path)?;
            read_part(
                file,
                0,
                &header,
                count,
                header.compressed_size,
                &mut notices,
            )
            .at_path(&data_path)
            .map_err(|e| e.with_path(path))?
        }
        DataFile::List { piece_dims } => {
            let files = files_for_pieces(&header, *piece_dims);
            let names = read_list(&mut reader, files, &mut budget).at_path(path)?;
            read_pieces(base, &names, &header, count)?
        }
        DataFile::Pattern {
            pattern,
            first,
            last,
            step,
        } => {
            let files = files_for_pieces(&header, header.ndims - 1);
            let names = pattern_names(pattern, *first, *last, *step, files).at_path(path)?;
            read_pieces(base, &names, &header, count)?
        }
    };
    // ITK's physical space, which MetaImage files are written in: LPS.
    let g = geometry(
        header.dims,
        header.spacing,
        header.origin,
        header.direction,
        isogrid::WorldFrame::Lps,
    )
    .at_path(path)?;
    let volume = Volume::with_geometry(g, data).at_path(path)?;
    let notices = notices
        .into_iter()
        .map(|n| format!("{}: {n}", path.display()))
        .collect();
    Ok((volume, notices))
}

/// The data files a MetaImage header at `path` names (none for `LOCAL` data), resolved against
/// its folder; `None` when the header does not parse (reading it fails anyway).
pub(crate) fn data_files(path: &Path) -> Option<Vec<std::path::PathBuf>> {
    let mut reader = BufReader::new(open_regular(path).ok()?);
    let mut budget = MAX_HEADER_BYTES;
    let (lines, _) = read_header_lines(&mut reader, &mut budget).ok()?;
    let header = header::parse(&lines).ok()?;
    let names = match &header.data {
        DataFile::Local => Vec::new(),
        DataFile::Single(name) => vec![name.clone()],
        DataFile::List { piece_dims } => {
            let files = files_for_pieces(&header, *piece_dims);
            read_list(&mut reader, files, &mut budget).ok()?
        }
        DataFile::Pattern {
            pattern,
            first,
            last,
            step,
        } => {
            let files = files_for_pieces(&header, header.ndims - 1);
            pattern_names(pattern, *first, *last, *step, files).ok()?
        }
    };
    let base = path.parent().unwrap_or(Path::new("."));
    Some(names.iter().map(|n| resolve(base, n)).collect())
}

/// Reads header lines up to and including `ElementDataFile`; returns them and the byte offset
/// right after that line (where `LOCAL` data starts).
fn read_header_lines<R: BufRead>(reader: &mut R, budget: &mut u64) -> Result<(Vec<String>, u64)> {
    let mut lines = Vec::new();
    let mut offset = 0u64;
    loop {
        let line = next_line(reader, budget)?
            .ok_or_else(|| Error::corrupt("MetaImage header has no ElementDataFile field"))?;
        offset += line.len() as u64;
        let text = line_text(&line)?;
        let is_last = text
            .split_once('=')
            .or_else(|| text.split_once(':'))
            .is_some_and(|(key, _)| key.trim().eq_ignore_ascii_case("ElementDataFile"));
        lines.push(text);
        if is_last {
            return Ok((lines, offset));
        }
    }
}

/// The `files` names that follow `ElementDataFile = LIST`, one per line.
fn read_list<R: BufRead>(reader: &mut R, files: usize, budget: &mut u64) -> Result<Vec<String>> {
    let mut names = Vec::new();
    while names.len() < files {
        let Some(line) = next_line(reader, budget)? else {
            return Err(Error::corrupt(format!(
                "ElementDataFile LIST needs {files} file names, the header holds {}",
                names.len()
            )));
        };
        let name = line_text(&line)?;
        if !name.is_empty() {
            names.push(name);
        }
    }
    Ok(names)
}

/// One line with its terminator, within the header size limit; `None` at the end of the file.
fn next_line<R: BufRead>(reader: &mut R, budget: &mut u64) -> Result<Option<Vec<u8>>> {
    let mut raw = Vec::new();
    let n = reader.by_ref().take(*budget).read_until(b'\n', &mut raw)? as u64;
    *budget -= n;
    if n == 0 {
        if *budget == 0 {
            return Err(Error::corrupt("MetaImage header is longer than 1 MiB"));
        }
        return Ok(None);
    }
    Ok(Some(raw))
}

fn line_text(raw: &[u8]) -> Result<String> {
    let text =
        std::str::from_utf8(raw).map_err(|_| Error::corrupt("MetaImage header is not text"))?;
    Ok(text.trim().to_string())
}

/// Files a `LIST` or pattern names: one per `piece_dims`-dimensional piece (0 = one slice).
fn files_for_pieces(h: &Header, piece_dims: usize) -> usize {
    let piece_dims = if piece_dims == 0 {
        h.ndims - 1
    } else {
        piece_dims
    };
    h.dims[piece_dims.min(3)..].iter().product()
}

/// The file names of a printf pattern: `files` numbers from `first` by `step`, within `last`.
fn pattern_names(
    pattern: &str,
    first: i64,
    last: Option<i64>,
    step: i64,
    files: usize,
) -> Result<Vec<String>> {
    let final_number = (files as i64 - 1)
        .checked_mul(step)
        .and_then(|span| span.checked_add(first))
        .ok_or_else(|| Error::corrupt("ElementDataFile pattern numbers overflow"))?;
    if let Some(last) = last {
        if last < final_number {
            return Err(Error::corrupt(format!(
                "ElementDataFile pattern numbers {first}..={last} step {step} name fewer than the {files} slices DimSize declares"
            )));
        }
    }
    (0..files as i64)
        .map(|i| format_number(pattern, first + i * step))
        .collect()
}

/// `pattern` with its one `%d` / `%Nd` / `%0Nd` (or `i`) conversion replaced by `n`.
fn format_number(pattern: &str, n: i64) -> Result<String> {
    let bad = || {
        Error::unsupported(format!(
            "ElementDataFile pattern '{}' is not a name with one %d, %Nd or %0Nd",
            clip(pattern)
        ))
    };
    let at = pattern.find('%').ok_or_else(bad)?;
    let spec = &pattern[at + 1..];
    let digits = spec.len() - spec.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    let width: usize = if digits == 0 {
        0
    } else {
        spec[..digits].parse().map_err(|_| bad())?
    };
    let rest = &spec[digits..];
    if !(rest.starts_with('d') || rest.starts_with('i')) || rest[1..].contains('%') || width > 32 {
        return Err(bad());
    }
    let number = if spec.starts_with('0') {
        format!("{n:0width$}")
    } else {
        format!("{n:width$}")
    };
    Ok(format!("{}{number}{}", &pattern[..at], &rest[1..]))
}

/// Reads the pieces of a `LIST` or pattern in order, each file holding an equal share.
fn read_pieces(base: &Path, names: &[String], h: &Header, count: usize) -> Result<VolumeData> {
    let part = count / names.len();
    let mut data: Option<VolumeData> = None;
    for name in names {
        let data_path = resolve(base, name);
        let file = open_regular(&data_path)?;
        let piece = read_part(file, 0, h, part, None, &mut Vec::new()).at_path(&data_path)?;
        data = Some(match data {
            None => piece,
            // Every piece is decoded with the same element type, so the variants always match.
            Some(d) => append(d, piece).unwrap_or_else(|(a, _)| a),
        });
    }
    data.ok_or_else(|| Error::corrupt("ElementDataFile names no files"))
}

/// Reads `count` samples from `file`, whose data starts at `after_header` unless `HeaderSize`
/// says otherwise, in the header's encoding.
///
/// A zlib stream is read to its end marker from everything that follows, whatever
/// `CompressedDataSize` says: the stream must end cleanly (its Adler-32 checked) right after the
/// declared sample bytes. MetaIO (ITK, SimpleITK, VTK) reads only `CompressedDataSize` bytes and,
/// when the field is too small, returns the samples past the inflated part as zeros without an
/// error; a field that disagrees with the stream gives a notice here instead.
fn read_part(
    file: File,
    after_header: u64,
    h: &Header,
    count: usize,
    compressed_size: Option<u64>,
    notices: &mut Vec<String>,
) -> Result<VolumeData> {
    let file_len = file.metadata()?.len();
    let needed = byte_count(count, h.elem)?;
    let start = match h.start {
        DataStart::Default => after_header,
        DataStart::At(n) => n,
        DataStart::End => {
            check_available(needed, file_len)?;
            file_len - needed
        }
    };
    let available = file_len.saturating_sub(start);
    let mut reader = BufReader::new(file);
    reader.seek(SeekFrom::Start(start.min(file_len)))?;
    if !h.binary {
        return read_text_samples(reader, available, h.elem, count, "MetaImage text data");
    }
    if !h.compressed {
        check_available(needed, available)?;
        return read_samples(&mut reader, h.elem, h.big_endian, count);
    }
    check_deflate_budget(needed, available)?;
    let mut stream = ZlibStream::new(reader.take(available));
    let data = read_samples(&mut stream, h.elem, h.big_endian, count).map_err(zlib_error)?;
    expect_end(&mut stream).map_err(zlib_error)?;
    if !stream.ended {
        return Err(Error::corrupt(
            "the zlib stream stops before its end marker: the file is truncated",
        ));
    }
    let used = stream.z.total_in();
    match compressed_size {
        Some(declared) if declared != used && declared != 0 => notices.push(format!(
            "CompressedDataSize says {declared} bytes but the zlib stream takes {used} \
             (read to its end and checked: the field is wrong, the data complete)"
        )),
        _ => {}
    }
    Ok(data)
}

/// A zlib stream as a reader that knows whether the stream reached its end marker (with its
/// Adler-32 checked): `flate2`'s readers end the same way on a stream cut short.
struct ZlibStream<R> {
    inner: R,
    buf: Box<[u8]>,
    pos: usize,
    len: usize,
    z: flate2::Decompress,
    ended: bool,
}

impl<R: Read> ZlibStream<R> {
    fn new(inner: R) -> Self {
        ZlibStream {
            inner,
            buf: vec![0; 64 << 10].into_boxed_slice(),
            pos: 0,
            len: 0,
            z: flate2::Decompress::new(true),
            ended: false,
        }
    }
}

impl<R: Read> Read for ZlibStream<R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        if self.ended || out.is_empty() {
            return Ok(0);
        }
        loop {
            if self.pos == self.len {
                self.len = self.inner.read(&mut self.buf)?;
                self.pos = 0;
            }
            let eof = self.len == 0;
            let (before_in, before_out) = (self.z.total_in(), self.z.total_out());
            let status = self
                .z
                .decompress(
                    &self.buf[self.pos..self.len],
                    out,
                    flate2::FlushDecompress::None,
                )
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))?;
            let consumed = (self.z.total_in() - before_in) as usize;
            let written = (self.z.total_out() - before_out) as usize;
            self.pos += consumed;
            if status == flate2::Status::StreamEnd {
                self.ended = true;
                return Ok(written);
            }
            if written > 0 || eof {
                // At the end of the input without the end marker: 0, and `ended` stays false.
                return Ok(written);
            }
            if consumed == 0 && self.pos < self.len {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    "the zlib stream makes no progress",
                ));
            }
        }
    }
}

/// A decompressor's OS-level error means the zlib stream is damaged.
fn zlib_error(e: Error) -> Error {
    if e.kind() == ErrorKind::Io {
        Error::corrupt(format!("zlib-compressed data is invalid: {}", e.message()))
    } else {
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn printf_patterns() {
        assert_eq!(format_number("s%03d.raw", 7).unwrap(), "s007.raw");
        assert_eq!(format_number("s%d.raw", 12).unwrap(), "s12.raw");
        assert_eq!(format_number("s%2i", 3).unwrap(), "s 3");
        assert!(format_number("s%s.raw", 1).is_err());
        assert!(format_number("s%d%d", 1).is_err());
        assert!(format_number("s%999999999d", 1).is_err());
        assert_eq!(
            pattern_names("a%d", 2, Some(6), 2, 3).unwrap(),
            ["a2", "a4", "a6"]
        );
        assert!(pattern_names("a%d", 2, Some(5), 2, 3).is_err());
    }
}

//! VTK XML image data (`.vti`), as VTK, ParaView and PyVista write it: one `ImageData` piece,
//! the point array named by `PointData Scalars` (else the first) as the volume.
//!
//! Spec: VTK's file formats (<https://docs.vtk.org/en/latest/design_documents/VTKFileFormats.html>);
//! where it is silent, what `vtkXMLImageDataReader` reads.
//!
//! - Grid: the `WholeExtent`'s samples, x fastest. One `Piece` whose `Extent` is the whole
//!   extent; a file split into several pieces is `Unsupported`, as is an array of more than one
//!   component (vectors, RGB) or point data that is all cell data.
//! - Types: `Int8` … `UInt64`, `Float32`, `Float64` (and VTK's older names `Char`,
//!   `UnsignedChar`, …), kept as [`crate::samples`] keeps them (i8 as i16).
//! - Data: `format="ascii"` (whitespace-separated values), `"binary"` (base64 inside the element)
//!   or `"appended"` (in `AppendedData`, raw or base64, at the array's `offset`). Binary data
//!   starts with a header of `header_type` words (UInt32 by default): the byte count, or with a
//!   `compressor` the block count, block size, last block size and each block's compressed size.
//!   In base64, uncompressed data is encoded in one run with its header, and compressed blocks
//!   in a run apart from theirs, as VTK writes them. Compressors: zlib
//!   and LZ4; LZMA is `Unsupported`. `byte_order="BigEndian"` is honoured.
//! - Geometry (index × spacing through the directions into world space): `Origin`, `Spacing`
//!   and `Direction` (row-major, its column `a` axis `a`'s world direction, as
//!   `vtkImageData` maps index to physical coordinates); an extent starting past 0 moves the
//!   origin to its first sample.
//! - Checks: the file is read whole (its size bounds everything else); every header is checked
//!   against the bytes there before a block is inflated, each block must inflate to exactly its
//!   declared size, and the samples to exactly the extent's count.

use crate::geometry::geometry;
use crate::samples::{read_samples, read_text_samples, sample_count, ElemType};
use base64::Engine;
use isogrid::{Error, Result, ResultExt, Volume};
use quick_xml::events::{BytesStart, Event};
use std::io::Read;
use std::path::Path;

/// Reads a `.vti` file. Errors name the file.
pub fn read_vti(path: &Path) -> Result<Volume> {
    let mut bytes = Vec::new();
    crate::data_file::open_regular(path)?
        .read_to_end(&mut bytes)
        .at_path(path)?;
    parse(&bytes).at_path(path)
}

/// What the XML says of the file and of the one array read.
#[derive(Default)]
struct Layout {
    big_endian: bool,
    header_u64: bool,
    compressor: Compressor,
    extent: Option<[i64; 6]>,
    origin: [f64; 3],
    spacing: [f64; 3],
    direction: Option<[[f64; 3]; 3]>,
    pieces: usize,
    scalars: Option<String>,
    array: Option<Array>,
    point_arrays: usize,
    cell_arrays: usize,
    appended: Option<Appended>,
}

#[derive(Default, Clone, Copy, PartialEq)]
enum Compressor {
    #[default]
    None,
    Zlib,
    Lz4,
}

struct Array {
    elem: ElemType,
    name: String,
    components: usize,
    format: Format,
    /// The element's text (ascii and binary formats).
    text: Vec<u8>,
}

#[derive(PartialEq)]
enum Format {
    Ascii,
    Binary,
    Appended(usize),
}

/// The `AppendedData` bytes after its `_` marker, and whether they are base64.
struct Appended {
    start: usize,
    base64: bool,
}

fn parse(bytes: &[u8]) -> Result<Volume> {
    let mut layout = read_layout(bytes)?;
    let extent = layout
        .extent
        .ok_or_else(|| Error::corrupt("no ImageData WholeExtent: not VTK image data"))?;
    if layout.pieces != 1 {
        return Err(Error::unsupported(format!(
            "{} pieces: only image data in one piece is read",
            layout.pieces
        )));
    }
    // A span beyond usize (or i64) is too large: as usize::MAX, sample_count refuses it.
    let dims: [usize; 3] = std::array::from_fn(|a| {
        extent[2 * a + 1]
            .checked_sub(extent[2 * a])
            .and_then(|n| n.checked_add(1))
            .and_then(|n| usize::try_from(n).ok())
            .unwrap_or(usize::MAX)
    });
    let count = sample_count(dims)?;
    let array = match layout.array.take() {
        Some(array) => array,
        None if layout.point_arrays > 0 => {
            return Err(Error::corrupt(format!(
                "PointData Scalars names '{}', which is not among its {} arrays",
                layout.scalars.clone().unwrap_or_default(),
                layout.point_arrays
            )))
        }
        None if layout.cell_arrays > 0 => {
            return Err(Error::unsupported(
                "the file holds cell data only: a volume is read from point data",
            ))
        }
        None => return Err(Error::corrupt("the file holds no point data array")),
    };
    if array.components != 1 {
        return Err(Error::unsupported(format!(
            "point array '{}' has {} components: only scalar arrays are volumes",
            array.name, array.components
        )));
    }
    let what = format!("point array '{}'", array.name);
    let data = match array.format {
        Format::Ascii => read_text_samples(
            &array.text[..],
            array.text.len() as u64,
            array.elem,
            count,
            &what,
        )?,
        Format::Binary => {
            let text: Vec<u8> = array
                .text
                .iter()
                .copied()
                .filter(|c| !c.is_ascii_whitespace())
                .collect();
            let raw = decode_binary(&text, 0, true, &layout, count, array.elem, &what)?;
            read_samples(&mut &raw[..], array.elem, layout.big_endian, count)?
        }
        Format::Appended(offset) => {
            let appended = layout.appended.as_ref().ok_or_else(|| {
                Error::corrupt(format!("{what} is appended but there is no AppendedData"))
            })?;
            let raw = decode_binary(
                &bytes[appended.start..],
                offset,
                appended.base64,
                &layout,
                count,
                array.elem,
                &what,
            )?;
            read_samples(&mut &raw[..], array.elem, layout.big_endian, count)?
        }
    };
    // Index → world: origin + D·(spacing ⊙ index); the extent's first sample is index 0 here.
    let d = layout
        .direction
        .unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let axis = |a: usize| [d[0][a], d[1][a], d[2][a]];
    let mut origin = layout.origin;
    for a in 0..3 {
        for (r, o) in origin.iter_mut().enumerate() {
            *o += axis(a)[r] * layout.spacing[a] * extent[2 * a] as f64;
        }
    }
    let g = geometry(
        dims,
        layout.spacing,
        origin,
        Some([axis(0), axis(1), axis(2)]),
        // VTK image data names no anatomical convention.
        isogrid::WorldFrame::Unknown,
    )?;
    Volume::with_geometry(g, data)
}

/// Walks the XML up to the `AppendedData` start tag (raw appended bytes are not XML).
fn read_layout(bytes: &[u8]) -> Result<Layout> {
    let head_end = find(bytes, b"<AppendedData")
        .and_then(|at| find(&bytes[at..], b">").map(|end| at + end + 1))
        .unwrap_or(bytes.len());
    let mut reader = quick_xml::Reader::from_reader(&bytes[..head_end]);
    let mut layout = Layout {
        spacing: [1.0; 3],
        ..Layout::default()
    };
    let mut stack: Vec<Vec<u8>> = Vec::new();
    let mut text_of: Option<Array> = None;
    let mut seen_root = false;
    let mut buf = Vec::new();
    loop {
        let event = reader
            .read_event_into(&mut buf)
            .map_err(|e| Error::corrupt(format!("not well-formed XML: {e}")))?;
        match event {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(event, Event::Empty(_));
                let name = e.name().as_ref().to_vec();
                let parent = stack.last().map(|p| p.as_slice());
                match name.as_slice() {
                    b"VTKFile" => {
                        seen_root = true;
                        root(e, &mut layout)?;
                    }
                    _ if !seen_root => {
                        return Err(Error::corrupt("not a VTK XML file (no VTKFile element)"))
                    }
                    b"ImageData" => {
                        layout.extent = Some(ints6(e, b"WholeExtent")?);
                        if let Some(o) = attr(e, b"Origin")? {
                            layout.origin = floats(&o, "Origin")?;
                        }
                        if let Some(s) = attr(e, b"Spacing")? {
                            layout.spacing = floats(&s, "Spacing")?;
                        }
                        if let Some(d) = attr(e, b"Direction")? {
                            let v = numbers::<f64>(&d, "Direction", 9)?;
                            layout.direction = Some(std::array::from_fn(|r| {
                                std::array::from_fn(|c| v[3 * r + c])
                            }));
                        }
                    }
                    b"Piece" => {
                        layout.pieces += 1;
                        if let (Some(piece), Some(whole)) = (attr(e, b"Extent")?, layout.extent) {
                            if numbers::<i64>(&piece, "Extent", 6)? != whole {
                                return Err(Error::unsupported(
                                    "a piece smaller than the whole extent: only image data in one piece is read",
                                ));
                            }
                        }
                    }
                    b"PointData" => layout.scalars = attr(e, b"Scalars")?,
                    b"DataArray" if parent == Some(b"CellData") => layout.cell_arrays += 1,
                    b"DataArray" if parent == Some(b"PointData") => {
                        layout.point_arrays += 1;
                        let array = data_array(e)?;
                        let wanted = match (&layout.scalars, &layout.array) {
                            (Some(s), _) => *s == array.name,
                            (None, existing) => existing.is_none(),
                        };
                        if wanted && !empty {
                            text_of = Some(array);
                        } else if wanted {
                            layout.array = Some(array);
                        }
                    }
                    b"AppendedData" => {
                        let base64 = match attr(e, b"encoding")?.as_deref() {
                            Some("raw") => false,
                            Some("base64") | None => true,
                            Some(other) => {
                                return Err(Error::unsupported(format!(
                                    "AppendedData encoding '{other}'"
                                )))
                            }
                        };
                        let marker = find(&bytes[head_end..], b"_").ok_or_else(|| {
                            Error::corrupt("AppendedData has no '_' before its data")
                        })?;
                        layout.appended = Some(Appended {
                            start: head_end + marker + 1,
                            base64,
                        });
                        break;
                    }
                    _ => {}
                }
                if !empty {
                    stack.push(name);
                }
            }
            Event::Text(t) => {
                if let Some(array) = text_of.as_mut() {
                    array.text.extend_from_slice(&t);
                }
            }
            Event::End(_) => {
                let closed = stack.pop();
                if closed.as_deref() == Some(b"DataArray") && text_of.is_some() {
                    layout.array = text_of.take();
                }
            }
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    if !seen_root {
        return Err(Error::corrupt("not a VTK XML file (no VTKFile element)"));
    }
    Ok(layout)
}

fn root(e: &BytesStart, layout: &mut Layout) -> Result<()> {
    match attr(e, b"type")?.as_deref() {
        Some("ImageData") => {}
        Some(other) => {
            return Err(Error::unsupported(format!(
                "a VTK {other} file: only ImageData is a volume"
            )))
        }
        None => return Err(Error::corrupt("VTKFile has no type")),
    }
    layout.big_endian = match attr(e, b"byte_order")?.as_deref() {
        Some("BigEndian") => true,
        Some("LittleEndian") | None => false,
        Some(other) => return Err(Error::corrupt(format!("byte_order '{other}'"))),
    };
    layout.header_u64 = match attr(e, b"header_type")?.as_deref() {
        Some("UInt64") => true,
        Some("UInt32") | None => false,
        Some(other) => return Err(Error::corrupt(format!("header_type '{other}'"))),
    };
    layout.compressor = match attr(e, b"compressor")?.as_deref() {
        None | Some("") => Compressor::None,
        Some("vtkZLibDataCompressor") => Compressor::Zlib,
        Some("vtkLZ4DataCompressor") => Compressor::Lz4,
        Some(other) => {
            return Err(Error::unsupported(format!(
                "compressor {other}: zlib and LZ4 are read (resave with one of them)"
            )))
        }
    };
    Ok(())
}

fn data_array(e: &BytesStart) -> Result<Array> {
    let name = attr(e, b"Name")?.unwrap_or_default();
    let kind = attr(e, b"type")?.ok_or_else(|| Error::corrupt("a DataArray has no type"))?;
    let elem = match kind.as_str() {
        "Int8" | "Char" | "SignedChar" => ElemType::I8,
        "UInt8" | "UnsignedChar" => ElemType::U8,
        "Int16" | "Short" => ElemType::I16,
        "UInt16" | "UnsignedShort" => ElemType::U16,
        "Int32" | "Int" => ElemType::I32,
        "UInt32" | "UnsignedInt" => ElemType::U32,
        "Int64" | "Long" | "LongLong" => ElemType::I64,
        "UInt64" | "UnsignedLong" | "UnsignedLongLong" => ElemType::U64,
        "Float32" | "Float" => ElemType::F32,
        "Float64" | "Double" => ElemType::F64,
        other => {
            return Err(Error::unsupported(format!(
                "point array '{name}' of type {other}"
            )))
        }
    };
    let components = match attr(e, b"NumberOfComponents")? {
        Some(n) => n
            .trim()
            .parse()
            .map_err(|_| Error::corrupt(format!("NumberOfComponents '{n}'")))?,
        None => 1,
    };
    let format = match attr(e, b"format")?.as_deref() {
        Some("ascii") => Format::Ascii,
        Some("binary") => Format::Binary,
        Some("appended") => {
            let offset = attr(e, b"offset")?
                .ok_or_else(|| Error::corrupt(format!("appended array '{name}' has no offset")))?;
            Format::Appended(
                offset
                    .trim()
                    .parse()
                    .map_err(|_| Error::corrupt(format!("offset '{offset}'")))?,
            )
        }
        other => {
            return Err(Error::corrupt(format!(
                "point array '{name}' has format {other:?}"
            )))
        }
    };
    Ok(Array {
        elem,
        name,
        components,
        format,
        text: Vec::new(),
    })
}

/// The sample bytes of an array stored as binary data at `at` of `data` (base64 text or raw
/// bytes): its header, then one uncompressed run or the compressed blocks.
fn decode_binary(
    data: &[u8],
    at: usize,
    base64: bool,
    layout: &Layout,
    count: usize,
    elem: ElemType,
    what: &str,
) -> Result<Vec<u8>> {
    let needed = count as u64 * elem.size() as u64;
    let word = if layout.header_u64 { 8 } else { 4 };
    let mut source = Source {
        data,
        at,
        base64,
        what,
    };
    let read_words = |source: &mut Source, n: usize| -> Result<Vec<u64>> {
        let bytes = source.take(n * word, true)?;
        Ok(bytes
            .chunks_exact(word)
            .map(|w| {
                let mut b = [0u8; 8];
                if layout.big_endian {
                    b[8 - word..].copy_from_slice(w);
                    u64::from_be_bytes(b)
                } else {
                    b[..word].copy_from_slice(w);
                    u64::from_le_bytes(b)
                }
            })
            .collect())
    };
    if layout.compressor == Compressor::None {
        // The header (the data's byte count) and the data, in one base64 run when encoded. The
        // header says the count its extent needs, checked on the header's own group first.
        let mut copy = source;
        let declared = read_words(&mut copy, 1)?[0];
        if declared != needed {
            return Err(Error::corrupt(format!(
                "{what} holds {declared} bytes; its extent needs {needed}"
            )));
        }
        let run = source.take(word + needed as usize, false)?;
        return Ok(run[word..].to_vec());
    }
    // Block count, block size, last block size, then each block's compressed size; the header's
    // first word is read alone to know how long it is.
    let mut copy = source;
    let blocks = read_words(&mut copy, 1)?[0];
    // Every block holds at least one byte, and its size takes a header word in the file.
    if blocks == 0 || blocks > needed || blocks > data.len() as u64 {
        return Err(Error::corrupt(format!(
            "{what} declares {blocks} compressed blocks"
        )));
    }
    let head = read_words(&mut source, 3 + blocks as usize)?;
    let (block, last) = (head[1], head[2]);
    let sizes = &head[3..];
    let last = if last == 0 { block } else { last };
    let total = block
        .checked_mul(blocks - 1)
        .and_then(|t| t.checked_add(last))
        .unwrap_or(u64::MAX);
    if total != needed || last > block {
        return Err(Error::corrupt(format!(
            "{what} inflates to {total} bytes; its extent needs {needed}"
        )));
    }
    let compressed: u64 = sizes
        .iter()
        .try_fold(0u64, |t, &s| t.checked_add(s))
        .unwrap_or(u64::MAX);
    crate::samples::check_deflate_budget(needed, compressed)?;
    let stream = source.take(usize::try_from(compressed).unwrap_or(usize::MAX), false)?;
    isogrid::memory::ensure_fits(&format!("{what} of {needed} bytes"), needed)?;
    let mut out = Vec::with_capacity(needed as usize);
    let mut from = 0usize;
    for (i, &size) in sizes.iter().enumerate() {
        let expected = if i + 1 == sizes.len() { last } else { block } as usize;
        let piece = &stream[from..from + size as usize];
        from += size as usize;
        let start = out.len();
        match layout.compressor {
            Compressor::Zlib => {
                let mut inflate = flate2::read::ZlibDecoder::new(piece).take(expected as u64 + 1);
                inflate.read_to_end(&mut out).map_err(|_| {
                    Error::corrupt(format!("{what}: block {i} is not valid zlib data"))
                })?;
            }
            Compressor::Lz4 => {
                let block = lz4_flex::block::decompress(piece, expected).map_err(|e| {
                    Error::corrupt(format!("{what}: block {i} is not valid LZ4 data: {e}"))
                })?;
                out.extend_from_slice(&block);
            }
            Compressor::None => unreachable!("uncompressed data returned above"),
        }
        if out.len() - start != expected {
            return Err(Error::corrupt(format!(
                "{what}: block {i} inflates to {} bytes, its header says {expected}",
                out.len() - start
            )));
        }
    }
    Ok(out)
}

/// Binary data read in order from raw bytes or base64 text. In base64, each `take` is one
/// separately encoded run, so it ends on a whole 4-character group; reading a header's first
/// word from a copy decodes only the groups that word needs.
#[derive(Clone, Copy)]
struct Source<'a> {
    data: &'a [u8],
    at: usize,
    base64: bool,
    what: &'a str,
}

impl Source<'_> {
    fn take(&mut self, n: usize, header: bool) -> Result<Vec<u8>> {
        let part = if header { "header" } else { "data" };
        let short = |have: usize| {
            Error::corrupt(format!(
                "{} is truncated: its {part} needs {n} bytes, {have} are there",
                self.what
            ))
        };
        if !self.base64 {
            let rest = self.data.get(self.at..).unwrap_or(&[]);
            if rest.len() < n {
                return Err(short(rest.len()));
            }
            self.at += n;
            return Ok(rest[..n].to_vec());
        }
        let chars = n.div_ceil(3) * 4;
        let rest = self.data.get(self.at..).unwrap_or(&[]);
        if rest.len() < chars {
            return Err(short(rest.len() / 4 * 3));
        }
        let decoded = base64::engine::general_purpose::STANDARD
            .decode(&rest[..chars])
            .map_err(|e| Error::corrupt(format!("{}: invalid base64: {e}", self.what)))?;
        self.at += chars;
        if decoded.len() < n {
            return Err(short(decoded.len()));
        }
        Ok(decoded[..n].to_vec())
    }
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

fn attr(e: &BytesStart, key: &[u8]) -> Result<Option<String>> {
    for a in e.attributes() {
        let a = a.map_err(|err| Error::corrupt(format!("not well-formed XML: {err}")))?;
        if a.key.as_ref() == key {
            let v = a
                .unescape_value()
                .map_err(|err| Error::corrupt(format!("not well-formed XML: {err}")))?;
            return Ok(Some(v.into_owned()));
        }
    }
    Ok(None)
}

fn numbers<T: std::str::FromStr>(text: &str, what: &str, n: usize) -> Result<Vec<T>> {
    let v = text
        .split_whitespace()
        .map(|t| t.parse::<T>())
        .collect::<std::result::Result<Vec<T>, _>>()
        .map_err(|_| Error::corrupt(format!("{what} '{text}' is not {n} numbers")))?;
    if v.len() != n {
        return Err(Error::corrupt(format!(
            "{what} '{text}' is not {n} numbers"
        )));
    }
    Ok(v)
}

fn floats(text: &str, what: &str) -> Result<[f64; 3]> {
    let v = numbers::<f64>(text, what, 3)?;
    Ok([v[0], v[1], v[2]])
}

fn ints6(e: &BytesStart, key: &[u8]) -> Result<[i64; 6]> {
    let text = attr(e, key)?.ok_or_else(|| Error::corrupt("ImageData has no WholeExtent"))?;
    let v = numbers::<i64>(&text, "WholeExtent", 6)?;
    if (0..3).any(|a| v[2 * a + 1] < v[2 * a]) {
        return Err(Error::corrupt(format!("WholeExtent '{text}' is empty")));
    }
    Ok(std::array::from_fn(|i| v[i]))
}

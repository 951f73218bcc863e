//! PLY reader (Turk, *The PLY Polygon File Format*, 1994): `ascii`, `binary_little_endian` and
//! `binary_big_endian`, any element layout.
//!
//! Reads the `x`, `y`, `z` properties of element `vertex` and the index list (`vertex_indices` or
//! `vertex_index`) of element `face`; every other element and property is parsed and skipped.

use super::{parse_number, push_fan, show, validate, Tokens, TriMesh};
use isogrid::{Error, Result};

/// A header can hold many comments but not megabytes; past this we stop looking for `end_header`.
pub(super) const MAX_HEADER_BYTES: usize = 1 << 20;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }
}

#[derive(Debug)]
enum Property {
    Scalar(ScalarType),
    List { count: ScalarType, item: ScalarType },
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<(String, Property)>,
}

impl Element {
    /// The fewest bytes one record can take, to check counts against the file size before
    /// allocating. ASCII needs at least one character and one separator per value.
    fn min_record_bytes(&self, encoding: Encoding) -> usize {
        let bytes: usize = self
            .properties
            .iter()
            .map(|(_, p)| match (encoding, p) {
                (Encoding::Ascii, _) => 2,
                (_, Property::Scalar(t)) => t.size(),
                (_, Property::List { count, .. }) => count.size(),
            })
            .sum();
        bytes.max(1)
    }

    /// The most bytes one binary record can take: lists at the largest length their count type
    /// can state. `None` when a count type states no useful bound (signed or floating counts
    /// wider than 16 bits, or an overflow).
    fn max_binary_record_bytes(&self) -> Option<u64> {
        self.properties.iter().try_fold(0u64, |sum, (_, p)| {
            let bytes = match p {
                Property::Scalar(t) => t.size() as u64,
                Property::List { count, item } => {
                    let most_items: u64 = match count {
                        ScalarType::U8 => u8::MAX as u64,
                        ScalarType::I8 => i8::MAX as u64,
                        ScalarType::U16 => u16::MAX as u64,
                        ScalarType::I16 => i16::MAX as u64,
                        ScalarType::U32 => u32::MAX as u64,
                        ScalarType::I32 => i32::MAX as u64,
                        ScalarType::F32 | ScalarType::F64 => return None,
                    };
                    most_items
                        .checked_mul(item.size() as u64)?
                        .checked_add(count.size() as u64)?
                }
            };
            sum.checked_add(bytes)
        })
    }

    fn property_index(&self, names: &[&str]) -> Option<usize> {
        self.properties
            .iter()
            .position(|(n, _)| names.contains(&n.as_str()))
    }
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    body_start: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header> {
    let limit = bytes.len().min(MAX_HEADER_BYTES);
    let mut pos = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0;
    loop {
        let rest = &bytes[pos..limit];
        let Some(len) = rest.iter().position(|&b| b == b'\n') else {
            return Err(Error::corrupt("PLY header has no end_header line"));
        };
        let line = String::from_utf8_lossy(&rest[..len]);
        pos += len + 1;
        line_no += 1;
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        let bad = |what: &str| Error::corrupt(format!("PLY header line {line_no}: {what}"));
        if line_no == 1 {
            if words != ["ply"] {
                return Err(Error::corrupt("not a PLY file (first line is not 'ply')"));
            }
            continue;
        }
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", kind, _version] => {
                encoding = Some(match *kind {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLittleEndian,
                    "binary_big_endian" => Encoding::BinaryBigEndian,
                    other => {
                        return Err(Error::unsupported(format!("PLY format '{other}'")));
                    }
                });
            }
            ["element", name, count] => {
                let count = count
                    .parse::<u64>()
                    .map_err(|_| bad(&format!("element count '{count}' is not a number")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let parse = |t: &str| {
                    ScalarType::parse(t).ok_or_else(|| bad(&format!("unknown type '{t}'")))
                };
                let property = Property::List {
                    count: parse(count)?,
                    item: parse(item)?,
                };
                elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?
                    .properties
                    .push((name.to_string(), property));
            }
            ["property", ty, name] => {
                let ty =
                    ScalarType::parse(ty).ok_or_else(|| bad(&format!("unknown type '{ty}'")))?;
                elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?
                    .properties
                    .push((name.to_string(), Property::Scalar(ty)));
            }
            ["end_header"] => break,
            _ => return Err(bad(&format!("cannot parse '{}'", show(line.as_bytes())))),
        }
    }
    let encoding = encoding.ok_or_else(|| Error::corrupt("PLY header has no format line"))?;
    Ok(Header {
        encoding,
        elements,
        body_start: pos,
    })
}

/// Reads values from the body in the header's encoding.
struct Body<'a> {
    encoding: Encoding,
    bytes: &'a [u8],
    pos: usize,
    tokens: Tokens<'a>,
}

impl<'a> Body<'a> {
    fn new(encoding: Encoding, bytes: &'a [u8]) -> Self {
        Body {
            encoding,
            bytes,
            pos: 0,
            tokens: Tokens::new(bytes),
        }
    }

    fn remaining(&self) -> usize {
        match self.encoding {
            Encoding::Ascii => self.bytes.len() - self.tokens.pos,
            _ => self.bytes.len() - self.pos,
        }
    }

    fn value(&mut self, ty: ScalarType) -> Result<f64> {
        if self.encoding == Encoding::Ascii {
            let token = self
                .tokens
                .next_token()
                .ok_or_else(|| Error::corrupt("PLY data ends early (file is truncated)"))?;
            return parse_number::<f64>(token).ok_or_else(|| {
                Error::corrupt(format!(
                    "PLY data line {}: '{}' is not a number",
                    self.tokens.line,
                    show(token)
                ))
            });
        }
        let size = ty.size();
        let raw = self
            .bytes
            .get(self.pos..self.pos + size)
            .ok_or_else(|| Error::corrupt("PLY data ends early (file is truncated)"))?;
        self.pos += size;
        let mut buf = [0u8; 8];
        buf[..size].copy_from_slice(raw);
        if self.encoding == Encoding::BinaryBigEndian {
            buf[..size].reverse();
        }
        Ok(match ty {
            ScalarType::I8 => buf[0] as i8 as f64,
            ScalarType::U8 => buf[0] as f64,
            ScalarType::I16 => i16::from_le_bytes([buf[0], buf[1]]) as f64,
            ScalarType::U16 => u16::from_le_bytes([buf[0], buf[1]]) as f64,
            ScalarType::I32 => i32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
            ScalarType::U32 => u32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
            ScalarType::F32 => f32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
            ScalarType::F64 => f64::from_le_bytes(buf),
        })
    }

    /// A list length: a non-negative integer the rest of the file can hold.
    fn list_len(&mut self, count: ScalarType, item: ScalarType) -> Result<usize> {
        let n = self.value(count)?;
        let min_item = if self.encoding == Encoding::Ascii {
            2
        } else {
            item.size()
        };
        if !(n >= 0.0 && n.fract() == 0.0) || n * min_item as f64 > self.remaining() as f64 {
            return Err(Error::corrupt(format!(
                "PLY list length {n} is negative, fractional or larger than the file"
            )));
        }
        Ok(n as usize)
    }
}

/// The most bytes a binary PLY file with the header at the start of `head` can hold: header plus
/// every element at its largest records. `None` for ASCII (text has no bound per value), a
/// header that does not parse, or no useful bound.
pub(super) fn max_file_bytes(head: &[u8]) -> Option<u64> {
    let header = parse_header(head).ok()?;
    if header.encoding == Encoding::Ascii {
        return None;
    }
    header
        .elements
        .iter()
        .try_fold(header.body_start as u64, |sum, e| {
            sum.checked_add(e.count.checked_mul(e.max_binary_record_bytes()?)?)
        })
}

pub(super) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let header = parse_header(bytes)?;
    let mut body = Body::new(header.encoding, &bytes[header.body_start..]);
    let mut mesh = TriMesh::default();
    let mut saw_vertices = false;
    let mut polygon: Vec<u32> = Vec::new();
    for element in &header.elements {
        let count = usize::try_from(element.count).unwrap_or(usize::MAX);
        let needed = count.saturating_mul(element.min_record_bytes(header.encoding));
        if needed > body.remaining() + 1 {
            return Err(Error::corrupt(format!(
                "PLY element '{}' declares {} records, more than the {} remaining bytes can hold",
                element.name,
                element.count,
                body.remaining()
            )));
        }
        match element.name.as_str() {
            "vertex" if !saw_vertices => {
                saw_vertices = true;
                let xyz = ["x", "y", "z"].map(|axis| element.property_index(&[axis]));
                let [Some(x), Some(y), Some(z)] = xyz else {
                    return Err(Error::corrupt("PLY vertex element lacks x, y or z"));
                };
                mesh.vertices.reserve(count);
                let mut record = vec![0.0f64; element.properties.len()];
                for _ in 0..count {
                    for (slot, (_, property)) in record.iter_mut().zip(&element.properties) {
                        *slot = match property {
                            Property::Scalar(t) => body.value(*t)?,
                            Property::List { count, item } => {
                                skip_list(&mut body, *count, *item)?;
                                0.0
                            }
                        };
                    }
                    mesh.vertices
                        .push([record[x] as f32, record[y] as f32, record[z] as f32]);
                }
            }
            "face" => {
                let indices = element
                    .property_index(&["vertex_indices", "vertex_index"])
                    .ok_or_else(|| {
                        Error::corrupt("PLY face element lacks a vertex_indices list")
                    })?;
                mesh.triangles.reserve(count);
                for face in 0..count {
                    for (p, (_, property)) in element.properties.iter().enumerate() {
                        match property {
                            Property::Scalar(t) => {
                                body.value(*t)?;
                            }
                            Property::List { count, item } if p == indices => {
                                let n = body.list_len(*count, *item)?;
                                polygon.clear();
                                for _ in 0..n {
                                    let v = body.value(*item)?;
                                    if !(v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64) {
                                        return Err(Error::corrupt(format!(
                                            "PLY face {face} has an invalid vertex index {v}"
                                        )));
                                    }
                                    polygon.push(v as u32);
                                }
                                push_fan(&polygon, &mut mesh.triangles);
                            }
                            Property::List { count, item } => skip_list(&mut body, *count, *item)?,
                        }
                    }
                }
            }
            _ => {
                for _ in 0..count {
                    for (_, property) in &element.properties {
                        match property {
                            Property::Scalar(t) => {
                                body.value(*t)?;
                            }
                            Property::List { count, item } => skip_list(&mut body, *count, *item)?,
                        }
                    }
                }
            }
        }
    }
    if !saw_vertices {
        return Err(Error::corrupt("PLY file has no vertex element"));
    }
    validate(&mesh)?;
    Ok(mesh)
}

fn skip_list(body: &mut Body, count: ScalarType, item: ScalarType) -> Result<()> {
    let n = body.list_len(count, item)?;
    for _ in 0..n {
        body.value(item)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::tests::sample_mesh;
    use super::*;

    /// Writes `mesh` as PLY with an extra per-vertex property and a per-face scalar, so the
    /// reader must skip properties it does not use. Faces: the square as one quad plus the two
    /// tip triangles, to exercise fan triangulation.
    fn write_ply(mesh: &TriMesh, encoding: &str) -> Vec<u8> {
        let faces: Vec<Vec<u32>> = vec![vec![0, 1, 2, 3], vec![0, 4, 1], vec![1, 4, 2]];
        let mut out = format!(
            "ply\nformat {encoding} 1.0\ncomment written by a test\nelement vertex {}\n\
             property float x\nproperty float y\nproperty double z\nproperty uchar red\n\
             element face {}\nproperty list uchar int vertex_indices\nproperty ushort flags\n\
             element extra 1\nproperty list uint short payload\nend_header\n",
            mesh.vertices.len(),
            faces.len()
        )
        .into_bytes();
        let be = encoding == "binary_big_endian";
        let put = |out: &mut Vec<u8>, le: &[u8], be_bytes: &[u8]| {
            out.extend_from_slice(if be { be_bytes } else { le })
        };
        if encoding == "ascii" {
            for v in &mesh.vertices {
                out.extend(format!("{} {} {} 200\n", v[0], v[1], v[2]).bytes());
            }
            for f in &faces {
                let idx: Vec<String> = f.iter().map(|i| i.to_string()).collect();
                out.extend(format!("{} {} 7\n", f.len(), idx.join(" ")).bytes());
            }
            out.extend(b"2 -5 6\n");
            return out;
        }
        for v in &mesh.vertices {
            put(&mut out, &v[0].to_le_bytes(), &v[0].to_be_bytes());
            put(&mut out, &v[1].to_le_bytes(), &v[1].to_be_bytes());
            let z = v[2] as f64;
            put(&mut out, &z.to_le_bytes(), &z.to_be_bytes());
            out.push(200);
        }
        for f in &faces {
            out.push(f.len() as u8);
            for &i in f {
                put(
                    &mut out,
                    &(i as i32).to_le_bytes(),
                    &(i as i32).to_be_bytes(),
                );
            }
            put(&mut out, &7u16.to_le_bytes(), &7u16.to_be_bytes());
        }
        put(&mut out, &2u32.to_le_bytes(), &2u32.to_be_bytes());
        put(&mut out, &(-5i16).to_le_bytes(), &(-5i16).to_be_bytes());
        put(&mut out, &6i16.to_le_bytes(), &6i16.to_be_bytes());
        out
    }

    #[test]
    fn all_encodings_round_trip() {
        let mesh = sample_mesh();
        for encoding in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let bytes = write_ply(&mesh, encoding);
            assert_eq!(parse(&bytes).unwrap(), mesh, "{encoding}");
        }
    }

    #[test]
    fn crlf_header_and_vertex_index_name() {
        let text = "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\n\
                    property float y\r\nproperty float z\r\nelement face 1\r\n\
                    property list uchar uint vertex_index\r\nend_header\r\n\
                    0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n";
        let mesh = parse(text.as_bytes()).unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
        assert_eq!(mesh.vertices[1], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn truncated_files_fail_cleanly() {
        let mesh = sample_mesh();
        for encoding in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let bytes = write_ply(&mesh, encoding);
            let header_len = bytes
                .windows(11)
                .position(|w| w == b"end_header\n")
                .unwrap()
                + 11;
            // Every cut inside the vertex and face data must fail (the last element, `extra`,
            // is optional data we skip, but cutting it still truncates it).
            for cut in (0..bytes.len() - 1).rev().step_by(3) {
                let result = parse(&bytes[..cut]);
                assert!(result.is_err(), "{encoding}: cut at {cut} was accepted");
                if cut >= header_len {
                    let msg = result.unwrap_err().to_string();
                    assert!(
                        msg.contains("truncated")
                            || msg.contains("remaining bytes")
                            || msg.contains("larger than the file")
                            || msg.contains("not a number"),
                        "{encoding} cut {cut}: {msg}"
                    );
                }
            }
        }
    }

    #[test]
    fn absurd_counts_fail_before_allocating() {
        let text = "ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\n\
                    property float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
        let err = parse(text.as_bytes()).unwrap_err();
        assert!(err.to_string().contains("declares"), "{err}");
        let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                    property float z\nelement face 1\nproperty list uint int vertex_indices\n\
                    end_header\n0 0 0\n4000000000 1 2 3\n";
        let err = parse(text.as_bytes()).unwrap_err();
        assert!(err.to_string().contains("larger than the file"), "{err}");
    }

    #[test]
    fn malformed_files_name_the_problem() {
        let cases: [(&str, &str); 7] = [
            ("plx\n", "not a PLY"),
            ("ply\nformat ascii 1.0\nelement vertex 1\n", "end_header"),
            ("ply\nformat xml 1.0\nend_header\n", "format 'xml'"),
            ("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n", "unknown type"),
            ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n", "lacks x, y or z"),
            (
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n",
                "beyond the 3 vertices",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
                 end_header\n0 zero 0\n",
                "'zero' is not a number",
            ),
        ];
        for (text, expected) in cases {
            let err = parse(text.as_bytes()).unwrap_err();
            assert!(err.to_string().contains(expected), "{expected}: got {err}");
        }
    }

    #[test]
    fn negative_index_is_rejected() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                    end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n";
        let err = parse(text.as_bytes()).unwrap_err();
        assert!(err.to_string().contains("invalid vertex index -1"), "{err}");
    }
}

//! STL reader, binary and ASCII.
//!
//! Binary: 80-byte header, little-endian u32 triangle count, then 50 bytes per triangle (normal,
//! three vertices as f32, u16 attribute). ASCII: `solid … facet normal … outer loop vertex x y z …
//! endloop endfacet … endsolid`. STL repeats each corner per triangle; corners with identical
//! coordinates are merged so the result is an indexed mesh (the normals are ignored).
//!
//! Many binary files begin with the word `solid` too, so a file whose size is exactly
//! `84 + 50·count` is taken as binary whatever its first bytes say.

use super::{parse_number, push_fan, show, validate, Tokens, TriMesh};
use isogrid::{Error, Result};
use std::collections::HashMap;

const HEADER: usize = 84;
const RECORD: usize = 50;

fn binary_count(bytes: &[u8]) -> Option<usize> {
    let raw: [u8; 4] = bytes.get(80..84)?.try_into().ok()?;
    Some(u32::from_le_bytes(raw) as usize)
}

fn is_exact_binary(bytes: &[u8]) -> bool {
    binary_count(bytes)
        .and_then(|n| n.checked_mul(RECORD)?.checked_add(HEADER))
        .is_some_and(|size| size == bytes.len())
}

fn starts_with_solid(bytes: &[u8]) -> bool {
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    bytes[start..].starts_with(b"solid")
}

/// Whether content sniffing should treat these bytes as STL.
pub(super) fn looks_like_stl(bytes: &[u8]) -> bool {
    is_exact_binary(bytes) || starts_with_solid(bytes)
}

pub(super) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let mesh = if is_exact_binary(bytes) || !starts_with_solid(bytes) {
        parse_binary(bytes)?
    } else {
        parse_ascii(bytes)?
    };
    validate(&mesh)?;
    Ok(mesh)
}

/// Merges corners with bit-identical coordinates (after folding −0 into +0).
#[derive(Default)]
struct Welder {
    mesh: TriMesh,
    index_of: HashMap<[u32; 3], u32>,
}

impl Welder {
    fn with_capacity(triangles: usize) -> Self {
        let mut w = Welder::default();
        w.mesh.triangles.reserve(triangles);
        w.index_of.reserve(triangles / 2);
        w.mesh.vertices.reserve(triangles / 2);
        w
    }

    fn vertex(&mut self, p: [f32; 3]) -> u32 {
        let p = p.map(|c| if c == 0.0 { 0.0 } else { c });
        let next = self.mesh.vertices.len() as u32;
        let mesh = &mut self.mesh;
        *self.index_of.entry(p.map(f32::to_bits)).or_insert_with(|| {
            mesh.vertices.push(p);
            next
        })
    }
}

fn parse_binary(bytes: &[u8]) -> Result<TriMesh> {
    let count = binary_count(bytes)
        .ok_or_else(|| Error::corrupt("binary STL is shorter than its 84-byte header"))?;
    let body = &bytes[HEADER..];
    if count.saturating_mul(RECORD) > body.len() {
        return Err(Error::corrupt(format!(
            "binary STL declares {count} triangles but holds only {} (file is truncated)",
            body.len() / RECORD
        )));
    }
    // More whole records than the count means the count is wrong (or two files were joined):
    // reading only `count` would drop triangles without a word. A partial record of trailing
    // bytes (padding some writers add) is ignored.
    if body.len() / RECORD > count {
        return Err(Error::corrupt(format!(
            "binary STL declares {count} triangles but holds {}",
            body.len() / RECORD
        )));
    }
    let mut welder = Welder::with_capacity(count);
    for record in body.chunks_exact(RECORD).take(count) {
        let f = |at: usize| {
            f32::from_le_bytes([record[at], record[at + 1], record[at + 2], record[at + 3]])
        };
        // Bytes 0..12 hold the facet normal, which we recompute when needed.
        let corners = [12, 24, 36].map(|at| welder.vertex([f(at), f(at + 4), f(at + 8)]));
        welder.mesh.triangles.push(corners);
    }
    Ok(welder.mesh)
}

fn parse_ascii(bytes: &[u8]) -> Result<TriMesh> {
    let mut tokens = Tokens::new(bytes);
    let mut welder = Welder::default();
    let mut polygon: Vec<u32> = Vec::new();
    let mut in_solid = false;
    while let Some(word) = tokens.next_token() {
        let line = tokens.line;
        let bad = |what: String| Error::corrupt(format!("STL line {line}: {what}"));
        match word {
            b"solid" => {
                // The rest of the line is the solid's name.
                in_solid = true;
                while tokens.bytes.get(tokens.pos).is_some_and(|&b| b != b'\n') {
                    tokens.pos += 1;
                }
            }
            b"endsolid" => {
                in_solid = false;
                while tokens.bytes.get(tokens.pos).is_some_and(|&b| b != b'\n') {
                    tokens.pos += 1;
                }
            }
            _ if !in_solid => return Err(bad(format!("'{}' outside a solid", show(word)))),
            b"facet" | b"normal" | b"outer" | b"loop" | b"endfacet" => {}
            b"vertex" => {
                let mut p = [0.0f32; 3];
                for c in p.iter_mut() {
                    let t = tokens.next_token().ok_or_else(|| {
                        bad("file ends inside a vertex (file is truncated)".into())
                    })?;
                    *c = parse_number(t)
                        .ok_or_else(|| bad(format!("'{}' is not a number", show(t))))?;
                }
                polygon.push(welder.vertex(p));
            }
            b"endloop" => {
                if polygon.len() < 3 {
                    return Err(bad("facet has fewer than 3 vertices".into()));
                }
                push_fan(&polygon, &mut welder.mesh.triangles);
                polygon.clear();
            }
            other => {
                // Numbers after `normal` are skipped here; anything else is garbage.
                if parse_number::<f32>(other).is_none() {
                    return Err(bad(format!("unexpected '{}'", show(other))));
                }
            }
        }
    }
    if in_solid || !polygon.is_empty() {
        return Err(Error::corrupt(
            "ASCII STL ends before 'endsolid' (file is truncated)",
        ));
    }
    Ok(welder.mesh)
}

#[cfg(test)]
mod tests {
    use super::super::tests::sample_mesh;
    use super::*;

    fn write_binary(mesh: &TriMesh, header: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; 80];
        out[..header.len()].copy_from_slice(header);
        out.extend((mesh.triangles.len() as u32).to_le_bytes());
        for t in &mesh.triangles {
            out.extend([0u8; 12]);
            for &i in t {
                for c in mesh.vertices[i as usize] {
                    out.extend(c.to_le_bytes());
                }
            }
            out.extend([0u8; 2]);
        }
        out
    }

    fn write_ascii(mesh: &TriMesh) -> String {
        let mut s = String::from("solid test object\n");
        for t in &mesh.triangles {
            s += "  facet normal 0 0 1.5e-1\n    outer loop\n";
            for &i in t {
                let v = mesh.vertices[i as usize];
                s += &format!("      vertex {:e} {} {}\n", v[0], v[1], v[2]);
            }
            s += "    endloop\n  endfacet\n";
        }
        s + "endsolid test object\n"
    }

    #[test]
    fn binary_round_trip_even_when_header_says_solid() {
        let mesh = sample_mesh();
        assert_eq!(parse(&write_binary(&mesh, b"binary")).unwrap(), mesh);
        assert_eq!(
            parse(&write_binary(&mesh, b"solid but binary")).unwrap(),
            mesh
        );
    }

    #[test]
    fn ascii_round_trip_welds_corners() {
        let mesh = sample_mesh();
        assert_eq!(parse(write_ascii(&mesh).as_bytes()).unwrap(), mesh);
    }

    #[test]
    fn truncated_and_malformed() {
        let mesh = sample_mesh();
        let binary = write_binary(&mesh, b"x");
        let err = parse(&binary[..binary.len() - 1]).unwrap_err();
        assert!(err.to_string().contains("truncated"), "{err}");
        let err = parse(&binary[..40]).unwrap_err();
        assert!(err.to_string().contains("84-byte header"), "{err}");

        let mut absurd = binary[..84].to_vec();
        absurd[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
        let err = parse(&absurd).unwrap_err();
        assert!(err.to_string().contains("declares 4294967295"), "{err}");

        let ascii = write_ascii(&mesh);
        let cut = ascii.find("endloop").unwrap();
        let err = parse(&ascii.as_bytes()[..cut]).unwrap_err();
        assert!(err.to_string().contains("truncated"), "{err}");
        let err = parse(ascii.replace("vertex 1e0", "vertex one").as_bytes()).unwrap_err();
        assert!(err.to_string().contains("'one' is not a number"), "{err}");
        let err = parse(ascii.replace("outer loop", "outer banana").as_bytes()).unwrap_err();
        assert!(
            err.to_string().contains("line 3: unexpected 'banana'"),
            "{err}"
        );
    }
}

//! Wavefront OBJ reader: `v x y z [w]` and `f a b c ...` statements.
//!
//! Face corners may be `v`, `v/vt`, `v//vn` or `v/vt/vn`; only the position index is used.
//! Positive indices are 1-based, negative ones count back from the latest vertex (OBJ spec,
//! "Referencing vertex data"). Polygons are fan-triangulated; every other statement (normals,
//! texture coordinates, groups, materials, lines) is ignored.

use super::{parse_number, push_fan, show, validate, TriMesh};
use isogrid::{Error, Result};

pub(super) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let mut mesh = TriMesh::default();
    let mut polygon: Vec<u32> = Vec::new();
    for (line_index, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = line_index + 1;
        let bad = |what: String| Error::corrupt(format!("OBJ line {line_no}: {what}"));
        let mut words = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|w| !w.is_empty());
        match words.next() {
            Some(b"v") => {
                let mut xyz = [0.0f32; 3];
                for c in xyz.iter_mut() {
                    let word = words
                        .next()
                        .ok_or_else(|| bad("vertex has fewer than 3 coordinates".into()))?;
                    *c = parse_number(word)
                        .ok_or_else(|| bad(format!("'{}' is not a number", show(word))))?;
                }
                mesh.vertices.push(xyz);
            }
            Some(b"f") => {
                polygon.clear();
                for word in words {
                    let index_text = word.split(|&b| b == b'/').next().unwrap_or(word);
                    let index: i64 = parse_number(index_text)
                        .ok_or_else(|| bad(format!("'{}' is not a vertex index", show(word))))?;
                    let resolved = match index {
                        0 => return Err(bad("vertex index 0 (OBJ indices start at 1)".into())),
                        i if i > 0 => i - 1,
                        i => mesh.vertices.len() as i64 + i,
                    };
                    let resolved = u32::try_from(resolved).map_err(|_| {
                        bad(format!("vertex index {index} is outside the vertex list"))
                    })?;
                    polygon.push(resolved);
                }
                if polygon.len() < 3 {
                    return Err(bad("face has fewer than 3 vertices".into()));
                }
                push_fan(&polygon, &mut mesh.triangles);
            }
            _ => {}
        }
    }
    validate(&mesh)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::super::tests::sample_mesh;
    use super::*;

    #[test]
    fn quads_negative_indices_and_slashes() {
        // The sample mesh's square as a quad with absolute indices and texture/normal refs; the
        // tip triangles with negative (relative) indices written right after vertex 5.
        let text = "# test\r\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\n\
                    vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3//1 4\nv 0.25 0.5 -1.5\n\
                    usemtl m\ns off\nf -5 -1 -4\nf 2 -1 3\nl 1 2\n";
        let mesh = parse(text.as_bytes()).unwrap();
        assert_eq!(mesh, sample_mesh());
    }

    #[test]
    fn malformed_lines_name_the_problem() {
        let cases = [
            ("v 1 2\n", "line 1: vertex has fewer than 3"),
            ("v 0 0 0\nv 1 x 0\n", "line 2: 'x' is not a number"),
            ("v 0 0 0\nf 0 1 1\n", "index 0"),
            ("v 0 0 0\nf -2 1 1\n", "index -2 is outside"),
            ("v 0 0 0\nf 1 1\n", "fewer than 3 vertices"),
            ("v 0 0 0\nf 1 2 a\n", "'a' is not a vertex index"),
            ("v 0 0 0\nf 1 2 3\n", "beyond the 1 vertices"),
            ("v 0 nan 0\nf 1 1 1\n", "non-finite"),
        ];
        for (text, expected) in cases {
            let err = parse(text.as_bytes()).unwrap_err();
            assert!(err.to_string().contains(expected), "{expected}: got {err}");
        }
    }
}

//! Mesh writers: binary little-endian PLY (the PLY 1.0 format of Turk, 1994), Wavefront OBJ, and
//! VTK XML PolyData (`.vtp`, VTK's "VTK File Formats" document), which ParaView and PyVista read
//! with the per-vertex attribute that VTK's PLY reader drops.
//!
//! All go through [`crate::fs::write_atomic`]; positions are written as stored (the frame
//! [`McMesh::place`] put them in).

use super::mesh::McMesh;
use crate::error::Result;
use crate::fs::write_atomic;
use std::io::Write;
use std::path::Path;

/// Bytes gathered before each write call.
const CHUNK: usize = 1 << 20;

impl McMesh {
    /// Writes a binary little-endian PLY: `float x, y, z` per vertex and a
    /// `list uchar uint vertex_indices` per face. Errors name `path`.
    pub fn write_ply(&self, path: &Path) -> Result<()> {
        self.write_ply_with_values(path, None)
    }

    /// [`McMesh::write_ply`] with a per-vertex scalar, `property float quality` after x, y, z (the
    /// attribute of `isogrid mc --color-by`; NaN where there is none). `quality` is the name
    /// MeshLab reads as the vertex scalar (VTK's PLY reader keeps no extra vertex property under
    /// any name). Errors name `path`.
    ///
    /// # Panics
    /// When `values` does not hold one value per vertex.
    pub fn write_ply_with_values(&self, path: &Path, values: Option<&[f32]>) -> Result<()> {
        if let Some(values) = values {
            assert_eq!(values.len(), self.positions.len(), "one value per vertex");
        }
        write_atomic(path, |out| {
            write!(
                out,
                "ply\nformat binary_little_endian 1.0\ncomment isogrid marching cubes\n\
                 element vertex {}\nproperty float x\nproperty float y\nproperty float z\n{}\
                 element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
                self.positions.len(),
                if values.is_some() {
                    "property float quality\n"
                } else {
                    ""
                },
                self.triangles.len()
            )?;
            let mut buf = Vec::with_capacity(CHUNK + 16);
            for (i, p) in self.positions.iter().enumerate() {
                for c in p {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
                if let Some(values) = values {
                    buf.extend_from_slice(&values[i].to_le_bytes());
                }
                if buf.len() >= CHUNK {
                    out.write_all(&buf)?;
                    buf.clear();
                }
            }
            for t in &self.triangles {
                buf.push(3);
                for i in t {
                    buf.extend_from_slice(&i.to_le_bytes());
                }
                if buf.len() >= CHUNK {
                    out.write_all(&buf)?;
                    buf.clear();
                }
            }
            out.write_all(&buf)?;
            Ok(())
        })
    }

    /// Writes a Wavefront OBJ (`v x y z` lines, then `f a b c` with 1-based indices). Coordinates
    /// are printed in the shortest form that reads back to the same f32. Errors name `path`.
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        write_atomic(path, |out| {
            writeln!(out, "# isogrid marching cubes")?;
            let mut buf = Vec::with_capacity(CHUNK + 128);
            for p in &self.positions {
                writeln!(buf, "v {} {} {}", p[0], p[1], p[2])?;
                if buf.len() >= CHUNK {
                    out.write_all(&buf)?;
                    buf.clear();
                }
            }
            for t in &self.triangles {
                writeln!(
                    buf,
                    "f {} {} {}",
                    t[0] as u64 + 1,
                    t[1] as u64 + 1,
                    t[2] as u64 + 1
                )?;
                if buf.len() >= CHUNK {
                    out.write_all(&buf)?;
                    buf.clear();
                }
            }
            out.write_all(&buf)?;
            Ok(())
        })
    }

    /// Writes VTK XML PolyData (`.vtp`): the positions as `Points` (Float32 x, y, z), the
    /// triangles as `Polys` (UInt32 `connectivity`, UInt64 `offsets`) and, with `values`, one
    /// Float32 per vertex as the point array of the given name, made the active scalars (NaN
    /// where there is none). The arrays follow as raw little-endian bytes in the appended-data
    /// section, each after its UInt64 byte count. Errors name `path`.
    ///
    /// # Panics
    /// When `values` does not hold one value per vertex.
    pub fn write_vtp(&self, path: &Path, values: Option<(&str, &[f32])>) -> Result<()> {
        if let Some((_, values)) = values {
            assert_eq!(values.len(), self.positions.len(), "one value per vertex");
        }
        let (n, t) = (self.positions.len() as u64, self.triangles.len() as u64);
        // Byte counts of the appended arrays, in order: values, points, connectivity, offsets.
        let sizes = [values.map_or(0, |_| 4 * n), 12 * n, 12 * t, 8 * t];
        let mut offsets = [0u64; 4];
        for i in 1..4 {
            offsets[i] = offsets[i - 1]
                + if sizes[i - 1] > 0 {
                    8 + sizes[i - 1]
                } else {
                    0
                };
        }
        write_atomic(path, |out| {
            writeln!(out, "<?xml version=\"1.0\"?>")?;
            writeln!(
                out,
                "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" \
                 header_type=\"UInt64\">\n  <PolyData>\n    <Piece NumberOfPoints=\"{n}\" \
                 NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{t}\">"
            )?;
            match values {
                Some((name, _)) => {
                    let name = xml_escaped(name);
                    writeln!(
                        out,
                        "      <PointData Scalars=\"{name}\">\n        <DataArray type=\"Float32\" \
                         Name=\"{name}\" format=\"appended\" offset=\"0\"/>\n      </PointData>"
                    )?;
                }
                None => writeln!(out, "      <PointData/>")?,
            }
            writeln!(
                out,
                "      <Points>\n        <DataArray type=\"Float32\" NumberOfComponents=\"3\" \
                 format=\"appended\" offset=\"{}\"/>\n      </Points>\n      <Polys>\n        \
                 <DataArray type=\"UInt32\" Name=\"connectivity\" format=\"appended\" offset=\"{}\"/>\n        \
                 <DataArray type=\"UInt64\" Name=\"offsets\" format=\"appended\" offset=\"{}\"/>\n      \
                 </Polys>\n    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">",
                offsets[1], offsets[2], offsets[3]
            )?;
            out.write_all(b"   _")?;
            let mut buf = Vec::with_capacity(CHUNK + 32);
            let mut block = |out: &mut dyn Write,
                             size: u64,
                             items: &mut dyn Iterator<Item = [u8; 4]>|
             -> std::io::Result<()> {
                out.write_all(&size.to_le_bytes())?;
                for bytes in items {
                    buf.extend_from_slice(&bytes);
                    if buf.len() >= CHUNK {
                        out.write_all(&buf)?;
                        buf.clear();
                    }
                }
                out.write_all(&buf)?;
                buf.clear();
                Ok(())
            };
            if let Some((_, values)) = values {
                block(out, sizes[0], &mut values.iter().map(|v| v.to_le_bytes()))?;
            }
            let coordinates = self.positions.iter().flatten();
            block(out, sizes[1], &mut coordinates.map(|c| c.to_le_bytes()))?;
            let indices = self.triangles.iter().flatten();
            block(out, sizes[2], &mut indices.map(|i| i.to_le_bytes()))?;
            // Each UInt64 offset (3, 6, 9, …) as its two little-endian halves.
            let ends = (1..=t).flat_map(|k| {
                let b = (3 * k).to_le_bytes();
                [[b[0], b[1], b[2], b[3]], [b[4], b[5], b[6], b[7]]]
            });
            block(out, sizes[3], &mut ends.into_iter())?;
            writeln!(out, "\n  </AppendedData>\n</VTKFile>")?;
            Ok(())
        })
    }
}

/// `text` with XML's five special characters escaped, for an attribute value.
fn xml_escaped(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => escaped.push_str("&amp;"),
            '<' => escaped.push_str("&lt;"),
            '>' => escaped.push_str("&gt;"),
            '"' => escaped.push_str("&quot;"),
            '\'' => escaped.push_str("&apos;"),
            c => escaped.push(c),
        }
    }
    escaped
}

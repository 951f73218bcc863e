//! Mesh writers into any `Write`: binary little-endian PLY (the PLY 1.0 format of Turk, 1994),
//! Wavefront OBJ and binary STL (3D Systems' StereoLithography Interface Specification, 1989: what
//! slicers for 3D printing take); VTK XML PolyData is [`super::vtp`]'s. A file is written through
//! [`crate::fs::write_atomic`] (`write_ply` and `write_obj` here, `isogrid_io::mesh_write` for
//! every format). Positions are written as stored (the frame [`McMesh::place`] put them in).

use super::mesh::McMesh;
use crate::error::{Error, Result};
use crate::fs::write_atomic;
use std::io::Write;
use std::path::Path;

/// Bytes gathered before each write call.
const CHUNK: usize = 1 << 20;

impl McMesh {
    /// Writes a binary little-endian PLY at `path`, atomically ([`McMesh::write_ply_to`] without
    /// values). Errors name `path`.
    pub fn write_ply(&self, path: &Path) -> Result<()> {
        write_atomic(path, |out| self.write_ply_to(out, None))
    }

    /// Writes a binary little-endian PLY into `out`: `float x, y, z` per vertex, with `values`
    /// then a per-vertex scalar `property float quality` (the attribute of `isogrid mc
    /// --color-by`; NaN where there is none: `quality` is the name MeshLab reads as the vertex
    /// scalar; VTK's PLY reader keeps no extra vertex property under any name), and a
    /// `list uchar uint vertex_indices` per face.
    ///
    /// # Panics
    /// When `values` does not hold one value per vertex.
    pub fn write_ply_to(&self, out: &mut dyn Write, values: Option<&[f32]>) -> Result<()> {
        if let Some(values) = values {
            assert_eq!(values.len(), self.positions.len(), "one value per vertex");
        }
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
    }

    /// Writes a binary STL: an 80-byte header (not starting with `solid`, which would read as
    /// ASCII STL), the triangle count (u32), then per triangle its unit normal (from the
    /// counter-clockwise winding, so pointing out; zero for a triangle of no area), its three
    /// corners (f32 x, y, z each) and a zero u16. A mesh of more than 2³²−1 triangles is
    /// refused.
    pub fn write_stl_to(&self, out: &mut dyn Write) -> Result<()> {
        let count = u32::try_from(self.triangles.len()).map_err(|_| {
            Error::invalid("STL counts triangles in 32 bits, and the mesh has more")
        })?;
        let mut header = [b' '; 80];
        let text = b"isogrid marching cubes, binary STL";
        header[..text.len()].copy_from_slice(text);
        out.write_all(&header)?;
        out.write_all(&count.to_le_bytes())?;
        let mut buf = Vec::with_capacity(CHUNK + 64);
        for t in &self.triangles {
            let n = self.area_normal(*t);
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let n = match len > 0.0 && len.is_finite() {
                true => n.map(|c| (c / len) as f32),
                false => [0.0; 3],
            };
            for c in n {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            for &v in t {
                for c in self.positions[v as usize] {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
            buf.extend_from_slice(&0u16.to_le_bytes());
            if buf.len() >= CHUNK {
                out.write_all(&buf)?;
                buf.clear();
            }
        }
        out.write_all(&buf)?;
        Ok(())
    }

    /// Writes a Wavefront OBJ (`v x y z` lines, then `f a b c` with 1-based indices). Coordinates
    /// are printed in the shortest form that reads back to the same f32. Errors name `path`.
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        write_atomic(path, |out| self.write_obj_to(out))
    }

    /// [`McMesh::write_obj`] into `out`.
    pub fn write_obj_to(&self, out: &mut dyn Write) -> Result<()> {
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
    }
}

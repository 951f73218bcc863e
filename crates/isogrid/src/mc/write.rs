//! Mesh writers: binary little-endian PLY (the PLY 1.0 format of Turk, 1994), Wavefront OBJ, and
//! VTK XML PolyData through [`super::vtp`], which ParaView and PyVista read with the per-vertex
//! attribute that VTK's PLY reader drops.
//!
//! All go through [`crate::fs::write_atomic`]; positions are written as stored (the frame
//! [`McMesh::place`] put them in).

use super::mesh::McMesh;
use super::vtp::{write_vtp, VtkArray, VtkValues, VtpArrays};
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

    /// Writes VTK XML PolyData (`.vtp`, [`super::vtp::write_vtp`]) with, given `values` (a name
    /// and one value per vertex), that Float32 point array as the active scalars (NaN where there
    /// is none). Errors name `path`.
    ///
    /// # Panics
    /// When `values` does not hold one value per vertex.
    pub fn write_vtp(&self, path: &Path, values: Option<(&str, &[f32])>) -> Result<()> {
        let point = values.map(|(name, values)| VtkArray {
            name,
            values: VtkValues::Float32(values),
        });
        let arrays = VtpArrays {
            point: point.as_slice(),
            ..Default::default()
        };
        write_vtp(path, &[self], arrays)
    }
}

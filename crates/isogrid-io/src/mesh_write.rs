//! The mesh file a name asks for, by its extension, written by the core's writers
//! (`isogrid::mc`, and [`crate::glb`] for glTF): binary PLY, OBJ, binary STL, VTK XML PolyData and
//! glTF 2.0 binary. One rule for `isogrid mc`'s
//! mesh and for one file per label. Positions are written as the mesh holds them: the caller
//! places it in world (patient) or index space first (`McMesh::place`); the formats carry no
//! unit.

use crate::glb::{glb_bytes, GltfMesh};
use isogrid::mc::vtp::{write_vtp_to, VtkArray, VtkValues, VtpArrays};
use isogrid::mc::McMesh;
use isogrid::{Error, Result};
use std::io::Write;
use std::path::Path;

/// A mesh file format `isogrid` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFileFormat {
    /// Binary little-endian PLY; per-vertex values as `float quality` (MeshLab's vertex scalar).
    Ply,
    /// Wavefront OBJ; no per-vertex values.
    Obj,
    /// Binary STL (3D printing); no per-vertex values.
    Stl,
    /// VTK XML PolyData (ParaView, PyVista); per-vertex values as a named point array.
    Vtp,
    /// glTF 2.0 binary (Blender, three.js, web viewers): one mesh named `isosurface` in the
    /// renderer's surface colour; per-vertex values as the vertex attribute `_VALUE`.
    Glb,
}

impl MeshFileFormat {
    /// The format `path`'s extension names (any case), or an error naming `path` that lists them.
    pub fn of(path: &Path) -> Result<Self> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("ply") => Ok(MeshFileFormat::Ply),
            Some("obj") => Ok(MeshFileFormat::Obj),
            Some("stl") => Ok(MeshFileFormat::Stl),
            Some("vtp") => Ok(MeshFileFormat::Vtp),
            Some("glb") => Ok(MeshFileFormat::Glb),
            _ => Err(
                Error::invalid("mesh output must end in .ply, .obj, .stl, .vtp or .glb")
                    .with_path(path),
            ),
        }
    }

    /// The format's name, as errors say it.
    pub fn name(self) -> &'static str {
        match self {
            MeshFileFormat::Ply => "PLY",
            MeshFileFormat::Obj => "OBJ",
            MeshFileFormat::Stl => "STL",
            MeshFileFormat::Vtp => "VTK PolyData",
            MeshFileFormat::Glb => "glTF",
        }
    }

    /// Whether the format holds a value per vertex.
    pub fn holds_values(self) -> bool {
        matches!(
            self,
            MeshFileFormat::Ply | MeshFileFormat::Vtp | MeshFileFormat::Glb
        )
    }

    /// Writes `mesh` in this format into `out`, with `values` (the attribute's name and one
    /// value per vertex) where the format holds them.
    ///
    /// # Panics
    /// When `values` are given to a format that holds none, or not one per vertex.
    pub fn write_to(
        self,
        mesh: &McMesh,
        out: &mut dyn Write,
        values: Option<(&str, &[f32])>,
    ) -> Result<()> {
        assert!(
            values.is_none() || self.holds_values(),
            "values in a format without them"
        );
        match self {
            MeshFileFormat::Ply => mesh.write_ply_to(out, values.map(|(_, v)| v)),
            MeshFileFormat::Obj => mesh.write_obj_to(out),
            MeshFileFormat::Stl => mesh.write_stl_to(out),
            MeshFileFormat::Vtp => {
                let point = values.map(|(name, values)| VtkArray {
                    name,
                    values: VtkValues::Float32(values),
                });
                let arrays = VtpArrays {
                    point: point.as_slice(),
                    ..Default::default()
                };
                write_vtp_to(out, &[mesh], arrays)
            }
            MeshFileFormat::Glb => {
                let [r, g, b] = isogrid::shading::ALBEDO;
                let surface = GltfMesh {
                    name: "isosurface",
                    color: [r, g, b, 1.0],
                    extras: None,
                    mesh,
                    values: values.map(|(_, v)| v),
                };
                let bytes = glb_bytes(&[surface], values.map(|(name, _)| name))?;
                Ok(out.write_all(&bytes)?)
            }
        }
    }

    /// [`MeshFileFormat::write_to`] the file `path`, atomically. Errors name `path`.
    pub fn write(self, mesh: &McMesh, path: &Path, values: Option<(&str, &[f32])>) -> Result<()> {
        isogrid::fs::write_atomic(path, |out| self.write_to(mesh, out, values))
    }
}

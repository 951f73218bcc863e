//! Where label meshes go, by the output's name: one `.glb` or `.vtp` of every label, a folder of
//! neuroglancer precomputed meshes (a name without an extension), or one file per label from a
//! template (`organs/{name}.stl`). The one rule `isogrid mc --labels` and Python's
//! `LabelGrid.write_meshes` follow.

use super::each::{is_template, write_each, EachFormat};
use super::gltf::write_glb;
use super::label_mesh::LabelMesh;
use super::precomputed::write_precomputed;
use super::vtp::write_vtp;
use isogrid::{Error, Result};
use std::path::Path;

/// An output of label meshes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LabelMeshOutput<'a> {
    /// glTF 2.0 binary: a named, coloured mesh per label.
    Glb(&'a Path),
    /// VTK XML PolyData: one mesh, each triangle's label and colour as cell arrays.
    Vtp(&'a Path),
    /// A new folder of neuroglancer's legacy precomputed meshes.
    Precomputed(&'a Path),
    /// One file per label, named from a template.
    Each(&'a Path, EachFormat),
}

impl<'a> LabelMeshOutput<'a> {
    /// The output `path` names; an unknown extension is an error naming `path` that lists them.
    pub fn of(path: &'a Path) -> Result<Self> {
        if is_template(path) {
            return Ok(LabelMeshOutput::Each(path, EachFormat::of(path)?));
        }
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("glb") => Ok(LabelMeshOutput::Glb(path)),
            Some("vtp") => Ok(LabelMeshOutput::Vtp(path)),
            None => Ok(LabelMeshOutput::Precomputed(path)),
            Some(_) => Err(Error::invalid(
                "label meshes are written as .glb (glTF 2.0), .vtp (VTK XML PolyData), a folder \
                 of neuroglancer precomputed meshes (a name without an extension), or one file \
                 per label named from a template such as organs/{name}.stl",
            )
            .with_path(path)),
        }
    }

    /// Whether the output keeps a value per vertex.
    pub fn holds_values(&self) -> bool {
        match self {
            LabelMeshOutput::Glb(_) | LabelMeshOutput::Vtp(_) => true,
            LabelMeshOutput::Precomputed(_) => false,
            LabelMeshOutput::Each(_, format) => format.holds_values(),
        }
    }

    /// What errors call the output's format.
    pub fn describe(&self) -> String {
        match self {
            LabelMeshOutput::Glb(_) => "glTF".into(),
            LabelMeshOutput::Vtp(_) => "VTK PolyData".into(),
            LabelMeshOutput::Precomputed(_) => "neuroglancer's precomputed meshes".into(),
            LabelMeshOutput::Each(_, EachFormat::Glb) => "glTF files".into(),
            LabelMeshOutput::Each(_, EachFormat::Mesh(f)) => format!("{} files", f.name()),
        }
    }

    /// Writes `meshes` (labels without triangles are left out), with `attribute`'s name over the
    /// meshes' values where they carry them and the output keeps them.
    pub fn write(&self, meshes: &[LabelMesh], attribute: Option<&str>) -> Result<()> {
        let attribute = attribute.filter(|_| self.holds_values());
        match *self {
            LabelMeshOutput::Glb(path) => write_glb(path, meshes, attribute),
            LabelMeshOutput::Vtp(path) => write_vtp(path, meshes, attribute),
            LabelMeshOutput::Precomputed(path) => write_precomputed(path, meshes),
            LabelMeshOutput::Each(template, _) => write_each(template, meshes, attribute).map(drop),
        }
    }
}

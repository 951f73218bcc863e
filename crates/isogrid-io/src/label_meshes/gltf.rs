//! glTF 2.0 binary (`.glb`) of per-label meshes, through the one glTF writer ([`crate::glb`]):
//! one node and mesh per label, named after it, its colour as the material's base colour, its
//! value in the node's `extras` as `{"label": "VALUE"}`, and with an attribute its values as the
//! vertex attribute `_VALUE`.

use super::label_mesh::LabelMesh;
use crate::glb::GltfMesh;
use isogrid::{Error, Result};
use std::path::Path;

/// Writes `meshes` (labels without triangles are left out) as a `.glb` at `path`, atomically,
/// with `attribute`'s name over the meshes' values where they carry them. Errors name `path`.
pub fn write_glb(path: &Path, meshes: &[LabelMesh], attribute: Option<&str>) -> Result<()> {
    let bytes = glb_bytes(meshes, attribute).map_err(|e| e.with_path(path))?;
    isogrid::fs::write_atomic(path, |out| Ok(out.write_all(&bytes)?))
}

/// The `.glb` file's bytes.
pub(crate) fn glb_bytes(meshes: &[LabelMesh], attribute: Option<&str>) -> Result<Vec<u8>> {
    if meshes.iter().all(|m| m.mesh.triangles.is_empty()) {
        return Err(Error::invalid("no label has a surface to write"));
    }
    let meshes: Vec<GltfMesh> = meshes
        .iter()
        .map(|m| {
            let [r, g, b] = m.label.albedo();
            GltfMesh {
                name: &m.label.name,
                color: [r, g, b, m.label.rgba[3] as f32 / 255.0],
                extras: Some(("label", m.value)),
                mesh: m.mesh,
                values: m.values,
            }
        })
        .collect();
    crate::glb::glb_bytes(&meshes, attribute)
}

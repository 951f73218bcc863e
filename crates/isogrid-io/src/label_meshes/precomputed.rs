//! neuroglancer's legacy single-resolution precomputed meshes, as its
//! `datasource/precomputed/meshes.md` lays them out, in a new folder:
//!
//! | file | content |
//! |---|---|
//! | `info` | `{"@type": "neuroglancer_legacy_mesh", "segment_properties": "segment_properties"}` |
//! | `<id>:0` | the manifest, `{"fragments": ["<id>:0:1"]}` |
//! | `<id>:0:1` | u32 LE vertex count, then x, y, z f32 LE per vertex, then u32 LE index triples |
//! | `segment_properties/info` | the labels' names, as an inline `label` property |
//!
//! `<id>` is the label value in base 10. neuroglancer draws the non-zero segments of a
//! segmentation and reads positions as nanometres; they are written in the units the caller
//! placed them in.

use super::label_mesh::LabelMesh;
use isogrid::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Writes `meshes` (label 0, the background, and labels without triangles are left out) as a new
/// folder `path`, atomically: the folder appears complete or not at all, and an existing `path`
/// is refused. Negative label values have no segment id and are refused. Errors name `path`.
pub fn write_precomputed(path: &Path, meshes: &[LabelMesh]) -> Result<()> {
    let written: Vec<&LabelMesh> = meshes
        .iter()
        .filter(|m| m.label.value != 0 && !m.mesh.triangles.is_empty())
        .collect();
    if written.is_empty() {
        return Err(Error::invalid("no non-zero label has a surface to write").with_path(path));
    }
    for m in &written {
        if m.value.parse::<u64>().is_err() {
            return Err(Error::invalid(format!(
                "label {} has no neuroglancer segment id (ids are unsigned 64-bit integers)",
                m.value
            ))
            .with_path(path));
        }
        if m.mesh.positions.iter().flatten().any(|c| !c.is_finite()) {
            return Err(Error::invalid(format!(
                "label {}'s mesh has a vertex beyond f32's range",
                m.value
            ))
            .with_path(path));
        }
    }
    let staged = isogrid::fs::stage_dir(path, |dir| {
        let write = |name: &str, bytes: &[u8]| -> Result<()> {
            let mut file = std::fs::File::create(dir.join(name))?;
            file.write_all(bytes)?;
            file.sync_all()?;
            Ok(())
        };
        write(
            "info",
            serde_json::json!({
                "@type": "neuroglancer_legacy_mesh",
                "segment_properties": "segment_properties",
            })
            .to_string()
            .as_bytes(),
        )?;
        for m in &written {
            let fragment = format!("{}:0:1", m.value);
            write(
                &format!("{}:0", m.value),
                serde_json::json!({ "fragments": [fragment] })
                    .to_string()
                    .as_bytes(),
            )?;
            let mesh = m.mesh;
            let mut bytes =
                Vec::with_capacity(4 + 12 * (mesh.positions.len() + mesh.triangles.len()));
            bytes.extend_from_slice(&(mesh.positions.len() as u32).to_le_bytes());
            for p in &mesh.positions {
                for c in p {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
            for t in &mesh.triangles {
                for v in t {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
            write(&fragment, &bytes)?;
        }
        std::fs::create_dir(dir.join("segment_properties"))?;
        write(
            "segment_properties/info",
            serde_json::json!({
                "@type": "neuroglancer_segment_properties",
                "inline": {
                    "ids": written.iter().map(|m| m.value).collect::<Vec<_>>(),
                    "properties": [{
                        "id": "label",
                        "type": "label",
                        "values": written.iter().map(|m| m.label.name.as_str()).collect::<Vec<_>>(),
                    }],
                },
            })
            .to_string()
            .as_bytes(),
        )?;
        Ok(())
    })?;
    staged.commit()
}

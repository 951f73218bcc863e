//! VTK XML PolyData (`.vtp`) of per-label meshes, for ParaView and PyVista, through the one `.vtp`
//! writer ([`isogrid::mc::vtp`]): the labels' meshes in one piece, each triangle's label value as
//! the cell array `label` (Int64, or UInt64 when a value passes Int64's range) and its colour as
//! `label_color` (sRGB UInt8 × 3: ParaView shows it as is with "Map Scalars" off), the labels'
//! values and names as the field arrays `label_values` and `label_names`, and with values, the
//! attribute as the active point array.

use super::label_mesh::LabelMesh;
use isogrid::mc::vtp::{write_vtp as write_poly_data, VtkArray, VtkValues, VtpArrays};
use isogrid::mc::McMesh;
use isogrid::{Error, Result};
use std::path::Path;

/// Writes `meshes` (labels without triangles are left out) as a `.vtp` at `path`, atomically,
/// with `attribute`'s name over the meshes' values where they carry them. Errors name `path`.
///
/// # Panics
/// When `attribute` is given and a written mesh has no values, or not one per vertex.
pub fn write_vtp(path: &Path, meshes: &[LabelMesh], attribute: Option<&str>) -> Result<()> {
    let written: Vec<&LabelMesh> = meshes
        .iter()
        .filter(|m| !m.mesh.triangles.is_empty())
        .collect();
    if written.is_empty() {
        return Err(Error::invalid("no label has a surface to write").with_path(path));
    }
    let signed: Option<Vec<i64>> = written.iter().map(|m| m.value.parse().ok()).collect();
    let unsigned: Vec<u64> = match &signed {
        Some(_) => Vec::new(),
        None => written
            .iter()
            .map(|m| m.value.parse())
            .collect::<Result<_, _>>()
            .map_err(|_| Error::invalid("a label value is not an integer").with_path(path))?,
    };
    let (values, per_mesh) = match &signed {
        Some(v) => (VtkValues::Int64(v), VtkValues::Int64PerMesh(v)),
        None => (
            VtkValues::UInt64(&unsigned),
            VtkValues::UInt64PerMesh(&unsigned),
        ),
    };
    let colours: Vec<[u8; 3]> = written
        .iter()
        .map(|m| [0, 1, 2].map(|c| m.label.rgba[c]))
        .collect();
    let names: Vec<String> = written.iter().map(|m| m.label.name.clone()).collect();
    let point_values: Vec<f32>;
    let point: Vec<VtkArray> = match attribute {
        Some(name) => {
            point_values = written
                .iter()
                .flat_map(|m| {
                    let v = m.values.expect("a mesh without values");
                    assert_eq!(v.len(), m.mesh.positions.len(), "one value per vertex");
                    v.iter().copied()
                })
                .collect();
            vec![VtkArray {
                name,
                values: VtkValues::Float32(&point_values),
            }]
        }
        None => Vec::new(),
    };
    let cell = [
        VtkArray {
            name: "label",
            values: per_mesh,
        },
        VtkArray {
            name: "label_color",
            values: VtkValues::RgbPerMesh(&colours),
        },
    ];
    let field = [
        VtkArray {
            name: "label_values",
            values,
        },
        VtkArray {
            name: "label_names",
            values: VtkValues::Strings(&names),
        },
    ];
    let pieces: Vec<&McMesh> = written.iter().map(|m| m.mesh).collect();
    let arrays = VtpArrays {
        point: &point,
        cell: &cell,
        field: &field,
    };
    write_poly_data(path, &pieces, arrays)
}

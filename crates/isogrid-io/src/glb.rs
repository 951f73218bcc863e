//! glTF 2.0 binary (`.glb`), the one writer of the format, through the `gltf` crate's JSON model
//! and GLB container: one node and mesh per [`GltfMesh`], named, its colour as the material's
//! base colour (linear, as glTF wants it), optional `extras` on the node. Indexed triangles, u32
//! indices, f32 positions with their bounds and unit vertex normals, and with an attribute its
//! values as the application-specific vertex attribute `_VALUE` (f32, NaN where there is none;
//! the accessor is named after the attribute), which three.js loads as `_value` and glTF viewers
//! that know no such attribute ignore. Positions are written as given (world or index space, as
//! the caller placed them: `McMesh::place`); glTF carries no unit.

use gltf::binary::{Glb, Header};
use gltf::json;
use isogrid::mc::McMesh;
use isogrid::{Error, Result};
use json::validation::Checked::Valid;
use json::validation::USize64;
use std::borrow::Cow;
use std::collections::BTreeMap;

/// One mesh of a `.glb`: an isosurface, or one label's surface.
#[derive(Debug, Clone, Copy)]
pub struct GltfMesh<'a> {
    /// The node's, mesh's and material's name.
    pub name: &'a str,
    /// The base colour, linear RGB and alpha (below 1: blended).
    pub color: [f32; 4],
    /// The node's `extras` as one key and text value (a label's `{"label": "VALUE"}`), or none.
    pub extras: Option<(&'a str, &'a str)>,
    pub mesh: &'a McMesh,
    /// One value per vertex of `mesh` (NaN where there is none), or none.
    pub values: Option<&'a [f32]>,
}

fn accessor(
    view: json::Index<json::buffer::View>,
    count: usize,
    component: json::accessor::ComponentType,
    type_: json::accessor::Type,
    bounds: Option<([f32; 3], [f32; 3])>,
) -> json::Accessor {
    json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64(0)),
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(component)),
        extensions: Default::default(),
        extras: Default::default(),
        type_: Valid(type_),
        min: bounds.map(|(lo, _)| json::Value::from(lo.to_vec())),
        max: bounds.map(|(_, hi)| json::Value::from(hi.to_vec())),
        name: None,
        normalized: false,
        sparse: None,
    }
}

/// The `.glb` file's bytes of `meshes` (those without triangles are left out), with `attribute`'s
/// name over the meshes' values where they carry them.
pub fn glb_bytes(meshes: &[GltfMesh], attribute: Option<&str>) -> Result<Vec<u8>> {
    let mut root = json::Root::default();
    let mut bin: Vec<u8> = Vec::new();
    let buffer = json::Index::new(0);
    let mut nodes = Vec::new();
    let view = |root: &mut json::Root,
                bin: &mut Vec<u8>,
                bytes: &[u8],
                target: json::buffer::Target|
     -> json::Index<json::buffer::View> {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        root.push(json::buffer::View {
            buffer,
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: Default::default(),
            extras: Default::default(),
            name: None,
            target: Some(Valid(target)),
        })
    };
    for m in meshes.iter().filter(|m| !m.mesh.triangles.is_empty()) {
        let positions = &m.mesh.positions;
        if positions.iter().flatten().any(|c| !c.is_finite()) {
            return Err(Error::invalid(format!(
                "{}'s mesh has a vertex beyond f32's range",
                m.name
            )));
        }
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let normals = vertex_normals(m.mesh);
        use json::accessor::{ComponentType, Type};
        use json::buffer::Target;
        let v = view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(positions),
            Target::ArrayBuffer,
        );
        let position = root.push(accessor(
            v,
            positions.len(),
            ComponentType::F32,
            Type::Vec3,
            Some((lo, hi)),
        ));
        let v = view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(&normals),
            Target::ArrayBuffer,
        );
        let normal = root.push(accessor(
            v,
            normals.len(),
            ComponentType::F32,
            Type::Vec3,
            None,
        ));
        let v = view(
            &mut root,
            &mut bin,
            bytemuck::cast_slice(&m.mesh.triangles),
            Target::ElementArrayBuffer,
        );
        let indices = root.push(accessor(
            v,
            3 * m.mesh.triangles.len(),
            ComponentType::U32,
            Type::Scalar,
            None,
        ));
        let values = match (attribute, m.values) {
            (Some(name), Some(values)) => {
                assert_eq!(values.len(), positions.len(), "one value per vertex");
                let v = view(
                    &mut root,
                    &mut bin,
                    bytemuck::cast_slice(values),
                    Target::ArrayBuffer,
                );
                let mut values =
                    accessor(v, positions.len(), ComponentType::F32, Type::Scalar, None);
                values.name = Some(name.to_string());
                Some(root.push(values))
            }
            _ => None,
        };
        let [r, g, b, alpha] = m.color;
        let material = root.push(json::Material {
            name: Some(m.name.to_string()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([r, g, b, alpha]),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(0.7),
                ..Default::default()
            },
            alpha_mode: Valid(if alpha < 1.0 {
                json::material::AlphaMode::Blend
            } else {
                json::material::AlphaMode::Opaque
            }),
            // A surface that reaches the volume's border is open there.
            double_sided: true,
            ..Default::default()
        });
        let primitive = json::mesh::Primitive {
            attributes: BTreeMap::from_iter(
                [
                    (Valid(json::mesh::Semantic::Positions), position),
                    (Valid(json::mesh::Semantic::Normals), normal),
                ]
                .into_iter()
                .chain(values.map(|v| (Valid(json::mesh::Semantic::Extras("VALUE".into())), v))),
            ),
            extensions: Default::default(),
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        };
        let mesh = root.push(json::Mesh {
            extensions: Default::default(),
            extras: Default::default(),
            name: Some(m.name.to_string()),
            primitives: vec![primitive],
            weights: None,
        });
        let extras = m
            .extras
            .map(|(key, value)| {
                let mut object = serde_json::Map::new();
                object.insert(key.to_string(), value.into());
                serde_json::value::RawValue::from_string(
                    serde_json::Value::Object(object).to_string(),
                )
                .map_err(|e| Error::invalid(format!("glTF extras: {e}")))
            })
            .transpose()?;
        nodes.push(root.push(json::Node {
            mesh: Some(mesh),
            name: Some(m.name.to_string()),
            extras,
            ..Default::default()
        }));
    }
    // No triangle at all: a file of no scene (glTF wants at least one node in a scene and one byte
    // in a buffer), which viewers open as empty.
    let bin = match nodes.is_empty() {
        true => None,
        false => {
            root.push(json::Buffer {
                byte_length: USize64::from(bin.len()),
                extensions: Default::default(),
                extras: Default::default(),
                name: None,
                uri: None,
            });
            let scene = root.push(json::Scene {
                extensions: Default::default(),
                extras: Default::default(),
                name: None,
                nodes,
            });
            root.scene = Some(scene);
            Some(Cow::Owned(bin))
        }
    };
    let json_bytes =
        json::serialize::to_vec(&root).map_err(|e| Error::invalid(format!("glTF JSON: {e}")))?;
    let glb = Glb {
        header: Header {
            magic: *b"glTF",
            version: 2,
            // Set by `to_vec`.
            length: 0,
        },
        json: Cow::Owned(json_bytes),
        bin,
    };
    glb.to_vec()
        .map_err(|e| Error::invalid(format!("writing the glTF container: {e}")))
}

/// Area-weighted vertex normals of `mesh`, unit length ((0, 0, 1) where the triangles around a
/// vertex cancel out): triangles wind counter-clockwise seen from outside, so they point out.
fn vertex_normals(mesh: &McMesh) -> Vec<[f32; 3]> {
    let mut sums = vec![[0.0f64; 3]; mesh.positions.len()];
    for t in &mesh.triangles {
        let n = mesh.area_normal(*t);
        for &v in t {
            for a in 0..3 {
                sums[v as usize][a] += n[a];
            }
        }
    }
    sums.iter()
        .map(|n| {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                n.map(|c| (c / len) as f32)
            } else {
                [0.0, 0.0, 1.0]
            }
        })
        .collect()
}

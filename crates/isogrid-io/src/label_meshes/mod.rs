//! Per-label meshes in formats other tools open: glTF 2.0 binary (`.glb`: one named, coloured mesh
//! per label, for Blender, three.js and any glTF viewer), VTK XML PolyData (`.vtp`: one mesh with
//! each triangle's label, for ParaView and PyVista) and neuroglancer's legacy precomputed meshes
//! (a folder: one fragment and manifest per segment, for connectomics viewers); or one file per
//! label, named from a template (`organs/{name}.stl`).
//!
//! Positions are written as given: the caller places each `McMesh` in world (patient) space or
//! index space first (`McMesh::place`); the formats carry no unit.

mod each;
mod gltf;
mod label_mesh;
mod output;
mod precomputed;
mod vtp;

pub use self::gltf::write_glb;
pub use each::{file_names, is_template, write_each, EachFormat};
pub use label_mesh::LabelMesh;
pub use output::LabelMeshOutput;
pub use precomputed::write_precomputed;
pub use vtp::write_vtp;

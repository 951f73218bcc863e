//! [`LabelMesh`], one label's mesh as the exporters take it, and the normals they write.

use isogrid::mc::McMesh;
use isogrid::Label;

/// One label's mesh, its table entry (value, name, colour) and its values of an attribute.
#[derive(Debug, Clone, Copy)]
pub struct LabelMesh<'a> {
    pub label: &'a Label,
    /// The label's value as text (`isogrid::labels::display_value`: signed volumes keep their
    /// sign).
    pub value: &'a str,
    pub mesh: &'a McMesh,
    /// One value per vertex of `mesh` (NaN where there is none), or none.
    pub values: Option<&'a [f32]>,
}

/// Area-weighted vertex normals of `mesh`, unit length ((0, 0, 1) where the triangles around a
/// vertex cancel out): triangles wind counter-clockwise seen from outside, so they point out.
pub(crate) fn vertex_normals(mesh: &McMesh) -> Vec<[f32; 3]> {
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

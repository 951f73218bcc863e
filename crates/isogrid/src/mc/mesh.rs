//! The Marching Cubes output types shared by the extraction, the snorm16 packing and the writers.

/// Which samples are inside the surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Inside {
    /// `value >= iso`: isogrid's rule, shared with the CGC extraction.
    #[default]
    AtOrAbove,
    /// `value > iso`: scikit-image's rule.
    Above,
}

/// An indexed triangle mesh from Marching Cubes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct McMesh {
    /// Vertex positions in the renderer's frame: sample (i, j, k) is at (i·sx, j·sy, k·sz), until
    /// [`McMesh::place`] moves them.
    pub positions: Vec<[f32; 3]>,
    /// Counter-clockwise seen from outside (value < iso), indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

use crate::error::{Error, Result};

/// The frame [`McMesh::place`] puts the vertices in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MeshSpace {
    /// The volume's world (patient) space: origin, spacing and directions, as nibabel's affine
    /// and ITK's physical points place sample (i, j, k).
    #[default]
    World,
    /// Sample indices: sample (i, j, k) at (i, j, k).
    Index,
}

impl McMesh {
    /// The vertices in index space (sample (i, j, k) at (i, j, k)), in f64, from the library's
    /// (i·sx, j·sy, k·sz) with `spacing`: where per-vertex values are looked up.
    pub fn index_positions(&self, spacing: [f64; 3]) -> Vec<[f64; 3]> {
        self.positions
            .iter()
            .map(|p| [0, 1, 2].map(|a| p[a] as f64 / spacing[a]))
            .collect()
    }

    /// `(p1 − p0) × (p2 − p0)` of `triangle`, in f64 in the frame the positions are in: twice its
    /// area, pointing out (triangles wind counter-clockwise seen from outside).
    pub fn area_normal(&self, triangle: [u32; 3]) -> [f64; 3] {
        let p = triangle.map(|v| self.positions[v as usize].map(f64::from));
        let (u, w) = (
            [0, 1, 2].map(|a| p[1][a] - p[0][a]),
            [0, 1, 2].map(|a| p[2][a] - p[0][a]),
        );
        [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ]
    }

    /// Moves the vertices from the renderer's frame (sample (i, j, k) at (i·sx, j·sy, k·sz)) into
    /// `space` of the volume of `geometry`. In world space sample (i, j, k) is at
    /// origin + i·sx·d_i + j·sy·d_j + k·sz·d_k, d_i, d_j, d_k being the direction rows. Directions
    /// that mirror (a flipped axis: negative determinant) would turn the triangles inside out, so
    /// their winding is reversed to stay counter-clockwise seen from outside. Sums are taken in
    /// f64 and rounded once to f32. A vertex beyond f32's range (a spacing or origin of 1e200) is
    /// an error: a mesh file of `inf` coordinates is no mesh.
    pub fn place(&mut self, geometry: &crate::volume::Geometry, space: MeshSpace) -> Result<()> {
        let s = geometry.spacing;
        match space {
            MeshSpace::Index => {
                for p in &mut self.positions {
                    *p = [0, 1, 2].map(|a| (p[a] as f64 / s[a]) as f32);
                }
            }
            MeshSpace::World => {
                let (o, d) = (geometry.origin, geometry.direction);
                for p in &mut self.positions {
                    let q = p.map(f64::from);
                    *p = [0, 1, 2]
                        .map(|a| (o[a] + q[0] * d[0][a] + q[1] * d[1][a] + q[2] * d[2][a]) as f32);
                }
                if crate::volume::directions_mirror(&d) {
                    for t in &mut self.triangles {
                        t.swap(1, 2);
                    }
                }
            }
        }
        if let Some(p) = self
            .positions
            .iter()
            .find(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(Error::too_large(format!(
                "a mesh vertex lands at {p:?}, beyond the range of 32-bit floats: the spacing {:?} \
                 or origin {:?} is too large",
                geometry.spacing, geometry.origin
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Geometry;

    #[test]
    fn world_space_applies_directions_and_keeps_the_winding_outward() {
        let mut g = Geometry::new([4, 4, 4]);
        g.spacing = [2.0, 3.0, 4.0];
        g.origin = [10.0, 20.0, 30.0];
        // x flipped: a mirror (determinant -1).
        g.direction = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mut mesh = McMesh {
            // Sample (1, 2, 3) in the renderer's frame.
            positions: vec![[2.0, 6.0, 12.0]; 3],
            triangles: vec![[0, 1, 2]],
        };
        let mut index = mesh.clone();
        mesh.place(&g, MeshSpace::World).unwrap();
        assert_eq!(mesh.positions[0], [8.0, 26.0, 42.0]);
        assert_eq!(mesh.triangles, vec![[0, 2, 1]]);
        index.place(&g, MeshSpace::Index).unwrap();
        assert_eq!(index.positions[0], [1.0, 2.0, 3.0]);
        assert_eq!(index.triangles, vec![[0, 1, 2]]);
        // A finite but huge origin gives vertices beyond f32: an error, not `inf`.
        g.origin = [1e200, 0.0, 0.0];
        let mut huge = McMesh {
            positions: vec![[2.0, 6.0, 12.0]],
            triangles: vec![],
        };
        let err = huge.place(&g, MeshSpace::World).unwrap_err();
        assert!(
            err.to_string()
                .contains("beyond the range of 32-bit floats"),
            "{err}"
        );
    }
}

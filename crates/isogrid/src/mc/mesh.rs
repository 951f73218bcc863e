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
    /// Vertex positions in world units without the origin: sample (i, j, k) is at (i·sx, j·sy, k·sz).
    pub positions: Vec<[f32; 3]>,
    /// Counter-clockwise seen from outside (value < iso), indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

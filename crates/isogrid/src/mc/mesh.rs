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

impl McMesh {
    /// Moves every vertex by `offset`: with a volume's origin, from the renderer's frame (sample
    /// (0, 0, 0) at zero) to the volume's world coordinates, as `isogrid mc` and Python's
    /// `marching_cubes` give them. Sums are taken in f64 and rounded once to f32.
    pub fn translate(&mut self, offset: [f64; 3]) {
        if offset == [0.0; 3] {
            return;
        }
        for p in &mut self.positions {
            *p = [0, 1, 2].map(|a| (p[a] as f64 + offset[a]) as f32);
        }
    }
}

//! The paper's compact MC vertex format (Table 3): positions as three snorm16 values scaled by
//! the mesh bounds, 6 bytes per vertex.

use super::mesh::McMesh;

/// An [`McMesh`] with quantised positions.
///
/// Decode: `position[a] = center[a] + half_extent[a] * (q[a] as f32 / 32767.0)`, for q in
/// −32767..=32767 (the snorm16 convention; −32768 is never written). The quantisation step along
/// axis `a` is `half_extent[a] / 32767`, and decoding is within half a step of the original
/// position. An axis with zero extent decodes to `center`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SnormMesh {
    pub positions: Vec<[i16; 3]>,
    /// Middle of the bounding box of the original positions (world units).
    pub center: [f32; 3],
    /// Half the size of that bounding box along each axis (world units, ≥ 0).
    pub half_extent: [f32; 3],
    pub triangles: Vec<[u32; 3]>,
}

const SNORM_MAX: f64 = 32767.0;

impl SnormMesh {
    /// The decoded position of vertex `v` (world units).
    pub fn position(&self, v: usize) -> [f32; 3] {
        let q = self.positions[v];
        std::array::from_fn(|a| self.center[a] + self.half_extent[a] * (q[a] as f32 / 32767.0))
    }
    /// All decoded positions.
    pub fn decode(&self) -> Vec<[f32; 3]> {
        (0..self.positions.len())
            .map(|v| self.position(v))
            .collect()
    }
    /// Bytes as counted in the paper: 6 per vertex + 12 per triangle (center and scale not counted).
    pub fn memory_bytes(&self) -> u64 {
        6 * self.positions.len() as u64 + 12 * self.triangles.len() as u64
    }
}

impl McMesh {
    /// Quantises positions to snorm16 over the mesh's bounding box; triangles are copied.
    pub fn to_snorm16(&self) -> SnormMesh {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f64);
                hi[a] = hi[a].max(p[a] as f64);
            }
        }
        if self.positions.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let center: [f32; 3] = std::array::from_fn(|a| (0.5 * (lo[a] + hi[a])) as f32);
        // Rounding the half extent up keeps the extreme vertices inside the representable range.
        let half_extent: [f32; 3] = std::array::from_fn(|a| {
            let h = (hi[a] - center[a] as f64).max(center[a] as f64 - lo[a]);
            let f = h as f32;
            if (f as f64) < h {
                f32::from_bits(f.to_bits() + 1)
            } else {
                f
            }
        });
        let positions = self
            .positions
            .iter()
            .map(|p| {
                std::array::from_fn(|a| {
                    if half_extent[a] == 0.0 {
                        return 0;
                    }
                    let unit = (p[a] as f64 - center[a] as f64) / half_extent[a] as f64;
                    (unit * SNORM_MAX).round().clamp(-SNORM_MAX, SNORM_MAX) as i16
                })
            })
            .collect();
        SnormMesh {
            positions,
            center,
            half_extent,
            triangles: self.triangles.clone(),
        }
    }
}

//! Morton (Z-order) codes inside a block, x in the lowest bit (paper §3.1: active cells and
//! metacells of a block are stored in Morton order).

/// Spreads the low 4 bits of `v` to bits 0, 3, 6, 9.
const fn spread4(v: u32) -> u32 {
    (v & 1) | (v & 2) << 2 | (v & 4) << 4 | (v & 8) << 6
}

/// Morton code of a cell inside a block (coordinates 0..16): 12 bits.
pub const fn cell_code(x: u32, y: u32, z: u32) -> u32 {
    spread4(x) | spread4(y) << 1 | spread4(z) << 2
}

/// Morton code of a metacell inside a block (coordinates 0..8): 9 bits.
pub const fn metacell_code(x: u32, y: u32, z: u32) -> u32 {
    cell_code(x, y, z)
}

/// Inverse of [`cell_code`].
pub const fn decode(code: u32) -> [u32; 3] {
    const fn compact(v: u32) -> u32 {
        (v & 1) | (v >> 2 & 2) | (v >> 4 & 4) | (v >> 6 & 8)
    }
    [compact(code), compact(code >> 1), compact(code >> 2)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_a_bijection_in_z_order() {
        let mut seen = vec![false; 4096];
        for z in 0..16 {
            for y in 0..16 {
                for x in 0..16 {
                    let c = cell_code(x, y, z);
                    assert!(!seen[c as usize]);
                    seen[c as usize] = true;
                    assert_eq!(decode(c), [x, y, z]);
                }
            }
        }
        assert_eq!(cell_code(1, 0, 0), 1);
        assert_eq!(cell_code(0, 1, 0), 2);
        assert_eq!(cell_code(0, 0, 1), 4);
        assert_eq!(cell_code(2, 0, 0), 8);
        // A cell's code is its metacell's code followed by its bit inside the metacell.
        assert_eq!(cell_code(5, 2, 3), metacell_code(2, 1, 1) << 3 | 0b101);
    }
}

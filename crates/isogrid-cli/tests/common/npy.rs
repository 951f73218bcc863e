//! Writing `.npy` files for the CLI tests (shared by the test binaries through `#[path]`).

use std::path::Path;

/// `data` as a C-order .npy of numpy type `descr` and shape `shape` (z, y, x).
pub fn write_npy(path: &Path, descr: &str, shape: [usize; 3], data: &[u8]) {
    let [a, b, c] = shape;
    let mut header =
        format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({a}, {b}, {c}), }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    std::fs::write(path, out).unwrap();
}

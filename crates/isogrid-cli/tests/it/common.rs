//! What the CLI tests share: running the binary, the one-line failure check, scratch folders
//! and `.npy` files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `isogrid ARGS` and returns what it did.
pub fn isogrid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(args)
        .output()
        .expect("runs the binary")
}

/// Runs `isogrid ARGS`, which must succeed.
pub fn isogrid_ok(args: &[&str]) -> Output {
    let out = isogrid(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs a command that must fail: non-zero exit, one line on stderr naming `mention`, no panic,
/// no cause printed twice. Returns the line.
pub fn fails(args: &[&str], mention: &str) -> String {
    let out = isogrid(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "{args:?} should fail");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("RUST_BACKTRACE"),
        "{args:?} panicked: {stderr}"
    );
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "{args:?}: want one line, got: {stderr}"
    );
    assert!(
        stderr.contains(mention),
        "{args:?}: {stderr} should mention {mention}"
    );
    let parts: Vec<&str> = stderr.trim_end().split(": ").collect();
    assert!(
        parts.windows(2).all(|w| w[0] != w[1]),
        "{args:?}: a cause is printed twice in {stderr}"
    );
    stderr
}

/// A test's folder under the system's temporary folder, removed when dropped, unless the test is
/// failing: its files are then left to look at.
pub struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A fresh folder for the test `name` (unique across the binary's modules), of this process.
pub fn temp_dir(name: &str) -> TempDir {
    let dir = std::env::temp_dir().join(format!("isogrid-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    TempDir(dir)
}

/// A path as the `&str` the binary's arguments take.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

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

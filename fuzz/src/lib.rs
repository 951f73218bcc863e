//! What every fuzz target shares: a small memory budget, so that an honest header declaring
//! gigabytes gets the readers' clear `TooLarge` error instead of an allocation that libFuzzer's
//! `-malloc_limit_mb` reports as a crash; and a per-process scratch folder, because most volume
//! readers take a path (they stat, open and sometimes follow a detached data file) rather than
//! bytes.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The budget the readers see through `isogrid::memory` (libFuzzer runs with a 1 GiB malloc limit).
pub const MEMORY_LIMIT: u64 = 256 << 20;

/// Sets the memory budget; call at the start of every iteration (an atomic store).
pub fn init() {
    isogrid::memory::set_limit(Some(MEMORY_LIMIT));
}

/// This process's scratch folder, on tmpfs when there is one; removed by nobody (it is reused by
/// every iteration and holds a few small files).
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let dir = base.join(format!("isogrid-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    })
}

/// Writes `bytes` to `name` in the scratch folder and returns its path.
pub fn scratch_file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch().join(name);
    std::fs::write(&path, bytes).expect("scratch file");
    path
}

/// Checks what every successful volume read promises: as many samples as the dimensions say,
/// finite positive spacing and a finite origin.
pub fn check_volume(volume: &isogrid::Volume) {
    let dims = volume.dims();
    assert_eq!(volume.data().len(), dims[0] * dims[1] * dims[2]);
    assert!(dims.iter().all(|&d| d > 0), "empty dims {dims:?}");
    assert!(
        volume.spacing().iter().all(|s| s.is_finite() && *s > 0.0),
        "spacing {:?}",
        volume.spacing()
    );
    assert!(
        volume.origin().iter().all(|o| o.is_finite()),
        "origin {:?}",
        volume.origin()
    );
    let _ = volume.value_range();
}

/// Reads `bytes` saved as `name` with `read` and checks the volume when it succeeds.
pub fn fuzz_volume(
    name: &str,
    bytes: &[u8],
    read: impl Fn(&Path) -> isogrid::Result<isogrid::Volume>,
) {
    init();
    let path = scratch_file(name, bytes);
    if let Ok(volume) = read(&path) {
        check_volume(&volume);
    }
}

/// Reads `bytes` as the file `name` with `--index t=T`, whole and (where the file opens by
/// region: an uncompressed NIfTI or MGH) by region: the two succeed together and agree, sample
/// for sample and in geometry, as streamed extraction relies on.
pub fn fuzz_frame_whole_and_by_region(name: &str, bytes: &[u8], t: u64) {
    init();
    let path = scratch_file(name, bytes);
    let options = isogrid_io::ReadOptions {
        zarr: isogrid_io::ZarrOptions {
            indices: vec![("t".to_string(), t)],
            ..Default::default()
        },
        ..Default::default()
    };
    let whole = isogrid_io::read_volume(&path, &options);
    if let Ok(volume) = &whole {
        check_volume(volume);
    }
    let region = match isogrid_io::open_region(&path, &options) {
        Ok(Some(mut source)) => isogrid_io::region::read_all(source.as_mut()),
        Ok(None) => return,
        Err(e) => Err(e),
    };
    match (whole, region) {
        (Ok(whole), Ok(region)) => {
            assert_eq!(whole.geometry(), region.geometry());
            // Bit for bit: NaN samples are equal when both readers keep the same NaN.
            let (a, b) = (whole.view().samples(), region.view().samples());
            assert_eq!(a.scalar_type(), b.scalar_type());
            assert!(
                (0..a.len()).all(|i| a.get_f64(i).to_bits() == b.get_f64(i).to_bits()),
                "samples differ"
            );
        }
        (Err(_), Err(_)) => {}
        (whole, region) => panic!(
            "whole: {:?}, by region: {:?}",
            whole.map(|v| v.dims()),
            region.map(|v| v.dims())
        ),
    }
}

/// Reads `bytes` as the NIfTI file `name` (`in.nii` or `in.nii.gz`) both whole and as the one
/// mask of a folder of masks, which streams it a chunk at a time into bits: the two succeed
/// together, and the mask's label is exactly where the whole volume's samples are inside (non-zero
/// integers, floats of at least ½).
pub fn fuzz_nifti_as_mask(name: &str, bytes: &[u8]) {
    init();
    let folder = scratch().join("masks");
    std::fs::create_dir_all(&folder).expect("scratch folder");
    let path = folder.join(name);
    std::fs::write(&path, bytes).expect("scratch file");
    let whole = isogrid_io::read_nifti(&path);
    let options = isogrid_io::ReadOptions::default();
    let masks = isogrid_io::labels::read_labels_of(&folder, None, &options);
    std::fs::remove_file(&path).expect("scratch file");
    let (whole, (masks, _)) = match (whole, masks) {
        (Ok(whole), Ok(masks)) => (whole, masks),
        (Err(_), Err(_)) => return,
        (whole, masks) => panic!(
            "whole: {:?}, as a mask: {:?}",
            whole.map(|_| ()),
            masks.map(|_| ())
        ),
    };
    check_volume(&whole);
    let [layer] = &masks.layers[..] else {
        panic!("{} layers from one mask", masks.layers.len())
    };
    assert_eq!(layer.volume.dims(), whole.dims());
    let float = !whole.scalar_type().is_integer();
    let samples = whole.data().samples();
    for i in 0..samples.len() {
        let v = samples.get_f64(i);
        let inside = if float { v >= 0.5 } else { v != 0.0 };
        assert_eq!(
            layer.volume.data().samples().get_f64(i) == 1.0,
            inside,
            "sample {i}"
        );
    }
}

/// Parses `bytes` as a mesh of `format` and checks the mesh when it succeeds; input starting with
/// the gzip magic goes through `read_mesh` as the file `gz_name` instead, to reach the bounded
/// inflation.
pub fn fuzz_mesh(bytes: &[u8], format: isogrid_io::mesh::MeshFormat, gz_name: &str) {
    init();
    let mesh = if bytes.starts_with(&[0x1f, 0x8b]) {
        isogrid_io::mesh::read_mesh(&scratch_file(gz_name, bytes))
    } else {
        isogrid_io::mesh::parse_mesh(bytes, format)
    };
    if let Ok(mesh) = mesh {
        let n = mesh.vertices.len();
        assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
        assert!(mesh.vertices.iter().flatten().all(|c| c.is_finite()));
    }
}

/// A Zarr store from one fuzz input, as a folder: the reader's own path (zarrs' `FilesystemStore`,
/// which a user's store goes through) rather than zarrs' `MemoryStore`, whose partial reads
/// panic on a suffix longer than the value (a shard shorter than its index) where the folder
/// store gives an error.
pub mod zarr_store {
    use std::path::PathBuf;

    /// Between two entries of a store (a line of its own; chosen to be absent from the seeds'
    /// chunks, which `zarr_seeds.py` checks).
    pub const SEPARATOR: &[u8] = b"\n%%zarr%%\n";

    /// At most this many entries are stored (a bound on the work per input).
    const MAX_ENTRIES: usize = 64;

    /// Writes the store the input describes into a fresh folder of the scratch area and returns
    /// it: entries `KEY\nVALUE` separated by [`SEPARATOR`]; entries without a newline, with a key
    /// zarrs refuses, or with `.`/`..` components are left out.
    pub fn folder_store(data: &[u8]) -> PathBuf {
        let root = super::scratch().join("in.zarr");
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).expect("store folder");
        for entry in split(data).take(MAX_ENTRIES) {
            let Some(newline) = entry.iter().position(|&b| b == b'\n') else {
                continue;
            };
            let (key, value) = (&entry[..newline], &entry[newline + 1..]);
            let Ok(key) = std::str::from_utf8(key) else {
                continue;
            };
            let plain = |part: &str| !part.is_empty() && part != "." && part != "..";
            if zarrs::storage::StoreKey::new(key).is_err() || !key.split('/').all(plain) {
                continue;
            }
            let path = root.join(key);
            // A key may name a folder another key already made a file (or the reverse).
            if let Some(parent) = path.parent() {
                if std::fs::create_dir_all(parent).is_err() {
                    continue;
                }
            }
            let _ = std::fs::write(&path, value);
        }
        root
    }
    fn split(mut data: &[u8]) -> impl Iterator<Item = &[u8]> {
        std::iter::from_fn(move || {
            if data.is_empty() {
                return None;
            }
            let end = data
                .windows(SEPARATOR.len())
                .position(|w| w == SEPARATOR)
                .unwrap_or(data.len());
            let entry = &data[..end];
            data = data.get(end + SEPARATOR.len()..).unwrap_or(&[]);
            Some(entry)
        })
    }
}

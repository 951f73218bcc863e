//! `extract --color-by`: the attribute section from every input path, resampling notices, and
//! bad attribute inputs.

use super::{fails, generated, isogrid, nrrd_u8_as_npy, ok_json, s, temp_dir};
use std::path::Path;

/// An f32 NRRD of `f(world position)` with the given geometry (axis-aligned, world = origin +
/// index × spacing).
fn float_nrrd(
    path: &Path,
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    f: impl Fn([f64; 3]) -> f32,
) {
    let mut bytes = format!(
        "NRRD0004\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: {} {} {}\n\
         space directions: ({},0,0) (0,{},0) (0,0,{})\nspace origin: ({},{},{})\nendian: little\nencoding: raw\n\n",
        dims[0], dims[1], dims[2], spacing[0], spacing[1], spacing[2], origin[0], origin[1], origin[2]
    )
    .into_bytes();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let w = [0, 1, 2].map(|a| origin[a] + [i, j, k][a] as f64 * spacing[a]);
                bytes.extend_from_slice(&f(w).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// The same surface and attribute give the same file whether the surface is streamed within a
/// budget or read whole, and whether the attribute is read by region or whole.
#[test]
fn color_by_gives_the_same_file_from_streamed_and_in_memory_inputs() {
    let dir = temp_dir("color-paths");
    let size = 64;
    let surface = generated(&dir, "sphere", size as u32);
    let surface_npy = dir.join("sphere.npy");
    nrrd_u8_as_npy(&surface, size, &surface_npy);
    let attribute = generated(&dir, "gyroid", size as u32);
    let attribute_npy = dir.join("gyroid.npy");
    nrrd_u8_as_npy(&attribute, size, &attribute_npy);
    let mut files = Vec::new();
    for (input, attr, budget) in [
        (&surface_npy, &attribute_npy, None),
        (&surface, &attribute, Some("60M")),
        (&surface, &attribute_npy, Some("4G")),
        (&surface_npy, &attribute, None),
    ] {
        let out = dir.join(format!("out{}.cgc", files.len()));
        let mut args = vec![
            "extract",
            s(input),
            "--iso",
            "127.5",
            "--color-by",
            s(attr),
            "-o",
            s(&out),
            "--json",
        ];
        if let Some(budget) = budget {
            args.extend(["--max-memory", budget]);
        }
        let report = ok_json(&args);
        assert_eq!(report["attribute"]["bits"], 16, "{report}");
        files.push(std::fs::read(&out).unwrap());
    }
    // The attribute's name (its file name) is in the file: same attribute file, same bytes.
    assert!(files[0] == files[2], "streamed surface: the files differ");
    assert!(files[1] == files[3], "in-memory surface: the files differ");
    // Across attribute files only the name field (64 bytes in the attribute section) differs.
    let differing = files[0]
        .iter()
        .zip(&files[1])
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(files[0].len(), files[1].len());
    assert!(
        differing <= 64 + 4 + 4 + 4,
        "{differing} bytes differ beyond the name and CRCs"
    );
    // The attribute is told by `info`, named after its file, and its section is in the file.
    let info = ok_json(&["info", s(&dir.join("out0.cgc")), "--json"]);
    assert_eq!(info["attribute"]["name"], "gyroid.npy");
    let range = info["attribute"]["range"].as_array().unwrap();
    assert!(
        range[0].as_f64().unwrap() < range[1].as_f64().unwrap(),
        "{info}"
    );
    // No scratch file is left beside the outputs.
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// An attribute on another grid is resampled with a one-line notice; one beside the surface's
/// volume, or unreadable, or with a bad precision, fails in one line and writes nothing.
#[test]
fn color_by_resamples_other_grids_and_refuses_bad_attributes() {
    let dir = temp_dir("color-resample");
    let surface = generated(&dir, "sphere", 40);
    let out = dir.join("out.cgc");
    // Coarser, shifted, covering the sphere: x + 2y in world units.
    let coarse = dir.join("coarse.nrrd");
    float_nrrd(
        &coarse,
        [17, 15, 16],
        [2.5, 3.0, 2.6],
        [-1.0, -2.0, 0.5],
        |w| (w[0] + 2.0 * w[1]) as f32,
    );
    let run = isogrid(&[
        "extract",
        s(&surface),
        "--iso",
        "127.5",
        "--color-by",
        s(&coarse),
        "-o",
        s(&out),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr
            .lines()
            .any(|l| l.contains("coarse.nrrd") && l.contains("resampled onto the surface")),
        "{stderr}"
    );
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    // The sphere spans about 8..31 in x and y: x + 2y on it lies within that box's range.
    let range = report["attribute"]["range"].as_array().unwrap();
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(
        lo > 3.0 * 5.0 && hi < 3.0 * 35.0 && hi - lo > 30.0,
        "{report}"
    );
    std::fs::remove_file(&out).unwrap();

    let far = dir.join("far.nrrd");
    float_nrrd(&far, [8, 8, 8], [1.0; 3], [500.0, 0.0, 0.0], |w| {
        w[0] as f32
    });
    let err = fails(
        &[
            "extract",
            s(&surface),
            "--iso",
            "127.5",
            "--color-by",
            s(&far),
            "-o",
            s(&out),
        ],
        "does not overlap",
    );
    assert!(
        err.contains("far.nrrd") && err.contains("sphere.nrrd"),
        "names both inputs: {err}"
    );
    assert!(!out.exists());

    // A 2-D array is a plane, not an attribute volume.
    let flat = dir.join("flat.nrrd");
    float_nrrd(&flat, [20, 20, 1], [1.0; 3], [0.0; 3], |w| w[0] as f32);
    let err = fails(
        &[
            "extract",
            s(&surface),
            "--iso",
            "127.5",
            "--color-by",
            s(&flat),
            "-o",
            s(&out),
        ],
        "is not 3-D",
    );
    assert!(err.contains("flat.nrrd"), "{err}");
    assert!(!out.exists());
    let broken = dir.join("broken.nrrd");
    std::fs::write(&broken, b"NRRD0004\ntype: float\n").unwrap();
    fails(
        &[
            "extract",
            s(&surface),
            "--iso",
            "127.5",
            "--color-by",
            s(&broken),
            "-o",
            s(&out),
        ],
        "broken.nrrd",
    );
    fails(
        &[
            "extract",
            s(&surface),
            "--iso",
            "127.5",
            "--color-by",
            s(&dir.join("missing.nrrd")),
            "-o",
            s(&out),
        ],
        "missing.nrrd",
    );
    // A usage error: clap's own message, which names the value.
    let bad_bits = isogrid(&[
        "extract",
        s(&surface),
        "--iso",
        "127.5",
        "--color-by",
        s(&coarse),
        "--attribute-precision",
        "12",
        "-o",
        s(&out),
    ]);
    assert!(!bad_bits.status.success());
    assert!(String::from_utf8_lossy(&bad_bits.stderr)
        .contains("attribute precision must be 8, 16 or 32, not 12"));
    // Streamed surfaces fail the same way and leave no scratch file.
    fails(
        &[
            "extract",
            s(&surface),
            "--iso",
            "127.5",
            "--color-by",
            s(&far),
            "--max-memory",
            "4G",
            "-o",
            s(&out),
        ],
        "does not overlap",
    );
    assert!(!out.exists());
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// `mc --color-by`: the attribute at every vertex as the PLY property `quality`, against the
/// analytic field (linear in position, which trilinear sampling reproduces exactly); OBJ, which
/// has no per-vertex values, is refused.
#[test]
fn mc_color_by_writes_each_vertex_value_into_the_ply() {
    let dir = temp_dir("color-mc");
    let surface = generated(&dir, "sphere", 32);
    let field = dir.join("field.nrrd");
    let f = |w: [f64; 3]| (2.0 * w[0] - w[1] + 0.5 * w[2]) as f32;
    float_nrrd(&field, [32, 32, 32], [1.0; 3], [0.0; 3], f);
    let ply = dir.join("m.ply");
    let report = ok_json(&[
        "mc",
        s(&surface),
        "--iso",
        "127.5",
        "--color-by",
        s(&field),
        "-o",
        s(&ply),
        "--json",
    ]);
    let bytes = std::fs::read(&ply).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(
        header.contains("property float z\nproperty float quality\n"),
        "{header}"
    );
    let vertices = report["vertices"].as_u64().unwrap() as usize;
    let mut checked = 0;
    for v in bytes[end..end + 16 * vertices].chunks_exact(16) {
        let x: Vec<f32> = v
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        // World space = index space here (spacing 1, origin 0).
        let expected = f([x[0] as f64, x[1] as f64, x[2] as f64]);
        assert!(
            (x[3] - expected).abs() <= 1e-3 * expected.abs().max(1.0),
            "{x:?} vs {expected}"
        );
        checked += 1;
    }
    assert!(checked > 500, "{checked} vertices");
    let err = fails(
        &[
            "mc",
            s(&surface),
            "--iso",
            "127.5",
            "--color-by",
            s(&field),
            "-o",
            s(&dir.join("m.obj")),
        ],
        "OBJ has no per-vertex values",
    );
    assert!(err.contains("m.obj"), "{err}");
    assert!(!dir.join("m.obj").exists());
    std::fs::remove_dir_all(dir).unwrap();
}

/// `--index c=0 --color-by c=1` on a two-channel ImageJ hyperstack (written by tifffile): channel 1
/// is channel 0 plus one, so at every surface point of channel 0's isosurface it is iso + 1.
#[test]
fn color_by_another_channel_of_an_imagej_hyperstack() {
    let dir = temp_dir("color-tiff-channel");
    let input = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../isogrid-io/tests/fixtures/ij_zcyx.tif");
    let out = dir.join("out.cgc");
    let iso = 200.0 * 125.5; // between samples: channel 0 is 200·(i + 10j + 100k)
    let run = isogrid(&[
        "extract",
        s(&input),
        "--iso",
        &iso.to_string(),
        "--index",
        "c=0",
        "--color-by",
        "c=1",
        "-o",
        s(&out),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert!(report["active_cells"].as_u64().unwrap() > 0, "{report}");
    let range = report["attribute"]["range"].as_array().unwrap();
    for v in range {
        assert!((v.as_f64().unwrap() - (iso + 1.0)).abs() < 0.01, "{report}");
    }
    // Without an index the error names the channels.
    let run = isogrid(&["extract", s(&input), "--iso", "1", "-o", s(&out)]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("2 channels (c=0..1)") && stderr.contains("--index c=N"),
        "{stderr}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

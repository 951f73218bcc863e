//! The `isogrid` binary end to end: JSON names, files it writes, and how it fails on bad input.

mod color;
mod hostile;
mod labels;
mod pack;

use crate::common::{fails, isogrid, s, temp_dir, write_npy};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Runs `args`, which must succeed, and returns the one note (`isogrid: note: ...`) it prints.
fn the_note(args: &[&str]) -> String {
    let out = isogrid(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {stderr}");
    let notes: Vec<&str> = stderr.lines().filter(|l| l.contains("note:")).collect();
    assert_eq!(notes.len(), 1, "{args:?}: {stderr}");
    notes[0].to_string()
}

fn ok_json(args: &[&str]) -> Value {
    let out = isogrid(args);
    assert!(
        out.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{args:?}: not one JSON object ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// `isogrid generate FIELD --size SIZE` into `dir`; the volume's path.
fn generated(dir: &Path, field: &str, size: u32) -> PathBuf {
    let volume = dir.join(format!("{field}.nrrd"));
    let out = isogrid(&[
        "generate",
        field,
        "--size",
        &size.to_string(),
        "-o",
        s(&volume),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    volume
}

/// `isogrid extract VOLUME --iso-normalized 0.5 -o CGC`, which must succeed.
fn extracted_at_half(volume: &Path, cgc: &Path) {
    let out = isogrid(&[
        "extract",
        s(volume),
        "--iso-normalized",
        "0.5",
        "-o",
        s(cgc),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// An isovalue outside the samples gives an empty grid: a success, with one note on stderr that
/// says why (extract, mc, info and a CPU render of it), and none where the surface is not empty.
#[test]
fn an_empty_surface_is_noted_once_with_the_sample_range() {
    let dir = temp_dir("empty");
    let volume = generated(&dir, "sphere", 24);
    let cgc = dir.join("empty.cgc");
    let png = dir.join("empty.png");
    let runs: [(&[&str], &str); 5] = [
        (
            &["extract", s(&volume), "--iso", "300", "-o", s(&cgc)],
            "every sample is below it",
        ),
        (
            &["mc", s(&volume), "--iso", "300"],
            "every sample is below it",
        ),
        (&["info", s(&cgc)], "every sample is below it"),
        (
            &[
                "render",
                s(&cgc),
                "--backend",
                "cpu",
                "--size",
                "64x48",
                "-o",
                s(&png),
            ],
            "every sample is below it",
        ),
        (
            &["extract", s(&volume), "--iso", "0"],
            "every sample is at or above it",
        ),
    ];
    for (args, why) in runs {
        let note = the_note(args);
        assert!(
            note.contains("no cell crosses the isovalue") && note.contains(why),
            "{args:?}: {}",
            note
        );
        assert!(note.contains("[0, 255]"), "{args:?}: {}", note);
    }
    let out = isogrid(&["extract", s(&volume), "--iso-normalized", "0.5"]);
    assert!(out.status.success());
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("note:"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn extract_info_and_mc_report_consistent_numbers() {
    let dir = temp_dir("flow");
    let volume = generated(&dir, "torus", 40);

    let cgc = dir.join("torus.cgc");
    let e = ok_json(&[
        "extract",
        s(&volume),
        "--iso-normalized",
        "0.5",
        "-o",
        s(&cgc),
        "--json",
    ]);
    let n = |v: &Value, k: &str| {
        v[k].as_u64()
            .unwrap_or_else(|| panic!("missing {k} in {v}"))
    };
    assert_eq!(e["dims"], serde_json::json!([40, 40, 40]));
    assert_eq!(n(&e, "precision"), 8);
    assert!(n(&e, "active_cells") > 1000);
    assert_eq!(n(&e, "metacell_slots"), 16 * n(&e, "clusters"));
    assert!(n(&e, "metacells") <= 15 * n(&e, "clusters"));
    assert_eq!(n(&e, "blocks"), 27);
    let bytes = &e["bytes"];
    assert_eq!(n(bytes, "metacells"), 12 * n(&e, "metacell_slots"));
    assert_eq!(n(bytes, "cells"), 8 * n(&e, "active_cells"));
    assert_eq!(
        n(bytes, "paper_total"),
        n(bytes, "metacells") + n(bytes, "cells")
    );
    assert_eq!(n(bytes, "blocks"), 16 * 27);
    for k in ["read", "extract", "write"] {
        assert!(e["seconds"][k].as_f64().is_some(), "seconds.{k}");
    }

    let i = ok_json(&["info", s(&cgc), "--json"]);
    for k in [
        "active_cells",
        "metacells",
        "metacell_slots",
        "clusters",
        "blocks",
        "nonempty_blocks",
    ] {
        assert_eq!(i[k], e[k], "{k} differs between extract and info");
    }
    assert_eq!(i["iso"], e["iso"]);
    // `info` of the volume itself: the same source, without extracting; read by region (a raw
    // spec) too, within memory, with the same value range.
    let v = ok_json(&["info", s(&volume), "--json"]);
    assert_eq!(v["dims"], serde_json::json!([40, 40, 40]));
    for k in ["scalar_type", "value_range", "spacing", "origin", "frame"] {
        assert_eq!(v[k], i["source"][k], "{k}");
    }
    let raw = dir.join("torus.raw");
    let torus = isogrid_io::read_volume(&volume, &Default::default()).unwrap();
    let isogrid::VolumeData::U8(samples) = torus.data() else {
        panic!("generate writes u8")
    };
    std::fs::write(&raw, samples).unwrap();
    let r = ok_json(&[
        "info",
        s(&raw),
        "--raw-shape",
        "40,40,40",
        "--raw-type",
        "u8",
        "--json",
    ]);
    assert_eq!(r["value_range"], v["value_range"]);
    assert_eq!(r["dims"], v["dims"]);
    // The source as `generate` wrote it: u8 over the full range, unit grid, no world convention.
    let source = &i["source"];
    assert_eq!(source["scalar_type"], "u8");
    assert_eq!(source["value_range"], serde_json::json!([0.0, 255.0]));
    assert_eq!(source["spacing"], serde_json::json!([1.0, 1.0, 1.0]));
    assert_eq!(source["origin"], serde_json::json!([0.0, 0.0, 0.0]));
    assert_eq!(source["frame"], serde_json::Value::Null);

    let ply = dir.join("torus.ply");
    let m = ok_json(&[
        "mc",
        s(&volume),
        "--iso-normalized",
        "0.5",
        "-o",
        s(&ply),
        "--json",
    ]);
    assert_eq!(
        n(&m, "bytes"),
        6 * n(&m, "vertices") + 12 * n(&m, "triangles")
    );
    // A closed torus: Euler characteristic V - E + F = 0 with E = 3F/2.
    assert_eq!(2 * n(&m, "vertices"), n(&m, "triangles"));
    assert!(std::fs::metadata(&ply).unwrap().len() > 12 * n(&m, "triangles"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn thread_count_does_not_change_the_file() {
    let dir = temp_dir("threads");
    let volume = dir.join("gyroid.nrrd");
    assert!(
        isogrid(&["generate", "gyroid", "--size", "48", "-o", s(&volume)])
            .status
            .success()
    );
    let files: Vec<Vec<u8>> = ["1", "2", "3"]
        .iter()
        .map(|t| {
            let out = dir.join(format!("g{t}.cgc"));
            ok_json(&[
                "extract",
                s(&volume),
                "--iso",
                "127.5",
                "--threads",
                t,
                "--precision",
                "4",
                "-o",
                s(&out),
                "--json",
            ]);
            std::fs::read(out).unwrap()
        })
        .collect();
    assert_eq!(files[0], files[1]);
    assert_eq!(files[0], files[2]);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn demo_compares_with_marching_cubes() {
    let dir = temp_dir("demo");
    let png = dir.join("demo.png");
    let d = ok_json(&[
        "demo",
        "--size",
        "48",
        "--image",
        s(&png),
        "--image-size",
        "64x48",
        "--json",
    ]);
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(d["image_backend"] == "gpu" || d["image_backend"] == "cpu");
    std::fs::remove_dir_all(dir).unwrap();
    let ratio = d["memory_ratio"].as_f64().unwrap();
    let cgc = d["cgc"]["bytes"]["paper_total"].as_f64().unwrap();
    let mc = d["mc"]["bytes"].as_f64().unwrap();
    assert!((ratio - cgc / mc).abs() < 1e-12 && ratio > 0.0);
}

#[test]
fn bad_input_gets_one_clear_line() {
    let dir = temp_dir("bad");
    let missing = dir.join("missing.nii.gz");
    fails(&["extract", s(&missing), "--iso", "1"], "missing.nii.gz");

    let garbage = dir.join("garbage.nrrd");
    std::fs::write(
        &garbage,
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\n\n",
    )
    .unwrap();
    fails(&["extract", s(&garbage), "--iso", "1"], "garbage.nrrd");

    let not_cgc = dir.join("not.cgc");
    std::fs::write(&not_cgc, vec![7u8; 1000]).unwrap();
    fails(&["info", s(&not_cgc)], "not.cgc");

    let raw = dir.join("v.raw");
    std::fs::write(&raw, vec![0u8; 999]).unwrap();
    fails(
        &[
            "extract",
            s(&raw),
            "--iso",
            "1",
            "--raw-shape",
            "10,10,10",
            "--raw-type",
            "u8",
        ],
        "v.raw",
    );

    let volume = dir.join("s.nrrd");
    assert!(
        isogrid(&["generate", "sphere", "--size", "16", "-o", s(&volume)])
            .status
            .success()
    );
    fails(
        &["extract", s(&volume), "--iso-normalized", "1.5"],
        "normalised isovalue",
    );
    fails(
        &["mc", s(&volume), "--iso", "1", "-o", s(&dir.join("m.off"))],
        "m.off: the mesh is written as a mesh file, so its name must end in .ply or .obj or .stl or .vtp or .glb",
    );
    fails(
        &[
            "extract",
            s(&volume),
            "--iso",
            "1",
            "-o",
            s(&dir.join("no/such/dir/x.cgc")),
        ],
        "x.cgc",
    );

    // An existing output survives a failed run.
    let keep = dir.join("keep.cgc");
    std::fs::write(&keep, b"old").unwrap();
    fails(
        &["extract", s(&missing), "--iso", "1", "-o", s(&keep)],
        "missing.nii.gz",
    );
    assert_eq!(std::fs::read(&keep).unwrap(), b"old");

    // Argument errors come from clap: non-zero exit, no panic.
    let out = isogrid(&[
        "extract",
        s(&volume),
        "--iso",
        "1",
        "--iso-normalized",
        "0.5",
    ]);
    assert!(!out.status.success() && !String::from_utf8_lossy(&out.stderr).contains("panicked"));
    std::fs::remove_dir_all(dir).unwrap();
}

/// The samples of an attached raw u8 NRRD (`isogrid generate` output) as a C-order `.npy`, which
/// `extract` reads whole: the in-memory reference for the streamed NRRD.
fn nrrd_u8_as_npy(nrrd: &Path, size: usize, npy: &Path) {
    let bytes = std::fs::read(nrrd).unwrap();
    let data = &bytes[bytes.len() - size * size * size..];
    write_npy(npy, "|u1", [size; 3], data);
}

/// Region-readable inputs stream within `--max-memory`; every budget from the least that works
/// up gives the in-memory file byte for byte, and one below it fails naming that least.
#[test]
fn streamed_extraction_matches_in_memory_over_budgets() {
    let dir = temp_dir("stream-budgets");
    let size = 150;
    let nrrd = generated(&dir, "hairball", size as u32);
    let npy = dir.join("hairball.npy");
    nrrd_u8_as_npy(&nrrd, size, &npy);
    let reference = dir.join("memory.cgc");
    let memory = ok_json(&[
        "extract",
        s(&npy),
        "--iso-normalized",
        "0.5",
        "-o",
        s(&reference),
        "--json",
    ]);
    let expected = std::fs::read(&reference).unwrap();

    let too_small = fails(
        &[
            "extract",
            s(&nrrd),
            "--iso-normalized",
            "0.5",
            "--max-memory",
            "1M",
            "-o",
            s(&dir.join("x.cgc")),
        ],
        "the least that works is",
    );
    let least = too_small
        .split("the least that works is ")
        .nth(1)
        .and_then(|t| t.split(" MiB").next())
        .and_then(|n| n.trim().parse::<u64>().ok())
        .unwrap_or_else(|| panic!("no size in {too_small}"));
    assert!(!dir.join("x.cgc").exists());

    for (budget, threads) in [
        (least, "1"),
        (least + 2, "2"),
        (least + 7, "3"),
        (4096, "2"),
    ] {
        let out = dir.join(format!("stream-{budget}.cgc"));
        let budget = format!("{budget}M");
        let streamed = ok_json(&[
            "extract",
            s(&nrrd),
            "--iso-normalized",
            "0.5",
            "--max-memory",
            &budget,
            "--threads",
            threads,
            "-o",
            s(&out),
            "--json",
        ]);
        assert_eq!(streamed["active_cells"], memory["active_cells"], "{budget}");
        assert!(
            std::fs::read(&out).unwrap() == expected,
            "budget {budget}: files differ"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// OME-Zarr through the CLI: extra axes need `--index`, and the levels differ in size.
#[test]
fn ome_zarr_extraction_needs_an_index_for_extra_axes() {
    let dir = temp_dir("ome-zarr");
    let ome = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../isogrid-io/tests/fixtures/zarr/ome_v04.zarr");
    let out = dir.join("ome.cgc");
    fails(
        &["extract", s(&ome), "--iso", "2040", "-o", s(&out)],
        "--index t=0,c=0",
    );
    fails(
        &[
            "extract",
            s(&ome),
            "--iso",
            "2040",
            "--index",
            "t=0,c",
            "-o",
            s(&out),
        ],
        "AXIS=I",
    );
    assert!(!out.exists());
    let full = ok_json(&[
        "extract",
        s(&ome),
        "--iso",
        "2040",
        "--index",
        "t=1,c=0",
        "-o",
        s(&out),
        "--json",
    ]);
    let half = ok_json(&[
        "extract",
        s(&ome),
        "--iso",
        "2040",
        "--index",
        "t=1,c=0",
        "--level",
        "1",
        "--json",
    ]);
    assert_eq!(full["dims"], serde_json::json!([20, 13, 35]));
    assert_eq!(half["dims"], serde_json::json!([10, 7, 18]));
    assert!(full["active_cells"].as_u64().unwrap() > half["active_cells"].as_u64().unwrap());
    assert!(half["active_cells"].as_u64().unwrap() > 0);
    std::fs::remove_dir_all(dir).unwrap();
}

/// Bad Zarr inputs fail in one line naming the problem and leave nothing in the output folder:
/// a corrupt chunk (named), a codec this build lacks, a budget below one slab (the least that
/// works is named); a missing chunk is the fill value, not an error.
#[test]
fn bad_zarr_inputs_fail_in_one_line_and_leave_no_output() {
    let dir = temp_dir("zarr-bad");
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../isogrid-io/tests/fixtures/zarr");
    let out = dir.join("out.cgc");
    let extract = |name: &str, extra: &[&str]| {
        let input = fixtures.join(name);
        let mut args = vec!["extract", s(&input), "--iso", "60", "-o", s(&out)];
        args.extend_from_slice(extra);
        args.iter().map(|a| a.to_string()).collect::<Vec<_>>()
    };
    let run = |args: Vec<String>, mention: &str| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails(&args, mention);
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    };
    run(extract("v2_corrupt_chunk.zarr", &[]), "chunk 1.0.1");
    run(extract("v2_lzma.zarr", &[]), "lzma");
    run(extract("v2_4d_unnamed.zarr", &[]), "--index dim0=0");
    run(
        extract("v2_blosc.zarr", &["--max-memory", "100K"]),
        "the least that works is",
    );
    let e = ok_json(
        &extract("v3_missing_chunk.zarr", &["--json"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(e["active_cells"].as_u64().unwrap() > 0);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn dicom_folder_with_two_series_notes_the_other_and_series_picks_it() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../isogrid-io/tests/fixtures");
    let dir = temp_dir("dicom-two-series");
    for n in ["a.dcm", "b.dcm", "c.dcm"] {
        std::fs::copy(
            fixtures.join("dicom_ct").join(n),
            dir.join(format!("ct_{n}")),
        )
        .unwrap();
    }
    for n in ["a.dcm", "b.dcm"] {
        std::fs::copy(
            fixtures.join("dicom_scaled").join(n),
            dir.join(format!("sc_{n}")),
        )
        .unwrap();
    }
    let ct = "1.2.826.0.1.3680043.8.498.8840649940829964383378619131949557239";
    let scaled = "1.2.826.0.1.3680043.8.498.60695371359384373647244921884165860996";
    let out = isogrid(&["extract", s(&dir), "--iso", "0", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let e: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(e["dims"], serde_json::json!([7, 5, 3]));
    let note = stderr
        .lines()
        .find(|l| l.contains("note:"))
        .expect("a notice");
    assert!(note.contains(&format!("reading {ct} (3 slices)")), "{note}");
    assert!(note.contains(&format!("{scaled} (2 slices)")), "{note}");
    assert!(note.contains("--series UID"), "{note}");

    let e = ok_json(&[
        "extract",
        s(&dir),
        "--iso",
        "0",
        "--series",
        scaled,
        "--json",
    ]);
    assert_eq!(e["dims"], serde_json::json!([7, 5, 2]));
    fails(
        &["extract", s(&dir), "--iso", "0", "--series", "1.2.3"],
        "has no series 1.2.3",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `mc -o` writes vertices in the volume's world coordinates: a ball of radius 5 mm centred at
/// sample (10, 8, 6) of an NRRD with spacing (0.5, 1, 2) mm and origin (−10, 20, 30) lies, in the
/// PLY, around origin + centre · spacing = (−5, 28, 42), every vertex within half a sample
/// diagonal of the sphere.
#[test]
fn mc_mesh_is_placed_at_the_volume_origin() {
    let dir = temp_dir("mc-origin");
    let (dims, spacing, origin) = ([21usize, 17, 13], [0.5, 1.0, 2.0], [-10.0, 20.0, 30.0]);
    let centre = [10.0 * 0.5, 8.0, 6.0 * 2.0];
    let mut header = format!(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: {} {} {}\nspace: left-posterior-superior\n\
         space directions: ({},0,0) (0,{},0) (0,0,{})\nspace origin: ({},{},{})\n\
         encoding: raw\nendian: little\n\n",
        dims[0],
        dims[1],
        dims[2],
        spacing[0],
        spacing[1],
        spacing[2],
        origin[0],
        origin[1],
        origin[2]
    )
    .into_bytes();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = [
                    i as f64 * spacing[0],
                    j as f64 * spacing[1],
                    k as f64 * spacing[2],
                ];
                let r = (0..3)
                    .map(|a| (p[a] - centre[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                header.extend_from_slice(&(r as f32).to_le_bytes());
            }
        }
    }
    let volume = dir.join("ball.nrrd");
    std::fs::write(&volume, header).unwrap();
    let ply = dir.join("ball.ply");
    // Inside is value >= iso, so the ball is the outside of the distance field: same surface.
    let m = ok_json(&["mc", s(&volume), "--iso", "5", "-o", s(&ply), "--json"]);
    let vertices = m["vertices"].as_u64().unwrap() as usize;
    assert!(vertices > 100, "{m}");

    let bytes = std::fs::read(&ply).unwrap();
    let end = b"end_header\n";
    let body = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let positions: Vec<[f64; 3]> = bytes[body..body + 12 * vertices]
        .chunks_exact(12)
        .map(|v| {
            [0, 1, 2].map(|a| f32::from_le_bytes(v[4 * a..4 * a + 4].try_into().unwrap()) as f64)
        })
        .collect();
    let world_centre = [0, 1, 2].map(|a| origin[a] + centre[a]);
    let half_diagonal = 0.5 * (0.25f64 + 1.0 + 4.0).sqrt();
    for p in &positions {
        let r = (0..3)
            .map(|a| (p[a] - world_centre[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            (r - 5.0).abs() < half_diagonal,
            "vertex {p:?} is {r} mm from the centre"
        );
    }
    let mean = [0, 1, 2].map(|a| positions.iter().map(|p| p[a]).sum::<f64>() / vertices as f64);
    for a in 0..3 {
        assert!(
            (mean[a] - world_centre[a]).abs() < 0.1,
            "vertex mean {mean:?}, ball centre {world_centre:?}"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// Vertices and 0-based faces of an OBJ written by `mc`.
fn read_obj(path: &Path) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut v, mut f) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let x: Vec<f64> = words.map(|w| w.parse().unwrap()).collect();
                v.push([x[0], x[1], x[2]]);
            }
            Some("f") => {
                let i: Vec<usize> = words
                    .map(|w| w.split('/').next().unwrap().parse::<usize>().unwrap() - 1)
                    .collect();
                f.push([i[0], i[1], i[2]]);
            }
            _ => {}
        }
    }
    (v, f)
}

/// `mc` writes the mesh in the volume's world space, directions included, by default, and in
/// sample indices with `--space index`: a ball in an NRRD with a flipped axis (a mirror) and in
/// one with oblique axes lies where the header's affine puts it, and its triangles keep their
/// orientation (the signed volume has the sign of the index-space mesh's).
#[test]
fn mc_mesh_is_in_world_space_with_directions_or_in_index_space() {
    let dir = temp_dir("mc-world");
    let (dims, spacing, origin) = ([21usize, 17, 13], [0.5, 1.0, 2.0], [-10.0, 20.0, 30.0]);
    let centre = [10.0, 8.0, 6.0]; // sample indices
    let (c, s30) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let cases: [(&str, [[f64; 3]; 3]); 2] = [
        (
            "flipped",
            [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        ),
        (
            "oblique",
            [
                [c, s30, 0.0],
                [-s30 * c, c * c, s30],
                [s30 * s30, -s30 * c, c],
            ],
        ),
    ];
    for (name, d) in cases {
        let dirs: Vec<String> = (0..3)
            .map(|a| {
                format!(
                    "({},{},{})",
                    d[a][0] * spacing[a],
                    d[a][1] * spacing[a],
                    d[a][2] * spacing[a]
                )
            })
            .collect();
        let mut bytes = format!(
            "NRRD0004\ntype: float\ndimension: 3\nsizes: {} {} {}\nspace: left-posterior-superior\n\
             space directions: {}\nspace origin: ({},{},{})\nencoding: raw\nendian: little\n\n",
            dims[0], dims[1], dims[2], dirs.join(" "), origin[0], origin[1], origin[2]
        )
        .into_bytes();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let idx = [i as f64, j as f64, k as f64];
                    let r = (0..3)
                        .map(|a| ((idx[a] - centre[a]) * spacing[a]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    bytes.extend_from_slice(&(r as f32).to_le_bytes());
                }
            }
        }
        let volume = dir.join(format!("{name}.nrrd"));
        std::fs::write(&volume, bytes).unwrap();
        let (world, index) = (
            dir.join(format!("{name}-w.obj")),
            dir.join(format!("{name}-i.obj")),
        );
        ok_json(&["mc", s(&volume), "--iso", "5", "-o", s(&world), "--json"]);
        ok_json(&[
            "mc",
            s(&volume),
            "--iso",
            "5",
            "--space",
            "index",
            "-o",
            s(&index),
            "--json",
        ]);
        let (wv, wf) = read_obj(&world);
        let (iv, i_f) = read_obj(&index);
        assert_eq!((wv.len(), wf.len()), (iv.len(), i_f.len()));
        assert!(wv.len() > 100);
        // The header's affine applied to the index-space vertices gives the world ones.
        for (w, i) in wv.iter().zip(&iv) {
            let expected: [f64; 3] = [0, 1, 2]
                .map(|x| origin[x] + (0..3).map(|a| i[a] * spacing[a] * d[a][x]).sum::<f64>());
            for x in 0..3 {
                assert!(
                    (w[x] - expected[x]).abs() < 1e-3,
                    "{name}: {w:?} != {expected:?}"
                );
            }
        }
        // The ball's centre is where the affine puts sample (10, 8, 6).
        let world_centre: [f64; 3] = [0, 1, 2].map(|x| {
            origin[x]
                + (0..3)
                    .map(|a| centre[a] * spacing[a] * d[a][x])
                    .sum::<f64>()
        });
        let mean = [0, 1, 2].map(|x| wv.iter().map(|p| p[x]).sum::<f64>() / wv.len() as f64);
        for x in 0..3 {
            assert!(
                (mean[x] - world_centre[x]).abs() < 0.1,
                "{name}: {mean:?} vs {world_centre:?}"
            );
        }
        // Index space is scaled, not mirrored: its winding is the reference.
        let signed_volume = |v: &[[f64; 3]], f: &[[usize; 3]]| {
            f.iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| v[i]);
                    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                        + a[2] * (b[0] * c[1] - b[1] * c[0])
                })
                .sum::<f64>()
                / 6.0
        };
        let (sw, si) = (signed_volume(&wv, &wf), signed_volume(&iv, &i_f));
        assert!(
            sw * si > 0.0,
            "{name}: signed volumes {sw} (world) and {si} (index)"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// A volume whose every sample is NaN has no cells at any isovalue; the note must say so, not
/// that every sample is at or above the isovalue in [0, 0] (the range a grid records for it).
#[test]
fn an_all_nan_volume_is_noted_as_such() {
    let dir = temp_dir("all-nan");
    let nrrd = dir.join("nan.nrrd");
    let mut bytes =
        b"NRRD0004\ntype: float\ndimension: 3\nsizes: 6 5 4\nencoding: raw\nendian: little\n\n"
            .to_vec();
    for _ in 0..6 * 5 * 4 {
        bytes.extend(f32::NAN.to_le_bytes());
    }
    std::fs::write(&nrrd, &bytes).unwrap();
    let cgc = dir.join("nan.cgc");
    let png = dir.join("n.png");
    // extract reads a raw NRRD by slabs; render extracts it in memory.
    let runs: [&[&str]; 2] = [
        &["extract", s(&nrrd), "--iso", "0", "-o", s(&cgc)],
        &[
            "render",
            s(&nrrd),
            "--iso",
            "0",
            "--backend",
            "cpu",
            "--size",
            "16x16",
            "-o",
            s(&png),
        ],
    ];
    for args in runs {
        let note = the_note(args);
        assert!(note.contains("every sample is NaN"), "{args:?}: {}", note);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `cargo install` builds the release profile: with line tables the binary was 232 MB. Profilers
/// get them from the `profiling` profile instead (release code, `debug = 1`).
#[test]
fn release_profile_carries_no_debug_info_and_profiling_does() {
    let manifest =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../Cargo.toml"))
            .expect("reads the workspace manifest");
    // The `key = value` lines of each `[section]`, comments dropped.
    let section = |name: &str| -> Vec<(String, String)> {
        let header = format!("[{name}]");
        manifest
            .lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .skip_while(|l| *l != header)
            .skip(1)
            .take_while(|l| !l.starts_with('['))
            .filter_map(|l| l.split_once('='))
            .map(|(k, v)| (k.trim().to_string(), v.trim().trim_matches('"').to_string()))
            .collect()
    };
    let release = section("profile.release");
    assert!(!release.is_empty(), "no [profile.release] in the manifest");
    let debug = release
        .iter()
        .find(|(k, _)| k == "debug")
        .map(|(_, v)| v.as_str());
    assert!(
        matches!(debug, None | Some("0") | Some("false") | Some("none")),
        "[profile.release] keeps debug info: debug = {debug:?}"
    );
    let profiling = section("profile.profiling");
    let get = |k: &str| {
        profiling
            .iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.as_str())
    };
    assert_eq!(get("inherits"), Some("release"), "{profiling:?}");
    assert!(
        matches!(
            get("debug"),
            Some("1")
                | Some("2")
                | Some("true")
                | Some("line-tables-only")
                | Some("limited")
                | Some("full")
        ),
        "{profiling:?}"
    );
}

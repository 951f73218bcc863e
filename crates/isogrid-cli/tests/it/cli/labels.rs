//! `extract --labels`: the file is the library's byte for byte, `info` lists the labels, and bad
//! requests fail in one line without writing anything.

use super::{fails, isogrid, ok_json, s, temp_dir};
use isogrid::{LabelOptions, LabelSelection, Volume, VolumeData};
use std::path::Path;

const DIMS: [usize; 3] = [34, 21, 27];

/// Touching boxes (5 and 700), a ball (9), a sheet (2) and background 0, as (x, y, z) u16.
fn labels() -> Vec<u16> {
    let [nx, ny, nz] = DIMS;
    let mut v = vec![0u16; nx * ny * nz];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let d = [x as f64 - 10.0, y as f64 - 10.0, z as f64 - 12.0];
                v[x + nx * (y + ny * z)] = if d.iter().map(|c| c * c).sum::<f64>() < 36.0 {
                    9
                } else if (3..16).contains(&y) && (4..24).contains(&z) {
                    if x > 16 {
                        700
                    } else {
                        5
                    }
                } else if y == 18 {
                    2
                } else {
                    0
                };
            }
        }
    }
    v
}

/// `data` as a C-order .npy of shape (z, y, x) with numpy type `descr`.
fn write_npy(path: &Path, descr: &str, data: &[u8]) {
    let [nx, ny, nz] = DIMS;
    super::write_npy(path, descr, [nz, ny, nx], data);
}

/// [`labels`] as `dir/labels.npy`, u16.
fn labels_npy(dir: &Path) -> std::path::PathBuf {
    let npy = dir.join("labels.npy");
    let bytes: Vec<u8> = labels().iter().flat_map(|v| v.to_le_bytes()).collect();
    write_npy(&npy, "<u2", &bytes);
    npy
}

#[test]
fn labels_give_the_librarys_file_and_info_lists_them() {
    let dir = temp_dir("labels");
    let data = labels();
    let npy = dir.join("labels.npy");
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
    write_npy(&npy, "<u2", &bytes);
    let volume = Volume::new(DIMS, VolumeData::U16(data)).unwrap();
    for (smooth, selection) in [("0", "all"), ("1.25", "all"), ("0", "2,5-9")] {
        let out = dir.join(format!("labels-{smooth}-{selection}.cgc"));
        let mut files = Vec::new();
        for threads in ["1", "2"] {
            let report = ok_json(&[
                "extract",
                s(&npy),
                "--labels",
                selection,
                "--smooth",
                smooth,
                "--threads",
                threads,
                "-o",
                s(&out),
                "--json",
            ]);
            files.push(std::fs::read(&out).unwrap());
            let mut options = LabelOptions::new(LabelSelection::parse(selection).unwrap());
            options.smooth = smooth.parse().unwrap();
            let grid = isogrid::extract_labels(&volume.view(), &options).unwrap();
            assert_eq!(files.last().unwrap(), &isogrid::cgc::to_bytes(&grid));
            let listed: Vec<(u64, u64)> = report["labels"]
                .as_array()
                .unwrap()
                .iter()
                .map(|l| (l["value"].as_u64().unwrap(), l["cells"].as_u64().unwrap()))
                .collect();
            let expected: Vec<(u64, u64)> = grid
                .labels()
                .unwrap()
                .table()
                .iter()
                .zip(grid.labels().unwrap().index())
                .map(|(l, e)| (l.value, e.cell_count))
                .collect();
            assert_eq!(listed, expected);
            let info = ok_json(&["info", s(&out), "--json"]);
            assert_eq!(info["labels"], report["labels"]);
        }
        assert_eq!(files[0], files[1], "thread count changed the file");
    }
    let info = ok_json(&["info", s(&dir.join("labels-0-2,5-9.cgc")), "--json"]);
    let names: Vec<&str> = info["labels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["label 2", "label 5", "label 9"]);
    let human = isogrid(&["info", s(&dir.join("labels-0-all.cgc"))]);
    let text = String::from_utf8_lossy(&human.stdout);
    assert!(
        text.contains("labels        4") && text.contains("label 700"),
        "{text}"
    );
}

/// `render VOLUME --labels` draws what `render` draws of the `.cgc` that `extract --labels` writes
/// of the same volume (image and label AOV, byte for byte, on the CPU), smoothing and choice of
/// labels included; CR of a label volume, and `--labels` of a `.cgc`, fail in one line.
#[test]
fn render_of_a_label_volume_draws_its_extracted_labels() {
    let dir = temp_dir("labels-render");
    let npy = labels_npy(&dir);
    for (selection, smooth) in [("all", "0"), ("2,5-9", "1")] {
        let cgc = dir.join("labels.cgc");
        ok_json(&[
            "extract",
            s(&npy),
            "--labels",
            selection,
            "--smooth",
            smooth,
            "-o",
            s(&cgc),
            "--json",
        ]);
        let draw = |input: &Path, label_args: &[&str], name: &str| {
            let (png, aov) = (
                dir.join(format!("{name}.png")),
                dir.join(format!("{name}.npy")),
            );
            let aov_arg = format!("label={}", s(&aov));
            let mut args = vec!["render", s(input)];
            args.extend_from_slice(label_args);
            args.extend([
                "--backend",
                "cpu",
                "--size",
                "64x48",
                "--hide",
                "5",
                "-o",
                s(&png),
                "--aov",
                &aov_arg,
                "--json",
            ]);
            ok_json(&args);
            (std::fs::read(&png).unwrap(), std::fs::read(&aov).unwrap())
        };
        let from_file = draw(&cgc, &[], "file");
        let from_volume = draw(&npy, &["--labels", selection, "--smooth", smooth], "volume");
        assert!(
            from_file == from_volume,
            "{selection} σ={smooth}: the renders differ"
        );
    }
    fails(
        &[
            "render",
            s(&npy),
            "--labels",
            "all",
            "--mode",
            "cr",
            "-o",
            s(&dir.join("cr.png")),
        ],
        "labels.npy: mode cr",
    );
    fails(
        &["render", s(&dir.join("labels.cgc")), "--labels", "all"],
        "is a .cgc file",
    );
    assert!(!dir.join("cr.png").exists());
}

/// Meshing every label is refused in one line, before it is tried, when the memory it needs is
/// not there (here under `ISOGRID_MEMORY_LIMIT`), and nothing is written.
#[test]
fn label_meshes_beyond_the_memory_limit_are_refused() {
    let dir = temp_dir("labels-mesh-limit");
    let npy = labels_npy(&dir);
    let glb = dir.join("labels.glb");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(["mc", s(&npy), "--labels", "all", "-o", s(&glb)])
        .env("ISOGRID_MEMORY_LIMIT", "64K")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("the mesh of every label needs") && stderr.contains("ISOGRID_MEMORY_LIMIT"),
        "{stderr}"
    );
    assert!(!glb.exists());
    // Without the limit the same command writes it.
    ok_json(&["mc", s(&npy), "--labels", "all", "-o", s(&glb), "--json"]);
    assert!(glb.exists());
}

/// The files under the folder `dir` (a precomputed mesh folder), by path within it.
fn folder_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let (path, name) = {
            let e = e.unwrap();
            (e.path(), e.file_name().to_string_lossy().to_string())
        };
        if path.is_dir() {
            let inner = folder_files(&path);
            files.extend(inner.into_iter().map(|(n, b)| (format!("{name}/{n}"), b)));
        } else {
            files.push((name, std::fs::read(path).unwrap()));
        }
    }
    files.sort();
    files
}

/// `mc FILE.cgc --labels SEL` meshes the selected labels of a grid extracted before, without its
/// volume: the same .glb and precomputed files, byte for byte, as `mc` of the volume with the
/// same selection and smoothing. What the grid fixed at extraction cannot be asked again, and an
/// isosurface grid has no labels to mesh.
#[test]
fn label_meshes_of_a_cgc_file_are_those_of_its_volume() {
    let dir = temp_dir("labels-mesh-cgc");
    let npy = labels_npy(&dir);
    for smooth in ["0", "1.25"] {
        let cgc = dir.join(format!("labels-{smooth}.cgc"));
        ok_json(&[
            "extract",
            s(&npy),
            "--labels",
            "all",
            "--smooth",
            smooth,
            "-o",
            s(&cgc),
            "--json",
        ]);
        for selection in ["all", "5-9"] {
            // `mc` of the grid and of the volume into OUT beside each other: their reports.
            let mesh_both = |out: &str| {
                let (from_cgc, from_volume) = (dir.join(format!("cgc-{out}")), dir.join(out));
                let of_cgc = ok_json(&[
                    "mc",
                    s(&cgc),
                    "--labels",
                    selection,
                    "-o",
                    s(&from_cgc),
                    "--json",
                ]);
                let of_volume = ok_json(&[
                    "mc",
                    s(&npy),
                    "--labels",
                    selection,
                    "--smooth",
                    smooth,
                    "-o",
                    s(&from_volume),
                    "--json",
                ]);
                assert_eq!(
                    of_cgc["labels"], of_volume["labels"],
                    "smooth {smooth}, {selection}"
                );
                assert_eq!(
                    of_cgc["triangles"], of_volume["triangles"],
                    "smooth {smooth}, {selection}"
                );
                (from_cgc, from_volume)
            };
            let (from_cgc, from_volume) = mesh_both("meshes.glb");
            let glb = std::fs::read(&from_cgc).unwrap();
            assert!(
                glb == std::fs::read(&from_volume).unwrap(),
                "smooth {smooth}, {selection}"
            );
            std::fs::remove_file(&from_cgc).unwrap();
            std::fs::remove_file(&from_volume).unwrap();
            let (from_cgc, from_volume) = mesh_both("meshes.vtp");
            let vtp = std::fs::read(&from_cgc).unwrap();
            assert!(vtp.starts_with(b"<?xml"));
            assert!(
                vtp == std::fs::read(&from_volume).unwrap(),
                "smooth {smooth}, {selection}"
            );
            std::fs::remove_file(&from_cgc).unwrap();
            std::fs::remove_file(&from_volume).unwrap();
            let (from_cgc, from_volume) = mesh_both("meshes");
            let files = folder_files(&from_cgc);
            // 5 and 9 only, each a manifest and a fragment, beside `info` and its properties.
            let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
            if selection == "5-9" {
                let expected = [
                    "5:0",
                    "5:0:1",
                    "9:0",
                    "9:0:1",
                    "info",
                    "segment_properties/info",
                ];
                assert_eq!(names, expected);
            }
            assert!(
                files == folder_files(&from_volume),
                "smooth {smooth}, {selection}"
            );
            std::fs::remove_dir_all(&from_cgc).unwrap();
            std::fs::remove_dir_all(&from_volume).unwrap();
        }
    }
    let cgc = dir.join("labels-0.cgc");
    let out = dir.join("out.glb");
    fails(
        &["mc", s(&cgc), "--labels", "6", "-o", s(&out)],
        "label 6: no such label in the grid",
    );
    fails(
        &[
            "mc",
            s(&cgc),
            "--labels",
            "all",
            "--smooth",
            "1",
            "-o",
            s(&out),
        ],
        "drop --smooth",
    );
    fails(
        &["mc", s(&cgc), "--iso", "3", "-o", s(&dir.join("out.ply"))],
        "a .cgc file holds a grid, not a volume",
    );
    fails(
        &[
            "mc",
            s(&npy),
            "--labels",
            "all",
            "--color-by",
            s(&npy),
            "-o",
            s(&dir.join("folder")),
        ],
        "carry no per-vertex values",
    );
    assert!(!dir.join("folder").exists());
    let iso = dir.join("iso.cgc");
    ok_json(&["extract", s(&npy), "--iso", "3", "-o", s(&iso), "--json"]);
    fails(
        &["mc", s(&iso), "--labels", "all", "-o", s(&out)],
        "holds an isosurface, not labels",
    );
    assert!(!out.exists() && !dir.join("out.ply").exists());
}

#[test]
fn bad_label_requests_fail_in_one_line_and_write_nothing() {
    let dir = temp_dir("labels-bad");
    let npy = dir.join("float.npy");
    let floats: Vec<u8> = labels()
        .iter()
        .enumerate()
        .map(|(i, &v)| if i == 7 { 0.5 } else { v as f32 })
        .flat_map(|v| v.to_le_bytes())
        .collect();
    write_npy(&npy, "<f4", &floats);
    let out = dir.join("out.cgc");
    fails(
        &["extract", s(&npy), "--labels", "all", "-o", s(&out)],
        "label values must be integers",
    );
    let good = labels_npy(&dir);
    fails(
        &[
            "extract",
            s(&good),
            "--iso",
            "3",
            "--smooth",
            "1",
            "-o",
            s(&out),
        ],
        "--labels",
    );
    fails(
        &[
            "extract",
            s(&good),
            "--labels",
            "all",
            "--smooth=-1",
            "-o",
            s(&out),
        ],
        "smoothing",
    );
    assert!(!out.exists());
    // A value asked for and absent is a notice, not an error.
    let report = isogrid(&["extract", s(&good), "--labels", "5,6", "-o", s(&out)]);
    assert!(report.status.success());
    let stderr = String::from_utf8_lossy(&report.stderr);
    assert!(stderr.contains("no label 6"), "{stderr}");
}

/// A label fixture of isogrid-io (scripts/make_label_fixtures.py).
fn label_fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../isogrid-io/tests/fixtures/labels")
        .join(name)
}

/// (value, name, colour) of every label `info --json` lists.
fn listed(cgc: &Path) -> Vec<(u64, String, String)> {
    ok_json(&["info", s(cgc), "--json"])["labels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| {
            (
                l["value"].as_u64().unwrap(),
                l["name"].as_str().unwrap().to_string(),
                l["color"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

#[test]
fn names_and_colours_come_from_the_file_and_the_table() {
    let dir = temp_dir("labels-names");
    // slicerio's layered segmentation: the tumour overlaps the liver, in a layer of its own.
    let out = dir.join("seg.cgc");
    ok_json(&[
        "extract",
        s(&label_fixture("two_layers.seg.nrrd")),
        "--labels",
        "all",
        "-o",
        s(&out),
        "--json",
    ]);
    let strings = |l: &[(u64, &str, &str)]| -> Vec<(u64, String, String)> {
        l.iter()
            .map(|&(v, n, c)| (v, n.to_string(), c.to_string()))
            .collect()
    };
    assert_eq!(
        listed(&out),
        strings(&[
            (1, "liver", "#336699ff"),
            (2, "portal vein", "#ff0033ff"),
            (3, "lesion 3", "#cccc00ff"),
            (4, "tumour", "#0099ffff"),
        ])
    );
    // The OME-Zarr image's label image, by name; a table wins over the file's names.
    let table = dir.join("lut.txt");
    std::fs::write(
        &table,
        "#No. Label Name: R G B A\n2 Cytosol 10 20 30 0\n8 Absent 1 1 1 0\n",
    )
    .unwrap();
    let out = dir.join("cells.cgc");
    let run = isogrid(&[
        "extract",
        s(&label_fixture("ome_v05.zarr")),
        "--labels",
        "all",
        "--labels-of",
        "cells",
        "--label-table",
        s(&table),
        "-o",
        s(&out),
    ]);
    assert!(run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("lut.txt: 1 label of the table is not among the labels extracted (8)"),
        "{stderr}"
    );
    assert_eq!(
        listed(&out),
        strings(&[
            (1, "nucleus", "#ff0000ff"),
            (2, "Cytosol", "#0a141eff"),
            (7, "label 7", "#0a141eff"),
        ])
    );
    let text = String::from_utf8_lossy(&isogrid(&["info", s(&out)]).stdout).to_string();
    assert!(
        text.contains("nucleus") && text.contains("Cytosol"),
        "{text}"
    );
    // `mc --labels` takes the same flags: the .glb's meshes carry the same names.
    let glb = dir.join("cells.glb");
    let run = isogrid(&[
        "mc",
        s(&label_fixture("ome_v05.zarr")),
        "--labels",
        "all",
        "--labels-of",
        "cells",
        "--label-table",
        s(&table),
        "-o",
        s(&glb),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("lut.txt: 1 label of the table is not among"),
        "{stderr}"
    );
    // The JSON chunk of the glTF binary: after the 12-byte header, its length and type.
    let bytes = std::fs::read(&glb).unwrap();
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
    let names: Vec<&str> = json["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["nucleus", "Cytosol", "label 7"]);
}

#[test]
fn bad_tables_and_label_image_names_fail_in_one_line() {
    let dir = temp_dir("labels-bad-tables");
    let out = dir.join("out.cgc");
    let seg = label_fixture("one_layer.seg.nrrd");
    let table = dir.join("bad.ctbl");
    std::fs::write(
        &table,
        "# Slicer\n1 tissue 128 174 128 255\n2 bone 241 214\n",
    )
    .unwrap();
    let stderr = fails(
        &[
            "extract",
            s(&seg),
            "--labels",
            "all",
            "--label-table",
            s(&table),
            "-o",
            s(&out),
        ],
        "label table line 3: 4 fields",
    );
    assert!(stderr.contains("bad.ctbl"), "{stderr}");
    fails(
        &[
            "extract",
            s(&label_fixture("ome_v04.zarr")),
            "--labels",
            "all",
            "--labels-of",
            "nuclei",
            "-o",
            s(&out),
        ],
        "no label image \"nuclei\"; the image has \"cells\"",
    );
    fails(
        &[
            "extract",
            s(&seg),
            "--iso",
            "1",
            "--label-table",
            s(&table),
            "-o",
            s(&out),
        ],
        "--labels",
    );
    assert!(!out.exists());
}

/// Blocky supervoxels (x, y, z), labels 1.., every one touching its neighbours, with boundaries
/// that shift along z so labels cross block layers and slabs at many heights.
pub(super) fn supervoxels(dims: [usize; 3]) -> Vec<u32> {
    let [nx, ny, nz] = dims;
    let mut v = Vec::with_capacity(nx * ny * nz);
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                v.push((1 + x / 13 + 20 * (y / 11) + 400 * ((z + (x * y) % 7) / 9)) as u32);
            }
        }
    }
    v
}

/// Runs `isogrid args` under `/usr/bin/time`, and returns whether it succeeded, its stderr and
/// its peak resident memory in bytes (GNU time's `%M`, the process's own `ru_maxrss`: measured
/// from a small parent, since Linux carries a forking parent's peak across `exec`).
#[cfg(target_os = "linux")]
fn peak_rss(args: &[&str]) -> (bool, String, u64) {
    let report = std::env::temp_dir().join(format!("isogrid-rss-{}.txt", std::process::id()));
    let done = std::process::Command::new("/usr/bin/time")
        .args(["-f", "%M", "-o", s(&report), env!("CARGO_BIN_EXE_isogrid")])
        .args(args)
        .stdout(std::process::Stdio::null())
        .output()
        .unwrap();
    let text = std::fs::read_to_string(&report).unwrap();
    std::fs::remove_file(&report).unwrap();
    let kib: u64 = text
        .lines()
        .last()
        .and_then(|l| l.trim().parse().ok())
        .unwrap_or_else(|| panic!("no peak in {text:?}"));
    let stderr = String::from_utf8_lossy(&done.stderr).into_owned();
    (done.status.success(), stderr, kib * 1024)
}

/// `--labels` within `--max-memory` on a raw volume (read by region) larger than the budget: the
/// file is the in-memory one byte for byte, with and without smoothing, at the least budget that
/// works and above; the process stays within the budget; and a budget below the least fails
/// naming it, writing nothing.
#[cfg(target_os = "linux")]
#[test]
fn streamed_labels_match_in_memory_within_the_budget() {
    if !Path::new("/usr/bin/time").exists() {
        eprintln!("skipped: no /usr/bin/time to measure the peak with");
        return;
    }
    let dir = temp_dir("labels-stream");
    let dims = [256, 256, 288];
    let data = supervoxels(dims);
    let raw = dir.join("sv.raw");
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&raw, &bytes).unwrap();
    drop(bytes);
    let volume_bytes = (data.len() * 4) as u64;
    let volume = Volume::new(dims, VolumeData::U32(data)).unwrap();
    let shape = "256,256,288";
    let raw_args = ["--raw-shape", shape, "--raw-type", "u32"];
    for smooth in ["0", "1"] {
        let mut options = LabelOptions::new(LabelSelection::All);
        options.smooth = smooth.parse().unwrap();
        let expected =
            isogrid::cgc::to_bytes(&isogrid::extract_labels(&volume.view(), &options).unwrap());
        let out = dir.join(format!("out-{smooth}.cgc"));
        let mut args = vec!["extract", s(&raw), "--labels", "all", "--smooth", smooth];
        args.extend(raw_args);
        let too_small = fails(
            &[&args[..], &["--max-memory", "1M", "-o", s(&out)]].concat(),
            "the least that works is",
        );
        let least: u64 = too_small
            .split("the least that works is ")
            .nth(1)
            .and_then(|t| t.split(" MiB").next())
            .and_then(|n| n.trim().parse().ok())
            .unwrap_or_else(|| panic!("no size in {too_small}"));
        assert!(!out.exists());
        // Smoothing is slower: its least budget alone.
        let budgets: &[(u64, &str)] = if smooth == "0" {
            &[(least, "1"), (least + 8, "2"), (4096, "2")]
        } else {
            &[(least, "2")]
        };
        for &(budget, threads) in budgets {
            let budget_arg = format!("{budget}M");
            let run = [
                &args[..],
                &[
                    "--max-memory",
                    &budget_arg,
                    "--threads",
                    threads,
                    "-o",
                    s(&out),
                ],
            ]
            .concat();
            let (ok, stderr, rss) = peak_rss(&run);
            assert!(ok, "{stderr}");
            assert!(
                std::fs::read(&out).unwrap() == expected,
                "σ {smooth}, budget {budget_arg}: files differ"
            );
            eprintln!(
                "σ {smooth}: budget {budget} MiB, peak RSS {:.1} MiB, volume {:.1} MiB",
                rss as f64 / (1 << 20) as f64,
                volume_bytes as f64 / (1 << 20) as f64
            );
            if budget < 1024 {
                assert!(
                    volume_bytes > budget << 20,
                    "the volume must not fit the budget"
                );
                assert!(
                    rss <= budget << 20,
                    "σ {smooth}: peak {rss} B over a budget of {budget} MiB"
                );
            }
        }
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// A one-layer Slicer segmentation in raw encoding reads by region: `--max-memory` binds it (a
/// budget below the least fails naming it, as for any streamed input), and the file, names and
/// colours included, is byte for byte the one its gzip twin gives (read whole).
#[test]
fn one_layer_segmentations_stream_with_their_names() {
    use std::io::Read;
    let dir = temp_dir("labels-seg-stream");
    let gz = label_fixture("one_layer.seg.nrrd");
    // The raw twin: the same header with `encoding: raw`, and the samples inflated.
    let bytes = std::fs::read(&gz).unwrap();
    let split = bytes.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let header = String::from_utf8(bytes[..split].to_vec()).unwrap();
    assert!(header.contains("encoding: gzip\n") && header.contains("Segment1_Name:=portal vein"));
    let mut samples = Vec::new();
    flate2::read::GzDecoder::new(&bytes[split..])
        .read_to_end(&mut samples)
        .unwrap();
    let raw = dir.join("one_layer_raw.seg.nrrd");
    let mut twin = header
        .replace("encoding: gzip\n", "encoding: raw\n")
        .into_bytes();
    twin.extend_from_slice(&samples);
    std::fs::write(&raw, twin).unwrap();

    let whole = dir.join("whole.cgc");
    let streamed = dir.join("streamed.cgc");
    let args = |input: &Path, out: &Path, budget: &'static str| {
        let mut a = vec!["extract".to_string(), s(input).to_string()];
        a.extend(["--labels", "all", "--max-memory", budget, "-o"].map(String::from));
        a.push(s(out).to_string());
        a
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        ok_json(&[&a[..], &["--json"]].concat())
    };
    // A kibibyte: below any streamed plan, so only a file read whole gets through, with a note
    // that the budget did not bind it.
    let read_whole: Vec<String> = args(&gz, &whole, "1K");
    let read_whole: Vec<&str> = read_whole.iter().map(String::as_str).collect();
    let done = isogrid(&read_whole);
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(done.status.success(), "{stderr}");
    assert!(
        stderr.contains("one_layer.seg.nrrd: read whole") && stderr.contains("--max-memory 1 KiB"),
        "{stderr}"
    );
    let refused: Vec<String> = args(&raw, &streamed, "1K");
    let refused: Vec<&str> = refused.iter().map(String::as_str).collect();
    fails(&refused, "the least that works is");
    assert!(!streamed.exists());
    run(args(&raw, &streamed, "256M"));
    assert_eq!(
        std::fs::read(&streamed).unwrap(),
        std::fs::read(&whole).unwrap()
    );
    let names: Vec<String> = listed(&streamed).into_iter().map(|l| l.1).collect();
    assert_eq!(names, ["liver", "portal vein", "lesion 3"]);
}

/// `extract` lists at most 200 labels in its table, then how many more there are and where to see
/// them all; `info` lists every one.
#[test]
fn extract_lists_the_first_labels_and_info_all_of_them() {
    let dir = temp_dir("labels-rows");
    let dims = [64, 64, 64];
    let bytes: Vec<u8> = supervoxels(dims)
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let npy = dir.join("sv.npy");
    super::write_npy(&npy, "<u4", [64, 64, 64], &bytes);
    let out = dir.join("sv.cgc");
    let label_rows = |text: &str| {
        text.lines()
            .filter(|l| l.starts_with("  ") && l.contains("  #"))
            .count()
    };
    let extracted = isogrid(&["extract", s(&npy), "--labels", "all", "-o", s(&out)]);
    assert!(extracted.status.success());
    let labels = ok_json(&["info", s(&out), "--json"])["labels"]
        .as_array()
        .unwrap()
        .len();
    assert!(labels > 200, "{labels} labels: too few for the test");
    let text = String::from_utf8_lossy(&extracted.stdout);
    assert_eq!(label_rows(&text), 200, "{text}");
    assert!(
        text.contains(&format!(
            "  ... and {} more: `isogrid info {}` lists them all\n",
            labels - 200,
            out.display()
        )),
        "{text}"
    );
    let info = isogrid(&["info", s(&out)]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert_eq!(label_rows(&text), labels, "{text}");
    assert!(!text.contains("more:"), "{text}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// A label volume without a surface gives an empty grid and one note that says why, from every
/// command that extracts or opens it: the label grid's reason (no label, one label filling the
/// volume, one sample thick), not an isovalue's. Before, `extract` said nothing when one label
/// filled the volume, called a one-plane volume one without labels, and `info` and `render` of
/// the file spoke of the isovalue 0.5.
#[test]
fn an_empty_label_surface_is_noted_with_its_reason() {
    let dir = temp_dir("labels-empty");
    let mut speck = vec![0u8; 42];
    speck[10] = 3;
    let cases = [
        (
            "filled",
            [5, 6, 7],
            vec![7u8; 210],
            "label 7 fills the whole volume",
        ),
        (
            "background",
            [5, 6, 7],
            vec![0u8; 210],
            "the volume holds no selected label",
        ),
        ("plane", [1, 6, 7], speck, "the volume is one sample thick"),
    ];
    for (name, shape, data, why) in cases {
        let npy = dir.join(format!("{name}.npy"));
        super::write_npy(&npy, "|u1", shape, &data);
        let cgc = dir.join(format!("{name}.cgc"));
        let png = dir.join(format!("{name}.png"));
        let runs: [&[&str]; 3] = [
            &["extract", s(&npy), "--labels", "all", "-o", s(&cgc)],
            &["info", s(&cgc)],
            &[
                "render",
                s(&npy),
                "--labels",
                "all",
                "--backend",
                "cpu",
                "--size",
                "32x24",
                "-o",
                s(&png),
            ],
        ];
        for args in runs {
            let note = super::the_note(args);
            assert!(
                note.contains("no selected label has a surface") && note.contains(why),
                "{args:?}: {note}"
            );
        }
    }
}

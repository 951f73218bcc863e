//! `isogrid render` and `isogrid bench rays` end to end: PNG and AOV files with the right shapes
//! (headers parsed here), JSON names, and one-line errors.

use crate::common::{fails, isogrid, s, write_npy};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(name: &str) -> crate::common::TempDir {
    crate::common::temp_dir(&format!("render-{name}"))
}

/// (descr, shape, data offset) of a .npy file, parsed from its header.
fn npy_header(path: &Path) -> (String, Vec<usize>, usize, usize) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let text = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
    let descr = text
        .split("'descr': '")
        .nth(1)
        .unwrap()
        .split('\'')
        .next()
        .unwrap();
    assert!(text.contains("'fortran_order': False"));
    let shape = text
        .split("'shape': (")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap();
    let shape = shape
        .split(',')
        .filter(|v| !v.trim().is_empty())
        .map(|v| v.trim().parse().unwrap())
        .collect();
    (descr.to_string(), shape, 10 + len, bytes.len() - 10 - len)
}

/// The f32 values of a little-endian `<f4` .npy file.
fn npy_f32(path: &Path) -> Vec<f32> {
    let (_, _, off, _) = npy_header(path);
    std::fs::read(path).unwrap()[off..]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

/// The JSON a successful run printed (fails the test with its stderr otherwise).
fn json_of(out: &Output) -> Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn volume(dir: &Path) -> PathBuf {
    let path = dir.join("sphere.nrrd");
    let out = isogrid(&["generate", "sphere", "--size", "24", "-o", s(&path)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    path
}

#[test]
fn render_writes_png_and_aovs_of_the_right_shapes() {
    let dir = temp_dir("aov");
    let input = volume(&dir);
    let (png, d, n, c) = (
        dir.join("a.png"),
        dir.join("d.npy"),
        dir.join("n.npy"),
        dir.join("c.npy"),
    );
    let aov = format!("depth={},normal={},cluster={}", s(&d), s(&n), s(&c));
    let out = isogrid(&[
        "render",
        s(&input),
        "--iso-normalized",
        "0.5",
        "--size",
        "30x20",
        "--view",
        "2",
        "--backend",
        "cpu",
        "-o",
        s(&png),
        "--aov",
        &aov,
        "--json",
    ]);
    let json = json_of(&out);
    assert!(out.stderr.is_empty(), "no notice with --backend cpu");
    assert_eq!(json["backend"], "cpu");
    assert_eq!(
        (json["width"].as_u64(), json["height"].as_u64()),
        (Some(30), Some(20))
    );
    let hits = json["hits"].as_u64().unwrap();
    assert!(hits > 20 && hits < 600, "{hits}");
    assert!(json["rays_per_second"].as_f64().unwrap() > 0.0);

    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 30);
    assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 20);

    for (path, descr, shape) in [
        (&d, "<f4", vec![20, 30]),
        (&n, "<f4", vec![20, 30, 3]),
        (&c, "<u4", vec![20, 30]),
    ] {
        let (got_descr, got_shape, offset, data) = npy_header(path);
        assert_eq!(
            (got_descr.as_str(), &got_shape),
            (descr, &shape),
            "{path:?}"
        );
        assert_eq!(offset % 64, 0);
        assert_eq!(data, shape.iter().product::<usize>() * 4);
    }
    // Misses: depth +inf exactly where cluster is u32::MAX; as many hits as the JSON says.
    let depth = npy_f32(&d);
    let (_, _, off, _) = npy_header(&c);
    let cluster: Vec<u32> = std::fs::read(&c).unwrap()[off..]
        .chunks(4)
        .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    for (t, id) in depth.iter().zip(&cluster) {
        assert_eq!(*t == f32::INFINITY, *id == u32::MAX);
    }
    assert_eq!(
        cluster.iter().filter(|&&id| id != u32::MAX).count() as u64,
        hits
    );

    // A .cgc input renders the same depth without --iso; pathtrace mode runs.
    let cgc = dir.join("g.cgc");
    assert!(isogrid(&[
        "extract",
        s(&input),
        "--iso-normalized",
        "0.5",
        "-o",
        s(&cgc)
    ])
    .status
    .success());
    let d2 = dir.join("d2.npy");
    let out = isogrid(&[
        "render",
        s(&cgc),
        "--size",
        "30x20",
        "--view",
        "2",
        "--mode",
        "pathtrace",
        "--backend",
        "cpu",
        "--spp",
        "2",
        "--aov",
        &format!("depth={}", s(&d2)),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(&d).unwrap(), std::fs::read(&d2).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Rejected by the argument parser: clap adds its usage hint after the one-line reason.
fn rejected(args: &[&str], mention: &str) {
    let out = isogrid(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "{args:?} should fail");
    let first = stderr.lines().next().unwrap_or("");
    assert!(
        first.contains(mention),
        "{args:?}: {stderr} should mention {mention}"
    );
}

#[test]
fn render_and_bench_fail_in_one_line() {
    let dir = temp_dir("bad");
    let input = volume(&dir);
    let i = s(&input);
    fails(
        &["render", i, "--iso", "100", "--camera", "1,2,3:0,0,0:0,1,0"],
        "EYE:TARGET:UP:FOVY",
    );
    fails(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--camera",
            "0,0,5:0,0,0:0,0,1:40",
        ],
        "parallel",
    );
    fails(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--backend",
            "cpu",
            "--mode",
            "cr",
        ],
        "GPU renderer",
    );
    fails(&["render", i], "--iso");
    fails(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--mode",
            "mc",
            "--backend",
            "cpu",
        ],
        "GPU",
    );
    fails(
        &["render", i, "--iso", "100", "-o", s(&dir.join("x.jpg"))],
        ".png",
    );
    // Primary rays are a choice of the GPU path tracer only.
    fails(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--mode",
            "cgc",
            "--primary",
            "traced",
        ],
        "primary",
    );
    fails(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--mode",
            "pathtrace",
            "--backend",
            "cpu",
            "--primary",
            "traced",
        ],
        "primary",
    );
    rejected(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--mode",
            "pathtrace",
            "--primary",
            "eye",
        ],
        "eye",
    );
    rejected(&["render", i, "--iso", "100", "--size", "0x10"], "WxH");
    rejected(
        &["render", i, "--iso", "100", "--aov", "albedo=a.npy"],
        "albedo",
    );
    fails(
        &[
            "render",
            i,
            "--iso",
            "100",
            "--mode",
            "pathtrace",
            "--env",
            s(&dir.join("none.hdr")),
        ],
        "none.hdr",
    );
    std::fs::write(dir.join("rays.bin"), [0u8; 25]).unwrap();
    fails(
        &[
            "bench",
            "rays",
            i,
            "--iso",
            "100",
            "--rays-file",
            s(&dir.join("rays.bin")),
        ],
        "rays.bin",
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bench_rays_reports_the_same_hits_for_both_crossings_and_any_thread_count() {
    let dir = temp_dir("bench");
    let input = volume(&dir);
    let run = |extra: &[&str]| -> Value {
        let mut args = vec![
            "bench",
            "rays",
            s(&input),
            "--iso-normalized",
            "0.5",
            "--rays",
            "3000",
            "--seed",
            "4",
            "--json",
        ];
        args.extend_from_slice(extra);
        let out = isogrid(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let a = run(&["--threads", "1"]);
    let b = run(&["--threads", "2", "--exact"]);
    let c = run(&["--threads", "2", "--traversal", "bvh"]);
    assert_eq!(a["rays"], 3000);
    assert_eq!(a["threads"], 1);
    assert_eq!(
        (&a["traversal"], &c["traversal"]),
        (&"blocks".into(), &"bvh".into())
    );
    // The two traversals run the same search inside a cluster.
    assert_eq!(a["hits"], c["hits"]);
    // Origins inside the box of a closed sphere: every ray starting outside the ball and aimed
    // at it hits, and every ray starting inside the ball hits; some miss.
    let hits = a["hits"].as_u64().unwrap();
    assert!(hits > 300 && hits < 3000, "{hits}");
    // A smooth sphere: the three samples find what the exact solver finds.
    assert_eq!(a["hits"], b["hits"]);
    assert!(a["bytes"].as_u64().unwrap() > 0);
    // CPU time is read where the clock exists, and a trace of a few milliseconds still shows:
    // no thread ran longer than the wall clock, and no CPU time is zero.
    #[cfg(unix)]
    for r in [&a, &b] {
        let (cpu, wall) = (
            r["cpu_seconds"].as_f64().unwrap(),
            r["seconds"].as_f64().unwrap(),
        );
        let threads = r["threads"].as_f64().unwrap();
        assert!(
            cpu > 0.0 && cpu <= threads * wall + 1e-3,
            "{cpu} s CPU, {wall} s"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--traversal bvh` draws the frame `--traversal blocks` draws: the same hit pixels, depths equal
/// to rounding, and both name their traversal and its build time in the JSON.
#[test]
fn render_traversals_draw_the_same_depth_image() {
    let dir = temp_dir("traversal");
    let input = volume(&dir);
    let render = |traversal: &str| -> (Value, Vec<f32>) {
        let depth = dir.join(format!("d_{traversal}.npy"));
        let aov = format!("depth={}", s(&depth));
        let out = isogrid(&[
            "render",
            s(&input),
            "--iso-normalized",
            "0.5",
            "--size",
            "48x32",
            "--view",
            "2",
            "--backend",
            "cpu",
            "--traversal",
            traversal,
            "--aov",
            &aov,
            "--json",
        ]);
        (json_of(&out), npy_f32(&depth))
    };
    let (a, da) = render("blocks");
    let (b, db) = render("bvh");
    for (json, name) in [(&a, "blocks"), (&b, "bvh")] {
        assert_eq!(json["traversal"], name);
        let build = json["tracer_build_seconds"].as_f64().unwrap();
        assert!(build >= 0.0 && build <= json["seconds"].as_f64().unwrap());
    }
    assert_eq!(a["hits"], b["hits"]);
    assert!(a["hits"].as_u64().unwrap() > 100, "{}", a["hits"]);
    for (i, (x, y)) in da.iter().zip(&db).enumerate() {
        assert!(
            x == y || (x - y).abs() <= 1e-6 * x.abs(),
            "pixel {i}: blocks {x}, bvh {y}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The GPU renderer and the CPU tracer draw the same isosurface: same hit pixels and depths
/// (both solve the paper's 3-sample crossing of the same stored corners). GPU path tracing with
/// traced primaries runs that very search on the same pixel-centre rays, so its depth AOV matches
/// the CPU's to rounding (1e-3 voxel; misses are inf in both).
#[test]
fn gpu_and_cpu_backends_agree_on_depth() {
    let dir = temp_dir("backends");
    let input = volume(&dir);
    let depth = |backend: &str, extra: &[&str]| -> Option<Vec<f32>> {
        let path = dir.join(format!("depth-{backend}-{}.npy", extra.len()));
        let aov = format!("depth={}", s(&path));
        let mut args = vec![
            "render",
            s(&input),
            "--iso-normalized",
            "0.5",
            "--size",
            "64x48",
            "--view",
            "2",
            "--backend",
            backend,
            "--aov",
            &aov,
            "--json",
        ];
        args.extend(extra);
        let out = isogrid(&args);
        if failed_for_want_of_a_gpu(&out, backend) {
            return None;
        }
        if !extra.is_empty() {
            let report: Value = serde_json::from_slice(&out.stdout).unwrap();
            assert_eq!(report["primary"], "traced");
            assert_eq!(report["drawn_cells"], Value::Null);
        }
        let bytes = std::fs::read(&path).unwrap();
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        Some(
            bytes[10 + header_len..]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect(),
        )
    };
    let Some(gpu) = depth("gpu", &[]) else {
        eprintln!("skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
        return;
    };
    let cpu = depth("cpu", &[]).unwrap();
    // GPU path tracing with traced primaries fills the depth AOV from the same crossing search.
    let traced = depth(
        "gpu",
        &[
            "--mode",
            "pathtrace",
            "--primary",
            "traced",
            "--bounces",
            "0",
        ],
    )
    .unwrap();
    assert_eq!(traced.len(), cpu.len());
    let traced_close = traced
        .iter()
        .zip(&cpu)
        .filter(|(t, c)| t == c || (*t - *c).abs() <= 1e-3)
        .count();
    assert!(
        traced_close as f64 >= 0.99 * cpu.len() as f64,
        "traced primaries: {traced_close} of {} depths within 1e-3 of the CPU's",
        cpu.len()
    );
    assert_eq!(gpu.len(), cpu.len());
    let same_side = gpu
        .iter()
        .zip(&cpu)
        .filter(|(g, c)| g.is_finite() == c.is_finite())
        .count();
    assert!(
        same_side as f64 >= 0.99 * gpu.len() as f64,
        "hit/miss agree on {same_side} of {}",
        gpu.len()
    );
    let both: Vec<f32> = gpu
        .iter()
        .zip(&cpu)
        .filter(|(g, c)| g.is_finite() && c.is_finite())
        .map(|(g, c)| (g - c).abs())
        .collect();
    assert!(both.len() > 100, "too few hits to compare");
    let close = both.iter().filter(|&&d| d <= 0.05).count();
    assert!(
        close as f64 >= 0.99 * both.len() as f64,
        "{close} of {} depths within 0.05 voxel",
        both.len()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Ctrl-C during a long CPU path trace stops it within a tile: the command ends by itself with a
/// one-line message and status 130, and writes no image.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_long_render_cleanly_and_writes_nothing() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let dir = temp_dir("sigint");
    let input = volume(&dir);
    let png = dir.join("never.png");
    // Hours of work at 100000 samples per pixel; the signal comes after a pause that covers
    // reading the input. A signal that lands before the render starts ends the process the
    // default way (no message): then try again with a longer pause.
    for pause in [1, 3, 8] {
        let child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
            .args([
                "render",
                s(&input),
                "--iso-normalized",
                "0.5",
                "--backend",
                "cpu",
            ])
            .args([
                "--mode",
                "pathtrace",
                "--spp",
                "100000",
                "--size",
                "320x240",
            ])
            .args(["-o", s(&png)])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_secs(pause));
        // SAFETY: sending SIGINT to our own child process.
        unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
        let start = Instant::now();
        let mut child = child;
        while child.try_wait().unwrap().is_none() {
            if start.elapsed() > Duration::from_secs(60) {
                child.kill().unwrap();
                panic!("still rendering 60 s after Ctrl-C");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let out = child.wait_with_output().unwrap();
        assert!(!png.exists(), "an image was written");
        if out.status.signal() == Some(libc::SIGINT) {
            continue;
        }
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(130), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("Ctrl-C") && stderr.contains("nothing written"),
            "{stderr}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
        return;
    }
    panic!("every Ctrl-C came before the render started");
}

/// An f32 NRRD on the grid of a `size`³ volume (spacing 1, origin 0, so world = index space)
/// holding `f(position)`.
fn float_field(path: &Path, size: usize, f: impl Fn([f64; 3]) -> f64) {
    let mut bytes = format!(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: {size} {size} {size}\nendian: little\nencoding: raw\n\n"
    )
    .into_bytes();
    for k in 0..size {
        for j in 0..size {
            for i in 0..size {
                bytes.extend_from_slice(&(f([i as f64, j as f64, k as f64]) as f32).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// `extract SURFACE --iso 127.5 --color-by FIELD` into `s.cgc` beside the surface.
fn colored_cgc(surface: &Path, field: &Path) -> PathBuf {
    let cgc = surface.with_file_name("s.cgc");
    json_of(&isogrid(&[
        "extract",
        s(surface),
        "--iso",
        "127.5",
        "--color-by",
        s(field),
        "-o",
        s(&cgc),
        "--json",
    ]));
    cgc
}

fn png_rgb(path: &Path) -> Vec<u8> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    buf
}

/// Whether a run failed, which it may only for want of a GPU adapter (asserted).
fn failed_for_want_of_a_gpu(out: &std::process::Output, label: &str) -> bool {
    if out.status.success() {
        return false;
    }
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no GPU adapter"), "{label}: {err}");
    true
}

/// ≥ 99 % of the hit pixels of a render show a value within 1 % of the colour range `clim` of
/// `f` at the exact hit point (eye + depth × the pixel's ray); misses show NaN.
fn assert_values_follow_the_hits(
    label: &str,
    values: &[f32],
    depths: &[f32],
    camera: &isogrid::Camera,
    f: impl Fn([f64; 3]) -> f64,
    [lo, hi]: [f64; 2],
) {
    let (mut hits, mut close) = (0, 0);
    let mut errors = Vec::new();
    for y in 0..camera.height {
        for x in 0..camera.width {
            let i = (x + camera.width * y) as usize;
            if !depths[i].is_finite() {
                assert!(
                    values[i].is_nan(),
                    "{label}: pixel {x},{y}: a miss with value {}",
                    values[i]
                );
                continue;
            }
            let ray = camera.ray(x, y);
            let p = [0, 1, 2].map(|a| ray.origin[a] + depths[i] as f64 * ray.direction[a]);
            let error = (values[i] as f64 - f(p)).abs() / (hi - lo);
            hits += 1;
            close += (error <= 0.01) as usize;
            errors.push(error);
        }
    }
    errors.sort_by(f64::total_cmp);
    eprintln!(
        "{label}: {hits} hits, {close} within 1 % of the range; median {:.4}, p99 {:.4}, max {:.4}",
        errors[errors.len() / 2],
        errors[errors.len() * 99 / 100],
        errors[errors.len() - 1]
    );
    assert!(hits > 1500, "{label}: {hits} hits");
    assert!(
        close as f64 >= 0.99 * hits as f64,
        "{label}: {close} of {hits} within 1 %"
    );
}

/// The value AOV against an independent reference: the attribute (linear in position, so the
/// trilinear field equals it) at the exact hit point, eye + depth × the pixel's ray. A cell stores
/// the value at its surface point, so a pixel sees that value wherever in the cell its ray hits;
/// on this sphere ≥ 99 % of hit pixels are within 1 % of the colour range. Colours follow the map.
#[test]
fn the_value_aov_is_the_attribute_at_the_hit_and_colours_follow_the_map() {
    let dir = temp_dir("color");
    let size = 80;
    let sphere = dir.join("sphere.nrrd");
    assert!(
        isogrid(&["generate", "sphere", "--size", "80", "-o", s(&sphere)])
            .status
            .success()
    );
    let field = dir.join("field.nrrd");
    let f = |p: [f64; 3]| p[0] + 2.0 * p[1];
    float_field(&field, size, f);
    let cgc = colored_cgc(&sphere, &field);
    let (w, h) = (160u32, 120u32);
    let (png, value, depth) = (dir.join("v.png"), dir.join("v.npy"), dir.join("d.npy"));
    let aovs = format!("value={},depth={}", s(&value), s(&depth));
    let report = json_of(&isogrid(&[
        "render",
        s(&cgc),
        "--backend",
        "cpu",
        "--view",
        "2",
        "--size",
        "160x120",
        "--aov",
        &aovs,
        "-o",
        s(&png),
        "--json",
    ]));
    assert_eq!(report["color"]["cmap"], "viridis", "{report}");
    let clim = report["color"]["clim"].as_array().unwrap();
    let (lo, hi) = (clim[0].as_f64().unwrap(), clim[1].as_f64().unwrap());
    let (values, depths) = (npy_f32(&value), npy_f32(&depth));
    let camera = isogrid::Camera::preset(2, [0.0; 3], [(size - 1) as f64; 3], w, h).unwrap();
    assert_values_follow_the_hits("cpu", &values, &depths, &camera, f, [lo, hi]);
    // Every GPU mode colours the same surface the same way: cgc with either raster, without
    // EWA, CR, the MC mesh (vertex values from the cells they lie on) and path tracing.
    let gpu_modes: [&[&str]; 6] = [
        &["--cell-raster", "hardware"],
        &["--cell-raster", "compute"],
        &["--mode", "cgc-noewa"],
        &["--mode", "cr"],
        &["--mode", "mc"],
        // The value under each pixel is the raster primary's, where the paths start.
        &["--mode", "pathtrace", "--spp", "2"],
    ];
    let (gpu_png, gpu_value, gpu_depth) =
        (dir.join("g.png"), dir.join("g.npy"), dir.join("gd.npy"));
    let gpu_aovs = format!("value={},depth={}", s(&gpu_value), s(&gpu_depth));
    for extra in gpu_modes {
        let label = extra.join(" ");
        let mut args = vec![
            "render",
            s(&sphere),
            "--iso",
            "127.5",
            "--color-by",
            s(&field),
            "--backend",
            "gpu",
            "--view",
            "2",
            "--size",
            "160x120",
            "--aov",
            &gpu_aovs,
            "-o",
            s(&gpu_png),
            "--json",
        ];
        args.extend(extra);
        let out = isogrid(&args);
        if failed_for_want_of_a_gpu(&out, &label) {
            eprintln!("{label}: skipped, no GPU adapter");
            break;
        }
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(report["backend"], "gpu", "{label}: {report}");
        let (gpu_values, gpu_depths) = (npy_f32(&gpu_value), npy_f32(&gpu_depth));
        assert_values_follow_the_hits(&label, &gpu_values, &gpu_depths, &camera, f, [lo, hi]);
    }
    // Viridis: the lowest visible values are bluer, the highest yellower (map order).
    let rgb = png_rgb(&png);
    let mut visible: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    visible.sort_by(f32::total_cmp);
    let (p10, p90) = (visible[visible.len() / 10], visible[visible.len() * 9 / 10]);
    let mean_of = |low: bool| {
        let mut sum = [0.0f64; 3];
        let mut n = 0.0;
        for i in 0..(w * h) as usize {
            if values[i].is_finite()
                && if low {
                    values[i] <= p10
                } else {
                    values[i] >= p90
                }
            {
                for c in 0..3 {
                    sum[c] += rgb[3 * i + c] as f64;
                }
                n += 1.0;
            }
        }
        assert!(n > 50.0, "{n} pixels");
        sum.map(|v| v / n)
    };
    let (low, high) = (mean_of(true), mean_of(false));
    assert!(
        low[2] > low[1] && high[1] > high[2],
        "low {low:?}, high {high:?}"
    );
    // Gray: every hit pixel is grey, with the same camera.
    json_of(&isogrid(&[
        "render",
        s(&cgc),
        "--backend",
        "cpu",
        "--view",
        "2",
        "--size",
        "160x120",
        "--cmap",
        "gray",
        "-o",
        s(&png),
        "--json",
    ]));
    let rgb = png_rgb(&png);
    let hit_pixels: Vec<usize> = (0..(w * h) as usize)
        .filter(|&i| depths[i].is_finite())
        .collect();
    let grey = hit_pixels
        .iter()
        .filter(|&&i| rgb[3 * i] == rgb[3 * i + 1] && rgb[3 * i + 1] == rgb[3 * i + 2])
        .count();
    assert_eq!(grey, hit_pixels.len());
    std::fs::remove_dir_all(dir).unwrap();
}

/// Colour options fail in one line: on the GPU renderer (which draws one colour), on a grid
/// without an attribute, with a bad range or an unknown map.
#[test]
fn colour_options_fail_clearly_where_they_cannot_be_drawn() {
    let dir = temp_dir("color-errors");
    let sphere = volume(&dir);
    let field = dir.join("field.nrrd");
    float_field(&field, 24, |p| p[2]);
    let cgc = colored_cgc(&sphere, &field);
    let plain = dir.join("plain.cgc");
    json_of(&isogrid(&[
        "extract",
        s(&sphere),
        "--iso",
        "127.5",
        "-o",
        s(&plain),
        "--json",
    ]));
    let png = dir.join("x.png");
    for (args, words) in [
        (
            vec![
                "render",
                s(&cgc),
                "--mode",
                "pathtrace",
                "--primary",
                "traced",
                "--aov",
                "value=v.npy",
                "-o",
                s(&png),
            ],
            "drop --primary traced",
        ),
        (
            vec!["render", s(&plain), "--cmap", "magma", "-o", s(&png)],
            "has none",
        ),
        (
            vec!["render", s(&cgc), "--clim", "5,5", "-o", s(&png)],
            "--clim",
        ),
        (
            vec!["render", s(&cgc), "--clim", "nan,1", "-o", s(&png)],
            "--clim",
        ),
        (
            vec!["render", s(&cgc), "--cmap", "jet", "-o", s(&png)],
            "viridis, magma",
        ),
    ] {
        let out = isogrid(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(words), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!png.exists(), "{args:?} wrote the image");
    }
    // A volume coloured on the fly renders the file's colours.
    let (a, b) = (dir.join("a.png"), dir.join("b.png"));
    json_of(&isogrid(&[
        "render",
        s(&cgc),
        "--size",
        "64x48",
        "-o",
        s(&a),
        "--json",
    ]));
    json_of(&isogrid(&[
        "render",
        s(&sphere),
        "--iso",
        "127.5",
        "--color-by",
        s(&field),
        "--size",
        "64x48",
        "-o",
        s(&b),
        "--json",
    ]));
    assert!(png_rgb(&a) == png_rgb(&b), "the same colours");
    std::fs::remove_dir_all(dir).unwrap();
}

/// `--colorbar`: every row of the bar is the colour table's entry for it (the table of
/// `isogrid::colormap`, itself checked against the published viridis ends), labels are drawn
/// beside it, and the rest of the image is the render without the bar.
#[test]
fn the_colour_bar_shows_the_table_and_leaves_the_picture_alone() {
    let dir = temp_dir("colorbar");
    let sphere = volume(&dir);
    let field = dir.join("field.nrrd");
    float_field(&field, 24, |p| p[0] - p[2]);
    let cgc = colored_cgc(&sphere, &field);
    let (plain, barred) = (dir.join("plain.png"), dir.join("bar.png"));
    let (w, h) = (320u32, 240u32);
    for (out, extra) in [(&plain, None), (&barred, Some("--colorbar"))] {
        let mut args = vec![
            "render",
            s(&cgc),
            "--backend",
            "cpu",
            "--size",
            "320x240",
            "--cmap",
            "magma",
            "-o",
            s(out),
            "--json",
        ];
        args.extend(extra);
        json_of(&isogrid(&args));
    }
    let (a, b) = (png_rgb(&plain), png_rgb(&barred));
    let table = isogrid::colormap::ColorMap::Magma.table();
    let (left, top, bottom) = isogrid_render::colorbar::bar_box(w, h);
    let at = |img: &[u8], x: u32, y: u32| {
        let i = 3 * (x + w * y) as usize;
        [img[i], img[i + 1], img[i + 2]]
    };
    for y in top..=bottom {
        let expected = table[isogrid_render::colorbar::entry_of_row(top, bottom, y)];
        assert_eq!(at(&b, left + 5, y), expected, "row {y}");
    }
    assert_eq!(at(&b, left + 5, bottom), table[0]);
    assert_eq!(at(&b, left + 5, top), table[255]);
    // Labels: white pixels left of the bar at its top, middle and bottom rows.
    for row in [top, (top + bottom) / 2, bottom] {
        let lit = (left - 70..left - 2)
            .flat_map(|x| (row.saturating_sub(5)..row + 5).map(move |y| (x, y)))
            .filter(|&(x, y)| at(&b, x, y) == [255, 255, 255])
            .count();
        assert!(lit > 5, "no label at row {row}");
    }
    // Left of the labels the picture is untouched.
    for y in 0..h {
        for x in 0..left - 80 {
            assert_eq!(at(&a, x, y), at(&b, x, y), "pixel {x},{y}");
        }
    }
    let out = isogrid(&[
        "render",
        s(&cgc),
        "--colorbar",
        "--size",
        "64x48",
        "-o",
        s(&barred),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--colorbar needs an image of at least"));
    std::fs::remove_dir_all(dir).unwrap();
}

/// A 24³ u8 label volume as .npy: three labels side by side along x in a ball, 0 around.
fn label_volume(dir: &Path) -> PathBuf {
    label_volume_of(dir, 24)
}

/// [`label_volume`] of `n`³ samples.
fn label_volume_of(dir: &Path, n: usize) -> PathBuf {
    let c = (n as f64 - 1.0) / 2.0;
    let r = 0.375 * n as f64;
    let mut data = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = [x, y, z].map(|v| v as f64 - c);
                let inside = p.iter().map(|v| v * v).sum::<f64>() < r * r;
                data.push(match inside {
                    true => 1 + ((p[0] + r) / (2.0 * r / 3.0)).clamp(0.0, 2.0) as u8,
                    false => 0,
                });
            }
        }
    }
    let path = dir.join("labels.npy");
    write_npy(&path, "|u1", [n; 3], &data);
    path
}

/// `isogrid extract INPUT --labels all` into `INPUT.cgc` beside it; the test fails when it does.
fn extract_labels(input: &Path) -> PathBuf {
    let cgc = input.with_extension("cgc");
    let out = isogrid(&["extract", s(input), "--labels", "all", "-o", s(&cgc)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    cgc
}

/// The arguments of a 48×32 CPU render of `cgc` (view 2) to `png` with the AOV `label_arg`.
fn label_render<'a>(cgc: &'a Path, label_arg: &'a str, png: &'a Path) -> Vec<&'a str> {
    let size = ["--backend", "cpu", "--view", "2", "--size", "48x32"];
    let mut args = vec!["render", s(cgc)];
    args.extend(size);
    args.extend(["--aov", label_arg, "-o", s(png)]);
    args
}

/// A temporary folder `name` holding the label grid of [`label_volume`], and the paths of a label
/// AOV and a PNG to render it to.
fn labels_to_render(name: &str) -> (crate::common::TempDir, PathBuf, PathBuf, PathBuf) {
    let dir = temp_dir(name);
    let cgc = extract_labels(&label_volume(&dir));
    let (aov, png) = (dir.join("label.npy"), dir.join("labels.png"));
    (dir, cgc, aov, png)
}

/// The values of a label AOV file (u64, row-major).
fn read_label_aov(path: &Path) -> Vec<u64> {
    std::fs::read(path).unwrap()[npy_header(path).2..]
        .chunks_exact(8)
        .map(|b| u64::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

/// `--show` / `--hide` and the label AOV: a u64 H×W file of label values, all ones on a miss,
/// without the hidden label; a label the grid lacks, or labels asked of a grid without them,
/// fail in one line with exit status 1.
#[test]
fn render_shows_and_hides_labels_and_writes_the_label_aov() {
    let (dir, cgc, aov, png) = labels_to_render("labels");
    let label_arg = format!("label={}", s(&aov));
    // Label 2 by value, and by its name (the table's default, in another case).
    for hide in [None, Some("2"), Some("LABEL 2")] {
        let mut args = label_render(&cgc, &label_arg, &png);
        args.push("--json");
        if let Some(h) = hide {
            args.extend(["--hide", h]);
        }
        json_of(&isogrid(&args));
        let (descr, shape, _, _) = npy_header(&aov);
        assert_eq!((descr.as_str(), shape), ("<u8", vec![32, 48]));
        let labels = read_label_aov(&aov);
        let count = |v: u64| labels.iter().filter(|&&l| l == v).count();
        assert!(
            count(u64::MAX) > 0 && count(1) > 0 && count(3) > 0,
            "{hide:?}"
        );
        assert_eq!(count(2) > 0, hide.is_none(), "{hide:?}");
        assert_eq!(
            count(1) + count(2) + count(3) + count(u64::MAX),
            labels.len()
        );
    }
    for flag in ["--show", "--hide"] {
        let args = ["render", s(&cgc), flag, "1,7", "-o", s(&png)];
        fails(&args, "label 7: no such label");
        assert_eq!(isogrid(&args).status.code(), Some(1));
        let args = ["render", s(&cgc), flag, "1,liver", "-o", s(&png)];
        fails(&args, "\"liver\": no label has this name");
    }
    let sphere = volume(&dir);
    fails(
        &[
            "render",
            s(&sphere),
            "--iso",
            "0.5",
            "--hide",
            "1",
            "-o",
            s(&png),
        ],
        "need a label grid",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--frame surface` makes the standard view frame the surface's box, with labels hidden the
/// shown labels': the one label shown fills far more of the image than in the grid's frame, and
/// nothing else is drawn; the GPU frames it as the CPU does (hit counts within 2 %).
#[test]
fn a_surface_view_frames_the_shown_labels() {
    let (dir, cgc, aov, png) = labels_to_render("frame-surface");
    let label_arg = format!("label={}", s(&aov));
    let hits = |frame: &str, backend: &str| -> Option<usize> {
        let mut args = vec!["render", s(&cgc), "--backend", backend, "--view", "2"];
        args.extend(["--size", "48x32", "--aov", &label_arg, "-o", s(&png)]);
        args.extend(["--show", "1", "--frame", frame]);
        let out = isogrid(&args);
        if failed_for_want_of_a_gpu(&out, backend) {
            return None;
        }
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let labels = read_label_aov(&aov);
        assert!(labels.iter().all(|&l| l == 1 || l == u64::MAX), "{frame}");
        Some(labels.iter().filter(|&&l| l == 1).count())
    };
    let (grid, surface) = (
        hits("grid", "cpu").unwrap(),
        hits("surface", "cpu").unwrap(),
    );
    assert!(
        grid > 0 && surface > 2 * grid,
        "{grid} hits framing the grid, {surface} the label"
    );
    if let Some(gpu) = hits("surface", "gpu") {
        assert!(
            gpu.abs_diff(surface) * 50 <= surface,
            "GPU {gpu}, CPU {surface}"
        );
    }
    let camera = "0,0,9:0,0,0:0,1,0:30";
    let out = isogrid(&["render", s(&cgc), "--frame", "surface", "--camera", camera]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(2) && err.contains("cannot be used with"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A signed label volume holding -1, whose value as u64 is all ones, the label AOV's miss: the
/// AOV is refused in one line while -1 is drawn, and written once it is hidden, with -1 nowhere
/// in it but on the misses.
#[test]
fn label_aov_refuses_a_shown_label_that_reads_as_a_miss() {
    let dir = temp_dir("label-minus-one");
    // The three-label ball as i32, label 1 turned into -1.
    let u8_path = label_volume(&dir);
    let bytes = std::fs::read(&u8_path).unwrap();
    let (_, _, off, _) = npy_header(&u8_path);
    let n = 24;
    let data: Vec<u8> = bytes[off..]
        .iter()
        .flat_map(|&v| match v {
            1 => (-1i32).to_le_bytes(),
            v => (v as i32).to_le_bytes(),
        })
        .collect();
    let npy = dir.join("signed.npy");
    write_npy(&npy, "<i4", [n; 3], &data);
    let cgc = extract_labels(&npy);
    let aov = dir.join("label.npy");
    let png = dir.join("signed.png");
    let label_arg = format!("label={}", s(&aov));
    let mut args = label_render(&cgc, &label_arg, &png);
    fails(&args, "label -1 cannot be told from a miss");
    assert_eq!(isogrid(&args).status.code(), Some(1));
    assert!(!png.exists() && !aov.exists(), "nothing is written");
    args.push("--hide=-1");
    let out = isogrid(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let labels = read_label_aov(&aov);
    let count = |v: u64| labels.iter().filter(|&&l| l == v).count();
    assert!(count(2) > 0 && count(3) > 0 && count(u64::MAX) > 0);
    assert_eq!(count(2) + count(3) + count(u64::MAX), labels.len());
    std::fs::remove_dir_all(&dir).ok();
}

/// A label grid coloured by an attribute (`extract --labels all --color-by`): the same file from
/// the label volume read whole and streamed; with a label hidden, every mode that colours shows
/// the attribute at the hit point (as [`assert_values_follow_the_hits`] checks for an isosurface)
/// and the label AOV never the hidden label, on the CPU and each GPU mode; MC, which draws the
/// labels' meshes in their colours, refuses the attribute in one line.
#[test]
fn labels_coloured_by_an_attribute_show_its_value_on_every_shown_label() {
    let dir = temp_dir("labels-attribute");
    // 80³, as the isosurface's test: a cell holds one value, which varies across it by up to
    // 3 units of x + 2y, so the picture's range must be wide enough for 1 % of it.
    let labels = label_volume_of(&dir, 80);
    let field = dir.join("field.nrrd");
    let f = |p: [f64; 3]| p[0] + 2.0 * p[1];
    float_field(&field, 80, f);
    let raw = dir.join("labels.raw");
    std::fs::write(
        &raw,
        &std::fs::read(&labels).unwrap()[npy_header(&labels).2..],
    )
    .unwrap();
    let (cgc, streamed) = (dir.join("labels.cgc"), dir.join("streamed.cgc"));
    for (input, out, extra) in [
        (&labels, &cgc, &[][..]),
        (
            &raw,
            &streamed,
            &[
                "--raw-shape",
                "80,80,80",
                "--raw-type",
                "u8",
                "--max-memory",
                "64M",
            ][..],
        ),
    ] {
        let mut args = vec!["extract", s(input), "--labels", "all", "--color-by"];
        args.extend([s(&field), "-o", s(out), "--json"]);
        args.extend(extra);
        let report = json_of(&isogrid(&args));
        assert_eq!(report["attribute"]["name"], "field.nrrd", "{report}");
        assert_eq!(report["labels"].as_array().unwrap().len(), 3, "{report}");
    }
    assert!(std::fs::read(&cgc).unwrap() == std::fs::read(&streamed).unwrap());
    let (w, h) = (200u32, 150u32);
    let camera = isogrid::Camera::preset(2, [0.0; 3], [79.0; 3], w, h).unwrap();
    let (png, value, depth, label) = (
        dir.join("v.png"),
        dir.join("v.npy"),
        dir.join("d.npy"),
        dir.join("l.npy"),
    );
    let aovs = format!(
        "value={},depth={},label={}",
        s(&value),
        s(&depth),
        s(&label)
    );
    let modes: [(&str, &[&str]); 5] = [
        ("cpu", &["--backend", "cpu"]),
        ("gpu cgc", &["--backend", "gpu"]),
        (
            "gpu cgc-noewa",
            &["--backend", "gpu", "--mode", "cgc-noewa"],
        ),
        (
            "gpu pathtrace",
            &["--backend", "gpu", "--mode", "pathtrace", "--spp", "2"],
        ),
        // The labels' meshes, each vertex the mean of its label's cells around it.
        ("gpu mc", &["--backend", "gpu", "--mode", "mc"]),
    ];
    for (name, extra) in modes {
        let mut args = vec!["render", s(&cgc), "--hide", "2", "--view", "2", "--size"];
        args.extend(["200x150", "--aov", &aovs, "-o", s(&png), "--json"]);
        args.extend(extra);
        let out = isogrid(&args);
        if failed_for_want_of_a_gpu(&out, name) {
            eprintln!("{name}: skipped, no GPU adapter");
            continue;
        }
        let report = json_of(&out);
        let clim = report["color"]["clim"].as_array().unwrap();
        let clim = [clim[0].as_f64().unwrap(), clim[1].as_f64().unwrap()];
        let (values, depths) = (npy_f32(&value), npy_f32(&depth));
        assert_values_follow_the_hits(name, &values, &depths, &camera, f, clim);
        let labels = read_label_aov(&label);
        assert!(!labels.contains(&2), "{name}: the hidden label shows");
        assert!(labels.contains(&1) && labels.contains(&3), "{name}");
        for (l, v) in labels.iter().zip(&values) {
            assert_eq!(*l == u64::MAX, v.is_nan(), "{name}: label {l}, value {v}");
        }
    }
}

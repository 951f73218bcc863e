//! `isogrid view` end to end: a scripted run in a real window under Xvfb must show the same
//! isosurface as the headless renderer for the same camera, and bad inputs must end in one-line
//! errors, and files dropped on the window (a real XDND drag from `xdnd_drop.py`) must open, or
//! show why they cannot. Window tests skip with a message (they do not fail) when `xvfb-run` is
//! not installed or the machine has no GPU adapter at all (Mesa lavapipe counts as one); the drop
//! tests also when python3 with python-xlib is missing.

use isogrid::colormap::{ColorMap, Coloring};
use isogrid::extract::attribute::sample_attribute_in_memory;
use isogrid::generate::{generate, Field};
use isogrid::shading::BACKGROUND_SRGB;
use isogrid::AttributePrecision;
use isogrid::{extract, Camera, ExtractOptions, Iso, VolumeData};
use isogrid_gpu::{GpuErrorKind, Mode, RenderOptions, Renderer, Scene};
use std::ffi::OsStr;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn temp_dir(name: &str) -> crate::common::TempDir {
    crate::common::temp_dir(&format!("view-{name}"))
}

fn xvfb_run() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    let found = std::env::split_paths(&path)
        .map(|d| d.join("xvfb-run"))
        .find(|p| p.is_file());
    if found.is_none() {
        eprintln!("skipping window test: xvfb-run is not installed (apt-get install xvfb)");
    }
    found
}

fn renderer() -> Option<Renderer> {
    match Renderer::new() {
        Ok(r) => Some(r),
        Err(e) if e.kind() == GpuErrorKind::NoAdapter => {
            eprintln!("skipping window test: no GPU adapter: {e}");
            None
        }
        Err(e) => panic!("GPU renderer failed to start: {e}"),
    }
}

/// The XDND source that drops files on the viewer, when python3 can run it.
fn xdnd_helper() -> Option<PathBuf> {
    let has_xlib = Command::new("python3")
        .args(["-c", "import Xlib"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_xlib {
        eprintln!(
            "skipping drag-and-drop test: python3 with python-xlib is not installed \
             (pip install python-xlib)"
        );
        return None;
    }
    Some(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/xdnd_drop.py"))
}

/// Runs `isogrid ARGS` on a fresh Xvfb screen (24-bit: Vulkan surfaces need a true-colour
/// visual, and xvfb-run's default screen is 8-bit), killing it after `limit`.
fn isogrid_in_xvfb(xvfb: &Path, args: &[&str], limit: Duration) -> Output {
    let mut command: Vec<&OsStr> = vec![OsStr::new(env!("CARGO_BIN_EXE_isogrid"))];
    command.extend(args.iter().map(OsStr::new));
    in_xvfb(xvfb, &command, limit)
}

/// Runs `isogrid view ARGS` on a fresh Xvfb screen at `w`×`h` for three frames, saving the last
/// one as `shot`; fails unless it exits 0, and returns its stdout.
fn scripted_view(xvfb: &Path, args: &[&str], [w, h]: [u32; 2], shot: &Path) -> String {
    let size = format!("{w}x{h}");
    let mut all = vec!["view"];
    all.extend_from_slice(args);
    all.extend([
        "--size",
        &size,
        "--frames",
        "3",
        "--screenshot",
        shot.to_str().unwrap(),
    ]);
    let out = isogrid_in_xvfb(xvfb, &all, Duration::from_secs(240));
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "view failed: {stderr}\n{stdout}");
    stdout
}

/// Runs `isogrid ARGS` on a fresh Xvfb screen and drops `file` on its window once it shows.
/// The exit status is the viewer's, or 100 + the helper's when the drop itself failed.
fn isogrid_in_xvfb_with_drop(
    xvfb: &Path,
    helper: &Path,
    file: &Path,
    args: &[&str],
    limit: Duration,
) -> Output {
    const SCRIPT: &str = r#"
helper=$1; file=$2; shift 2
"$@" & viewer=$!
python3 "$helper" "$file"; dropped=$?
if [ "$dropped" -ne 0 ]; then kill "$viewer"; wait "$viewer"; exit $((100 + dropped)); fi
wait "$viewer"
"#;
    let mut command: Vec<&OsStr> = ["bash", "-c", SCRIPT, "bash"]
        .into_iter()
        .map(OsStr::new)
        .collect();
    command.extend([helper.as_os_str(), file.as_os_str()]);
    command.push(OsStr::new(env!("CARGO_BIN_EXE_isogrid")));
    command.extend(args.iter().map(OsStr::new));
    in_xvfb(xvfb, &command, limit)
}

fn in_xvfb(xvfb: &Path, command: &[&OsStr], limit: Duration) -> Output {
    let mut child = Command::new(xvfb)
        .args(["-a", "-s", "-screen 0 1280x1024x24 -nolisten tcp"])
        .args(command)
        .env("NODEVICE_SELECT", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts xvfb-run");
    let start = Instant::now();
    loop {
        if child.try_wait().expect("waits for xvfb-run").is_some() {
            break;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                let _ = e.read_to_string(&mut err);
            }
            panic!("{command:?} did not finish within {limit:?}; stderr: {err}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    child.wait_with_output().expect("collects the output")
}

/// "… rendered image at X,Y size WxH px" from the viewer's stdout.
fn image_region(stdout: &str) -> Option<[u32; 4]> {
    let rest = stdout.split("rendered image at ").nth(1)?;
    let (xy, rest) = rest.split_once(" size ")?;
    let (x, y) = xy.split_once(',')?;
    let (w, rest) = rest.split_once('x')?;
    let h = rest.split_whitespace().next()?;
    Some([x, y, w, h].map(|v| v.trim().parse().unwrap_or(u32::MAX)))
}

/// The PNG as (width, height, RGB bytes).
fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    assert!(channels >= 3 && info.bit_depth == png::BitDepth::Eight);
    let rgb = buf[..info.buffer_size()]
        .chunks_exact(channels)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    (info.width, info.height, rgb)
}

fn is_background(rgb: &[u8]) -> bool {
    (0..3).all(|c| (rgb[c] as i32 - BACKGROUND_SRGB[c] as i32).abs() <= 3)
}

#[test]
fn scripted_window_shows_the_headless_image() {
    let Some(xvfb) = xvfb_run() else { return };
    let Some(renderer) = renderer() else { return };
    let dir = temp_dir("scripted");
    let volume = generate(Field::Torus, 40, 1);
    let input = dir.join("torus.nrrd");
    isogrid_io::write_nrrd(&input, &volume).unwrap();
    let shot = dir.join("window.png");
    let (w, h) = (320u32, 240u32);
    let stdout = scripted_view(
        &xvfb,
        &[input.to_str().unwrap(), "--iso-normalized", "0.5"],
        [w, h],
        &shot,
    );
    assert_window_shows(&renderer, &volume, &shot, &stdout, [w, h]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A surface without an active cell draws nothing; the window says why in the words of the
/// command line's note (and a scripted run prints it), at an isovalue above every sample.
#[test]
fn scripted_window_says_why_a_surface_is_empty() {
    let Some(xvfb) = xvfb_run() else { return };
    if renderer().is_none() {
        return;
    }
    let dir = temp_dir("empty");
    let input = dir.join("torus.nrrd");
    isogrid_io::write_nrrd(&input, &generate(Field::Torus, 24, 1)).unwrap();
    let note = crate::common::isogrid(&["extract", input.to_str().unwrap(), "--iso", "1000"]);
    let note = String::from_utf8_lossy(&note.stderr);
    let note = note
        .lines()
        .find_map(|l| l.strip_prefix(&format!("isogrid: note: {}: ", input.display())))
        .expect("extract notes the empty surface")
        .to_string();
    let shot = dir.join("window.png");
    let stdout = scripted_view(
        &xvfb,
        &[input.to_str().unwrap(), "--iso", "1000"],
        [160, 120],
        &shot,
    );
    assert!(
        stdout.contains(&format!("isogrid view: note: {note}")),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A volume whose axes are a mirror image of the world's (here FreeSurfer's LIA, in an NRRD whose
/// space is RAS) is shown as its world lies: the window shows what the headless renderer draws
/// with the mirrored camera (`isogrid render`'s, through the front door), which is not the
/// picture along the stored axes (the surface is lopsided, so its mirror image differs).
#[test]
fn scripted_window_shows_a_mirrored_volume_as_its_world_lies() {
    let Some(xvfb) = xvfb_run() else { return };
    let Some(renderer) = renderer() else { return };
    let dir = temp_dir("lia");
    let input = dir.join("lopsided_lia.nrrd");
    let n = 32usize;
    let field: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let p = [i % n, i / n % n, i / (n * n)].map(|c| c as f32);
            let distance = |c: [f32; 3]| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f32>().sqrt();
            (9.0 - distance([14.0, 14.0, 15.0])).max(4.5 - distance([25.0, 21.0, 15.0]))
        })
        .collect();
    let geometry = isogrid::Geometry {
        direction: [[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
        frame: isogrid::WorldFrame::Ras,
        ..isogrid::Geometry::new([n; 3])
    };
    let volume = isogrid::Volume::with_geometry(geometry, VolumeData::F32(field)).unwrap();
    isogrid_io::write_nrrd(&input, &volume).unwrap();
    let size = [160, 120];
    let shot = dir.join("window.png");
    let stdout = scripted_view(
        &xvfb,
        &[input.to_str().unwrap(), "--iso-normalized", "0.5"],
        size,
        &shot,
    );
    assert!(!stdout.contains("mirror image"), "{stdout}");
    assert_window_shows(&renderer, &volume, &shot, &stdout, size);
    // The stored axes' picture is another one.
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    assert!(grid.info().mirrors_world());
    let gpu = renderer.upload_grid(&grid).unwrap();
    let (lo, hi) = grid.info().world_bounds();
    let camera = Camera::preset(2, lo, hi, size[0], size[1]).unwrap();
    let [plain, mirrored] = [false, true].map(|m| {
        renderer
            .render_with(
                Scene::Grid(&gpu),
                &camera.with_mirror(m),
                Mode::Cgc,
                &RenderOptions::default(),
            )
            .unwrap()
    });
    let pixels = (size[0] * size[1]) as usize;
    let differ = (0..pixels)
        .filter(|&i| {
            plain.is_hit(i) != mirrored.is_hit(i)
                || (0..3).any(|c| plain.rgba8[4 * i + c].abs_diff(mirrored.rgba8[4 * i + c]) > 8)
        })
        .count();
    assert!(differ * 10 > pixels, "{differ} of {pixels} pixels differ");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A volume coloured by a second one (`--color-by`, `--cmap`) shows, in the window, what the
/// headless renderer draws with the same colour map over the attribute's range; and the picture is
/// in colour, not grey.
#[test]
fn scripted_window_shows_the_coloured_headless_image() {
    let Some(xvfb) = xvfb_run() else { return };
    let Some(renderer) = renderer() else { return };
    let dir = temp_dir("coloured");
    let volume = generate(Field::Torus, 40, 1);
    let attribute = generate(Field::Gyroid, 40, 1);
    let (input, colour_by) = (dir.join("torus.nrrd"), dir.join("gyroid.nrrd"));
    isogrid_io::write_nrrd(&input, &volume).unwrap();
    isogrid_io::write_nrrd(&colour_by, &attribute).unwrap();
    let shot = dir.join("window.png");
    let (w, h) = (320u32, 240u32);
    let stdout = scripted_view(
        &xvfb,
        &[
            input.to_str().unwrap(),
            "--iso-normalized",
            "0.5",
            "--color-by",
            colour_by.to_str().unwrap(),
            "--cmap",
            "magma",
        ],
        [w, h],
        &shot,
    );
    assert_window_shows_colored(
        &renderer,
        &volume,
        Some((&attribute, ColorMap::Magma)),
        &shot,
        &stdout,
        [w, h],
    );
    // Magma runs from black through purple and red to pale yellow: hit pixels differ in hue.
    let [x, y, _, _] = image_region(&stdout).unwrap();
    let (sw, _, pixels) = read_png(&shot);
    let (mut hits, mut chromatic) = (0, 0);
    for py in 0..h {
        for px in 0..w {
            let s = (((y + py) * sw + x + px) * 3) as usize;
            let p = &pixels[s..s + 3];
            if !is_background(p) {
                hits += 1;
                let (max, min) = (p.iter().max().unwrap(), p.iter().min().unwrap());
                chromatic += (max - min > 40) as u32;
            }
        }
    }
    assert!(
        chromatic * 2 > hits,
        "{chromatic} of {hits} hit pixels in colour"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A label volume opened with `--labels all --hide 4`: the window shows what `isogrid render
/// --hide 4` draws of the same labels (through the render front door, the GPU path `render` takes
/// for this request), and not what it draws with every label shown, in CGC mode and in MC mode
/// (the labels' meshes, made from their cells without the volume), and coloured by a second
/// volume (`--color-by`) in CGC mode. On 3³ cubes of 11 touching labels, so hiding label 4
/// reveals its neighbours' faces.
#[test]
fn scripted_window_hides_labels_as_render_hide_does() {
    let Some(xvfb) = xvfb_run() else { return };
    if renderer().is_none() {
        return;
    }
    let dir = temp_dir("labels");
    let volume = isogrid::generate::labelled_cubes(24);
    let input = dir.join("cubes.nrrd");
    isogrid_io::write_nrrd(&input, &volume).unwrap();
    let gyroid = generate(Field::Gyroid, 24, 1);
    let colour_by = dir.join("gyroid.nrrd");
    isogrid_io::write_nrrd(&colour_by, &gyroid).unwrap();
    for (mode, attribute) in [
        (Mode::Cgc, None),
        (Mode::Mc, None),
        (Mode::Cgc, Some((colour_by.as_path(), &gyroid))),
    ] {
        window_hides_labels_as_render_does(&xvfb, &dir, &input, &volume, mode, attribute);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// [`scripted_window_hides_labels_as_render_hide_does`] in `mode`, coloured by `attribute` (its
/// file and samples) when given.
fn window_hides_labels_as_render_does(
    xvfb: &Path,
    dir: &Path,
    input: &Path,
    volume: &isogrid::Volume,
    mode: Mode,
    attribute: Option<(&Path, &isogrid::Volume)>,
) {
    let shot = dir.join(format!("window-{}.png", mode.name()));
    let (w, h) = (320u32, 240u32);
    let mut args = vec![
        input.to_str().unwrap(),
        "--labels",
        "all",
        "--hide",
        "4",
        "--mode",
        mode.name(),
    ];
    if let Some((path, _)) = attribute {
        args.extend(["--color-by", path.to_str().unwrap()]);
    }
    let stdout = scripted_view(xvfb, &args, [w, h], &shot);

    let mut grid = isogrid::extract_labels(
        &volume.view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap();
    if let Some((_, samples)) = attribute {
        let values =
            sample_attribute_in_memory(&grid, &samples.view(), "a", AttributePrecision::Code16)
                .unwrap();
        grid = grid.with_attribute(values).unwrap();
    }
    let ctx = isogrid_render::RenderContext::new();
    let render = |hide: Option<&str>| {
        let request = isogrid_render::RenderRequest::new(isogrid_render::RequestParts {
            mode,
            backend: isogrid_render::Backend::Gpu,
            camera: isogrid_render::CameraSpec::View(2),
            size: (w, h),
            frames: 3,
            hide: hide.map(|v| isogrid::LabelSelection::parse(v).unwrap()),
            color: attribute.map(|_| isogrid_render::ColorSpec {
                map: ColorMap::Viridis,
                clim: None,
            }),
            ..Default::default()
        })
        .unwrap();
        let placement = isogrid_render::Placement::Gpu;
        isogrid_render::render(&ctx, &request, placement, &grid, None, &Default::default())
            .unwrap()
            .rgb8
    };
    let (hidden, all) = (render(Some("4")), render(None));

    let [x, y, rw, rh] = image_region(&stdout).unwrap_or_else(|| panic!("no image: {stdout}"));
    assert_eq!(
        [rw, rh],
        [w, h],
        "the image is shown at one texel per pixel"
    );
    let (sw, _, pixels) = read_png(&shot);
    let close = |a: &[u8], b: &[u8]| (0..3).all(|c| (a[c] as i32 - b[c] as i32).abs() <= 6);
    let (mut same, mut changed, mut same_where_changed) = (0u64, 0u64, 0u64);
    for py in 0..h {
        for px in 0..w {
            let s = (((y + py) * sw + x + px) * 3) as usize;
            let window = &pixels[s..s + 3];
            let i = 3 * (py * w + px) as usize;
            let (hid, shown) = (&hidden[i..i + 3], &all[i..i + 3]);
            same += close(window, hid) as u64;
            if !close(hid, shown) {
                changed += 1;
                same_where_changed += close(window, hid) as u64;
            }
        }
    }
    let total = (w * h) as u64;
    let coloured = if attribute.is_some() {
        ", coloured"
    } else {
        ""
    };
    eprintln!(
        "{mode}{coloured}: window = render --hide 4 on {same}/{total} pixels; on \
         {same_where_changed}/{changed} of those hiding changes"
    );
    assert!(
        changed > total / 100,
        "hiding label 4 changed {changed} pixels"
    );
    assert!(same * 100 >= total * 98, "{same} of {total} pixels agree");
    assert!(
        same_where_changed * 100 >= changed * 95,
        "{mode}: {same_where_changed} of the {changed} pixels hiding changes agree"
    );
}

/// The rendered image region of screenshot `shot` (located from the viewer's `stdout`) shows what
/// the headless renderer draws for `volume` at normalised isovalue 0.5, camera view 2, `[w, h]`
/// pixels, CGC mode.
fn assert_window_shows(
    renderer: &Renderer,
    volume: &isogrid::Volume,
    shot: &Path,
    stdout: &str,
    size: [u32; 2],
) {
    assert_window_shows_colored(renderer, volume, None, shot, stdout, size);
}

/// As [`assert_window_shows`], the surface coloured by `attribute` (a volume on the same grid,
/// 16-bit values) through `map` over the attribute's range, when given.
fn assert_window_shows_colored(
    renderer: &Renderer,
    volume: &isogrid::Volume,
    attribute: Option<(&isogrid::Volume, ColorMap)>,
    shot: &Path,
    stdout: &str,
    [w, h]: [u32; 2],
) {
    let [x, y, rw, rh] =
        image_region(stdout).unwrap_or_else(|| panic!("no image region in the output: {stdout}"));
    assert_eq!(
        [rw, rh],
        [w, h],
        "the image is shown at one texel per pixel"
    );

    let (sw, sh, pixels) = read_png(shot);
    assert!(
        x + w <= sw && y + h <= sh,
        "{x},{y} {w}x{h} outside {sw}x{sh}"
    );

    // The same camera, headless.
    let mut grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let mut options = RenderOptions {
        frames: 3,
        ..Default::default()
    };
    if let Some((attribute, map)) = attribute {
        let values =
            sample_attribute_in_memory(&grid, &attribute.view(), "a", AttributePrecision::Code16)
                .unwrap();
        let clim = Coloring::default_clim(values.info().range);
        options.coloring = Some(Coloring::new(map, clim).unwrap());
        grid = grid.with_attribute(values).unwrap();
    }
    let gpu = renderer.upload_grid(&grid).unwrap();
    // Mirrored where the grid's axes mirror its world, as the front door's cameras are.
    let (lo, hi) = grid.info().world_bounds();
    let camera = Camera::preset(2, lo, hi, w, h)
        .unwrap()
        .with_mirror(grid.info().mirrors_world());
    let frame = renderer
        .render_with(Scene::Grid(&gpu), &camera, Mode::Cgc, &options)
        .unwrap();

    let (mut agree, mut hits, mut colour_diff, mut both) = (0u64, 0u64, 0u64, 0u64);
    for py in 0..h {
        for px in 0..w {
            let s = (((y + py) * sw + x + px) * 3) as usize;
            let window = &pixels[s..s + 3];
            let i = (py * w + px) as usize;
            let headless_hit = frame.is_hit(i);
            let window_hit = !is_background(window);
            hits += headless_hit as u64;
            agree += (headless_hit == window_hit) as u64;
            if headless_hit && window_hit {
                both += 1;
                colour_diff += (0..3)
                    .map(|c| (window[c] as i64 - frame.rgba8[4 * i + c] as i64).unsigned_abs())
                    .sum::<u64>();
            }
        }
    }
    let total = (w * h) as u64;
    // A test that cannot fail would pass on an empty or full image: the torus covers part of it.
    assert!(
        hits > total / 20 && hits < total * 9 / 10,
        "{hits} of {total} pixels hit"
    );
    let agreement = agree as f64 / total as f64;
    assert!(
        agreement >= 0.98,
        "hit/miss agree on {:.2} % of pixels",
        agreement * 100.0
    );
    let mean_diff = colour_diff as f64 / (3 * both.max(1)) as f64;
    assert!(
        mean_diff < 4.0,
        "mean colour difference {mean_diff:.2} on shared hits"
    );
}

/// Runs a scripted view that must fail: non-zero exit, the last stderr line names `mention`.
fn view_fails(xvfb: &Path, args: &[&str], mention: &str) {
    let out = isogrid_in_xvfb(xvfb, args, Duration::from_secs(120));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} should fail: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?} panicked: {stderr}");
    // xvfb-run's own complaints come after the viewer's last line; on CI it once reported
    // "problem while cleaning up temporary directory" there.
    let last = stderr
        .trim_end()
        .lines()
        .rfind(|l| !l.starts_with("xvfb-run:"))
        .unwrap_or_default();
    assert!(last.starts_with("isogrid: error:"), "{args:?}: {stderr}");
    assert!(
        last.contains(mention),
        "{args:?}: {last:?} should mention {mention}"
    );
}

#[test]
fn scripted_window_reports_bad_inputs() {
    let Some(xvfb) = xvfb_run() else { return };
    if renderer().is_none() {
        return;
    }
    let dir = temp_dir("bad");
    let missing = dir.join("missing.nrrd");
    view_fails(
        &xvfb,
        &["view", missing.to_str().unwrap(), "--frames", "1"],
        "missing.nrrd",
    );

    // A .cgc file holds no volume, so CR cannot be drawn, nor MC of a grid without labels.
    let volume = generate(Field::Sphere, 20, 1);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let cgc = dir.join("sphere.cgc");
    isogrid::cgc::write(&cgc, &grid).unwrap();
    for mode in ["cr", "mc"] {
        view_fails(
            &xvfb,
            &[
                "view",
                cgc.to_str().unwrap(),
                "--mode",
                mode,
                "--frames",
                "1",
            ],
            "needs the original volume",
        );
    }
    // --show / --hide name labels of a label grid: a value it lacks, or a grid without labels.
    view_fails(
        &xvfb,
        &[
            "view",
            cgc.to_str().unwrap(),
            "--hide",
            "3",
            "--frames",
            "1",
        ],
        "has none",
    );
    let cubes = dir.join("cubes.nrrd");
    isogrid_io::write_nrrd(&cubes, &isogrid::generate::labelled_cubes(12)).unwrap();
    view_fails(
        &xvfb,
        &[
            "view",
            cubes.to_str().unwrap(),
            "--labels",
            "all",
            "--show",
            "40",
            "--frames",
            "1",
        ],
        "no such label",
    );
    // CR samples the label values themselves, which are no surface.
    view_fails(
        &xvfb,
        &[
            "view",
            cubes.to_str().unwrap(),
            "--labels",
            "all",
            "--mode",
            "cr",
            "--frames",
            "1",
        ],
        "a label volume's are no surface",
    );
    // A float volume is no label volume.
    let float = isogrid::Volume::new(
        [8, 8, 8],
        isogrid::VolumeData::F32((0..512).map(|i| i as f32 * 0.37).collect()),
    )
    .unwrap();
    isogrid_io::write_nrrd(&dir.join("float.nrrd"), &float).unwrap();
    view_fails(
        &xvfb,
        &[
            "view",
            dir.join("float.nrrd").to_str().unwrap(),
            "--labels",
            "all",
            "--frames",
            "1",
        ],
        "float.nrrd",
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn arguments_are_checked_before_any_window_opens() {
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_isogrid"))
            .args(args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap()
    };
    for (args, mention) in [
        (&["view", "--frames", "2"][..], "needs an INPUT"),
        (&["view", "x.nrrd", "--size", "0x10"], "size must be WxH"),
        (
            &["view", "x.nrrd", "--iso-normalized", "1.5"],
            "outside [0, 1]",
        ),
        (&["view", "x.nrrd", "--mode", "wireframe"], "wireframe"),
        (&["view", "x.nrrd", "--screenshot", "a.png"], "--frames"),
        (&["view", "x.nrrd", "--smooth", "1"], "--labels"),
        (&["view", "x.cgc", "--labels", "all"], "is a .cgc file"),
        // "1-x" could be a label's name ("3rd-Ventricle" is one); an empty part cannot.
        (
            &["view", "x.nrrd", "--labels", "1,,2"],
            "is not a whole number or a range",
        ),
    ] {
        let out = run(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(
            stderr.contains(mention),
            "{args:?}: {stderr} should mention {mention}"
        );
    }
}

/// Pixels of the image region in pure error red (egui's `error_fg_color`, text of an error
/// drawn where the image would be); the isosurface's shading never comes close to it.
fn error_red_pixels(shot: &Path, stdout: &str) -> usize {
    let [x, y, w, h] =
        image_region(stdout).unwrap_or_else(|| panic!("no image region in the output: {stdout}"));
    let (sw, sh, pixels) = read_png(shot);
    assert!(x + w <= sw && y + h <= sh);
    (y..y + h)
        .flat_map(|py| (x..x + w).map(move |px| ((py * sw + px) * 3) as usize))
        .filter(|&s| pixels[s] >= 200 && pixels[s + 1] <= 60 && pixels[s + 2] <= 60)
        .count()
}

#[test]
fn a_volume_dropped_on_the_window_replaces_the_open_one() {
    let Some(xvfb) = xvfb_run() else { return };
    let Some(helper) = xdnd_helper() else { return };
    let Some(renderer) = renderer() else { return };
    let dir = temp_dir("drop");
    let first = dir.join("torus.nrrd");
    isogrid_io::write_nrrd(&first, &generate(Field::Torus, 32, 1)).unwrap();
    // A file name that needs percent-encoding in the URI list.
    let dropped = dir.join("dropped sphere.nrrd");
    let sphere = generate(Field::Sphere, 32, 1);
    isogrid_io::write_nrrd(&dropped, &sphere).unwrap();
    let shot = dir.join("window.png");
    let (w, h) = (240u32, 180u32);
    let out = isogrid_in_xvfb_with_drop(
        &xvfb,
        &helper,
        &dropped,
        &[
            "view",
            first.to_str().unwrap(),
            "--size",
            &format!("{w}x{h}"),
            "--frames",
            "2",
            "--screenshot",
            shot.to_str().unwrap(),
            "--wait-for-drop",
        ],
        Duration::from_secs(240),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "view failed: {stderr}\n{stdout}");
    assert!(
        stdout.contains(&format!("dropped {}", dropped.display())),
        "the viewer did not get the dropped file: {stdout}"
    );
    assert_window_shows(&renderer, &sphere, &shot, &stdout, [w, h]);
    // The control for the error test below: an image has no error text.
    assert_eq!(error_red_pixels(&shot, &stdout), 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_corrupt_file_dropped_on_the_window_shows_its_error_without_ending_the_viewer() {
    let Some(xvfb) = xvfb_run() else { return };
    let Some(helper) = xdnd_helper() else { return };
    if renderer().is_none() {
        return;
    }
    let dir = temp_dir("drop-corrupt");
    let first = dir.join("torus.nrrd");
    let volume = generate(Field::Torus, 32, 1);
    isogrid_io::write_nrrd(&first, &volume).unwrap();
    // A .cgc file cut off in the middle of its cells.
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let whole = dir.join("whole.cgc");
    isogrid::cgc::write(&whole, &grid).unwrap();
    let bytes = std::fs::read(&whole).unwrap();
    let corrupt = dir.join("cut.cgc");
    std::fs::write(&corrupt, &bytes[..bytes.len() / 2]).unwrap();
    let shot = dir.join("window.png");
    let out = isogrid_in_xvfb_with_drop(
        &xvfb,
        &helper,
        &corrupt,
        &[
            "view",
            first.to_str().unwrap(),
            "--size",
            "240x180",
            "--frames",
            "1",
            "--screenshot",
            shot.to_str().unwrap(),
            "--wait-for-drop",
        ],
        Duration::from_secs(240),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "a bad dropped file must not end the viewer: {stderr}\n{stdout}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("cut.cgc")).collect();
    assert_eq!(errors.len(), 1, "one error line for the file: {stderr}");
    assert!(
        errors[0].starts_with(&format!("isogrid view: {}: ", corrupt.display())),
        "{errors:?}"
    );
    assert!(
        stdout.contains("showed why the dropped file cannot be opened"),
        "{stdout}"
    );
    let red = error_red_pixels(&shot, &stdout);
    assert!(
        red >= 20,
        "the error is not shown in the image area ({red} red pixels)"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

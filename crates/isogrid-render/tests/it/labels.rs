//! Label grids through the front door: the label AOV of every backend and mode against an
//! independent reference, a ray march through the label volume itself (not the grid), and
//! `show` / `hide` changing exactly the pixels that reference says.

use isogrid::generate::labelled_ball;
use isogrid::{extract_labels, CellGrid, LabelOptions, LabelSelection, Progress, Volume};
use isogrid_render::{
    render, Aov, Backend, CameraSpec, CellRaster, Mode, Placement, Primary, RenderContext,
    RenderRequest, RequestParts,
};

const MISS: u64 = u64::MAX;
const SIZE: (u32, u32) = (64, 48);

/// The labelled ball (three labels side by side along x, touching on two planes) and its grid.
fn ball() -> (Volume, CellGrid) {
    let volume = labelled_ball(24);
    let grid = extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    (volume, grid)
}

/// The label each pixel's centre ray meets first, by marching the label volume: steps of 1/50
/// voxel, and at each point the trilinear interpolant of every shown label's indicator (1 on its
/// samples, 0 elsewhere); the first label to reach ½ (the surface the extraction stores) is hit.
fn march(volume: &Volume, camera: &isogrid::Camera, shown: impl Fn(u64) -> bool) -> Vec<u64> {
    let [nx, ny, nz] = volume.dims();
    let view = volume.view();
    let label = |i: usize, j: usize, k: usize| view.get(i, j, k) as u64;
    let hi = [nx, ny, nz].map(|n| (n - 1) as f64);
    let mut out = Vec::new();
    for y in 0..camera.height {
        for x in 0..camera.width {
            let ray = camera.ray(x, y);
            // The ray's span in the box of samples.
            let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
            for a in 0..3 {
                let inv = 1.0 / ray.direction[a];
                let (u, v) = ((0.0 - ray.origin[a]) * inv, (hi[a] - ray.origin[a]) * inv);
                t0 = t0.max(u.min(v));
                t1 = t1.min(u.max(v));
            }
            let mut hit = MISS;
            let mut t = t0;
            while t <= t1 && hit == MISS {
                let p = [0, 1, 2].map(|a| (ray.origin[a] + t * ray.direction[a]).clamp(0.0, hi[a]));
                let c = [0, 1, 2].map(|a| (p[a].floor() as usize).min([nx, ny, nz][a] - 2));
                let f = [0, 1, 2].map(|a| p[a] - c[a] as f64);
                let mut best = 0.5;
                for corner in 0..8 {
                    let l = label(
                        c[0] + (corner & 1),
                        c[1] + (corner >> 1 & 1),
                        c[2] + (corner >> 2),
                    );
                    if !shown(l) {
                        continue;
                    }
                    let mut w = 0.0;
                    for k in 0..8 {
                        let q = [k & 1, k >> 1 & 1, k >> 2];
                        if label(c[0] + q[0], c[1] + q[1], c[2] + q[2]) == l {
                            w += (0..3)
                                .map(|a| if q[a] == 1 { f[a] } else { 1.0 - f[a] })
                                .product::<f64>();
                        }
                    }
                    if w >= best {
                        best = w;
                        hit = l;
                    }
                }
                t += 0.02;
            }
            out.push(hit);
        }
    }
    out
}

/// Pixels whose reference label equals that of their four neighbours (not on a silhouette or a
/// boundary between labels, where a pixel-centre ray may fall either way).
fn interior(reference: &[u64]) -> Vec<bool> {
    interior_of(reference, SIZE.0 as usize, SIZE.1 as usize)
}

/// [`interior`] of a `w` × `h` image.
fn interior_of(reference: &[u64], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && [i - 1, i + 1, i - w, i + w]
                    .iter()
                    .all(|&j| reference[j] == reference[i])
        })
        .collect()
}

fn request(
    mode: Mode,
    backend: Backend,
    primary: Option<Primary>,
    raster: CellRaster,
    hide: Option<&str>,
) -> RenderRequest {
    RenderRequest::new(RequestParts {
        mode,
        backend,
        primary,
        cell_raster: raster,
        camera: CameraSpec::View(2),
        size: SIZE,
        samples: 1,
        aovs: vec![Aov::Label],
        hide: hide.map(|h| LabelSelection::parse(h).unwrap()),
        ..RequestParts::default()
    })
    .unwrap()
}

/// Every backend and mode: the label AOV agrees with the march on ≥ 99 % of interior pixels,
/// with all labels and with the middle label hidden; hiding it changes the pixels the march
/// says it shows (there the labels beside it show their own surfaces, seen from its side) and
/// no interior pixel else.
#[test]
fn label_aov_matches_a_march_of_the_label_volume_and_hiding_changes_what_it_says() {
    let (volume, grid) = ball();
    let (lo, hi) = grid.info().world_bounds();
    let camera = isogrid::Camera::preset(2, lo, hi, SIZE.0, SIZE.1).unwrap();
    let all = march(&volume, &camera, |l| l != 0);
    let hidden = march(&volume, &camera, |l| l != 0 && l != 2);
    let (inside_all, inside_hidden) = (interior(&all), interior(&hidden));
    // The middle label covers pixels, and hiding it shows the others' faces there.
    let exposed = (0..all.len())
        .filter(|&i| all[i] == 2 && (hidden[i] == 1 || hidden[i] == 3))
        .count();
    assert!(
        exposed > 50,
        "only {exposed} pixels show a face that hiding label 2 exposes"
    );

    let ctx = RenderContext::new();
    let gpu = ctx.adapter().is_some();
    if !gpu {
        eprintln!("GPU cases skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    }
    let mut cases = vec![
        ("cpu cgc", Mode::Cgc, Backend::Cpu, None, CellRaster::Auto),
        (
            "cpu pathtrace",
            Mode::PathTrace,
            Backend::Cpu,
            None,
            CellRaster::Auto,
        ),
    ];
    if gpu {
        cases.extend([
            (
                "gpu cgc compute",
                Mode::Cgc,
                Backend::Gpu,
                None,
                CellRaster::Compute,
            ),
            (
                "gpu cgc hardware",
                Mode::Cgc,
                Backend::Gpu,
                None,
                CellRaster::Hardware,
            ),
            (
                "gpu cgc-noewa",
                Mode::CgcNoEwa,
                Backend::Gpu,
                None,
                CellRaster::Auto,
            ),
            (
                "gpu pathtrace raster",
                Mode::PathTrace,
                Backend::Gpu,
                Some(Primary::Raster),
                CellRaster::Auto,
            ),
            (
                "gpu pathtrace traced",
                Mode::PathTrace,
                Backend::Gpu,
                Some(Primary::Traced),
                CellRaster::Auto,
            ),
            // The Marching Cubes meshes of the labels' stored cells, no volume given.
            ("gpu mc", Mode::Mc, Backend::Gpu, None, CellRaster::Auto),
        ]);
    }
    for (name, mode, backend, primary, raster) in cases {
        let placement = match backend {
            Backend::Cpu => Placement::Cpu,
            _ => Placement::Gpu,
        };
        let draw = |hide: Option<&str>| {
            let request = request(mode, backend, primary, raster, hide);
            let out = render(&ctx, &request, placement, &grid, None, &Progress::new()).unwrap();
            out.label.expect("a label grid's render has the label AOV")
        };
        let (got_all, got_hidden) = (draw(None), draw(Some("2")));
        for (what, got, want, inside) in [
            ("all labels", &got_all, &all, &inside_all),
            ("label 2 hidden", &got_hidden, &hidden, &inside_hidden),
        ] {
            let n = inside.iter().filter(|&&i| i).count();
            let agree = (0..got.len())
                .filter(|&i| inside[i] && got[i] == want[i])
                .count();
            eprintln!(
                "{name}, {what}: label agrees with the march on {agree} of {n} interior pixels"
            );
            assert!(
                agree as f64 >= 0.99 * n as f64,
                "{name}, {what}: {agree} of {n}"
            );
        }
        // Hiding label 2 changes exactly the pixels the march says: those it showed.
        let (mut changed_elsewhere, mut kept_where_hidden, mut judged) = (0, 0, 0);
        for i in 0..all.len() {
            if !(inside_all[i] && inside_hidden[i]) {
                continue;
            }
            judged += 1;
            let changed = got_all[i] != got_hidden[i];
            if all[i] == 2 {
                kept_where_hidden += (!changed) as usize;
            } else {
                changed_elsewhere += changed as usize;
            }
            assert_ne!(
                got_hidden[i], 2,
                "{name}: hidden label 2 drawn at pixel {i}"
            );
        }
        eprintln!(
            "{name}: hiding label 2 left {kept_where_hidden} of its pixels and changed {changed_elsewhere} others, of {judged}"
        );
        assert!(
            (kept_where_hidden + changed_elsewhere) as f64 <= 0.01 * judged as f64,
            "{name}: {kept_where_hidden} + {changed_elsewhere} of {judged}"
        );
    }
}

/// Two labels touching on the plane x = 11.5 (label 1 below, 2 above) inside a box of 0.
fn two_labels() -> CellGrid {
    let n = 24usize;
    let samples: Vec<u8> = (0..n * n * n)
        .map(|i| {
            let p = [i % n, i / n % n, i / (n * n)];
            if p.iter().any(|&c| !(2..n - 2).contains(&c)) {
                0
            } else if p[0] < 12 {
                1
            } else {
                2
            }
        })
        .collect();
    let volume = Volume::new([n; 3], isogrid::VolumeData::U8(samples)).unwrap();
    extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap()
}

/// Where two labels touch both surfaces coincide. Seen from inside label 1, or with label 1
/// hidden from its side, the shared boundary shows label 2 (the surface the rays enter: the
/// tracers' tie rule, the rasters' back-face depth bias) on every backend, without speckle
/// (pixels whose label differs from all four neighbours); before the rule the compute and
/// hardware rasters speckled 59 and 90 of these 1728 pixels. MC mode draws the labels' meshes
/// under the same rule.
#[test]
fn a_shared_boundary_shows_the_label_beyond_it_without_speckle() {
    let grid = two_labels();
    let ctx = RenderContext::new();
    let mut cases = vec![("cpu cgc", Mode::Cgc, Backend::Cpu, None, CellRaster::Auto)];
    if ctx.adapter().is_some() {
        cases.extend([
            (
                "gpu cgc compute",
                Mode::Cgc,
                Backend::Gpu,
                None,
                CellRaster::Compute,
            ),
            (
                "gpu cgc hardware",
                Mode::Cgc,
                Backend::Gpu,
                None,
                CellRaster::Hardware,
            ),
            (
                "gpu pathtrace traced",
                Mode::PathTrace,
                Backend::Gpu,
                Some(Primary::Traced),
                CellRaster::Auto,
            ),
            // The labels' meshes share the boundary's vertices: their back-face depth rule.
            ("gpu mc", Mode::Mc, Backend::Gpu, None, CellRaster::Auto),
        ]);
    }
    let (w, h) = (48usize, 36usize);
    let mut results: Vec<(&str, Option<&str>, usize, usize)> = Vec::new();
    for (name, mode, backend, primary, raster) in cases {
        for hide in [None, Some("1")] {
            let request = RenderRequest::new(RequestParts {
                mode,
                backend,
                primary,
                cell_raster: raster,
                // Inside label 1, looking along +x at the boundary, which fills the view.
                camera: CameraSpec::LookAt {
                    eye: [6.0, 11.3, 11.6],
                    target: [12.0, 11.3, 11.6],
                    up: [0.0, 1.0, 0.0],
                    fovy_degrees: 60.0,
                },
                size: (w as u32, h as u32),
                samples: 1,
                aovs: vec![Aov::Label],
                hide: hide.map(|h| LabelSelection::parse(h).unwrap()),
                ..RequestParts::default()
            })
            .unwrap();
            let placement = match backend {
                Backend::Cpu => Placement::Cpu,
                _ => Placement::Gpu,
            };
            let out = render(&ctx, &request, placement, &grid, None, &Progress::new()).unwrap();
            let label = out.label.unwrap();
            let beyond = label.iter().filter(|&&l| l == 2).count();
            let speckle = (0..w * h)
                .filter(|&i| {
                    let (x, y) = (i % w, i / w);
                    x > 0
                        && y > 0
                        && x + 1 < w
                        && y + 1 < h
                        && [i - 1, i + 1, i - w, i + w]
                            .iter()
                            .all(|&j| label[j] != label[i])
                })
                .count();
            eprintln!(
                "{name}, hide {hide:?}: {beyond} of {} pixels show label 2, {speckle} speckled",
                w * h
            );
            results.push((name, hide, beyond, speckle));
        }
    }
    for (name, hide, beyond, speckle) in results {
        // The boundary square spans ±9.5 around the view axis at distance 5.5: the whole view.
        assert!(
            beyond as f64 >= 0.99 * (w * h) as f64,
            "{name} hide {hide:?}: {beyond}"
        );
        assert_eq!(speckle, 0, "{name} hide {hide:?}");
    }
}

/// Voronoi cells of 40 seeds in 40³ (labels touching everywhere, on slanted boundaries whose
/// Marching Cubes triangulations differ from label to label) at `spacing`.
fn voronoi(spacing: [f64; 3]) -> CellGrid {
    let n = 40usize;
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as f64 / (1u64 << 31) as f64 * n as f64
    };
    let seeds: Vec<[f64; 3]> = (0..40).map(|_| [next(), next(), next()]).collect();
    let samples: Vec<u16> = (0..n * n * n)
        .map(|i| {
            let p = [i % n, i / n % n, i / (n * n)].map(|c| c as f64);
            let d = |s: &[f64; 3]| (0..3).map(|a| (p[a] - s[a]).powi(2)).sum::<f64>();
            (0..seeds.len())
                .min_by(|&a, &b| d(&seeds[a]).total_cmp(&d(&seeds[b])))
                .unwrap() as u16
                + 1
        })
        .collect();
    let volume = Volume::new([n; 3], isogrid::VolumeData::U16(samples))
        .unwrap()
        .with_spacing(spacing)
        .unwrap();
    extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap()
}

/// Where labels touch on slanted boundaries, MC shows the label the cell raster shows (the face
/// the ray enters): through the open faces of a volume of touching labels, on ≥ 97 % of the
/// pixels inside a label of the cell raster's (this small image's edges miss the rest), whatever
/// the spacing: the back-face slack is half the grid's smallest spacing in world units (at
/// spacing 10 a slack of half a world unit matched on 92 % only).
#[test]
fn mc_shows_the_label_beyond_a_slanted_boundary_at_any_spacing() {
    let ctx = RenderContext::new();
    if ctx.adapter().is_none() {
        eprintln!("skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
        return;
    }
    let (w, h) = (160usize, 120usize);
    for spacing in [[1.0, 1.0, 1.0], [10.0, 10.0, 15.0], [0.1, 0.1, 0.1]] {
        let grid = voronoi(spacing);
        let draw = |mode| {
            let request = RenderRequest::new(RequestParts {
                mode,
                backend: Backend::Gpu,
                camera: CameraSpec::View(2),
                size: (w as u32, h as u32),
                aovs: vec![Aov::Label],
                ..RequestParts::default()
            })
            .unwrap();
            render(
                &ctx,
                &request,
                Placement::Gpu,
                &grid,
                None,
                &Progress::new(),
            )
            .unwrap()
            .label
            .unwrap()
        };
        let (cells, mesh) = (draw(Mode::Cgc), draw(Mode::Mc));
        let interior = interior_of(&cells, w, h);
        let inside: Vec<usize> = (0..w * h)
            .filter(|&i| cells[i] != MISS && interior[i])
            .collect();
        let agree = inside.iter().filter(|&&i| mesh[i] == cells[i]).count();
        eprintln!(
            "spacing {spacing:?}: mc = cells on {agree} of {} pixels",
            inside.len()
        );
        assert!(inside.len() > w * h / 10);
        assert!(
            agree as f64 >= 0.97 * inside.len() as f64,
            "spacing {spacing:?}: {agree} of {}",
            inside.len()
        );
    }
}

/// MC mode colours each label as the cell modes do: over each label's interior pixels (by the
/// label AOVs), the mean colour of the MC render points the same way in RGB as that of the cell
/// raster (the shading differs: face normals against EWA normals), and the labels' colours differ.
#[test]
fn mc_draws_each_label_in_its_colour() {
    let (_, grid) = ball();
    let ctx = RenderContext::new();
    if ctx.adapter().is_none() {
        eprintln!("skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
        return;
    }
    let draw = |mode| {
        let request = request(mode, Backend::Gpu, None, CellRaster::Auto, None);
        render(
            &ctx,
            &request,
            Placement::Gpu,
            &grid,
            None,
            &Progress::new(),
        )
        .unwrap()
    };
    let (mc, cells) = (draw(Mode::Mc), draw(Mode::Cgc));
    let (mc_label, cell_label) = (mc.label.unwrap(), cells.label.unwrap());
    // Each label's mean colour direction over the pixels inside its region in both renders.
    let direction = |rgb8: &[u8], label: &[u64], inside: &[bool], l: u64| {
        let mut sum = [0f64; 3];
        for i in (0..label.len()).filter(|&i| inside[i] && label[i] == l) {
            for c in 0..3 {
                sum[c] += rgb8[3 * i + c] as f64;
            }
        }
        let norm = sum.iter().map(|v| v * v).sum::<f64>().sqrt();
        sum.map(|v| v / norm)
    };
    let (mc_inside, cell_inside) = (interior(&mc_label), interior(&cell_label));
    let both: Vec<bool> = (0..mc_label.len())
        .map(|i| mc_inside[i] && cell_inside[i] && mc_label[i] == cell_label[i])
        .collect();
    let mut directions = Vec::new();
    for l in 1..=3u64 {
        let n = (0..both.len())
            .filter(|&i| both[i] && mc_label[i] == l)
            .count();
        if n < 30 {
            continue; // out of view, or a sliver
        }
        let (a, b) = (
            direction(&mc.rgb8, &mc_label, &both, l),
            direction(&cells.rgb8, &cell_label, &both, l),
        );
        let cos: f64 = (0..3).map(|c| a[c] * b[c]).sum();
        eprintln!("label {l}: {n} pixels, mc {a:.3?} cells {b:.3?}, cosine {cos:.4}");
        assert!(cos > 0.995, "label {l}: mc {a:?} against cells {b:?}");
        directions.push(a);
    }
    assert!(directions.len() >= 2, "{} labels in view", directions.len());
    for (i, a) in directions.iter().enumerate() {
        for b in &directions[i + 1..] {
            let cos: f64 = (0..3).map(|c| a[c] * b[c]).sum();
            assert!(cos < 0.99, "two labels look alike: {a:?} and {b:?}");
        }
    }
}

/// `backend: auto` places a label grid like any other grid and the render runs wherever it lands
/// (the GPU tracer once refused label grids, so auto on a hardware GPU failed for path tracing).
#[test]
fn auto_backend_renders_label_grids_in_every_mode_it_places() {
    let (_, grid) = ball();
    let ctx = RenderContext::new();
    for (mode, primary) in [
        (Mode::Cgc, None),
        (Mode::PathTrace, None),
        (Mode::PathTrace, Some(Primary::Traced)),
    ] {
        if primary.is_some() && ctx.adapter().is_none() {
            continue; // naming primary rays asks for a GPU
        }
        let request = request(mode, Backend::Auto, primary, CellRaster::Auto, Some("1"));
        let decision = ctx.decide(&request).unwrap();
        let out = render(
            &ctx,
            &request,
            decision.placement,
            &grid,
            None,
            &Progress::new(),
        )
        .unwrap_or_else(|e| panic!("{mode:?} {primary:?} on {:?}: {e}", decision.placement));
        let label = out.label.unwrap();
        assert!(label.iter().any(|&l| l == 2 || l == 3) && !label.contains(&1));
    }
}

//! Colour by an attribute in the GPU path tracer: every surface a path meets takes its colour as
//! albedo, as in the CPU path tracer, with raster or traced primaries and with the grid in one
//! page or in more page groups than one pass binds (the wavefront kernels).

use crate::{interior_pixels, new_renderer, renderer, scene};
use isogrid::colormap::{ColorMap, Coloring};
use isogrid::extract::attribute::sample_attribute_in_memory;
use isogrid::generate::Field;
use isogrid::{AttributePrecision, Camera, CellGrid, Volume, VolumeData};
use isogrid_gpu::{PathTraceOptions, PrimaryRays, Renderer};
use isogrid_trace::{Environment, RenderOptions, Shading};

/// `grid` (of an n³ volume) coloured by `value` of each sample's index (x, y, z), a volume on the
/// same grid coded at 16 bits, and turbo over the attribute's range.
pub fn coloured_by(
    grid: CellGrid,
    n: usize,
    value: impl Fn(usize, usize, usize) -> f32,
) -> (CellGrid, Coloring) {
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| value(i % n, i / n % n, i / (n * n)))
        .collect();
    let attribute = Volume::new([n; 3], VolumeData::F32(data)).unwrap();
    let values = sample_attribute_in_memory(
        &grid,
        &attribute.view(),
        "value",
        AttributePrecision::Code16,
    )
    .unwrap();
    let coloring =
        Coloring::new(ColorMap::Turbo, Coloring::default_clim(values.info().range)).unwrap();
    (grid.with_attribute(values).unwrap(), coloring)
}

/// A 32³ sphere coloured by its x index, and the colouring.
fn coloured_sphere() -> (CellGrid, Coloring) {
    let (_, grid) = scene(Field::Sphere, 32, None);
    coloured_by(grid, 32, |x, _, _| x as f32)
}

/// Mean linear radiance over `pixels`.
fn mean(pixels: &[usize], radiance: impl Fn(usize) -> [f32; 3]) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for &i in pixels {
        let r = radiance(i);
        for c in 0..3 {
            sum[c] += r[c] as f64;
        }
    }
    sum.map(|s| s / pixels.len() as f64)
}

fn gpu_path_trace(
    r: &Renderer,
    grid: &CellGrid,
    camera: &Camera,
    coloring: &Coloring,
    primary: PrimaryRays,
) -> isogrid_gpu::Frame {
    let gpu = r.upload_grid(grid).unwrap();
    r.path_trace(
        &gpu,
        camera,
        &PathTraceOptions {
            frames: 48,
            bounces: 2,
            primary,
            coloring: Some(coloring),
            ..Default::default()
        },
    )
    .unwrap()
}

/// The sphere's left and right thirds (low and high x: turbo's blue and red ends) have the CPU
/// path tracer's mean colour on the GPU, within 0.03 per channel, for raster and traced
/// primaries and for a grid split over more page groups than one pass binds.
#[test]
fn gpu_path_tracing_takes_each_surface_colour_as_its_albedo_like_the_cpu() {
    let Some(r) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    let (grid, coloring) = coloured_sphere();
    let size = 64u32;
    let camera = Camera {
        eye: [15.5, 15.5, 75.5],
        target: [15.5, 15.5, 15.5],
        up: [0.0, 1.0, 0.0],
        fovy_degrees: 40.0,
        width: size,
        height: size,
        mirrored: false,
    };
    let cpu = isogrid_trace::render(
        &grid,
        &camera,
        &RenderOptions {
            shading: Shading::PathTrace(isogrid_trace::PathTraceOptions {
                samples_per_pixel: 48,
                bounces: 2,
                environment: Environment::Sky,
                seed: 5,
                ..Default::default()
            }),
            coloring: Some(coloring.clone()),
            ..Default::default()
        },
    )
    .unwrap();
    // Split so that tracing needs the wavefront kernels (more than six pages).
    paged.set_page_bytes((grid.cells().len() / 12).max(256) as u64);
    assert!(paged.upload_grid(&grid).unwrap().page_count() > 6);
    let runs = [
        ("raster primaries", r, PrimaryRays::Raster),
        ("traced primaries", r, PrimaryRays::Traced),
        ("raster primaries, paged", &paged, PrimaryRays::Raster),
        ("traced primaries, paged", &paged, PrimaryRays::Traced),
    ];
    for (label, renderer, primary) in runs {
        let gpu = gpu_path_trace(renderer, &grid, &camera, &coloring, primary);
        let both = |i: usize| gpu.is_hit(i) && cpu.cluster[i] != u32::MAX;
        let inside = interior_pixels(size as usize, (size * size) as usize, both);
        let third = |lo: u32, hi: u32| -> Vec<usize> {
            let columns = lo * size / 3..hi * size / 3;
            inside
                .iter()
                .copied()
                .filter(|&i| columns.contains(&(i as u32 % size)))
                .collect()
        };
        for (side, pixels) in [("left", third(0, 1)), ("right", third(2, 3))] {
            assert!(pixels.len() > 50, "{label} {side}: {} pixels", pixels.len());
            let g = mean(&pixels, |i| gpu.linear[i]);
            let c = mean(&pixels, |i| cpu.radiance[i]);
            eprintln!("{label} {side}: GPU {g:.3?} CPU {c:.3?}");
            for ch in 0..3 {
                assert!(
                    (g[ch] - c[ch]).abs() <= 0.03,
                    "{label} {side} channel {ch}: GPU {g:.3?} vs CPU {c:.3?}"
                );
            }
        }
        // Turbo: blue on the left (low x), red on the right.
        let (left, right) = (
            mean(&third(0, 1), |i| gpu.linear[i]),
            mean(&third(2, 3), |i| gpu.linear[i]),
        );
        assert!(
            left[2] > left[0] && right[0] > right[2],
            "{label}: left {left:.3?}, right {right:.3?}"
        );
    }
}

/// The built-in ball of three labels side by side along x, as a label grid.
fn labelled_ball() -> CellGrid {
    isogrid::extract_labels(
        &isogrid::generate::labelled_ball(40).view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap()
}

/// Per label, the mean of `colour` over the pixels whose four neighbours show the same label
/// (no edge mixing), for labels with at least 30 such pixels.
fn label_means(
    grid: &CellGrid,
    (w, h): (usize, usize),
    cluster: impl Fn(usize) -> u32,
    colour: impl Fn(usize) -> [f64; 3],
) -> Vec<(usize, [f64; 3])> {
    let cluster_labels = grid.labels().unwrap().cluster_labels();
    let label_at = |i: usize| match cluster(i) {
        u32::MAX => None,
        c => Some(cluster_labels[c as usize] as usize),
    };
    let mut sums = vec![([0.0f64; 3], 0u32); grid.labels().unwrap().table().len()];
    for i in 0..w * h {
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            continue;
        }
        let Some(l) = label_at(i) else { continue };
        if [i - 1, i + 1, i - w, i + w]
            .iter()
            .any(|&j| label_at(j) != Some(l))
        {
            continue;
        }
        let c = colour(i);
        for k in 0..3 {
            sums[l].0[k] += c[k];
        }
        sums[l].1 += 1;
    }
    sums.iter()
        .enumerate()
        .filter(|(_, (_, n))| *n >= 30)
        .map(|(l, (s, n))| (l, s.map(|v| v / *n as f64)))
        .collect()
}

/// A label grid is drawn in its labels' colours on the GPU as on the CPU: the raster (Phong) gives
/// each label's pixels the CPU's hue.
#[test]
fn label_grids_are_drawn_in_their_label_colours_like_the_cpu() {
    let Some(r) = renderer() else { return };
    let grid = labelled_ball();
    let (w, h) = (128usize, 96usize);
    let (lo, hi) = grid.info().world_bounds();
    let camera = Camera::preset(2, lo, hi, w as u32, h as u32).unwrap();
    let gpu_grid = r.upload_grid(&grid).unwrap();
    // Phong: sRGB means within 3 levels.
    let gpu = r
        .render(
            isogrid_gpu::Scene::Grid(&gpu_grid),
            &camera,
            isogrid_gpu::Mode::Cgc,
            2,
        )
        .unwrap();
    let cpu = isogrid_trace::render(&grid, &camera, &RenderOptions::default()).unwrap();
    let g = label_means(
        &grid,
        (w, h),
        |i| gpu.cluster[i],
        |i| std::array::from_fn(|c| gpu.rgba8[4 * i + c] as f64),
    );
    let c = label_means(
        &grid,
        (w, h),
        |i| cpu.cluster[i],
        |i| std::array::from_fn(|k| cpu.rgb8[3 * i + k] as f64),
    );
    assert!(g.len() >= 2, "{} labels seen", g.len());
    // The colours' directions (shading brightness differs with the EWA normals): the same hue.
    let unit = |v: &[f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    };
    for ((gl, gm), (cl, cm)) in g.iter().zip(&c) {
        assert_eq!(gl, cl);
        let (a, b) = (unit(gm), unit(cm));
        let cos: f64 = (0..3).map(|k| a[k] * b[k]).sum();
        eprintln!("label {gl}: GPU {gm:.1?} CPU {cm:.1?} cos {cos:.5}");
        assert!(cos > 0.998, "label {gl}: GPU {gm:?} CPU {cm:?}");
    }
    // Path tracing: linear means within 0.03, with raster and traced primaries.
    let cpu_pt = isogrid_trace::render(
        &grid,
        &camera,
        &RenderOptions {
            shading: Shading::PathTrace(isogrid_trace::PathTraceOptions {
                samples_per_pixel: 32,
                bounces: 2,
                environment: Environment::Sky,
                seed: 3,
                ..Default::default()
            }),
            ..Default::default()
        },
    )
    .unwrap();
    let c = label_means(
        &grid,
        (w, h),
        |i| cpu_pt.cluster[i],
        |i| cpu_pt.radiance[i].map(|v| v as f64),
    );
    for primary in [PrimaryRays::Raster, PrimaryRays::Traced] {
        let gpu = r
            .path_trace(
                &gpu_grid,
                &camera,
                &PathTraceOptions {
                    frames: 32,
                    bounces: 2,
                    primary,
                    ..Default::default()
                },
            )
            .unwrap();
        let g = label_means(
            &grid,
            (w, h),
            |i| gpu.cluster[i],
            |i| gpu.linear[i].map(|v| v as f64),
        );
        assert_eq!(g.len(), c.len(), "{primary:?}: labels seen");
        for ((gl, gm), (cl, cm)) in g.iter().zip(&c) {
            assert_eq!(gl, cl);
            eprintln!("{primary:?} label {gl}: GPU {gm:.3?} CPU {cm:.3?}");
            assert!(
                (0..3).all(|k| (gm[k] - cm[k]).abs() <= 0.03),
                "{primary:?} label {gl}: GPU {gm:?} CPU {cm:?}"
            );
        }
    }
}

/// Label colours one storage binding cannot hold (4 B per cluster and 16 B per label) are refused
/// before anything is uploaded, in words that name the CPU tracer, for a grid and for a label
/// mesh; where they fit, the same uploads succeed.
#[test]
fn label_colours_past_one_binding_are_refused_in_plain_words() {
    let Some(mut r) = new_renderer() else { return };
    let grid = isogrid::extract_labels(
        &isogrid::generate::labelled_cubes(32).view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap();
    let labels = grid.labels().unwrap().table().len();
    let needed = 4 * (2 + grid.clusters() as u64) + 16 * (labels as u64 + 1);
    assert!(needed > 256, "{needed} bytes fit the smallest page");
    r.set_page_bytes(needed - 1);
    let e = r
        .upload_grid(&grid)
        .err()
        .expect("colours past the binding");
    let text = e.to_string();
    assert!(
        text.contains("label colours") && text.contains("--backend cpu"),
        "{text}"
    );
    r.set_page_bytes(needed);
    r.upload_grid(&grid).unwrap();
    // A label mesh: 4 B per label and 16 B per label.
    let (mesh, vertex_labels) = isogrid::mc::labelled_mesh(&grid).unwrap();
    let table = grid.labels().unwrap().table();
    let table = [table; 12].concat(); // enough labels to pass the smallest page
    let needed = 4 * (2 + table.len() as u64) + 16 * (table.len() as u64 + 1);
    r.set_page_bytes(needed - 1);
    let spacing = grid.info().spacing;
    let e = r
        .upload_label_mesh(&mesh, &vertex_labels, &table, spacing, None)
        .err();
    assert!(e.is_some_and(|e| e.to_string().contains("label colours")));
    r.set_page_bytes(needed);
    r.upload_label_mesh(&mesh, &vertex_labels, &table, spacing, None)
        .unwrap();
}

/// The GPU tracer's walk tests every label's metacell at a position (a label grid repeats
/// positions across its labels' runs): its hits are the CPU tracer's, with the same label, on
/// rays from outside the ball and from inside its labels (which meet the boundaries between
/// touching labels from both sides).
#[test]
fn label_grid_rays_hit_like_the_cpu_tracer_with_the_same_label() {
    let Some(r) = renderer() else { return };
    // The ball, and a 32³ checkerboard of 3³ cubes of 11 labels (every cube touches others on
    // every side, and a block holds dozens of labels' runs, so positions repeat many times).
    let cubes = isogrid::extract_labels(
        &isogrid::generate::labelled_cubes(32).view(),
        &isogrid::LabelOptions::new(isogrid::LabelSelection::All),
    )
    .unwrap();
    for (name, grid, centre, reach) in [
        ("ball", labelled_ball(), 19.5, 16.0),
        ("cubes", cubes, 15.5, 28.0),
    ] {
        label_rays_agree(r, name, &grid, centre, reach);
    }
}

/// GPU `trace_rays` against the CPU tracer on `grid`: random rays around the grid's box, and
/// rays from a cube of side `reach` about `centre`, where labels touch.
fn label_rays_agree(r: &Renderer, name: &str, grid: &CellGrid, centre: f64, reach: f64) {
    let cluster_labels = grid.labels().unwrap().cluster_labels();
    let cpu = isogrid_trace::Tracer::new(grid, isogrid_trace::Crossing::Samples3);
    let gpu_grid = r.upload_grid(grid).unwrap();
    let hi = grid.info().world_bounds().1;
    let outside = crate::pathtrace::random_rays(hi, 3000, 5);
    let mut rng = crate::pathtrace::Rng(17);
    let inside: Vec<isogrid::Ray> = (0..3000)
        .map(|_| isogrid::Ray {
            origin: std::array::from_fn(|_| centre + reach * (rng.next() - 0.5)),
            direction: rng.direction(),
        })
        .collect();
    for (what, rays) in [("from outside", outside), ("from inside", inside)] {
        let what = format!("{name}, rays {what}");
        let gpu = r.trace_rays(&gpu_grid, &rays).unwrap();
        let (mut agree, mut both, mut close, mut same_label) = (0, 0, 0, 0);
        for (ray, got) in rays.iter().zip(&gpu) {
            let want = cpu.closest_hit(ray, 0.0, f64::INFINITY);
            agree += (want.is_some() == got.is_some()) as usize;
            if let (Some(want), Some(got)) = (want, got) {
                both += 1;
                close += ((got.t as f64 - want.t).abs() <= 0.05) as usize;
                same_label += (cluster_labels[want.cluster as usize]
                    == cluster_labels[got.cluster as usize]) as usize;
            }
        }
        let n = rays.len();
        eprintln!(
            "{what}: {n} rays, hit/miss agree {agree}, both hit {both}, \
             same label {same_label}, within 0.05 {close}"
        );
        assert!(both >= n / 5, "{what}: too few hits ({both})");
        assert!(agree as f64 >= 0.999 * n as f64, "{what}: {agree} of {n}");
        assert!(
            same_label as f64 >= 0.999 * both as f64,
            "{what}: {same_label} of {both}"
        );
        assert!(
            close as f64 >= 0.999 * both as f64,
            "{what}: {close} of {both}"
        );
    }
}

//! Path tracing with traced primary rays (`PrimaryRays::Traced`): the frame's AOVs are the CPU
//! tracer's closest hits of the same pixel-centre rays, in one page and in several; the image
//! estimates the same radiance as the hybrid (raster primaries) and the CPU path tracer; and no
//! raster, culling or shading pass runs.

use crate::paged_trace::quarter_binding;
use crate::{interior_pixels, new_renderer, renderer, scene, MeanEstimate};
use isogrid::generate::Field;
use isogrid::{extract, Camera, CellGrid, ExtractOptions, Iso, Precision};
use isogrid_gpu::{EnvMap, Frame, GpuGrid, PathTraceOptions, PrimaryRays, Renderer};
use isogrid_trace::{Crossing, Tracer};

fn traced(frames: u32, bounces: u32) -> PathTraceOptions<'static> {
    PathTraceOptions {
        frames,
        bounces,
        primary: PrimaryRays::Traced,
        ..Default::default()
    }
}

fn oblique(grid: &CellGrid, width: u32, height: u32) -> Camera {
    let (lo, hi) = grid.info().world_bounds();
    Camera::preset(2, lo, hi, width, height).unwrap()
}

/// Compares a traced-primary frame's AOVs with `Tracer::closest_hit` (the paper's three samples
/// per cell, as the GPU) of `camera.ray(x, y)`. Both run the same search and refinement, the GPU
/// in f32 and in cell units, the CPU in f64, so they can disagree on hit or miss only where a ray
/// grazes a crossing pair thinner than f32 rounding (hence 99 %), and where both hit they bracket
/// the same crossing to 2⁻¹² of a third of a cell; what remains is f32 rounding of positions some
/// 50–100 units from the eye, about 1e-5 units, so 1e-3 units (a thousandth of a voxel) leaves a
/// wide margin while a crossing in another cell or a wrong sample would be off by 0.01–1 voxel.
/// The normal is the same gradient at that point (within 0.5°), the cluster the same cluster.
fn assert_aovs_match_the_cpu(label: &str, grid: &CellGrid, camera: &Camera, frame: &Frame) {
    let cpu = Tracer::new(grid, Crossing::Samples3);
    let (mut agree, mut both, mut close, mut normals, mut clusters) = (0, 0, 0, 0, 0);
    let mut worst = 0.0f64;
    let pixels = (camera.width * camera.height) as usize;
    for i in 0..pixels {
        let ray = camera.ray(i as u32 % camera.width, i as u32 / camera.width);
        let want = cpu.closest_hit(&ray, 0.0, f64::INFINITY);
        let got = frame.is_hit(i);
        agree += (want.is_some() == got) as usize;
        if got {
            assert!(frame.depth[i].is_finite(), "{label}: pixel {i} hit at inf");
            let n = frame.normal[i];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-4, "{label}: normal {n:?}");
        } else {
            assert_eq!(frame.depth[i], f32::INFINITY, "{label}: pixel {i}");
            assert!(frame.normal[i].iter().all(|v| v.is_nan()), "{label}");
        }
        let Some(want) = want.filter(|_| got) else {
            continue;
        };
        both += 1;
        let err = (frame.depth[i] as f64 - want.t).abs();
        worst = worst.max(err);
        if err <= 1e-3 {
            close += 1;
            let n = frame.normal[i].map(|v| v as f64);
            let cos = (0..3).map(|a| n[a] * want.normal[a]).sum::<f64>();
            normals += (cos.clamp(-1.0, 1.0).acos().to_degrees() <= 0.5) as usize;
            clusters += (frame.cluster[i] == want.cluster) as usize;
        }
    }
    eprintln!(
        "{label}: {pixels} pixels, hit/miss agree {agree}, both hit {both}, depth within 1e-3 \
         {close} (worst {worst:.2e}), normals within 0.5° {normals}, same cluster {clusters}"
    );
    assert!(both >= 200, "{label}: too few hits ({both})");
    assert!(agree as f64 >= 0.99 * pixels as f64, "{label}: {agree}");
    assert!(
        close as f64 >= 0.99 * both as f64,
        "{label}: {close} of {both}"
    );
    assert!(normals as f64 >= 0.99 * close as f64, "{label}: {normals}");
    assert!(
        clusters as f64 >= 0.99 * close as f64,
        "{label}: {clusters}"
    );
}

#[test]
fn traced_primary_aovs_are_the_cpu_tracers_closest_hits() {
    let Some(r) = renderer() else { return };
    let mut cases: Vec<(String, CellGrid)> = Vec::new();
    for (field, size, precision) in [
        (Field::Gyroid, 32, None),
        (Field::Sphere, 40, Some(Precision::Bits4)),
        (Field::Hairball, 40, Some(Precision::Float32)),
    ] {
        cases.push((format!("{field} {size}"), scene(field, size, precision).1));
    }
    // Anisotropic spacing: traversal runs in cell units, depths are world units.
    let volume = isogrid::generate::generate(Field::Torus, 36, 7)
        .with_spacing([1.0, 0.7, 1.4])
        .unwrap();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    cases.push(("torus 36 anisotropic".into(), grid));
    for (label, grid) in &cases {
        let camera = oblique(grid, 80, 60);
        let gpu = r.upload_grid(grid).unwrap();
        let frame = r.path_trace(&gpu, &camera, &traced(1, 0)).unwrap();
        assert_aovs_match_the_cpu(label, grid, &camera, &frame);
    }
}

/// A grid split into several pages (all bound at once, `trace_pages.wgsl`) gives the same AOVs
/// and image as one page: the same arithmetic, only the page lookup differs.
#[test]
fn traced_primaries_work_on_paged_grids() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    let (_, grid) = scene(Field::Gyroid, 40, None);
    paged.set_page_bytes(quarter_binding(&grid));
    let a = one_page.upload_grid(&grid).unwrap();
    let b = paged.upload_grid(&grid).unwrap();
    assert!(b.page_count() >= 3, "{} pages", b.page_count());
    let camera = oblique(&grid, 48, 40);
    let one = one_page.path_trace(&a, &camera, &traced(2, 2)).unwrap();
    let many = paged.path_trace(&b, &camera, &traced(2, 2)).unwrap();
    assert_aovs_match_the_cpu("gyroid 40 in pages", &grid, &camera, &many);
    assert_eq!(one.cluster, many.cluster);
    assert_eq!(one.depth, many.depth);
    assert_eq!(one.linear, many.linear);
}

/// Traced primaries skip every raster pass: no cell is drawn or probed, and where the device has
/// timestamps only the trace pass is timed (the frame is that pass). The hybrid on the same view
/// draws cells and times its raster and shading passes, so both checks can fail.
#[test]
fn traced_primaries_record_only_the_trace_pass() {
    let Some(r) = renderer() else { return };
    let (_, grid) = scene(Field::Torus, 32, None);
    let gpu = r.upload_grid(&grid).unwrap();
    let camera = oblique(&grid, 40, 32);
    let hybrid = r
        .path_trace(
            &gpu,
            &camera,
            &PathTraceOptions {
                frames: 2,
                bounces: 1,
                ..Default::default()
            },
        )
        .unwrap();
    let only_traced = r.path_trace(&gpu, &camera, &traced(2, 1)).unwrap();
    assert!(hybrid.drawn_cells > 0);
    assert_eq!(only_traced.drawn_cells, 0);
    assert_eq!(only_traced.probed_cells, 0);
    if r.has_timestamps() {
        let (h, t) = (hybrid.timings, only_traced.timings);
        assert!(h.raster_ms.is_some() && h.shade_ms.is_some() && h.cull_ms.is_some());
        assert_eq!(
            (t.raster_ms, t.ewa_ms, t.shade_ms, t.cull_ms),
            (None, None, None, None)
        );
        assert!(t.trace_ms.is_some());
        assert_eq!(t.frame_ms, t.trace_ms);
        eprintln!(
            "torus 32, 40x32, 1 bounce: hybrid frame {:?} ms (trace {:?}), traced {:?} ms",
            h.frame_ms, h.trace_ms, t.frame_ms
        );
    }
}

fn path_trace(
    r: &Renderer,
    grid: &GpuGrid,
    camera: &Camera,
    env: &isogrid_gpu::GpuEnvMap,
    primary: PrimaryRays,
) -> Frame {
    r.path_trace(
        grid,
        camera,
        &PathTraceOptions {
            frames: 24,
            bounces: 3,
            env: Some(env),
            primary,
            ..Default::default()
        },
    )
    .unwrap()
}

/// Traced and raster primaries estimate the same image under a uniform environment, and traced
/// primaries agree with the CPU path tracer too. Compared over interior surface pixels (the
/// pixel and its 4 neighbours hit in every image: at silhouettes the CPU's jittered primaries mix
/// in the environment). The CPU's random numbers are its own, so against it the tolerance is 5
/// standard errors of the difference of independent means. The two GPU modes share their random
/// numbers per pixel and sample, so their difference is compared per pixel, its mean within 5 of
/// its own standard errors (which are smaller). The one real difference, the hybrid's
/// EWA-smoothed primary normals, biased the mean by less than one of them here.
#[test]
fn traced_and_raster_primaries_agree_on_the_mean() {
    use isogrid_trace::{Environment, PathTraceOptions as CpuOptions, RenderOptions, Shading};
    let Some(r) = renderer() else { return };
    let radiance = [0.9f32, 0.7, 0.5];
    let env = r.upload_env(&EnvMap::constant(radiance).unwrap()).unwrap();
    let (size, pixels) = (32, 64u32);
    for field in [Field::Torus, Field::Gyroid] {
        let (_, grid) = scene(field, size, None);
        let camera = oblique(&grid, pixels, pixels);
        let gpu_grid = r.upload_grid(&grid).unwrap();
        let raster = path_trace(r, &gpu_grid, &camera, &env, PrimaryRays::Raster);
        let traced = path_trace(r, &gpu_grid, &camera, &env, PrimaryRays::Traced);
        let options = RenderOptions {
            shading: Shading::PathTrace(CpuOptions {
                samples_per_pixel: 24,
                bounces: 3,
                environment: Environment::Uniform(radiance),
                seed: 11,
                ..CpuOptions::default()
            }),
            ..RenderOptions::default()
        };
        let cpu = isogrid_trace::render(&grid, &camera, &options).unwrap();
        let interior = interior_pixels(pixels as usize, cpu.radiance.len(), |i| {
            raster.is_hit(i) && traced.is_hit(i) && cpu.cluster[i] != u32::MAX
        });
        assert!(interior.len() > 150, "{field}: {} pixels", interior.len());
        for c in 0..3 {
            let t = MeanEstimate::of(interior.iter().map(|&i| traced.linear[i][c] as f64));
            let k = MeanEstimate::of(interior.iter().map(|&i| cpu.radiance[i][c] as f64));
            let d = MeanEstimate::of(
                interior
                    .iter()
                    .map(|&i| (traced.linear[i][c] - raster.linear[i][c]) as f64),
            );
            eprintln!(
                "{field} channel {c}: traced {:.4} ± {:.4}, CPU {:.4} ± {:.4}, traced − raster \
                 {:.5} ± {:.5}",
                t.mean, t.standard_error, k.mean, k.standard_error, d.mean, d.standard_error
            );
            let independent = 5.0 * t.standard_error.hypot(k.standard_error);
            assert!(
                (t.mean - k.mean).abs() <= independent,
                "{field} channel {c}: traced {} vs CPU {} (tolerance {independent})",
                t.mean,
                k.mean
            );
            let paired = 5.0 * d.standard_error;
            assert!(
                d.mean.abs() <= paired,
                "{field} channel {c}: traced − raster {} (tolerance {paired})",
                d.mean
            );
        }
    }
}

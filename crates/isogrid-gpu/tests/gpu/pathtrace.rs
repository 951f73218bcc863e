//! Hybrid path tracing (paper §3.6): secondary-ray traversal against the brute-force reference,
//! energy conservation (white furnace), an analytic cosine-weighted integral, the environment on
//! misses, progressive accumulation and its reset, and bad requests.

use crate::reference::Reference;
use crate::{interior_pixels, path_trace_on_both, renderer, scene, MeanEstimate};
use isogrid::generate::Field;
use isogrid::shading::{to_srgb8, ALBEDO};
use isogrid::{extract, Camera, EnvMap, ExtractOptions, Iso, Precision, Ray, Volume, VolumeData};
use isogrid_gpu::{
    GpuErrorKind, Mode, PathTraceOptions, PrimaryRays, RenderOptions, Scene, ViewState,
};

/// Small deterministic generator (SplitMix64) for test rays.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn direction(&mut self) -> [f64; 3] {
        let z = 2.0 * self.next() - 1.0;
        let phi = std::f64::consts::TAU * self.next();
        let r = (1.0 - z * z).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Random rays from the grid box grown by 4 voxels, in random directions: about half start inside
/// the solid (their first crossing is an exit), some miss the box.
pub fn random_rays(hi: [f64; 3], count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    (0..count)
        .map(|_| Ray {
            origin: std::array::from_fn(|a| -4.0 + (hi[a] + 8.0) * rng.next()),
            direction: rng.direction(),
        })
        .collect()
}

/// The GPU traversal (blocks → occupied metacells → cells, 3 samples + bisection per cell) finds
/// the same first crossing as fine stepping (1/32 voxel) + bisection over the whole grid. They can
/// differ only where a ray grazes a double crossing thinner than a third of a cell, hence 99 %;
/// where both hit the crossing is the same one up to bisection precision, so 0.05 voxel, and the
/// normal is the same formula at that point, so 2°.
#[test]
fn secondary_ray_traversal_matches_the_brute_force_reference() {
    let Some(r) = renderer() else { return };
    let mut cases: Vec<(String, Volume, isogrid::CellGrid)> = Vec::new();
    for (field, size, precision) in [
        (Field::Gyroid, 32, None),
        (Field::Sphere, 40, Some(Precision::Bits4)),
        (Field::MarschnerLobb, 40, None),
        (Field::Hairball, 48, Some(Precision::Float32)),
    ] {
        let (volume, grid) = scene(field, size, precision);
        cases.push((format!("{field} {size}"), volume, grid));
    }
    // Anisotropic spacing: traversal runs in cell units, distances are world units.
    let volume = isogrid::generate::generate(Field::Torus, 36, 7)
        .with_spacing([1.0, 0.7, 1.4])
        .unwrap();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    cases.push(("torus 36 anisotropic".into(), volume, grid));

    for (i, (label, volume, grid)) in cases.iter().enumerate() {
        let gpu = r.upload_grid(grid).unwrap();
        let (_, hi) = grid.info().world_bounds();
        let rays = random_rays(hi, 3000, 17 + i as u64);
        let hits = r.trace_rays(&gpu, &rays).unwrap();
        let reference = Reference::new(volume, grid);
        let (mut agree, mut both, mut close, mut normals_ok) = (0, 0, 0, 0);
        let mut max_error = 0.0f64;
        for (ray, gpu_hit) in rays.iter().zip(&hits) {
            let want = reference.trace(ray);
            if want.is_some() != gpu_hit.is_some() {
                continue;
            }
            agree += 1;
            let (Some(want), Some(got)) = (want, gpu_hit) else {
                continue;
            };
            both += 1;
            let err = (got.t as f64 - want.t).abs();
            max_error = max_error.max(err);
            if err <= 0.05 {
                close += 1;
                let n = got.normal.map(|v| v as f64);
                if dot(n, want.normal).clamp(-1.0, 1.0).acos().to_degrees() <= 2.0 {
                    normals_ok += 1;
                }
            }
        }
        eprintln!(
            "{label}: {} rays, hit/miss agree {agree}, both hit {both}, within 0.05 voxel {close} (max error {max_error:.4}), normals within 2° {normals_ok}",
            rays.len()
        );
        assert!(both >= 300, "{label}: too few hits ({both})");
        assert!(
            agree as f64 >= 0.99 * rays.len() as f64,
            "{label}: hit/miss agree {agree}"
        );
        assert!(
            close as f64 >= 0.99 * both as f64,
            "{label}: {close} of {both} close"
        );
        assert!(
            normals_ok as f64 >= 0.99 * close as f64,
            "{label}: normals {normals_ok}"
        );
    }
}

fn camera(size: usize, view: u8, width: u32, height: u32) -> Camera {
    let hi = [(size - 1) as f64; 3];
    Camera::preset(view, [0.0; 3], hi, width, height).unwrap()
}

/// With albedo 1 and a white environment every path that escapes carries exactly 1, whatever the
/// geometry, and one that runs out of bounces 0; sums of 0s and 1s are exact in f32, so a pixel
/// is k/N for N samples, never above 1, and the mean is the fraction of escaped paths. Off the
/// convex sphere every path escapes at its first bounce (N/N everywhere); the torus can trap a
/// path for a few bounces, so with 16 a pixel may lose at most one sample; the gyroid's labyrinth
/// keeps paths for many (with 16 bounces it kept 1.5 %), so with 32 only the mean is bounded.
/// The mean must be within 1 % of 1: a tracer that let paths leak into the solid would trap them.
#[test]
fn white_furnace_stays_white() {
    white_furnace(PrimaryRays::Raster);
}

/// The same furnace with primary rays traced rather than rasterised.
#[test]
fn white_furnace_stays_white_with_traced_primaries() {
    white_furnace(PrimaryRays::Traced);
}

fn white_furnace(primary: PrimaryRays) {
    let Some(r) = renderer() else { return };
    let white = r.upload_env(&EnvMap::constant([1.0; 3]).unwrap()).unwrap();
    for (field, size, bounces, pixels, frames, lost_per_pixel) in [
        (Field::Sphere, 40, 3, 96, 4, 0),
        (Field::Torus, 40, 16, 96, 4, 1),
        (Field::Gyroid, 24, 32, 40, 4, 4),
    ] {
        let started = std::time::Instant::now();
        let (_, grid) = scene(field, size, None);
        let gpu = r.upload_grid(&grid).unwrap();
        let cam = camera(size, 2, pixels, pixels);
        let frame = r
            .path_trace(
                &gpu,
                &cam,
                &PathTraceOptions {
                    frames,
                    bounces,
                    env: Some(&white),
                    albedo: [1.0; 3],
                    primary,
                    ..Default::default()
                },
            )
            .unwrap();
        assert_eq!(frame.samples, frames);
        let hits = (0..frame.linear.len()).filter(|&i| frame.is_hit(i)).count();
        assert!(hits > 400, "{field}: only {hits} surface pixels");
        let values: Vec<f32> = frame.linear.iter().flatten().copied().collect();
        let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64;
        let min = values.iter().cloned().fold(f32::INFINITY, f32::min);
        let max = values.iter().cloned().fold(0.0f32, f32::max);
        eprintln!(
            "{field} furnace ({primary:?} primaries): mean {mean:.5}, min {min}, max {max}, {hits} hit pixels, {:.2} s",
            started.elapsed().as_secs_f64()
        );
        assert!(
            max <= 1.0 + 1e-6,
            "{field}: a pixel exceeds the furnace ({max})"
        );
        assert!((mean - 1.0).abs() <= 0.01, "{field}: mean {mean}");
        for v in &values {
            let k = v * frames as f32;
            assert!(
                (k - k.round()).abs() <= 1e-4,
                "{field}: {v} is not k/{frames}"
            );
        }
        assert!(
            min >= 1.0 - lost_per_pixel as f32 / frames as f32 - 1e-6,
            "{field}: a pixel lost more than {lost_per_pixel} samples ({min})"
        );
    }
}

/// An environment linear in the direction, L(ω) = c0 + c·ω, seen by a Lambertian plane with unit
/// normal n: (1/π)∫ L(ω) (n·ω) dω over the upper hemisphere is c0 + (2/3) c·n, so every plane pixel
/// converges to albedo · (c0 + (2/3) c·n). The plane is the exact zero set of a linear field
/// stored as floats, so no secondary ray meets it again and 3 bounces equal 1. Each sample lies
/// in albedo · [c0 − |c|, c0 + |c|] (a hard bound per pixel); the mean over 48² pixels × 8
/// samples has a standard error near 0.2 %, so it must be within 1 %.
#[test]
fn a_lit_plane_integrates_the_environment_with_cosine_weights() {
    let Some(r) = renderer() else { return };
    let size = 40usize;
    let nrm = {
        let n = [0.3f64, 1.0, 0.25];
        let len = dot(n, n).sqrt();
        n.map(|v| v / len)
    };
    let centre = [(size - 1) as f64 / 2.0; 3];
    let mut data = Vec::with_capacity(size * size * size);
    for k in 0..size {
        for j in 0..size {
            for i in 0..size {
                let p = [
                    i as f64 - centre[0],
                    j as f64 - centre[1],
                    k as f64 - centre[2],
                ];
                data.push(-dot(p, nrm) as f32);
            }
        }
    }
    let volume = Volume::new([size; 3], VolumeData::F32(data)).unwrap();
    let mut options = ExtractOptions::new(Iso::Value(0.0));
    options.precision = Some(Precision::Float32);
    let grid = extract(&volume.view(), &options).unwrap();
    let gpu = r.upload_grid(&grid).unwrap();

    let c0 = [1.0f64, 0.9, 0.8];
    let c = [[0.3, 0.5, -0.2], [-0.2, 0.4, 0.3], [0.1, -0.3, 0.35]];
    let radiance = |d: [f32; 3]| -> [f32; 3] {
        let d = d.map(|v| v as f64);
        std::array::from_fn(|ch| (c0[ch] + dot(c[ch], d)) as f32)
    };
    let env = r
        .upload_env(&EnvMap::from_fn(256, 128, radiance).unwrap())
        .unwrap();
    let cam = Camera {
        eye: std::array::from_fn(|a| centre[a] + 30.0 * nrm[a] + [4.0, 0.0, 3.0][a]),
        target: centre,
        up: [0.0, 0.0, -1.0],
        fovy_degrees: 30.0,
        width: 48,
        height: 48,
        mirrored: false,
    };
    let frames = 8;
    let frame = r
        .path_trace(
            &gpu,
            &cam,
            &PathTraceOptions {
                frames,
                bounces: 3,
                env: Some(&env),
                ..Default::default()
            },
        )
        .unwrap();
    assert!(
        (0..frame.linear.len()).all(|i| frame.is_hit(i)),
        "the plane must fill the image"
    );
    for ch in 0..3 {
        let a = ALBEDO[ch] as f64;
        let expected = a * (c0[ch] + 2.0 / 3.0 * dot(c[ch], nrm));
        let spread = dot(c[ch], c[ch]).sqrt();
        let (lo, hi) = (a * (c0[ch] - spread), a * (c0[ch] + spread));
        let values: Vec<f64> = frame.linear.iter().map(|p| p[ch] as f64).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        eprintln!("plane channel {ch}: mean {mean:.5}, expected {expected:.5}");
        assert!(
            (mean - expected).abs() <= 0.01 * expected,
            "channel {ch}: {mean} vs {expected}"
        );
        assert!(
            values.iter().all(|&v| v >= lo - 1e-4 && v <= hi + 1e-4),
            "channel {ch}"
        );
    }
    // Without bounces the surface receives nothing.
    let dark = r
        .path_trace(
            &gpu,
            &cam,
            &PathTraceOptions {
                frames: 1,
                bounces: 0,
                env: Some(&env),
                ..Default::default()
            },
        )
        .unwrap();
    assert!(dark.linear.iter().all(|p| *p == [0.0; 3]));
}

/// Primary misses show the environment along the pixel's ray: the built-in sky exactly as
/// `isogrid::env_map::sky`, and an uploaded map as `EnvMap::from_fn` painted it (a linear
/// radiance, so bilinear lookup is exact to about 1e-3).
#[test]
fn misses_show_the_sky_or_the_environment_map() {
    let Some(r) = renderer() else { return };
    let (_, grid) = scene(Field::Sphere, 32, None);
    let gpu = r.upload_grid(&grid).unwrap();
    let cam = Camera {
        eye: [15.5, 20.0, 70.0],
        target: [15.5, 15.5, 15.5],
        up: [0.0, 1.0, 0.0],
        fovy_degrees: 100.0,
        width: 64,
        height: 48,
        mirrored: false,
    };
    let sky = r.path_trace(&gpu, &cam, &Default::default()).unwrap();
    let radiance = |d: [f32; 3]| [0.5 + 0.4 * d[0], 0.6 + 0.3 * d[1], 0.7 - 0.5 * d[2]];
    let env = r
        .upload_env(&EnvMap::from_fn(360, 180, radiance).unwrap())
        .unwrap();
    let mapped = r
        .path_trace(
            &gpu,
            &cam,
            &PathTraceOptions {
                env: Some(&env),
                ..Default::default()
            },
        )
        .unwrap();
    let mut misses = 0;
    for i in 0..sky.linear.len() {
        if sky.is_hit(i) {
            continue;
        }
        misses += 1;
        let d = cam
            .ray(i as u32 % cam.width, i as u32 / cam.width)
            .direction
            .map(|v| v as f32);
        let want = isogrid::env_map::sky(d);
        for ch in 0..3 {
            assert!(
                (sky.linear[i][ch] - want[ch]).abs() <= 1e-4 + 1e-4 * want[ch],
                "pixel {i}: sky {:?} vs {want:?}",
                sky.linear[i]
            );
        }
        let want = radiance(d);
        for ch in 0..3 {
            assert!(
                (mapped.linear[i][ch] - want[ch]).abs() <= 2e-3,
                "pixel {i}: env {:?} vs {want:?}",
                mapped.linear[i]
            );
        }
        let srgb = sky.linear[i].map(to_srgb8);
        for (want, got) in srgb.iter().zip(&sky.rgba8[4 * i..4 * i + 3]) {
            assert!(want.abs_diff(*got) <= 1, "pixel {i} tone map");
        }
    }
    assert!(misses > 1000, "only {misses} misses");
}

/// Samples accumulate while the view rests and restart when it changes; the RNG depends only on
/// the pixel and the sample index, so a restarted view reproduces its first image exactly.
#[test]
fn accumulation_restarts_when_the_view_changes() {
    let Some(r) = renderer() else { return };
    let (_, grid) = scene(Field::Torus, 32, None);
    let gpu = r.upload_grid(&grid).unwrap();
    let a = camera(32, 2, 48, 40);
    let mut b = a;
    b.eye[0] += 3.0;
    let frames = |n| PathTraceOptions {
        frames: n,
        ..Default::default()
    };
    let mut view = ViewState::new();
    let first = r.path_trace_view(&mut view, &gpu, &a, &frames(2)).unwrap();
    assert_eq!(first.samples, 2);
    let more = r.path_trace_view(&mut view, &gpu, &a, &frames(3)).unwrap();
    assert_eq!(more.samples, 5);
    assert_ne!(
        first.linear, more.linear,
        "more samples must change a noisy image"
    );
    // Through render_view too: Mode::PathTrace keeps accumulating the same view.
    let via_mode = r
        .render_view(
            &mut view,
            Scene::Grid(&gpu),
            &a,
            Mode::PathTrace,
            &RenderOptions {
                frames: 1,
                ..Default::default()
            },
        )
        .unwrap();
    assert_eq!(via_mode.samples, 6);
    assert!(via_mode.timings.trace_ms.is_some() || !r.has_timestamps());

    let moved = r.path_trace_view(&mut view, &gpu, &b, &frames(1)).unwrap();
    assert_eq!(moved.samples, 1);
    let back = r.path_trace_view(&mut view, &gpu, &a, &frames(2)).unwrap();
    assert_eq!(back.samples, 2);
    // Same samples as the first image. Not bit-identical: EWA splats are blended in whatever
    // order the rasteriser emits them, so primary normals can differ in the last bits and a few
    // paths take another turn; a restart that failed would differ everywhere.
    let diffs: Vec<f32> = back
        .linear
        .iter()
        .zip(&first.linear)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .collect();
    let mean_diff = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let close = diffs.iter().filter(|&&d| d <= 1e-3).count();
    assert!(
        mean_diff < 2e-3,
        "mean |Δ| {mean_diff} after returning to the first camera"
    );
    assert!(
        close as f64 >= 0.98 * diffs.len() as f64,
        "{close} of {} values match",
        diffs.len()
    );
    let other_bounces = r
        .path_trace_view(
            &mut view,
            &gpu,
            &a,
            &PathTraceOptions {
                frames: 1,
                bounces: 1,
                ..Default::default()
            },
        )
        .unwrap();
    assert_eq!(other_bounces.samples, 1);
    // A call without a view starts afresh, whatever the views of the same grid hold.
    let one_off = r.path_trace(&gpu, &a, &frames(1)).unwrap();
    assert_eq!(one_off.samples, 1);
}

#[test]
fn bad_path_trace_requests_fail_cleanly() {
    let Some(r) = renderer() else { return };
    let (_, grid) = scene(Field::Sphere, 24, None);
    let gpu = r.upload_grid(&grid).unwrap();
    let cam = camera(24, 1, 16, 16);
    for options in [
        PathTraceOptions {
            bounces: 65,
            ..Default::default()
        },
        PathTraceOptions {
            albedo: [1.5, 0.5, 0.5],
            ..Default::default()
        },
    ] {
        let e = r.path_trace(&gpu, &cam, &options).unwrap_err();
        assert_eq!(e.kind(), GpuErrorKind::InvalidInput, "{e}");
    }
    let zero = Ray {
        origin: [1.0; 3],
        direction: [0.0; 3],
    };
    assert_eq!(
        r.trace_rays(&gpu, &[zero]).unwrap_err().kind(),
        GpuErrorKind::InvalidInput
    );
}

/// A grid without active cells: every pixel sees the sky, no sample is lost.
#[test]
fn an_empty_grid_shows_only_the_environment() {
    let Some(r) = renderer() else { return };
    let volume = Volume::new([20, 20, 20], VolumeData::U8(vec![3; 8000])).unwrap();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(100.0))).unwrap();
    let gpu = r.upload_grid(&grid).unwrap();
    let cam = camera(20, 2, 24, 24);
    let frame = r.path_trace(&gpu, &cam, &Default::default()).unwrap();
    for (i, px) in frame.linear.iter().enumerate() {
        let d = cam
            .ray(i as u32 % 24, i as u32 / 24)
            .direction
            .map(|v| v as f32);
        let want = isogrid::env_map::sky(d);
        assert!((0..3).all(|ch| (px[ch] - want[ch]).abs() <= 1e-4 + 1e-4 * want[ch]));
    }
}

/// The GPU hybrid path tracer and the CPU path tracer (`isogrid_trace`) estimate the same image:
/// same grid, camera, albedo, bounces and a uniform environment. Their random numbers differ, so
/// only the means over the surface pixels are compared, against several standard errors.
#[test]
fn gpu_and_cpu_path_tracers_agree_on_the_mean() {
    let Some(r) = renderer() else { return };
    let env = EnvMap::constant([0.9, 0.7, 0.5]).unwrap();
    let (size, pixels, samples, bounces) = (32, 64, 24, 3);
    for field in [Field::Torus, Field::Gyroid] {
        let (_, grid) = scene(field, size, None);
        let cam = camera(size, 2, pixels, pixels);
        let (gpu, cpu) = path_trace_on_both(r, &grid, &cam, &env, (samples, bounces, 5));
        // Interior surface pixels of both images (silhouettes would bias the comparison).
        let both = interior_pixels(pixels as usize, gpu.linear.len(), |i| {
            gpu.is_hit(i) && cpu.cluster[i] != u32::MAX
        });
        assert!(
            both.len() > 150,
            "{field}: {} common surface pixels",
            both.len()
        );
        for c in 0..3 {
            let MeanEstimate {
                mean: g,
                standard_error: g_err,
            } = MeanEstimate::of(both.iter().map(|&i| gpu.linear[i][c] as f64));
            let MeanEstimate {
                mean: k,
                standard_error: k_err,
            } = MeanEstimate::of(both.iter().map(|&i| cpu.radiance[i][c] as f64));
            // 5 standard errors of the difference of two independent estimates.
            let tolerance = 5.0 * (g_err * g_err + k_err * k_err).sqrt();
            eprintln!("{field} channel {c}: GPU {g:.4} ± {g_err:.4}, CPU {k:.4} ± {k_err:.4}");
            assert!(
                (g - k).abs() <= tolerance,
                "{field} channel {c}: GPU {g} vs CPU {k} (tolerance {tolerance})"
            );
        }
    }
}

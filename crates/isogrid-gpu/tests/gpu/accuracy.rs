//! Images against the CPU reference ray caster: hit/miss and depth per pixel, normals per mode.

use crate::reference::{compare, Agreement, Reference};
use crate::{renderer, scene};
use isogrid::generate::Field;
use isogrid::{Camera, Precision, Volume};
use isogrid_gpu::{Mode, Scene};

/// Depth tolerance of the cell modes: 0.05 voxel (unit spacing).
const DEPTH_TOLERANCE: f64 = 0.05;

fn report(label: &str, a: &Agreement) {
    eprintln!(
        "{label}: hit/miss agree {:.4}, depth within tolerance {:.4} of {} common hits (max error {:.4}), normal angle median {:.2}° p95 {:.2}° p99 {:.2}°",
        a.hit_fraction(),
        a.depth_fraction(),
        a.both_hit,
        a.max_depth_error,
        a.angle_quantile(0.5),
        a.angle_quantile(0.95),
        a.angle_quantile(0.99)
    );
}

fn camera(volume: &Volume, view: u8, width: u32, height: u32) -> Camera {
    let hi = volume.dims().map(|d| (d - 1) as f64);
    Camera::preset(view, [0.0; 3], hi, width, height).unwrap()
}

/// The cell raster with trilinear-gradient normals computes the same crossing as the reference
/// with 3 samples instead of fine stepping: it can only miss double crossings inside one third of a
/// cell (grazing rays), hence 99 % of pixels; hits then agree to the bisection's precision, and the
/// normal is the same formula at a point at most 0.05 voxel away, hence 2° for 99 %.
#[test]
fn cgc_without_ewa_matches_the_reference_ray_caster() {
    let Some(r) = renderer() else { return };
    for (field, size, view) in [
        (Field::Sphere, 40, 2),
        (Field::Gyroid, 32, 1),
        (Field::MarschnerLobb, 40, 2),
    ] {
        let (volume, grid) = scene(field, size, None);
        let cam = camera(&volume, view, 128, 96);
        let gpu = r.upload_grid(&grid).unwrap();
        let frame = r
            .render(Scene::Grid(&gpu), &cam, Mode::CgcNoEwa, 1)
            .unwrap();
        let reference = Reference::new(&volume, &grid).render(&cam);
        let a = compare(&frame, &reference, DEPTH_TOLERANCE);
        report(&format!("{field} {size} view {view} CgcNoEwa"), &a);
        assert!(
            a.both_hit > 1000,
            "{field}: too few hits to say anything ({})",
            a.both_hit
        );
        assert!(a.hit_fraction() >= 0.99, "{field}: {a:?}");
        assert!(a.depth_fraction() >= 0.99, "{field}: {a:?}");
        assert!(
            a.angle_quantile(0.99) <= 2.0,
            "{field}: p99 normal angle {}",
            a.angle_quantile(0.99)
        );
    }
}

/// 1-, 4-, 8-, 16- and 32-bit corner records decode as `layout::read_corner` does; the reference reads
/// the same records, so all precisions must agree equally well.
#[test]
fn every_corner_precision_decodes_like_the_core() {
    let Some(r) = renderer() else { return };
    for precision in Precision::ALL {
        let (volume, grid) = scene(Field::Torus, 32, Some(precision));
        let cam = camera(&volume, 2, 64, 64);
        let gpu = r.upload_grid(&grid).unwrap();
        let frame = r
            .render(Scene::Grid(&gpu), &cam, Mode::CgcNoEwa, 1)
            .unwrap();
        let a = compare(
            &frame,
            &Reference::new(&volume, &grid).render(&cam),
            DEPTH_TOLERANCE,
        );
        report(&format!("torus 32 {precision:?}"), &a);
        assert!(a.both_hit > 300);
        assert!(a.hit_fraction() >= 0.99, "{precision:?}: {a:?}");
        assert!(a.depth_fraction() >= 0.99, "{precision:?}: {a:?}");
        assert!(a.angle_quantile(0.99) <= 2.0, "{precision:?}");
    }
}

/// Anisotropic spacing: world = cell coordinates × spacing on the GPU as in the camera and reference.
#[test]
fn anisotropic_spacing_matches_the_reference() {
    let Some(r) = renderer() else { return };
    let volume = isogrid::generate::generate(Field::Torus, 32, 1)
        .with_spacing([1.0, 1.5, 0.7])
        .unwrap();
    let grid = isogrid::extract(
        &volume.view(),
        &isogrid::ExtractOptions::new(isogrid::Iso::Normalized(0.5)),
    )
    .unwrap();
    let (lo, hi) = grid.info().world_bounds();
    let cam = Camera::preset(2, lo, hi, 96, 96).unwrap();
    let gpu = r.upload_grid(&grid).unwrap();
    let frame = r
        .render(Scene::Grid(&gpu), &cam, Mode::CgcNoEwa, 1)
        .unwrap();
    let a = compare(
        &frame,
        &Reference::new(&volume, &grid).render(&cam),
        DEPTH_TOLERANCE * 0.7,
    );
    report("torus 32 spacing (1, 1.5, 0.7)", &a);
    assert!(
        a.both_hit > 500 && a.hit_fraction() >= 0.99 && a.depth_fraction() >= 0.99,
        "{a:?}"
    );
    assert!(a.angle_quantile(0.99) <= 2.0);
}

/// With EWA the hit and depth are still the raster's; normals become a Gaussian-weighted average of
/// cell normals (gradient at the cell centre) within about one cell, so they differ from the
/// per-pixel trilinear gradient by the change of the normal over a cell: on these shapes (radii of
/// curvature ≥ 4 voxels, so ≤ ~15° per voxel, and the trilinear gradient's own kinks at cell faces)
/// a median under 4° and a 95th percentile under 10° (measured on lavapipe: sphere 1.2°/2.4°,
/// torus 2.5°/6.0°).
#[test]
fn cgc_with_ewa_keeps_depth_and_smooths_normals() {
    let Some(r) = renderer() else { return };
    for (field, size, view) in [(Field::Sphere, 40, 2), (Field::Torus, 40, 1)] {
        let (volume, grid) = scene(field, size, None);
        let cam = camera(&volume, view, 128, 96);
        let gpu = r.upload_grid(&grid).unwrap();
        let frame = r.render(Scene::Grid(&gpu), &cam, Mode::Cgc, 1).unwrap();
        let a = compare(
            &frame,
            &Reference::new(&volume, &grid).render(&cam),
            DEPTH_TOLERANCE,
        );
        report(&format!("{field} {size} view {view} Cgc (EWA)"), &a);
        assert!(
            a.hit_fraction() >= 0.99 && a.depth_fraction() >= 0.99,
            "{a:?}"
        );
        assert!(
            a.angle_quantile(0.5) <= 4.0 && a.angle_quantile(0.95) <= 10.0,
            "{field}"
        );
        // EWA must actually change the normals: the per-pixel gradient agrees to 0.02°.
        assert!(
            a.angle_quantile(0.5) >= 0.2,
            "{field}: EWA normals equal the raster normals"
        );
        for n in frame.normal.iter().filter(|n| !n[0].is_nan()) {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-3, "normal {n:?} is not unit");
        }
    }
}

/// CR samples the original u8 volume, whose values equal the 8-bit codes, so the crossing is the
/// reference's; its normals are central differences interpolated trilinearly, which differ from
/// the cell's trilinear gradient by the same order as the EWA normals (measured: sphere 1.2°/2.1°,
/// gyroid 4.4°/8.7° median/p95), hence a median under 6° and a 95th percentile under 12°.
#[test]
fn cr_baseline_matches_the_reference() {
    let Some(r) = renderer() else { return };
    for (field, size, view) in [(Field::Sphere, 40, 1), (Field::Gyroid, 32, 2)] {
        let (volume, grid) = scene(field, size, None);
        let cam = camera(&volume, view, 128, 96);
        let gpu = r.upload_grid(&grid).unwrap();
        let vol = r.upload_volume(&volume.view(), &gpu).unwrap();
        let frame = r
            .render(
                Scene::Volume {
                    grid: &gpu,
                    volume: &vol,
                },
                &cam,
                Mode::Cr,
                1,
            )
            .unwrap();
        let a = compare(
            &frame,
            &Reference::new(&volume, &grid).render(&cam),
            DEPTH_TOLERANCE,
        );
        report(&format!("{field} {size} view {view} Cr"), &a);
        assert!(
            a.both_hit > 1000 && a.hit_fraction() >= 0.99 && a.depth_fraction() >= 0.99,
            "{a:?}"
        );
        assert!(
            a.angle_quantile(0.5) <= 6.0 && a.angle_quantile(0.95) <= 12.0,
            "{field}"
        );
    }
}

/// MC replaces the trilinear surface by linear interpolation along cell edges and flat triangles:
/// inside a cell the two surfaces differ by up to a few tenths of a voxel where the trilinear
/// surface bends (saddles, high curvature), and snorm16 adds < 0.001 voxel. Hence 0.3 voxel for
/// 98 % of common hits, and 98 % hit/miss agreement (silhouettes move by that much too).
#[test]
fn mc_baseline_depth_is_within_the_mesh_approximation_error() {
    let Some(r) = renderer() else { return };
    for (field, size, view) in [(Field::Sphere, 40, 2), (Field::Gyroid, 32, 1)] {
        let (volume, grid) = scene(field, size, None);
        let cam = camera(&volume, view, 128, 96);
        let mesh = isogrid::mc::marching_cubes(&volume.view(), grid.info().iso);
        let gpu = r.upload_mesh(&mesh).unwrap();
        let frame = r.render(Scene::Mesh(&gpu), &cam, Mode::Mc, 1).unwrap();
        let a = compare(&frame, &Reference::new(&volume, &grid).render(&cam), 0.3);
        report(&format!("{field} {size} view {view} Mc"), &a);
        assert!(
            a.both_hit > 1000 && a.hit_fraction() >= 0.98 && a.depth_fraction() >= 0.98,
            "{a:?}"
        );
        assert!(
            a.angle_quantile(0.5) <= 10.0,
            "{field}: flat triangles vs trilinear gradient"
        );
    }
}

/// The shading pass reproduces `isogrid::shading` (camera-space lights, sRGB) from the frame's own
/// normals, and misses are the background colour: this keeps shade.wgsl in sync with shading.rs.
#[test]
fn shading_matches_the_core_shading_model() {
    let Some(r) = renderer() else { return };
    let (volume, grid) = scene(Field::Torus, 32, None);
    let cam = camera(&volume, 2, 128, 96);
    let gpu = r.upload_grid(&grid).unwrap();
    for mode in [Mode::Cgc, Mode::CgcNoEwa] {
        let frame = r.render(Scene::Grid(&gpu), &cam, mode, 1).unwrap();
        let (right, up, forward) = cam.basis();
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut hits = 0;
        for i in 0..frame.cluster.len() {
            let rgb = &frame.rgba8[4 * i..4 * i + 3];
            if !frame.is_hit(i) {
                assert_eq!(rgb, isogrid::shading::BACKGROUND_SRGB, "pixel {i}");
                continue;
            }
            hits += 1;
            let n = frame.normal[i].map(|v| v as f64);
            let d = cam
                .ray(i as u32 % cam.width, i as u32 / cam.width)
                .direction;
            let n_cam = [dot(n, right), dot(n, up), -dot(n, forward)].map(|v| v as f32);
            let view = [-dot(d, right), -dot(d, up), dot(d, forward)].map(|v| v as f32);
            let expected = isogrid::shading::shade(n_cam, view).map(isogrid::shading::to_srgb8);
            for c in 0..3 {
                assert!(
                    (rgb[c] as i32 - expected[c] as i32).abs() <= 2,
                    "{mode:?} pixel {i}: {rgb:?} vs {expected:?}"
                );
            }
        }
        assert!(hits > 400, "{hits} hits");
    }
}

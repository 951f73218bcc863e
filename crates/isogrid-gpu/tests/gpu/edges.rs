//! Empty scenes, paging, bad requests and timings.

use crate::reference::{compare, Reference};
use crate::{new_renderer, renderer, scene};
use isogrid::generate::Field;
use isogrid::{extract, Camera, ExtractOptions, Iso, Volume, VolumeData};
use isogrid_gpu::{GpuErrorKind, Mode, RenderOptions, Scene};

#[test]
fn empty_extraction_renders_the_background() {
    let Some(r) = renderer() else { return };
    let volume = Volume::new([20, 20, 20], VolumeData::U8(vec![3; 8000])).unwrap();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(100.0))).unwrap();
    assert_eq!(grid.active_cells(), 0);
    let cam = Camera::preset(1, [0.0; 3], [19.0; 3], 40, 30).unwrap();
    let gpu = r.upload_grid(&grid).unwrap();
    let vol = r.upload_volume(&volume.view(), &gpu).unwrap();
    let mesh = r
        .upload_mesh(&isogrid::mc::marching_cubes(&volume.view(), 100.0))
        .unwrap();
    for (mode, scene) in [
        (Mode::Cgc, Scene::Grid(&gpu)),
        (Mode::CgcNoEwa, Scene::Grid(&gpu)),
        (
            Mode::Cr,
            Scene::Volume {
                grid: &gpu,
                volume: &vol,
            },
        ),
        (Mode::Mc, Scene::Mesh(&mesh)),
    ] {
        let frame = r.render(scene, &cam, mode, 2).unwrap();
        assert!(frame.cluster.iter().all(|&c| c == u32::MAX), "{mode:?}");
        assert!(frame.depth.iter().all(|d| *d == f32::INFINITY));
        assert!(frame.normal.iter().all(|n| n.iter().all(|v| v.is_nan())));
        for px in frame.rgba8.chunks(4) {
            assert_eq!(&px[..3], isogrid::shading::BACKGROUND_SRGB, "{mode:?}");
        }
    }
}

/// A tiny binding limit splits the grid into many pages (several per 16³ block), which must render
/// exactly like one page: same crossings, same cluster ids (global), and the reference agrees.
#[test]
fn a_grid_larger_than_one_binding_renders_in_pages() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    paged.set_page_bytes(4096);
    let (volume, grid) = scene(Field::Gyroid, 32, None);
    let cam = Camera::preset(2, [0.0; 3], [31.0; 3], 96, 72).unwrap();
    let a = one_page.upload_grid(&grid).unwrap();
    let b = paged.upload_grid(&grid).unwrap();
    assert_eq!(a.page_count(), 1);
    assert!(b.page_count() > 10, "only {} pages", b.page_count());
    for options in [
        RenderOptions {
            frames: 1,
            occlusion_culling: false,
            backface_culling: false,
            ..Default::default()
        },
        RenderOptions {
            frames: 10,
            ..Default::default()
        },
    ] {
        let fa = one_page
            .render_with(Scene::Grid(&a), &cam, Mode::CgcNoEwa, &options)
            .unwrap();
        let fb = paged
            .render_with(Scene::Grid(&b), &cam, Mode::CgcNoEwa, &options)
            .unwrap();
        assert_eq!(fa.cluster, fb.cluster);
        assert_eq!(fa.rgba8, fb.rgba8);
        let agreement = compare(&fb, &Reference::new(&volume, &grid).render(&cam), 0.05);
        assert!(agreement.hit_fraction() >= 0.99 && agreement.depth_fraction() >= 0.99);
    }
}

#[test]
fn a_mode_without_its_data_or_an_oversized_image_is_refused() {
    let Some(r) = renderer() else { return };
    let (_, grid) = scene(Field::Sphere, 16, None);
    let gpu = r.upload_grid(&grid).unwrap();
    let cam = Camera::preset(1, [0.0; 3], [15.0; 3], 16, 16).unwrap();
    for mode in [Mode::Mc, Mode::Cr] {
        let e = r
            .render(Scene::Grid(&gpu), &cam, mode, 1)
            .expect_err("must fail");
        assert_eq!(e.kind(), GpuErrorKind::InvalidInput, "{e}");
    }
    let huge = Camera {
        width: 1 << 20,
        ..cam
    };
    assert_eq!(
        r.render(Scene::Grid(&gpu), &huge, Mode::Cgc, 1)
            .err()
            .unwrap()
            .kind(),
        GpuErrorKind::TooLarge
    );
    let other = Volume::new([8, 8, 8], VolumeData::U8(vec![0; 512])).unwrap();
    assert_eq!(
        r.upload_volume(&other.view(), &gpu).err().unwrap().kind(),
        GpuErrorKind::InvalidInput
    );
}

/// Timestamps: present for the passes that ran where the adapter has timestamp queries.
#[test]
fn pass_timings_are_reported_for_the_passes_that_ran() {
    let Some(r) = renderer() else { return };
    let (_, grid) = scene(Field::Sphere, 24, None);
    let gpu = r.upload_grid(&grid).unwrap();
    let cam = Camera::preset(2, [0.0; 3], [23.0; 3], 48, 32).unwrap();
    let ewa = r
        .render(Scene::Grid(&gpu), &cam, Mode::Cgc, 3)
        .unwrap()
        .timings;
    let plain = r
        .render(Scene::Grid(&gpu), &cam, Mode::CgcNoEwa, 3)
        .unwrap()
        .timings;
    if !r.has_timestamps() {
        eprintln!("adapter has no timestamp queries: {ewa:?}");
        assert_eq!(ewa, Default::default());
        return;
    }
    assert!(
        ewa.raster_ms.is_some()
            && ewa.ewa_ms.is_some()
            && ewa.shade_ms.is_some()
            && ewa.cull_ms.is_some()
    );
    assert!(plain.raster_ms.is_some() && plain.ewa_ms.is_none());
    assert!(ewa.raster_ms.unwrap() >= ewa.ewa_ms.unwrap());
}

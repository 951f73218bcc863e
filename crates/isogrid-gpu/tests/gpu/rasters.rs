//! The compute cell raster against the hardware one: the same per-pixel test on the same lists must
//! give the same image, whichever raster walks the pixels, with and without the visibility buffer,
//! in every cell mode and across pages.

use crate::{new_renderer, renderer, scene};
use isogrid::generate::Field;
use isogrid::Camera;
use isogrid_gpu::{CellRaster, Frame, Mode, RenderOptions, Renderer, Scene};

fn render(
    r: &Renderer,
    scene: Scene<'_>,
    cam: &Camera,
    mode: Mode,
    raster: CellRaster,
    frames: u32,
    culling: bool,
) -> Frame {
    let options = RenderOptions {
        frames,
        occlusion_culling: culling,
        backface_culling: culling,
        cell_raster: raster,
        coloring: None,
    };
    let frame = r.render_with(scene, cam, mode, &options).unwrap();
    assert_eq!(
        frame.cell_raster,
        Some(raster),
        "the raster asked for did not run"
    );
    frame
}

/// Pixels whose hit/miss differ, and the largest depth difference over common hits (world units).
/// Fragment and compute shaders may round the same expressions differently (fused multiply-adds),
/// so depths are compared to 1e-4 voxel, far below the crossing's own error (≈ 1e-4 after
/// bisection in a unit cell) and the 0.05 voxel of the reference tests; a hit/miss flip needs a
/// crossing within that distance of a cell face at a rectangle's edge, a handful of pixels at most.
fn differences(a: &Frame, b: &Frame) -> (usize, f32) {
    let mut flips = 0;
    let mut max_depth = 0.0f32;
    for i in 0..a.depth.len() {
        match (a.is_hit(i), b.is_hit(i)) {
            (true, true) => max_depth = max_depth.max((a.depth[i] - b.depth[i]).abs()),
            (false, false) => {}
            _ => flips += 1,
        }
    }
    (flips, max_depth)
}

fn assert_same(label: &str, hardware: &Frame, compute: &Frame) {
    let hits = (0..hardware.depth.len())
        .filter(|&i| hardware.is_hit(i))
        .count();
    let (flips, max_depth) = differences(hardware, compute);
    eprintln!("{label}: {hits} hits, {flips} hit/miss flips, max depth difference {max_depth:e}");
    assert!(
        hits > 1000,
        "{label}: too few hits to say anything ({hits})"
    );
    assert!(
        flips * 1000 <= hits,
        "{label}: {flips} pixels flip between rasters"
    );
    assert!(max_depth <= 1e-4, "{label}: depths differ by {max_depth}");
    let same_cluster = (0..hits.max(1))
        .zip(hardware.cluster.iter().zip(&compute.cluster))
        .filter(|(_, (a, b))| a == b)
        .count();
    assert!(
        same_cluster * 100 >= 99 * hits,
        "{label}: cluster ids differ on {} pixels",
        hits - same_cluster
    );
}

#[test]
fn compute_and_hardware_rasters_draw_the_same_image() {
    let Some(r) = renderer() else { return };
    for (field, size, view) in [
        (Field::Gyroid, 32, 1),
        (Field::MarschnerLobb, 40, 2),
        (Field::Sphere, 40, 2),
    ] {
        let (volume, grid) = scene(field, size, None);
        let hi = volume.dims().map(|d| (d - 1) as f64);
        let cam = Camera::preset(view, [0.0; 3], hi, 128, 96).unwrap();
        let gpu = r.upload_grid(&grid).unwrap();
        let vol = r.upload_volume(&volume.view(), &gpu).unwrap();
        for mode in [Mode::CgcNoEwa, Mode::Cgc, Mode::Cr] {
            let scene = if mode == Mode::Cr {
                Scene::Volume {
                    grid: &gpu,
                    volume: &vol,
                }
            } else {
                Scene::Grid(&gpu)
            };
            // One frame without culling, then the converged visibility buffer (probes, newly
            // visible clusters and the resolve over both lists).
            for (frames, culling) in [(1, false), (6, true)] {
                let hardware = render(r, scene, &cam, mode, CellRaster::Hardware, frames, culling);
                let compute = render(r, scene, &cam, mode, CellRaster::Compute, frames, culling);
                let label =
                    format!("{field} view {view} {mode:?} frames {frames} culling {culling}");
                assert_same(&label, &hardware, &compute);
                if mode == Mode::Cgc {
                    // EWA and shading read the G-buffer; identical inputs give near-identical colour.
                    let differing = hardware
                        .rgba8
                        .chunks(4)
                        .zip(compute.rgba8.chunks(4))
                        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.abs_diff(*y) > 2))
                        .count();
                    assert!(
                        differing * 200 <= hardware.rgba8.len() / 4,
                        "{label}: {differing} pixels differ in colour"
                    );
                }
            }
        }
    }
}

/// A tiny binding limit splits the grid into many pages; the compute raster resolves visibility
/// across pages through one depth buffer, so pages must not change the image.
#[test]
fn the_compute_raster_renders_paged_grids_like_one_page() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    paged.set_page_bytes(4096);
    let (volume, grid) = scene(Field::Gyroid, 32, None);
    let hi = volume.dims().map(|d| (d - 1) as f64);
    let cam = Camera::preset(2, [0.0; 3], hi, 96, 72).unwrap();
    let a = one_page.upload_grid(&grid).unwrap();
    let b = paged.upload_grid(&grid).unwrap();
    assert!(b.page_count() > 10, "only {} pages", b.page_count());
    for (frames, culling) in [(1, false), (8, true)] {
        let fa = render(
            one_page,
            Scene::Grid(&a),
            &cam,
            Mode::CgcNoEwa,
            CellRaster::Compute,
            frames,
            culling,
        );
        let fb = render(
            &paged,
            Scene::Grid(&b),
            &cam,
            Mode::CgcNoEwa,
            CellRaster::Compute,
            frames,
            culling,
        );
        assert_eq!(
            fa.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
            fb.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(fa.rgba8, fb.rgba8);
    }
}

/// `Auto` takes the compute raster for a standard view and the hardware one when the eye is inside
/// the grid's box, where a cell can cover much of the screen.
#[test]
fn auto_picks_the_compute_raster_unless_cells_can_grow_large() {
    let Some(r) = renderer() else { return };
    let (volume, grid) = scene(Field::Sphere, 40, None);
    let hi = volume.dims().map(|d| (d - 1) as f64);
    let gpu = r.upload_grid(&grid).unwrap();
    let far = Camera::preset(1, [0.0; 3], hi, 64, 48).unwrap();
    let inside = Camera::parse("20,20,3:20,20,39:0,1,0:60", 64, 48).unwrap();
    let auto = |cam: &Camera| {
        r.render_with(
            Scene::Grid(&gpu),
            cam,
            Mode::CgcNoEwa,
            &RenderOptions::default(),
        )
        .unwrap()
        .cell_raster
    };
    assert_eq!(auto(&far), Some(CellRaster::Compute));
    assert_eq!(auto(&inside), Some(CellRaster::Hardware));
}

//! One uploaded grid drawn by two views: each [`ViewState`] keeps its own visibility bits, frame
//! counter and accumulated samples, so two cameras drawn alternately get exactly the frames that
//! a fresh renderer drawing only that camera gets.

use crate::{new_renderer, renderer, scene};
use isogrid::generate::Field;
use isogrid::Camera;
use isogrid_gpu::{CellRaster, Frame, Mode, RenderOptions, Renderer, Scene, ViewState};

/// Render calls per camera.
const CALLS: usize = 4;

/// The compute raster: its depth test is an atomic maximum and its EWA sums are integers, so a
/// frame is bit-for-bit reproducible (the hardware raster blends EWA splats in whatever order the
/// rasteriser emits them, which may change the last bits of a normal).
const OPTIONS: RenderOptions = RenderOptions {
    frames: 1,
    occlusion_culling: true,
    backface_culling: true,
    cell_raster: CellRaster::Compute,
    coloring: None,
};

fn assert_same(label: &str, got: &Frame, want: &Frame) {
    assert_eq!(got.rgba8, want.rgba8, "{label}: colours differ");
    assert_eq!(got.cluster, want.cluster, "{label}: cluster ids differ");
    let bits = |f: &Frame| -> Vec<u32> {
        let depth = f.depth.iter().map(|d| d.to_bits());
        let normal = f.normal.iter().flatten().map(|n| n.to_bits());
        let linear = f.linear.iter().flatten().map(|l| l.to_bits());
        depth.chain(normal).chain(linear).collect()
    };
    assert!(
        bits(got) == bits(want),
        "{label}: depth, normal or radiance bits differ"
    );
    assert_eq!(got.drawn_cells, want.drawn_cells, "{label}: drawn cells");
    assert_eq!(got.probed_cells, want.probed_cells, "{label}: probed cells");
    assert_eq!(got.samples, want.samples, "{label}: samples");
}

/// `CALLS` frames of `camera` alone, on a grid of its own, with a view of its own.
fn alone(r: &Renderer, grid: &isogrid::CellGrid, camera: &Camera, mode: Mode) -> Vec<Frame> {
    let gpu = r.upload_grid(grid).unwrap();
    let mut view = ViewState::new();
    (0..CALLS)
        .map(|_| {
            r.render_view(&mut view, Scene::Grid(&gpu), camera, mode, &OPTIONS)
                .unwrap()
        })
        .collect()
}

#[test]
fn two_views_of_one_grid_drawn_alternately_match_each_view_drawn_alone() {
    let Some(r) = renderer() else { return };
    // The reference renderer draws one camera at a time; it shares nothing with `r`.
    let Some(fresh) = new_renderer() else { return };
    // A hairball occludes itself, so culling leaves out clusters and probes find new ones.
    let (volume, grid) = scene(Field::Hairball, 40, None);
    let hi = volume.dims().map(|d| (d - 1) as f64);
    let cameras = [
        Camera::preset(1, [0.0; 3], hi, 96, 72).unwrap(),
        Camera::preset(2, [0.0; 3], hi, 80, 64).unwrap(),
    ];
    let shared = r.upload_grid(&grid).unwrap();
    for mode in [Mode::Cgc, Mode::PathTrace] {
        let mut views = [ViewState::new(), ViewState::new()];
        let mut alternating: [Vec<Frame>; 2] = [Vec::new(), Vec::new()];
        for _ in 0..CALLS {
            for (v, camera) in cameras.iter().enumerate() {
                let frame = r
                    .render_view(&mut views[v], Scene::Grid(&shared), camera, mode, &OPTIONS)
                    .unwrap();
                alternating[v].push(frame);
            }
        }
        for (v, camera) in cameras.iter().enumerate() {
            let reference = alone(&fresh, &grid, camera, mode);
            for (call, (got, want)) in alternating[v].iter().zip(&reference).enumerate() {
                assert_same(&format!("{mode:?} view {v} call {call}"), got, want);
            }
            // The comparison has something to compare: after the first call culling draws
            // fewer cells than the first frame's all-visible draw, and samples accumulate.
            let (first, last) = (&reference[0], &reference[CALLS - 1]);
            assert!(
                last.drawn_cells < first.drawn_cells,
                "{mode:?} view {v}: culling never kicked in ({} then {})",
                first.drawn_cells,
                last.drawn_cells
            );
            if mode == Mode::PathTrace {
                assert_eq!(last.samples, CALLS as u32);
            }
        }

        // One state shared by both cameras restarts at every switch: its later frames draw
        // every visible cluster again and hold one sample, so they differ from the ones above.
        let mut one = ViewState::new();
        let mut last = None;
        for _ in 0..CALLS {
            for camera in &cameras {
                last = Some(
                    r.render_view(&mut one, Scene::Grid(&shared), camera, mode, &OPTIONS)
                        .unwrap(),
                );
            }
        }
        let last = last.unwrap();
        let separate = &alternating[1][CALLS - 1];
        assert!(
            last.drawn_cells > separate.drawn_cells || last.samples < separate.samples,
            "{mode:?}: a shared state went unnoticed ({} cells, {} samples)",
            last.drawn_cells,
            last.samples
        );
    }
}

//! The interactive side: a scene uploaded once and drawn by a view across calls draws what the
//! one-shot `render` draws, and path tracing accumulates in the view while its view is unchanged.

use isogrid::generate::{generate, Field};
use isogrid::{extract, ErrorKind, ExtractOptions, Iso, Progress};
use isogrid_render::{
    render, Backend, CameraSpec, Mode, Placement, RenderContext, RenderRequest, RequestParts,
    SceneView, UploadedScene,
};

fn request(mode: Mode, samples: u32, eye: [f64; 3]) -> RenderRequest {
    RenderRequest::new(RequestParts {
        mode,
        backend: Backend::Gpu,
        camera: CameraSpec::LookAt {
            eye,
            target: [11.5; 3],
            up: [0.0, 0.0, 1.0],
            fovy_degrees: 40.0,
        },
        size: (40, 30),
        samples,
        ..RequestParts::default()
    })
    .unwrap()
}

#[test]
fn a_kept_scene_draws_what_one_shot_renders_draw_and_accumulates_samples() {
    let ctx = RenderContext::new();
    if ctx.adapter().is_none() {
        eprintln!("skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
        return;
    }
    let volume = generate(Field::Sphere, 24, 0);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let eye = [60.0, 40.0, 30.0];
    let progress = Progress::new();
    let mut scene = UploadedScene::new(&ctx, grid.info()).unwrap();
    let mut view = SceneView::new();

    // Nothing uploaded yet: refused with a clear error, no frame.
    assert!(!scene.can_draw(Mode::Cgc));
    let err = scene
        .render(&mut view, &request(Mode::Cgc, 1, eye), &progress)
        .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::InvalidInput, "{err}");

    scene.show_grid(&grid).unwrap();
    let cgc = request(Mode::Cgc, 1, eye);
    let kept = scene.render(&mut view, &cgc, &progress).unwrap();
    let one_shot = render(&ctx, &cgc, Placement::Gpu, &grid, None, &progress).unwrap();
    assert_eq!(kept.rgb8, one_shot.rgb8);
    assert_eq!(kept.cluster, one_shot.cluster);
    assert!(kept.hits() > 50, "{}", kept.hits());

    // CR needs the volume, laid out by the grid shown.
    assert!(!scene.can_draw(Mode::Cr));
    scene.show_volume(&volume).unwrap();
    let cr = request(Mode::Cr, 1, eye);
    let kept = scene.render(&mut view, &cr, &progress).unwrap();
    let one_shot = render(&ctx, &cr, Placement::Gpu, &grid, Some(&volume), &progress).unwrap();
    assert_eq!(kept.rgb8, one_shot.rgb8);
    // Another grid of the same input (here the same one again) keeps the volume's samples.
    scene.show_grid(&grid).unwrap();
    assert!(scene.can_draw(Mode::Cr) && !scene.can_draw(Mode::Mc));

    // Path tracing: one sample per call accumulates while the view stays, and two calls of one
    // sample are the one-shot render of two samples (the samples are seeded by their index).
    let one = request(Mode::PathTrace, 1, eye);
    let first = scene.render(&mut view, &one, &progress).unwrap();
    let second = scene.render(&mut view, &one, &progress).unwrap();
    assert_eq!((first.samples, second.samples), (Some(1), Some(2)));
    let two = request(Mode::PathTrace, 2, eye);
    let one_shot = render(&ctx, &two, Placement::Gpu, &grid, None, &progress).unwrap();
    assert_eq!(one_shot.samples, Some(2));
    assert_eq!(second.rgb8, one_shot.rgb8);
    // Another camera starts afresh; so does a second view of the same scene.
    let moved = request(Mode::PathTrace, 1, [62.0, 40.0, 30.0]);
    assert_eq!(
        scene.render(&mut view, &moved, &progress).unwrap().samples,
        Some(1)
    );
    let mut other_view = SceneView::new();
    assert_eq!(
        scene
            .render(&mut other_view, &one, &progress)
            .unwrap()
            .samples,
        Some(1)
    );
    assert_eq!(progress.counts(), (1, 1));
}

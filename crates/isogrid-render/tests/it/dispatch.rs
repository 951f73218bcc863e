//! Dispatch: the front door draws what the renderers draw when called directly, counts progress,
//! and stops on cancel within a tile (CPU) or a frame (GPU) with `ErrorKind::Cancelled`.

use isogrid::generate::{generate, Field};
use isogrid::{extract, CellGrid, ErrorKind, ExtractOptions, Iso, Progress};
use isogrid_render::{
    render, Backend, CameraSpec, Mode, Placement, RenderContext, RenderRequest, RequestParts,
};
use std::sync::OnceLock;

fn sphere() -> &'static CellGrid {
    static GRID: OnceLock<CellGrid> = OnceLock::new();
    GRID.get_or_init(|| {
        let volume = generate(Field::Sphere, 24, 0);
        extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap()
    })
}

fn path_trace(size: (u32, u32), samples: u32, backend: Backend) -> RenderRequest {
    RenderRequest::new(RequestParts {
        mode: Mode::PathTrace,
        backend,
        camera: CameraSpec::View(2),
        size,
        samples,
        ..RequestParts::default()
    })
    .unwrap()
}

#[test]
fn cpu_dispatch_draws_what_the_tracer_draws() {
    let grid = sphere();
    let request = path_trace((40, 30), 3, Backend::Cpu);
    let ctx = RenderContext::new();
    let progress = Progress::new();
    let out = render(&ctx, &request, Placement::Cpu, grid, None, &progress).unwrap();
    let (lo, hi) = grid.info().world_bounds();
    let camera = isogrid::Camera::preset(2, lo, hi, 40, 30).unwrap();
    let options = isogrid_trace::RenderOptions {
        shading: isogrid_trace::Shading::PathTrace(isogrid_trace::PathTraceOptions {
            samples_per_pixel: 3,
            ..Default::default()
        }),
        ..Default::default()
    };
    let direct = isogrid_trace::render(grid, &camera, &options).unwrap();
    assert_eq!(out.rgb8, direct.rgb8);
    assert_eq!(out.cluster, direct.cluster);
    assert!(out.hits() > 50 && out.hits() < 1200, "{}", out.hits());
    assert_eq!((out.placement, out.samples), (Placement::Cpu, Some(3)));
    // Rows of the primary pass and of each sample pass, all done.
    assert_eq!(progress.counts(), (4 * 30, 4 * 30));
}

#[test]
fn cpu_render_stops_within_a_tile_of_cancel() {
    let grid = sphere();
    // Far more work than the test waits for: 4096 samples of a 256×192 image.
    let request = path_trace((256, 192), 4096, Backend::Cpu);
    let ctx = RenderContext::new();
    let progress = Progress::new();
    let err = std::thread::scope(|s| {
        let worker = s.spawn(|| render(&ctx, &request, Placement::Cpu, grid, None, &progress));
        // Cancel once some rows are done, so the render is inside a sample pass.
        while progress.counts().0 < 200 && !worker.is_finished() {
            std::thread::yield_now();
        }
        progress.cancel();
        worker.join().unwrap().unwrap_err()
    });
    assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
    let (done, total) = progress.counts();
    assert!(done < total, "{done} of {total}");
    assert!(err.to_string().contains("interrupted"), "{err}");
}

#[test]
fn gpu_path_tracing_counts_frames_and_stops_on_cancel() {
    let ctx = RenderContext::new();
    if ctx.adapter().is_none() {
        eprintln!("skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
        return;
    }
    let grid = sphere();
    let request = path_trace((32, 24), 5, Backend::Gpu);
    let progress = Progress::new();
    let out = render(&ctx, &request, Placement::Gpu, grid, None, &progress).unwrap();
    assert_eq!((out.placement, out.samples), (Placement::Gpu, Some(5)));
    assert_eq!(progress.counts(), (5, 5));
    // Cancelled before the first frame: no frame runs.
    let cancelled = Progress::new();
    cancelled.cancel();
    let err = render(&ctx, &request, Placement::Gpu, grid, None, &cancelled).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
    // Cancelled mid-way: stops before the last of many frames.
    let long = path_trace((32, 24), 100_000, Backend::Gpu);
    let progress = Progress::new();
    let err = std::thread::scope(|s| {
        let worker = s.spawn(|| render(&ctx, &long, Placement::Gpu, grid, None, &progress));
        while progress.counts().0 < 2 && !worker.is_finished() {
            std::thread::yield_now();
        }
        progress.cancel();
        worker.join().unwrap().unwrap_err()
    });
    assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
    assert!(progress.counts().0 < 100_000);
}

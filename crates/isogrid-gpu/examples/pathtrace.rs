//! Path traces a generated volume (hybrid: raster primaries, traced secondaries, paper §3.6) and
//! writes the accumulated image as a PNG, printing per-frame times, e.g.
//! `cargo run --release -p isogrid-gpu --example pathtrace -- torus 64 out.png [view] [width] [height] [frames] [bounces]`.

use isogrid::generate::{generate, Field};
use isogrid::{extract, Camera, ExtractOptions, Iso};
use isogrid_gpu::{PathTraceOptions, Renderer, ViewState};
use std::error::Error;
use std::time::Instant;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_string());
    let field: Field = arg(0, "torus").parse()?;
    let size: usize = arg(1, "64").parse()?;
    let out = arg(2, "pathtrace.png");
    let view: u8 = arg(3, "2").parse()?;
    let width: u32 = arg(4, "256").parse()?;
    let height: u32 = arg(5, "192").parse()?;
    let frames: u32 = arg(6, "16").parse()?;
    let bounces: u32 = arg(7, "3").parse()?;

    let volume = generate(field, size, 1);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5)))?;
    let renderer = Renderer::new()?;
    println!("adapter: {}", renderer.adapter_info());
    let (lo, hi) = grid.info().world_bounds();
    let camera = Camera::preset(view, lo, hi, width, height)?;
    let gpu_grid = renderer.upload_grid(&grid)?;
    let options = |frames| PathTraceOptions {
        frames,
        bounces,
        ..Default::default()
    };
    // The first frame allocates the accumulation; time the others one call (one frame) each.
    let mut view = ViewState::new();
    let mut frame = renderer.path_trace_view(&mut view, &gpu_grid, &camera, &options(1))?;
    let mut wall = Vec::new();
    for _ in 1..frames {
        let start = Instant::now();
        frame = renderer.path_trace_view(&mut view, &gpu_grid, &camera, &options(1))?;
        wall.push(start.elapsed().as_secs_f64() * 1e3);
    }
    wall.sort_by(|a, b| a.total_cmp(b));
    let t = frame.timings;
    println!(
        "{field} {size}^3, {} active cells, {width}x{height}, {bounces} bounces, {} samples per pixel",
        grid.active_cells(),
        frame.samples
    );
    if let Some(median) = wall.get(wall.len() / 2) {
        println!("wall per frame (1 spp, with read-back): median {median:.1} ms");
    }
    println!(
        "last frame GPU: raster {:?} ms, shade {:?} ms, trace {:?} ms, frame {:?} ms",
        t.raster_ms, t.shade_ms, t.trace_ms, t.frame_ms
    );
    isogrid::fs::write_atomic(std::path::Path::new(&out), |w| {
        let mut encoder = png::Encoder::new(w, width, height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let png_error = |e: png::EncodingError| isogrid::Error::invalid(format!("PNG: {e}"));
        encoder
            .write_header()
            .map_err(png_error)?
            .write_image_data(&frame.rgba8)
            .map_err(png_error)
    })?;
    println!("wrote {out}");
    Ok(())
}

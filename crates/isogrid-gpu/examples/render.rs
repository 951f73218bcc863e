//! Renders a generated volume with the GPU renderer and writes a PNG, e.g.
//! `cargo run -p isogrid-gpu --example render -- sphere 64 cgc out.png [view] [width] [height] [frames]`.
//! Modes: cgc, cgc-no-ewa, mc, cr. Prints the adapter and the pass timings.

use isogrid::generate::{generate, Field};
use isogrid::{extract, Camera, ExtractOptions, Iso};
use isogrid_gpu::{Mode, Renderer, Scene};
use std::error::Error;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_string());
    let field: Field = arg(0, "torus").parse()?;
    let size: usize = arg(1, "64").parse()?;
    let mode = match arg(2, "cgc").as_str() {
        "cgc" => Mode::Cgc,
        "cgc-no-ewa" => Mode::CgcNoEwa,
        "mc" => Mode::Mc,
        "cr" => Mode::Cr,
        other => return Err(format!("unknown mode {other}").into()),
    };
    let out = arg(3, "render.png");
    let view: u8 = arg(4, "2").parse()?;
    let width: u32 = arg(5, "512").parse()?;
    let height: u32 = arg(6, "384").parse()?;
    let frames: u32 = arg(7, "4").parse()?;

    let volume = generate(field, size, 1);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5)))?;
    let renderer = Renderer::new()?;
    println!("adapter: {}", renderer.adapter_info());
    let (lo, hi) = grid.info().world_bounds();
    let camera = Camera::preset(view, lo, hi, width, height)?;
    let gpu_grid = renderer.upload_grid(&grid)?;
    let frame = match mode {
        Mode::Mc => {
            let mesh = isogrid::mc::marching_cubes(&volume.view(), grid.info().iso);
            let gpu_mesh = renderer.upload_mesh(&mesh)?;
            renderer.render(Scene::Mesh(&gpu_mesh), &camera, mode, frames)?
        }
        Mode::Cr => {
            let gpu_volume = renderer.upload_volume(&volume.view(), &gpu_grid)?;
            renderer.render(
                Scene::Volume {
                    grid: &gpu_grid,
                    volume: &gpu_volume,
                },
                &camera,
                mode,
                frames,
            )?
        }
        _ => renderer.render(Scene::Grid(&gpu_grid), &camera, mode, frames)?,
    };
    println!(
        "{field} {size}^3: {} active cells, {} clusters, {} page(s); {}x{} {mode:?}, {frames} frames; hits {}",
        grid.active_cells(),
        grid.clusters(),
        gpu_grid.page_count(),
        width,
        height,
        (0..frame.cluster.len()).filter(|&i| frame.is_hit(i)).count()
    );
    println!(
        "timings (median over frames after the first): {:?}",
        frame.timings
    );
    let file = std::fs::File::create(&out)?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header()?.write_image_data(&frame.rgba8)?;
    println!("wrote {out}");
    Ok(())
}

//! `isogrid demo`: the README's main job. Builds a built-in volume, extracts clustered grid cells,
//! and compares their memory and extraction time with the Marching Cubes mesh (paper Table 3).

use crate::args::ThreadArgs;
use crate::report::{group, mb, print_json, GridReport, MeshReport, Seconds};
use anyhow::Result;
use isogrid::generate::{generate, Field};
use isogrid::mc::marching_cubes;
use isogrid::{extract, ExtractOptions, GridStats, Iso, Progress};
use isogrid_render::{render, CameraSpec, Placement, RenderContext, RenderRequest, RequestParts};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Built-in volume to use.
    #[arg(long, default_value = "hairball")]
    pub field: Field,
    /// Samples per axis.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=2048))]
    pub size: u32,
    #[command(flatten)]
    pub threads: ThreadArgs,
    /// Picture of the isosurface (PNG), rendered where `isogrid render --backend auto` would.
    #[arg(long, value_name = "OUT.png", default_value = "isogrid-demo.png")]
    pub image: PathBuf,
    /// Size of the picture.
    #[arg(long, value_name = "WxH", default_value = "960x540", value_parser = super::render::parse_size)]
    pub image_size: (u32, u32),
    /// Also write the grid to this .cgc file.
    #[arg(short, long, value_name = "OUT.cgc")]
    pub output: Option<PathBuf>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct DemoReport {
    field: String,
    size: u32,
    cgc: GridReport,
    mc: MeshReport,
    /// CGC memory (Table 3's figure) over the MC mesh's.
    memory_ratio: f64,
    /// MC extraction time over CGC extraction time.
    speedup: f64,
    /// Where the picture was rendered: "gpu" or "cpu".
    image_backend: &'static str,
    image: PathBuf,
}

/// Renders view 2 of the grid to a PNG where the front door's policy places it; returns the
/// backend used and a description.
fn picture(
    grid: &isogrid::CellGrid,
    path: &std::path::Path,
    size: (u32, u32),
) -> Result<(&'static str, String)> {
    let request = RenderRequest::new(RequestParts {
        camera: CameraSpec::View(2),
        size,
        frames: 2,
        ..RequestParts::default()
    })?;
    let ctx = RenderContext::new();
    let decision = ctx.decide(&request)?;
    let image = render(
        &ctx,
        &request,
        decision.placement,
        grid,
        None,
        &Progress::new(),
    )?;
    isogrid_io::image::write_png(path, size.0, size.1, 3, &image.rgb8)?;
    Ok(match decision.placement {
        Placement::Gpu => ("gpu", image.adapter),
        Placement::Cpu => ("cpu", decision.note.unwrap_or(image.adapter)),
    })
}

pub fn run(args: Args) -> Result<()> {
    let mut outs = vec![crate::outputs::Output {
        role: "the picture",
        path: &args.image,
        extensions: &[".png"],
    }];
    outs.extend(args.output.as_deref().map(|path| crate::outputs::Output {
        role: "the grid",
        path,
        extensions: &[".cgc"],
    }));
    crate::outputs::check(&[], &outs)?;
    let start = Instant::now();
    let volume = generate(args.field, args.size as usize, 1);
    let generated = start.elapsed().as_secs_f64();
    let view = volume.view();
    let iso = Iso::Normalized(0.5);

    let start = Instant::now();
    let grid = args
        .threads
        .install(|| extract(&view, &ExtractOptions::new(iso)))??;
    let cgc_seconds = start.elapsed().as_secs_f64();
    let mut write = 0.0;
    if let Some(out) = &args.output {
        let start = Instant::now();
        isogrid::cgc::write(out, &grid)?;
        write = start.elapsed().as_secs_f64();
    }
    let stats = GridStats::of(&grid);

    let start = Instant::now();
    let mesh = args
        .threads
        .install(|| marching_cubes(&view, grid.info().iso))?;
    let mc_seconds = start.elapsed().as_secs_f64();

    let cgc = GridReport::new(
        &stats,
        Seconds {
            read: generated,
            extract: cgc_seconds,
            write,
        },
    );
    let mc = MeshReport {
        dims: stats.dims,
        iso: grid.info().iso,
        vertices: mesh.vertex_count() as u64,
        triangles: mesh.triangle_count() as u64,
        bytes: mesh.memory_bytes(),
        labels: None,
        seconds: Seconds {
            read: generated,
            extract: mc_seconds,
            write: 0.0,
        },
    };
    let memory_ratio = stats.bytes.paper_total as f64 / mc.bytes.max(1) as f64;
    let speedup = mc_seconds / cgc_seconds.max(1e-9);
    let (image_backend, renderer) = args
        .threads
        .install(|| picture(&grid, &args.image, args.image_size))??;
    if args.json {
        return print_json(&DemoReport {
            field: args.field.to_string(),
            size: args.size,
            cgc,
            mc,
            memory_ratio,
            speedup,
            image_backend,
            image: args.image.clone(),
        });
    }
    outln!(
        "isogrid demo: built-in '{}' volume, {}³ u8, generated in {generated:.2} s",
        args.field,
        args.size
    );
    outln!("isovalue: normalised 0.5 (= {})\n", grid.info().iso);
    outln!("== clustered grid cells (paper §3.1)");
    cgc.print_human(None, "")?;
    outln!("\n== Marching Cubes mesh (indexed, snorm16 positions, u32 indices)");
    mc.print_human()?;
    outln!("\n== comparison (paper Table 3: CGC uses about 37 % of the MC mesh's memory)");
    outln!(
        "memory        CGC {} vs MC {}: {:.1} %",
        mb(stats.bytes.paper_total),
        mb(mc.bytes),
        100.0 * memory_ratio
    );
    outln!(
        "extraction    CGC {:.3} s vs MC {:.3} s: {speedup:.1}x faster ({} cells vs {} triangles)",
        cgc_seconds,
        mc_seconds,
        group(stats.active_cells),
        group(mc.triangles)
    );
    outln!("\n== picture (view 2, cell rasterisation with EWA normals and deferred shading on a GPU; ray traced on the CPU otherwise)");
    outln!("wrote         {} ({renderer})", args.image.display());
    if let Some(out) = &args.output {
        outln!("wrote         {}", out.display());
    }
    Ok(())
}

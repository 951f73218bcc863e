//! `isogrid render`: an image of the isosurface with optional AOVs as `.npy`. On a GPU adapter
//! (lavapipe counts) by cell rasterisation (paper §3.2–3.4) or the MC / CR baselines; on the CPU
//! by ray tracing the same structure (§3.6) with the same shading, or path tracing under an
//! environment. `--backend auto` prefers the GPU and falls back to the CPU with a notice.

use super::render_gpu;
use crate::args::{parse_precision, InputArgs, ThreadArgs, TraversalArg};
use crate::outputs::{self, Output};
use crate::report::print_json;
use crate::{input, progress};
use anyhow::{bail, Context, Result};
use isogrid::{extract, Camera, CellGrid, ExtractOptions, Iso, Precision, Volume};
use isogrid_trace::{
    render_with_progress, Crossing, Environment, PathTraceOptions, RenderOptions, Shading,
};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `--iso V | --iso-normalized V`, needed unless the input is a `.cgc` file.
#[derive(clap::Args, Debug, Clone)]
#[group(required = false, multiple = false)]
pub struct OptionalIso {
    /// Isovalue in data units: a sample is inside when value >= V.
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<f64>,
    /// Isovalue as a fraction of the volume's value range (the paper uses 0.5).
    #[arg(long, value_name = "V")]
    pub iso_normalized: Option<f64>,
}

/// Where the grid of a render or benchmark comes from.
#[derive(clap::Args, Debug, Clone)]
pub struct GridSource {
    /// A .cgc file, or a volume (.nii/.nii.gz, .nrrd, .npy, .tif, .mha, .mrc, DICOM folder, raw) to
    /// extract.
    pub input: PathBuf,
    #[command(flatten)]
    pub iso: OptionalIso,
    /// Bits per stored corner value when extracting: 4, 8, 16 or 32.
    #[arg(long, value_name = "BITS", value_parser = parse_precision)]
    pub precision: Option<Precision>,
    #[command(flatten)]
    pub input_args: InputArgs,
}

fn is_cgc(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("cgc"))
}

impl GridSource {
    /// Opens the `.cgc` file or reads and extracts the volume (on the current rayon pool).
    pub fn load(&self) -> Result<CellGrid> {
        Ok(self.load_with_volume()?.0)
    }

    /// Like [`GridSource::load`], also keeping the volume (absent for `.cgc` files).
    pub fn load_with_volume(&self) -> Result<(CellGrid, Option<Volume>)> {
        if is_cgc(&self.input) {
            if self.iso.iso.is_some() || self.iso.iso_normalized.is_some() {
                bail!(
                    "{}: a .cgc file has its isovalue already; drop --iso/--iso-normalized",
                    self.input.display()
                );
            }
            if self.precision.is_some() {
                bail!(
                    "{}: a .cgc file has its precision already; drop --precision \
                     (or extract the volume again with it)",
                    self.input.display()
                );
            }
            let grid = isogrid::cgc::open(&self.input)?;
            crate::report::note_if_empty(&self.input, &grid);
            return Ok((grid, None));
        }
        let iso = match (self.iso.iso, self.iso.iso_normalized) {
            (Some(v), _) => Iso::Value(v),
            (_, Some(t)) => Iso::Normalized(t),
            _ => bail!(
                "{}: a volume needs --iso V or --iso-normalized V",
                self.input.display()
            ),
        };
        let (volume, _) = input::read_volume(&self.input, &self.input_args.read_options()?)?;
        let spinner = progress::spinner("extracting".into());
        let options = ExtractOptions {
            iso,
            precision: self.precision,
        };
        let grid = extract(&volume.view(), &options)
            .with_context(|| format!("{}: extraction failed", self.input.display()))?;
        spinner.finish_and_clear();
        crate::report::note_if_empty(&self.input, &grid);
        Ok((grid, Some(volume)))
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// The clustered grid cell isosurface: cell rasterisation with EWA normals on the GPU, ray
    /// traced on the CPU; Blinn–Phong shaded.
    Cgc,
    /// GPU only: cell rasterisation without EWA normal interpolation.
    CgcNoewa,
    /// GPU only: the Marching Cubes mesh.
    Mc,
    /// GPU only: cell rasterisation sampling the original volume.
    Cr,
    /// Path tracing under an environment: on the GPU hybrid (raster primaries, traced secondaries)
    /// or fully traced (--primary traced), one sample per pixel per frame, so --frames is the
    /// sample count; or on the CPU (--spp).
    Pathtrace,
}

/// Where GPU path tracing gets its primary hits.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primary {
    /// The paper's hybrid: rasterised (cell raster, EWA normals, deferred shading).
    Raster,
    /// Traced from the eye like the secondary rays, in the same compute pass, with no raster
    /// pass (faster on GPUs whose graphics pipeline is slow next to their compute).
    Traced,
}

impl Primary {
    fn name(self) -> &'static str {
        match self {
            Primary::Raster => "raster",
            Primary::Traced => "traced",
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellRasterArg {
    Auto,
    Hardware,
    Compute,
}

impl From<CellRasterArg> for isogrid_gpu::CellRaster {
    fn from(arg: CellRasterArg) -> Self {
        match arg {
            CellRasterArg::Auto => isogrid_gpu::CellRaster::Auto,
            CellRasterArg::Hardware => isogrid_gpu::CellRaster::Hardware,
            CellRasterArg::Compute => isogrid_gpu::CellRaster::Compute,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    Auto,
    Cpu,
    Gpu,
}

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub source: GridSource,
    /// What to draw.
    #[arg(long, value_enum, default_value = "cgc")]
    pub mode: Mode,
    /// Where to render: `auto` uses a GPU adapter when there is one, else the CPU.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    /// GPU: render the view this many times (the visibility buffer converges; timings are the
    /// median over frames after the first).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub frames: u32,
    /// GPU: draw every cluster every frame (turns off the visibility buffer of §3.3), to measure
    /// what culling saves.
    #[arg(long)]
    pub no_occlusion_culling: bool,
    /// GPU: which raster draws the cells: `compute` (one thread per cell), `hardware` (the
    /// paper's screen rectangles through the graphics pipeline) or `auto` (compute unless cells
    /// can cover more than 32 pixels across, as when the eye is inside the volume).
    #[arg(long, value_enum, default_value = "auto")]
    pub cell_raster: CellRasterArg,
    /// Image size in pixels.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Standard view of the grid's box: 1 (front) or 2 (oblique).
    #[arg(long, value_name = "1|2", default_value_t = 1, conflicts_with = "camera",
          value_parser = clap::value_parser!(u8).range(1..=2))]
    pub view: u8,
    /// Camera as EYE:TARGET:UP:FOVY in world units (points x,y,z; FOVY in degrees).
    #[arg(long, value_name = "EYE:TARGET:UP:FOVY", allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Write the image here (PNG).
    #[arg(short, long, value_name = "OUT.png")]
    pub output: Option<PathBuf>,
    /// Per-pixel outputs as .npy: depth=D.npy (f32 HxW, inf on miss), normal=N.npy (f32 HxWx3,
    /// NaN on miss), cluster=C.npy (u32 HxW, 4294967295 on miss), comma-separated.
    #[arg(long, value_name = "NAME=FILE,...", value_parser = parse_aovs)]
    pub aov: Option<Aovs>,
    /// Path tracing: samples per pixel.
    #[arg(long, value_name = "N", default_value_t = 16,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: u32,
    /// Path tracing: scatterings per path.
    #[arg(long, value_name = "N", default_value_t = 3)]
    pub bounces: u32,
    /// Path tracing: environment, `sky` or an equirectangular .hdr/.exr map (+y up).
    #[arg(long, value_name = "sky|FILE", default_value = "sky")]
    pub env: String,
    /// GPU path tracing: primary rays `raster` (the hybrid, default) or `traced`.
    #[arg(long, value_enum, value_name = "raster|traced")]
    pub primary: Option<Primary>,
    /// Path tracing: random seed.
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub seed: u64,
    /// Solve the exact crossing (cubic roots) instead of the paper's three samples per cell.
    #[arg(long)]
    pub exact: bool,
    /// CPU: how rays find candidate metacells, the same image either way (`bvh` traces each ray
    /// a little faster but takes longer to build, so one frame is rarely faster with it; see
    /// docs/benchmarks-render-cpu.md).
    #[arg(long, value_enum, default_value_t = TraversalArg::Blocks)]
    pub traversal: TraversalArg,
    #[command(flatten)]
    pub threads: ThreadArgs,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Output paths of `--aov`.
#[derive(Clone, Debug, Default)]
pub struct Aovs {
    pub depth: Option<PathBuf>,
    pub normal: Option<PathBuf>,
    pub cluster: Option<PathBuf>,
}

fn parse_aovs(s: &str) -> Result<Aovs, String> {
    let mut aovs = Aovs::default();
    for part in s.split(',') {
        let (name, file) = part
            .split_once('=')
            .filter(|(_, f)| !f.is_empty())
            .ok_or_else(|| format!("AOV {part:?} is not NAME=FILE"))?;
        let slot = match name.trim() {
            "depth" => &mut aovs.depth,
            "normal" => &mut aovs.normal,
            "cluster" => &mut aovs.cluster,
            other => return Err(format!("unknown AOV {other:?} (depth, normal or cluster)")),
        };
        if slot.replace(PathBuf::from(file)).is_some() {
            return Err(format!("AOV {name} given twice"));
        }
    }
    Ok(aovs)
}

/// "1280x720" → (1280, 720).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let max = isogrid_trace::render::MAX_PIXELS;
    let bad = || format!("size must be WxH, positive integers with W·H at most {max}, not {s:?}");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w as u64 * h as u64 > max {
        return Err(bad());
    }
    Ok((w, h))
}

#[derive(Serialize)]
struct RenderReport {
    backend: &'static str,
    /// The GPU adapter (name and API), for GPU renders.
    adapter: Option<String>,
    mode: &'static str,
    /// CPU: the crossing solver.
    crossing: Option<&'static str>,
    /// CPU: the traversal, and the part of `seconds` spent building it.
    traversal: Option<&'static str>,
    tracer_build_seconds: Option<f64>,
    width: u32,
    height: u32,
    /// Rendering only (not reading, extracting, uploading or writing), wall clock.
    seconds: f64,
    /// Pixels whose centre ray hit the surface.
    hits: u64,
    active_cells: u64,
    clusters: u64,
    /// CPU: rays traced and their rate.
    rays: Option<u64>,
    rays_per_second: Option<f64>,
    spp: Option<u32>,
    bounces: Option<u32>,
    /// GPU path tracing: where primary hits come from, "raster" or "traced".
    primary: Option<&'static str>,
    /// GPU: frames rendered, per-pass GPU times, cells drawn and probed in the last frame.
    frames: Option<u32>,
    gpu_ms: Option<render_gpu::GpuTimes>,
    drawn_cells: Option<u64>,
    probed_cells: Option<u64>,
    /// GPU: the raster that drew the cells, `compute` or `hardware`.
    cell_raster: Option<&'static str>,
    output: Option<PathBuf>,
}

/// The pixels and AOVs of a render, whichever backend made them.
struct Rendered {
    channels: u8,
    pixels: Vec<u8>,
    depth: Vec<f32>,
    normal: Vec<[f32; 3]>,
    cluster: Vec<u32>,
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Cgc => "cgc",
        Mode::CgcNoewa => "cgc-noewa",
        Mode::Mc => "mc",
        Mode::Cr => "cr",
        Mode::Pathtrace => "pathtrace",
    }
}

fn gpu_mode(mode: Mode) -> Option<isogrid_gpu::Mode> {
    match mode {
        Mode::Cgc => Some(isogrid_gpu::Mode::Cgc),
        Mode::CgcNoewa => Some(isogrid_gpu::Mode::CgcNoEwa),
        Mode::Mc => Some(isogrid_gpu::Mode::Mc),
        Mode::Cr => Some(isogrid_gpu::Mode::Cr),
        Mode::Pathtrace => None,
    }
}

/// Picks the backend before any data is read, so impossible requests fail fast.
fn choose_renderer(
    backend: Backend,
    mode: Mode,
    primary: Option<Primary>,
) -> Result<Option<isogrid_gpu::Renderer>> {
    if primary.is_some() && mode != Mode::Pathtrace {
        bail!(
            "--primary applies to --mode pathtrace on the GPU only, not to --mode {}",
            mode_name(mode)
        );
    }
    if primary.is_some() && backend == Backend::Cpu {
        bail!("--primary applies to GPU path tracing only; drop it or use --backend gpu");
    }
    if let (Some(p), Backend::Auto) = (primary, backend) {
        // Naming the primaries asks for the GPU path tracer; falling back would ignore it.
        return render_gpu::renderer()?.map(Some).ok_or_else(|| {
            anyhow::anyhow!(
                "--primary {} needs a GPU adapter and none was found",
                p.name()
            )
        });
    }
    let gpu_only = matches!(mode, Mode::CgcNoewa | Mode::Mc | Mode::Cr);
    match backend {
        Backend::Cpu if gpu_only => bail!(
            "mode {} needs the GPU renderer; on the CPU use --mode cgc or pathtrace",
            mode_name(mode)
        ),
        Backend::Cpu => Ok(None),
        Backend::Gpu => render_gpu::renderer()?.map(Some).ok_or_else(|| {
            anyhow::anyhow!(
                "no GPU adapter found (for a CPU Vulkan driver install mesa-vulkan-drivers)"
            )
        }),
        Backend::Auto => match render_gpu::renderer()? {
            Some(r) => Ok(Some(r)),
            None if gpu_only => bail!(
                "mode {} needs a GPU adapter and none was found",
                mode_name(mode)
            ),
            None => {
                eprintln!("isogrid: no GPU adapter, rendering on the CPU");
                Ok(None)
            }
        },
    }
}

/// Fills the GPU fields of the report and hands back the frame's pixels and AOVs.
fn gpu_rendered(report: &mut RenderReport, out: render_gpu::GpuRender, frames: u32) -> Rendered {
    report.backend = "gpu";
    report.adapter = Some(out.adapter);
    report.frames = Some(frames);
    report.gpu_ms = Some(out.times);
    let f = out.frame;
    report.hits = f.cluster.iter().filter(|&&c| c != u32::MAX).count() as u64;
    Rendered {
        channels: 4,
        pixels: f.rgba8,
        depth: f.depth,
        normal: f.normal,
        cluster: f.cluster,
    }
}

/// Host memory per pixel of a render, bytes: the CPU tracer keeps each pixel's primary hit
/// (64), radiance (12), path-tracing sum (24), sRGB (3), depth (4), normal (12) and cluster (4),
/// and the PNG encoder a row-filtered copy (4); the GPU read-back holds RGBA, depth, normal and
/// cluster (24) and their staging copies.
const BYTES_PER_PIXEL: u64 = 128;

/// The files `args` writes, checked against each other and the inputs before any work.
fn check_outputs(args: &Args) -> Result<()> {
    let mut outs = Vec::new();
    if let Some(path) = &args.output {
        outs.push(Output {
            role: "the image",
            path,
            extensions: &[".png"],
        });
    }
    if let Some(aovs) = &args.aov {
        for (role, path) in [
            ("the depth AOV", &aovs.depth),
            ("the normal AOV", &aovs.normal),
            ("the cluster AOV", &aovs.cluster),
        ] {
            if let Some(path) = path {
                outs.push(Output {
                    role,
                    path,
                    extensions: &[".npy"],
                });
            }
        }
    }
    let env = Path::new(&args.env);
    let mut inputs = vec![args.source.input.as_path()];
    if args.mode == Mode::Pathtrace && !args.env.eq_ignore_ascii_case("sky") {
        inputs.push(env);
    }
    outputs::check(&inputs, &outs)
}

pub fn run(args: Args) -> Result<()> {
    // Check everything that does not need the data first.
    check_outputs(&args)?;
    let (width, height) = args.size;
    isogrid::memory::ensure_fits(
        &format!("a {width}x{height} render"),
        width as u64 * height as u64 * BYTES_PER_PIXEL,
    )?;
    if let Some(spec) = &args.camera {
        Camera::parse(spec, width, height)?;
    }
    let env_map = match args.mode {
        Mode::Pathtrace if !args.env.eq_ignore_ascii_case("sky") => {
            Some(isogrid_io::image::read_env_map(Path::new(&args.env))?)
        }
        _ => None,
    };
    // The input before the GPU: a bad file or a missing --iso fails without starting a device
    // (whose drivers may print their own lines).
    let (grid, volume) = args.threads.install(|| args.source.load_with_volume())??;
    let renderer = choose_renderer(args.backend, args.mode, args.primary)?;
    let camera = match &args.camera {
        Some(spec) => Camera::parse(spec, width, height)?,
        None => {
            let (lo, hi) = grid.info().world_bounds();
            Camera::preset(args.view, lo, hi, width, height)?
        }
    };
    let mut report = RenderReport {
        backend: "cpu",
        adapter: None,
        mode: mode_name(args.mode),
        crossing: None,
        traversal: None,
        tracer_build_seconds: None,
        width,
        height,
        seconds: 0.0,
        hits: 0,
        active_cells: grid.active_cells() as u64,
        clusters: grid.clusters() as u64,
        rays: None,
        rays_per_second: None,
        spp: None,
        bounces: None,
        primary: None,
        frames: None,
        gpu_ms: None,
        drawn_cells: None,
        probed_cells: None,
        cell_raster: None,
        output: args.output.clone(),
    };

    let rendered = match (&renderer, gpu_mode(args.mode)) {
        (Some(renderer), None) => {
            let spinner = progress::spinner("path tracing on the GPU".into());
            let start = Instant::now();
            let primary = args.primary.unwrap_or(Primary::Raster);
            let out = render_gpu::path_trace(
                renderer,
                &grid,
                &camera,
                args.frames,
                args.bounces,
                env_map.as_ref(),
                match primary {
                    Primary::Raster => isogrid_gpu::PrimaryRays::Raster,
                    Primary::Traced => isogrid_gpu::PrimaryRays::Traced,
                },
            )?;
            report.seconds = start.elapsed().as_secs_f64();
            spinner.finish_and_clear();
            report.spp = Some(out.frame.samples);
            report.bounces = Some(args.bounces);
            report.primary = Some(primary.name());
            gpu_rendered(&mut report, out, args.frames)
        }
        (Some(renderer), Some(mode)) => {
            let spinner = progress::spinner("rendering on the GPU".into());
            let start = Instant::now();
            let out = render_gpu::render(
                renderer,
                &grid,
                volume.as_ref(),
                &camera,
                mode,
                &isogrid_gpu::RenderOptions {
                    frames: args.frames,
                    occlusion_culling: !args.no_occlusion_culling,
                    cell_raster: args.cell_raster.into(),
                    ..Default::default()
                },
            )?;
            report.seconds = start.elapsed().as_secs_f64();
            spinner.finish_and_clear();
            report.cell_raster = out.frame.cell_raster.map(|r| match r {
                isogrid_gpu::CellRaster::Hardware => "hardware",
                _ => "compute",
            });
            report.drawn_cells = Some(out.frame.drawn_cells);
            report.probed_cells = Some(out.frame.probed_cells);
            gpu_rendered(&mut report, out, args.frames)
        }
        _ => {
            let shading = match args.mode {
                Mode::Pathtrace => Shading::PathTrace(PathTraceOptions {
                    samples_per_pixel: args.spp,
                    bounces: args.bounces,
                    environment: env_map.map_or(Environment::Sky, Environment::Map),
                    seed: args.seed,
                    ..PathTraceOptions::default()
                }),
                _ => Shading::Phong,
            };
            let crossing = if args.exact {
                Crossing::Exact
            } else {
                Crossing::Samples3
            };
            let options = RenderOptions {
                crossing,
                traversal: args.traversal.into(),
                shading,
            };
            let passes = match &options.shading {
                Shading::PathTrace(p) => 1 + p.samples_per_pixel as u64,
                Shading::Phong => 1,
            };
            let bar = progress::bar("rendering", passes);
            let start = Instant::now();
            let image = args.threads.install(|| {
                render_with_progress(&grid, &camera, &options, &|done, _| bar.set_position(done))
            })??;
            report.seconds = start.elapsed().as_secs_f64();
            bar.finish_and_clear();
            report.crossing = Some(if args.exact { "exact" } else { "samples3" });
            report.traversal = Some(options.traversal.name());
            report.tracer_build_seconds = Some(image.build_seconds);
            report.hits = image.hits() as u64;
            report.rays = Some(image.rays_traced);
            report.rays_per_second = Some(image.rays_traced as f64 / report.seconds.max(1e-9));
            if args.mode == Mode::Pathtrace {
                report.spp = Some(args.spp);
                report.bounces = Some(args.bounces);
            }
            Rendered {
                channels: 3,
                pixels: image.rgb8,
                depth: image.depth,
                normal: image.normal,
                cluster: image.cluster,
            }
        }
    };

    if let Some(out) = &args.output {
        isogrid_io::image::write_png(out, width, height, rendered.channels, &rendered.pixels)?;
    }
    if let Some(aovs) = &args.aov {
        if let Some(p) = &aovs.depth {
            isogrid_io::image::write_npy_f32_hw(p, width, height, &rendered.depth)?;
        }
        if let Some(p) = &aovs.normal {
            isogrid_io::image::write_npy_f32_hw3(p, width, height, &rendered.normal)?;
        }
        if let Some(p) = &aovs.cluster {
            isogrid_io::image::write_npy_u32_hw(p, width, height, &rendered.cluster)?;
        }
    }
    if args.json {
        return print_json(&report);
    }
    let on = match &report.adapter {
        Some(a) => format!("on the GPU ({a})"),
        None => "on the CPU".to_string(),
    };
    println!(
        "rendered      {width}x{height} {} {on} in {:.3} s ({} of {} pixels hit)",
        report.mode,
        report.seconds,
        report.hits,
        width as u64 * height as u64
    );
    if let Some(t) = &report.gpu_ms {
        let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2} ms"));
        println!(
            "gpu passes    raster {} (without EWA {}), shade {}, cull {}, trace {}, frame {}",
            ms(t.raster_ms),
            ms(t.raster_no_ewa_ms),
            ms(t.shade_ms),
            ms(t.cull_ms),
            ms(t.trace_ms),
            ms(t.frame_ms)
        );
    }
    if let Some(out) = &args.output {
        println!("wrote         {}", out.display());
    }
    Ok(())
}

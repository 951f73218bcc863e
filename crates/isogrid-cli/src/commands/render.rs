//! `isogrid render`: an image of the isosurface, traced on the CPU (paper §3.6) with the shared
//! Blinn–Phong shading, or path traced under an environment; optional AOVs as `.npy`.
//!
//! The GPU renderer (cell rasterisation, §3.2–3.4) is not part of this build: `--backend gpu`
//! fails, `auto` falls back to the CPU with a notice.

use crate::args::{parse_precision, InputArgs, ThreadArgs};
use crate::report::print_json;
use crate::{input, progress};
use anyhow::{bail, Context, Result};
use isogrid::trace::{
    render_with_progress, Crossing, Environment, PathTraceOptions, RenderOptions, Shading,
};
use isogrid::{extract, Camera, CellGrid, ExtractOptions, Iso, Precision};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `--iso V | --iso-normalized V`, needed unless the input is a `.cgc` file.
#[derive(clap::Args, Debug, Clone)]
#[group(required = false, multiple = false)]
pub struct OptionalIso {
    /// Isovalue in data units: a sample is inside when value >= V.
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub iso: Option<f64>,
    /// Isovalue as a fraction of the volume's value range (the paper uses 0.5).
    #[arg(long, value_name = "V")]
    pub iso_normalized: Option<f64>,
}

/// Where the grid of a render or benchmark comes from.
#[derive(clap::Args, Debug, Clone)]
pub struct GridSource {
    /// A .cgc file, or a volume (.nii/.nii.gz, .nrrd, .npy, .tif, DICOM folder, raw) to extract.
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
        if is_cgc(&self.input) {
            if self.iso.iso.is_some() || self.iso.iso_normalized.is_some() {
                bail!(
                    "{}: a .cgc file has its isovalue already; drop --iso/--iso-normalized",
                    self.input.display()
                );
            }
            return Ok(isogrid::cgc::open(&self.input)?);
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
        Ok(grid)
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// The clustered grid cell isosurface (traced on the CPU), Blinn–Phong shaded.
    Cgc,
    /// GPU only: cell rasterisation without EWA normal interpolation.
    CgcNoewa,
    /// GPU only: the Marching Cubes mesh.
    Mc,
    /// GPU only: cell rasterisation sampling the original volume.
    Cr,
    /// Monte Carlo path tracing under an environment (CPU).
    Pathtrace,
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
    /// Where to render.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
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
    /// Path tracing: random seed.
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub seed: u64,
    /// Solve the exact crossing (cubic roots) instead of the paper's three samples per cell.
    #[arg(long)]
    pub exact: bool,
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
    let bad = || format!("size must be WxH with positive integers, not {s:?}");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w as u64 * h as u64 > isogrid::trace::render::MAX_PIXELS {
        return Err(bad());
    }
    Ok((w, h))
}

#[derive(Serialize)]
struct RenderReport {
    backend: &'static str,
    mode: &'static str,
    crossing: &'static str,
    width: u32,
    height: u32,
    /// Rendering only (not reading, extracting or writing).
    seconds: f64,
    /// Pixels whose centre ray hit the surface.
    hits: u64,
    rays: u64,
    rays_per_second: f64,
    spp: Option<u32>,
    bounces: Option<u32>,
    output: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    // Check everything that does not need the data first.
    if args.backend == Backend::Gpu {
        bail!("GPU backend not available in this build");
    }
    let mode_name = match args.mode {
        Mode::Cgc => "cgc",
        Mode::Pathtrace => "pathtrace",
        Mode::CgcNoewa | Mode::Mc | Mode::Cr => bail!(
            "mode {:?} needs the GPU renderer; on the CPU use --mode cgc or pathtrace",
            args.mode
        ),
    };
    if let Some(out) = &args.output {
        if !out
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            bail!("{}: the image output must end in .png", out.display());
        }
    }
    let (width, height) = args.size;
    if let Some(spec) = &args.camera {
        Camera::parse(spec, width, height)?;
    }
    let shading = match args.mode {
        Mode::Pathtrace => Shading::PathTrace(PathTraceOptions {
            samples_per_pixel: args.spp,
            bounces: args.bounces,
            environment: if args.env.eq_ignore_ascii_case("sky") {
                Environment::Sky
            } else {
                Environment::Map(isogrid_io::image::read_env_map(Path::new(&args.env))?)
            },
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

    let grid = args.threads.install(|| args.source.load())??;
    let camera = match &args.camera {
        Some(spec) => Camera::parse(spec, width, height)?,
        None => {
            let (lo, hi) = grid.info().world_bounds();
            Camera::preset(args.view, lo, hi, width, height)?
        }
    };
    let options = RenderOptions { crossing, shading };
    let passes = match &options.shading {
        Shading::PathTrace(p) => 1 + p.samples_per_pixel as u64,
        Shading::Phong => 1,
    };
    if args.backend == Backend::Auto {
        eprintln!("isogrid: no GPU renderer, rendering on the CPU");
    }
    let bar = progress::bar("rendering", passes);
    let start = Instant::now();
    let image = args.threads.install(|| {
        render_with_progress(&grid, &camera, &options, &|done, _| bar.set_position(done))
    })??;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();

    if let Some(out) = &args.output {
        isogrid_io::image::write_png(out, width, height, 3, &image.rgb8)?;
    }
    if let Some(aovs) = &args.aov {
        if let Some(p) = &aovs.depth {
            isogrid_io::image::write_npy_f32_hw(p, width, height, &image.depth)?;
        }
        if let Some(p) = &aovs.normal {
            isogrid_io::image::write_npy_f32_hw3(p, width, height, &image.normal)?;
        }
        if let Some(p) = &aovs.cluster {
            isogrid_io::image::write_npy_u32_hw(p, width, height, &image.cluster)?;
        }
    }
    let path_traced = matches!(options.shading, Shading::PathTrace(_));
    let report = RenderReport {
        backend: "cpu",
        mode: mode_name,
        crossing: if args.exact { "exact" } else { "samples3" },
        width,
        height,
        seconds,
        hits: image.hits() as u64,
        rays: image.rays_traced,
        rays_per_second: image.rays_traced as f64 / seconds.max(1e-9),
        spp: path_traced.then_some(args.spp),
        bounces: path_traced.then_some(args.bounces),
        output: args.output.clone(),
    };
    if args.json {
        print_json(&report)
    } else {
        println!(
            "rendered      {width}x{height} {mode_name} on the CPU in {seconds:.3} s ({} of {} pixels hit, {:.2} Mrays/s)",
            report.hits,
            width as u64 * height as u64,
            report.rays_per_second / 1e6
        );
        if let Some(out) = &args.output {
            println!("wrote         {}", out.display());
        }
        Ok(())
    }
}

//! `isogrid render`: an image of the isosurface with optional AOVs as `.npy`. The flags become an
//! [`isogrid_render::RenderRequest`]; the front door's policy places it on the GPU renderer or the
//! CPU tracer and runs it with a progress bar, and Ctrl-C stops it cleanly with nothing written.

use crate::args::{parse_labels_or_names, ThreadArgs, TraversalArg};
use crate::grid_source::GridSource;
use crate::outputs::{self, Output};
use crate::progress;
use crate::report::print_json;
use anyhow::{bail, Context, Result};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use isogrid::colormap::{ColorMap, Coloring};
use isogrid::{Camera, Progress};
use isogrid_render::{
    Aov, Backend, CameraSpec, CellRaster, ColorSpec, Crossing, EnvSource, Mode, Placement, Primary,
    RenderContext, RenderRequest, Rendered, RequestParts,
};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Samples per pixel of path tracing when neither `--spp` nor `--frames` says.
const DEFAULT_SAMPLES: u32 = 16;

/// `--mode`, by the front door's names (also the viewer's).
pub fn mode_parser() -> impl TypedValueParser<Value = Mode> {
    PossibleValuesParser::new(Mode::ALL.map(Mode::name)).map(|s| s.parse::<Mode>().unwrap())
}

fn backend_parser() -> impl TypedValueParser<Value = Backend> {
    PossibleValuesParser::new(["auto", "cpu", "gpu"]).map(|s| s.parse::<Backend>().unwrap())
}

fn primary_parser() -> impl TypedValueParser<Value = Primary> {
    PossibleValuesParser::new(["raster", "traced"]).map(|s| s.parse::<Primary>().unwrap())
}

fn cell_raster_parser() -> impl TypedValueParser<Value = CellRaster> {
    PossibleValuesParser::new(["auto", "hardware", "compute"]).map(|s| match s.as_str() {
        "hardware" => CellRaster::Hardware,
        "compute" => CellRaster::Compute,
        _ => CellRaster::Auto,
    })
}

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub source: GridSource,
    /// What to draw: `cgc` (cell rasterisation with EWA normals on the GPU, ray traced on the
    /// CPU; Blinn–Phong), GPU only `cgc-noewa` (no EWA), `mc` (the Marching Cubes mesh) and `cr`
    /// (cells sampling the original volume), or `pathtrace` (under an environment; on the GPU
    /// one sample per pixel per frame, raster or traced primaries).
    #[arg(long, default_value = "cgc", value_parser = mode_parser())]
    pub mode: Mode,
    /// Where to render: `auto` takes a hardware GPU adapter when there is one; with only a
    /// software one (lavapipe) the faster backend for the mode (docs/benchmarks-render-policy.md);
    /// else the CPU.
    #[arg(long, default_value = "auto", value_parser = backend_parser())]
    pub backend: Backend,
    /// GPU raster modes: render the view this many times (the visibility buffer converges;
    /// timings are the median over frames after the first). Path tracing: the sample count,
    /// when --spp is not given.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub frames: Option<u32>,
    /// GPU: draw every cluster every frame (turns off the visibility buffer of §3.3), to measure
    /// what culling saves.
    #[arg(long)]
    pub no_occlusion_culling: bool,
    /// GPU: which raster draws the cells: `compute` (one thread per cell), `hardware` (the
    /// paper's screen rectangles through the graphics pipeline) or `auto` (compute unless cells
    /// can cover more than 32 pixels across, as when the eye is inside the volume).
    #[arg(long, default_value = "auto", value_parser = cell_raster_parser())]
    pub cell_raster: CellRaster,
    /// Image size in pixels.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Standard view of the grid's box: 1 (front) or 2 (oblique).
    #[arg(long, value_name = "1|2", default_value_t = 1, conflicts_with = "camera",
          value_parser = clap::value_parser!(u8).range(1..=2))]
    pub view: u8,
    /// What the standard view frames: `grid` (the grid's box) or `surface` (the box of the
    /// active cells; with --show/--hide, of the shown labels'), so that a small structure fills
    /// the image.
    #[arg(long, value_enum, default_value_t = Frame::Grid, conflicts_with = "camera")]
    pub frame: Frame,
    /// Camera as EYE:TARGET:UP:FOVY, points as x,y,z in index × spacing units (sample (i, j, k)
    /// at (i·sx, j·sy, k·sz)), FOVY in degrees. Where the volume's axes mirror its world, the
    /// image is mirrored back so that it shows the world as it lies.
    #[arg(long, value_name = "EYE:TARGET:UP:FOVY", allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Write the image here (PNG).
    #[arg(short, long, value_name = "OUT.png")]
    pub output: Option<PathBuf>,
    /// Per-pixel outputs as .npy: depth=D.npy (f32 HxW, inf on miss), normal=N.npy (f32 HxWx3,
    /// NaN on miss), cluster=C.npy (u32 HxW, 4294967295 on miss), value=V.npy (f32 HxW, the
    /// attribute at the hit cell, NaN on a miss), label=L.npy (u64 HxW, the label value under
    /// the pixel of a label grid, 18446744073709551615 on a miss), comma-separated.
    #[arg(long, value_name = "NAME=FILE,...", value_parser = parse_aovs)]
    pub aov: Option<Aovs>,
    /// Path tracing: samples per pixel, on either backend (default 16, or --frames).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Path tracing: scatterings per path.
    #[arg(long, value_name = "N", default_value_t = 3)]
    pub bounces: u32,
    /// Path tracing: environment, `sky` or an equirectangular .hdr/.exr map (+y up).
    #[arg(long, value_name = "sky|FILE", default_value = "sky")]
    pub env: String,
    /// GPU path tracing: primary rays `raster` (the hybrid, default) or `traced`.
    #[arg(long, value_name = "raster|traced", value_parser = primary_parser())]
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
    /// Colour map of the attribute (a .cgc's own, or --color-by): viridis (default), magma,
    /// inferno, plasma, cividis, turbo, gray or rdbu.
    #[arg(long, value_name = "NAME", value_parser = parse_cmap)]
    pub cmap: Option<ColorMap>,
    /// Values the colour map spans, LO,HI (default: the attribute's range on the surface).
    #[arg(long, value_name = "LO,HI", value_parser = parse_clim, allow_hyphen_values = true)]
    pub clim: Option<[f64; 2]>,
    /// Draw a colour bar of the attribute's map, labelled with its range, at the image's right
    /// edge.
    #[arg(long)]
    pub colorbar: bool,
    /// A label grid: draw only these labels, by value or name, e.g. 1,5-9 or liver,spleen (all
    /// by default).
    #[arg(long, value_name = "LABELS", value_parser = parse_labels_or_names, allow_hyphen_values = true)]
    pub show: Option<isogrid::LabelSelection>,
    /// A label grid: do not draw these labels (values or names), e.g. 0,3; their neighbours show
    /// their own surfaces where they touched them.
    #[arg(long, value_name = "LABELS", value_parser = parse_labels_or_names, allow_hyphen_values = true)]
    pub hide: Option<isogrid::LabelSelection>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

pub(crate) fn parse_cmap(s: &str) -> Result<ColorMap, String> {
    ColorMap::from_name(s).map_err(|e| e.to_string())
}

/// "LO,HI" → [LO, HI], finite with LO < HI.
pub(crate) fn parse_clim(s: &str) -> Result<[f64; 2], String> {
    let bad = || format!("--clim takes LO,HI with finite LO < HI, not {s:?}");
    let (lo, hi) = s.split_once(',').ok_or_else(bad)?;
    let clim = [
        lo.trim().parse().map_err(|_| bad())?,
        hi.trim().parse().map_err(|_| bad())?,
    ];
    isogrid::colormap::check_clim(clim).map_err(|_| bad())?;
    Ok(clim)
}

/// Output paths of `--aov`.
#[derive(Clone, Debug, Default)]
pub struct Aovs {
    pub depth: Option<PathBuf>,
    pub normal: Option<PathBuf>,
    pub cluster: Option<PathBuf>,
    pub value: Option<PathBuf>,
    pub label: Option<PathBuf>,
}

impl Aovs {
    fn slot(&mut self, aov: Aov) -> &mut Option<PathBuf> {
        match aov {
            Aov::Depth => &mut self.depth,
            Aov::Normal => &mut self.normal,
            Aov::Cluster => &mut self.cluster,
            Aov::Value => &mut self.value,
            Aov::Label => &mut self.label,
        }
    }

    /// (AOV, file) of each requested output.
    fn files(&self) -> Vec<(Aov, &PathBuf)> {
        [
            (Aov::Depth, &self.depth),
            (Aov::Normal, &self.normal),
            (Aov::Cluster, &self.cluster),
            (Aov::Value, &self.value),
            (Aov::Label, &self.label),
        ]
        .into_iter()
        .filter_map(|(aov, path)| path.as_ref().map(|p| (aov, p)))
        .collect()
    }
}

fn parse_aovs(s: &str) -> Result<Aovs, String> {
    let mut aovs = Aovs::default();
    for part in s.split(',') {
        let (name, file) = part
            .split_once('=')
            .filter(|(_, f)| !f.is_empty())
            .ok_or_else(|| format!("AOV {part:?} is not NAME=FILE"))?;
        let aov: Aov = name.parse().map_err(|e: isogrid::Error| e.to_string())?;
        if aovs.slot(aov).replace(PathBuf::from(file)).is_some() {
            return Err(format!("AOV {name} given twice"));
        }
    }
    Ok(aovs)
}

/// "1280x720" → (1280, 720).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let max = isogrid_render::MAX_PIXELS;
    let bad = || format!("size must be WxH, positive integers with W·H at most {max}, not {s:?}");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w as u64 * h as u64 > max {
        return Err(bad());
    }
    Ok((w, h))
}

/// Per-pass GPU milliseconds (median over frames after the first), `null` where unmeasured.
#[derive(Serialize, Default)]
pub struct GpuTimes {
    /// Depth + G-buffer: cell raster (both visibility passes) plus EWA, or the MC mesh (Table 4).
    pub raster_ms: Option<f64>,
    /// Raster without the EWA pass.
    pub raster_no_ewa_ms: Option<f64>,
    pub ewa_ms: Option<f64>,
    pub shade_ms: Option<f64>,
    pub cull_ms: Option<f64>,
    pub frame_ms: Option<f64>,
    /// Path tracing: the compute pass tracing secondary rays (and primary ones when traced).
    pub trace_ms: Option<f64>,
}

impl From<isogrid_gpu::PassTimings> for GpuTimes {
    fn from(t: isogrid_gpu::PassTimings) -> Self {
        GpuTimes {
            raster_ms: t.raster_ms,
            raster_no_ewa_ms: t.raster_ms.map(|r| r - t.ewa_ms.unwrap_or(0.0)),
            ewa_ms: t.ewa_ms,
            shade_ms: t.shade_ms,
            cull_ms: t.cull_ms,
            frame_ms: t.frame_ms,
            trace_ms: t.trace_ms,
        }
    }
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
    gpu_ms: Option<GpuTimes>,
    drawn_cells: Option<u64>,
    probed_cells: Option<u64>,
    /// GPU: the raster that drew the cells, `compute` or `hardware`.
    cell_raster: Option<&'static str>,
    /// The colour map and range when the surface is coloured by its attribute.
    color: Option<ColorReport>,
    output: Option<PathBuf>,
}

#[derive(Serialize)]
struct ColorReport {
    attribute: String,
    cmap: &'static str,
    clim: [f64; 2],
}

impl RenderReport {
    fn new(
        args: &Args,
        grid: &isogrid::CellGrid,
        r: Rendered,
        coloring: Option<&Coloring>,
    ) -> (Self, Rendered) {
        let path_trace = args.mode == Mode::PathTrace;
        let cpu = r.cpu.as_ref();
        let gpu = r.gpu.as_ref();
        let report = RenderReport {
            backend: match r.placement {
                Placement::Cpu => "cpu",
                Placement::Gpu => "gpu",
            },
            adapter: gpu.map(|_| r.adapter.clone()),
            mode: args.mode.name(),
            crossing: cpu.map(|c| c.crossing),
            traversal: cpu.map(|c| c.traversal),
            tracer_build_seconds: cpu.map(|c| c.build_seconds),
            width: r.width,
            height: r.height,
            seconds: r.seconds,
            hits: r.hits() as u64,
            active_cells: grid.active_cells() as u64,
            clusters: grid.clusters() as u64,
            rays: cpu.map(|c| c.rays),
            rays_per_second: cpu.map(|c| c.rays as f64 / r.seconds.max(1e-9)),
            spp: r.samples,
            bounces: path_trace.then_some(args.bounces),
            primary: gpu
                .filter(|_| path_trace)
                .map(|_| args.primary.unwrap_or_default().name()),
            frames: gpu.map(|g| g.frames),
            gpu_ms: gpu.map(|g| GpuTimes::from(g.timings)),
            drawn_cells: gpu.filter(|_| !path_trace).map(|g| g.drawn_cells),
            probed_cells: gpu.filter(|_| !path_trace).map(|g| g.probed_cells),
            cell_raster: gpu.and_then(|g| g.cell_raster).map(|c| match c {
                CellRaster::Hardware => "hardware",
                _ => "compute",
            }),
            color: grid.attribute().zip(coloring).map(|(a, c)| ColorReport {
                attribute: a.info().name.clone(),
                cmap: c.map.name(),
                clim: c.clim,
            }),
            output: args.output.clone(),
        };
        (report, r)
    }
}

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
    let aov_files = args.aov.as_ref().map(Aovs::files).unwrap_or_default();
    for (aov, path) in &aov_files {
        outs.push(Output {
            role: match aov {
                Aov::Depth => "the depth AOV",
                Aov::Normal => "the normal AOV",
                Aov::Cluster => "the cluster AOV",
                Aov::Value => "the value AOV",
                Aov::Label => "the label AOV",
            },
            path,
            extensions: &[".npy"],
        });
    }
    let env = EnvSource::parse(&args.env);
    let mut inputs = vec![args.source.input.as_path()];
    inputs.extend(env.path());
    let color_by = args.source.color.color_by.as_deref().map(Path::new);
    inputs.extend(color_by.filter(|p| p.exists()));
    outputs::check(&inputs, &outs)
}

/// Whether the flags ask for colour whatever the grid holds.
fn color_asked(args: &Args) -> bool {
    args.cmap.is_some()
        || args.clim.is_some()
        || args.colorbar
        || args.source.color.color_by.is_some()
        || args.aov.as_ref().is_some_and(|a| a.value.is_some())
}

/// The request the flags describe (checked, environment map read); `colored`: colour the
/// surface by the grid's attribute.
fn request(args: &Args, colored: bool) -> Result<RenderRequest> {
    let (width, height) = args.size;
    let camera = match &args.camera {
        Some(spec) => {
            let c = Camera::parse(spec, width, height)?;
            CameraSpec::LookAt {
                eye: c.eye,
                target: c.target,
                up: c.up,
                fovy_degrees: c.fovy_degrees,
            }
        }
        None => match args.frame {
            Frame::Grid => CameraSpec::View(args.view),
            Frame::Surface => CameraSpec::SurfaceView(args.view),
        },
    };
    // Path tracing takes one sample per GPU frame, so --frames has long meant its samples.
    let samples = match (args.spp, args.frames) {
        (Some(spp), Some(frames)) if args.mode == Mode::PathTrace && spp != frames => bail!(
            "--spp {spp} and --frames {frames} both set the samples of path tracing; give one"
        ),
        (Some(spp), _) => spp,
        (None, Some(frames)) if args.mode == Mode::PathTrace => frames,
        _ => DEFAULT_SAMPLES,
    };
    let parts = RequestParts {
        mode: args.mode,
        backend: args.backend,
        camera,
        size: args.size,
        environment: EnvSource::parse(&args.env),
        samples,
        frames: args.frames.unwrap_or(1),
        bounces: args.bounces,
        primary: args.primary,
        traversal: args.traversal.into(),
        crossing: if args.exact {
            Crossing::Exact
        } else {
            Crossing::Samples3
        },
        seed: args.seed,
        aovs: args
            .aov
            .as_ref()
            .map(|a| a.files().into_iter().map(|(aov, _)| aov).collect())
            .unwrap_or_default(),
        occlusion_culling: !args.no_occlusion_culling,
        cell_raster: args.cell_raster,
        color: colored.then(|| ColorSpec {
            map: args.cmap.unwrap_or_default(),
            clim: args.clim,
        }),
        show: args.show.clone(),
        hide: args.hide.clone(),
    };
    Ok(RenderRequest::new(parts)?)
}

/// `--frame`: the box a standard view frames.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Frame {
    Grid,
    Surface,
}

pub fn run(args: Args) -> Result<()> {
    // Everything that does not need the data first.
    check_outputs(&args)?;
    request(&args, color_asked(&args))?;
    if args.source.label.labels.is_some() && args.mode == Mode::Cr {
        bail!(
            "{}: mode cr samples the volume's values, and a label volume's values are no surface; \
             draw its labels with cgc, cgc-noewa, mc or pathtrace",
            args.source.input.display()
        );
    }
    let (min_w, min_h) = isogrid_render::colorbar::MIN_SIZE;
    if args.colorbar && (args.size.0 < min_w || args.size.1 < min_h) {
        bail!(
            "--colorbar needs an image of at least {min_w}x{min_h} pixels, not {}x{}",
            args.size.0,
            args.size.1
        );
    }
    // The input before the GPU: a bad file or a missing --iso fails without starting a device
    // (whose drivers may print their own lines).
    let (grid, volume) = args.threads.install(|| args.source.load_with_volume())??;
    if color_asked(&args) && grid.attribute().is_none() {
        bail!(
            "{}: --cmap, --clim, --colorbar and the value AOV colour by the grid's attribute, and it has none \
             (extract with --color-by ATTR, or give --color-by here)",
            args.source.input.display()
        );
    }
    let request = request(&args, grid.attribute().is_some())?;
    // --show / --hide name labels of this grid: checked before a backend is chosen.
    isogrid_render::label_choice(&request, &grid)
        .with_context(|| args.source.input.display().to_string())?;
    let ctx = RenderContext::new();
    let decision = ctx.decide(&request)?;
    if let Some(note) = &decision.note {
        eprintln!("isogrid: {note}");
    }
    let progress = Arc::new(Progress::new());
    let message = match decision.placement {
        Placement::Cpu => "rendering on the CPU",
        Placement::Gpu => "rendering on the GPU",
    };
    let rendered = progress::watched(message, &progress, || {
        args.threads.install(|| {
            isogrid_render::render(
                &ctx,
                &request,
                decision.placement,
                &grid,
                volume.as_ref(),
                &progress,
            )
        })
    })?;
    let rendered = match rendered {
        Err(e) if e.kind() == isogrid::ErrorKind::Cancelled => {
            return Err(anyhow::Error::from(e).context("render stopped by Ctrl-C, nothing written"))
        }
        r => r.with_context(|| args.source.input.display().to_string())?,
    };
    let (width, height) = args.size;
    let coloring = match (&request.parts().color, grid.attribute()) {
        (Some(spec), Some(attribute)) => Some(spec.coloring(attribute.info())?),
        _ => None,
    };
    let (report, mut rendered) = RenderReport::new(&args, &grid, rendered, coloring.as_ref());
    if let (true, Some(coloring)) = (args.colorbar, &coloring) {
        isogrid_render::colorbar::draw(&mut rendered.rgb8, width, height, coloring)?;
    }

    // Every output is written before any replaces its file: a failure (a full disk) leaves all
    // of them as they were.
    let mut staged = Vec::new();
    if let Some(out) = &args.output {
        staged.push(isogrid_io::image::stage_png(
            out,
            width,
            height,
            3,
            &rendered.rgb8,
        )?);
    }
    for (aov, path) in args.aov.as_ref().map(Aovs::files).unwrap_or_default() {
        staged.push(match aov {
            Aov::Depth => {
                isogrid_io::image::stage_npy_f32_hw(path, width, height, &rendered.depth)?
            }
            Aov::Normal => {
                isogrid_io::image::stage_npy_f32_hw3(path, width, height, &rendered.normal)?
            }
            Aov::Cluster => {
                isogrid_io::image::stage_npy_u32_hw(path, width, height, &rendered.cluster)?
            }
            Aov::Value => {
                let value = rendered.value.as_ref().ok_or_else(|| {
                    anyhow::anyhow!("the value AOV came back empty from the renderer")
                })?;
                isogrid_io::image::stage_npy_f32_hw(path, width, height, value)?
            }
            Aov::Label => {
                let label = rendered.label.as_ref().ok_or_else(|| {
                    anyhow::anyhow!("the label AOV came back empty from the renderer")
                })?;
                isogrid_io::image::stage_npy(path, &[height as usize, width as usize], label)?
            }
        });
    }
    for file in staged {
        file.commit()?;
    }
    if args.json {
        return print_json(&report);
    }
    let on = match &report.adapter {
        Some(a) => format!("on the GPU ({a})"),
        None => "on the CPU".to_string(),
    };
    outln!(
        "rendered      {width}x{height} {} {on} in {:.3} s ({} of {} pixels hit)",
        report.mode,
        report.seconds,
        report.hits,
        width as u64 * height as u64
    );
    if let Some(t) = &report.gpu_ms {
        let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2} ms"));
        outln!(
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
        outln!("wrote         {}", out.display());
    }
    for (aov, path) in args.aov.as_ref().map(Aovs::files).unwrap_or_default() {
        outln!("wrote         {} ({} AOV)", path.display(), aov.name());
    }
    Ok(())
}

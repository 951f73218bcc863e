//! `isogrid view`: the interactive viewer (`isogrid-viewer`), or with `--frames` a scripted run
//! that renders a few frames in a real window, saves a screenshot and exits.

use crate::args::{parse_precision, InputArgs};
use crate::color_by::ColorByArgs;
use anyhow::{bail, Result};
use isogrid::colormap::ColorMap;
use isogrid::{Iso, Precision};
use isogrid_viewer::{AttributeSource, Mode, ViewerOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A volume (any format `extract` reads) or a .cgc file; omit to drop one on the window.
    pub input: Option<PathBuf>,
    /// Initial isovalue in data units (default: --iso-normalized 0.5). Ignored for .cgc files.
    #[arg(
        long,
        value_name = "V",
        allow_hyphen_values = true,
        conflicts_with = "iso_normalized"
    )]
    pub iso: Option<f64>,
    /// Initial isovalue as a fraction of the volume's value range.
    #[arg(long, value_name = "V")]
    pub iso_normalized: Option<f64>,
    /// Bits per stored corner value: 1, 4, 8, 16 or 32 (default: by sample type).
    #[arg(long, value_name = "BITS", value_parser = parse_precision)]
    pub precision: Option<Precision>,
    /// What to draw: cgc, cgc-noewa, mc (Marching Cubes mesh), cr (needs the volume) or pathtrace
    /// (GPU hybrid path tracing, refined while the camera rests).
    #[arg(long, default_value = "cgc", value_parser = super::render::mode_parser())]
    pub mode: Mode,
    /// Initial camera: the paper's view 1 (front) or 2 (oblique).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub view: u8,
    /// Fixed render size in pixels (default: the size of the window's image area).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<[u32; 2]>,
    /// Scripted run: render this many full-size frames, then exit.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub frames: Option<u32>,
    /// Scripted run: save a PNG of the window after the last frame (needs --frames).
    #[arg(long, value_name = "OUT.png", requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// For tests of drag and drop: the scripted run waits for a file dropped on the window and
    /// renders it, or captures the window showing why it cannot be opened (exit status 0).
    #[arg(long, hide = true, requires = "frames")]
    pub wait_for_drop: bool,
    #[command(flatten)]
    pub color: ColorByArgs,
    /// Initial colour map: viridis (default), magma, inferno, plasma, cividis, turbo, gray or rdbu.
    #[arg(long, value_name = "NAME", value_parser = super::render::parse_cmap)]
    pub cmap: Option<ColorMap>,
    /// Initial values the colour map spans, LO,HI (default: the attribute's range on the surface).
    #[arg(long, value_name = "LO,HI", value_parser = super::render::parse_clim, allow_hyphen_values = true)]
    pub clim: Option<[f64; 2]>,
    /// Show the surfaces of a label volume's labels (all but 0, or a list such as 1,5-9,liver), as
    /// `extract --labels` extracts them, with the label list; the isovalue does not apply.
    #[arg(long, value_name = "all|1,5-9", value_parser = crate::args::parse_labels_or_names, conflicts_with_all = ["iso", "iso_normalized"])]
    pub labels: Option<isogrid::LabelSelection>,
    /// With --labels: smooth each label's indicator by a Gaussian of SIGMA voxels (as `extract
    /// --smooth`).
    #[arg(long, value_name = "SIGMA", requires = "labels")]
    pub smooth: Option<f64>,
    /// A label grid: draw only these labels at first, by value or name, e.g. 1,5-9 or liver (as
    /// `render --show`); the label list in the window changes them.
    #[arg(long, value_name = "LABELS", value_parser = crate::args::parse_labels_or_names, allow_hyphen_values = true)]
    pub show: Option<isogrid::LabelSelection>,
    /// A label grid: hide these labels at first, e.g. 0,3 (as `render --hide`).
    #[arg(long, value_name = "LABELS", value_parser = crate::args::parse_labels_or_names, allow_hyphen_values = true)]
    pub hide: Option<isogrid::LabelSelection>,
    #[command(flatten)]
    pub input_args: InputArgs,
}

pub fn run(args: Args) -> Result<()> {
    let iso = match (args.iso, args.iso_normalized) {
        (Some(v), _) => Iso::Value(v),
        (None, Some(t)) if (0.0..=1.0).contains(&t) => Iso::Normalized(t),
        (None, Some(t)) => bail!("--iso-normalized {t} is outside [0, 1]"),
        (None, None) => Iso::Normalized(0.5),
    };
    if args.frames.is_some() && args.input.is_none() && !args.wait_for_drop {
        bail!("--frames needs an INPUT to render");
    }
    let mode = args.mode;
    if let Some(path) = &args.screenshot {
        let inputs: Vec<&std::path::Path> = args.input.as_deref().into_iter().collect();
        crate::outputs::check(
            &inputs,
            &[crate::outputs::Output {
                role: "the screenshot",
                path,
                extensions: &[".png"],
            }],
        )?;
    }
    let read_options = args.input_args.read_options()?;
    if let (Some(input), Some(_)) = (&args.input, &args.labels) {
        if crate::grid_source::is_cgc(input) {
            bail!(
                "--labels reads a label volume; {} is a .cgc file, whose labels (if any) are listed as they are",
                input.display()
            );
        }
    }
    let attribute = match &args.input {
        Some(input) if args.color.color_by.is_some() && crate::grid_source::is_cgc(input) => {
            bail!("--color-by colours a volume's surfaces; {} is a .cgc file, which brings its own attribute", input.display());
        }
        Some(input) => args
            .color
            .attribute(input, &read_options)?
            .map(|a| AttributeSource {
                path: a.path,
                read_options: a.options,
                name: a.name,
            }),
        None if args.color.color_by.is_some() => {
            bail!("--color-by colours the surfaces of INPUT; name a volume to colour")
        }
        None => None,
    };
    isogrid_viewer::run(ViewerOptions {
        input: args.input,
        read_options,
        iso,
        precision: args.precision,
        mode,
        view: args.view,
        size: args.size,
        frames: args.frames,
        screenshot: args.screenshot,
        wait_for_drop: args.wait_for_drop,
        attribute,
        cmap: args.cmap.unwrap_or_default(),
        clim: args.clim,
        show: args.show,
        hide: args.hide,
        labels: args.labels.map(|selection| isogrid::LabelOptions {
            selection,
            smooth: args.smooth.unwrap_or(crate::args::DEFAULT_SMOOTH),
            precision: args.precision,
        }),
    })?;
    Ok(())
}

/// "WxH" → [W, H], each in 1..=8192.
fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let bad = || format!("size must be WxH with W and H in 1..=8192, not {s:?}");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=8192).contains(n))
    };
    Ok([parse(w).ok_or_else(bad)?, parse(h).ok_or_else(bad)?])
}

//! `isogrid extract`: volume → clustered grid cells (paper §3.1) → `.cgc`.

use crate::args::{parse_precision, InputArgs, IsoArgs, ThreadArgs};
use crate::outputs::{self, Output};
use crate::report::{print_json, GridReport, Seconds};
use crate::{input, progress};
use anyhow::{Context, Result};
use isogrid::{extract, ExtractOptions, GridStats, Precision};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Volume: .nii/.nii.gz, .nrrd/.nhdr, .npy, .tif/.tiff, .mha/.mhd, .mrc/.map, a DICOM folder,
    /// or raw with --raw-shape.
    pub input: PathBuf,
    #[command(flatten)]
    pub iso: IsoArgs,
    /// Bits per stored corner value: 4, 8, 16 or 32 (default: 8 for u8 volumes, 16 otherwise).
    #[arg(long, value_name = "BITS", value_parser = parse_precision)]
    pub precision: Option<Precision>,
    #[command(flatten)]
    pub threads: ThreadArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
    /// Write the grid to this .cgc file.
    #[arg(short, long, value_name = "OUT.cgc")]
    pub output: Option<PathBuf>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let output = args.output.as_deref().map(|path| Output {
        role: "the grid",
        path,
        extensions: &[".cgc"],
    });
    outputs::check(&[&args.input], output.as_slice())?;
    let (volume, read) = input::read_volume(&args.input, &args.input_args.read_options()?)?;
    let options = ExtractOptions {
        iso: args.iso.iso(),
        precision: args.precision,
    };
    let spinner = progress::spinner("extracting".into());
    // The pool is started before the clock: thread start-up is not extraction.
    let pool = args.threads.pool()?;
    let start = Instant::now();
    let grid = pool
        .install(|| extract(&volume.view(), &options))
        .with_context(|| format!("{}: extraction failed", args.input.display()))?;
    let extract_seconds = start.elapsed().as_secs_f64();
    spinner.finish_and_clear();
    crate::report::note_if_empty(&args.input, &grid);
    let mut write = 0.0;
    if let Some(out) = &args.output {
        let start = Instant::now();
        isogrid::cgc::write(out, &grid)?;
        write = start.elapsed().as_secs_f64();
    }
    let report = GridReport::new(
        &GridStats::of(&grid),
        Seconds {
            read,
            extract: extract_seconds,
            write,
        },
    );
    if args.json {
        print_json(&report)
    } else {
        report.print_human();
        if let Some(out) = &args.output {
            println!("wrote         {}", out.display());
        }
        Ok(())
    }
}

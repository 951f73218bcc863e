//! `isogrid pack`: the packed transfer form (`.cgcz`, `isogrid::cgc::pack`) of a `.cgc` file or of
//! a volume's surface, for the web viewer on a slow link or a static host.

use crate::grid_source::GridSource;
use crate::outputs::{self, Output};
use anyhow::{Context, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub source: GridSource,
    /// The .cgcz file to write.
    #[arg(short, long, value_name = "FILE.cgcz")]
    pub output: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    outputs::check(
        &[args.source.input.as_path()],
        &[Output {
            role: "the packed file",
            path: &args.output,
            extensions: &[".cgcz"],
        }],
    )?;
    let grid = args.source.load()?;
    let mut sizes = None;
    let progress = std::sync::Arc::new(isogrid::Progress::new());
    let written = crate::progress::watched("packing", &progress, || {
        isogrid::fs::write_atomic_file(&args.output, |f| {
            sizes = Some(isogrid::cgc::pack_into_with_progress(&grid, f, &progress)?);
            Ok(())
        })
    });
    match written {
        Err(e) if e.kind() == isogrid::ErrorKind::Cancelled => {
            return Err(anyhow::Error::from(e).context("packing stopped by Ctrl-C, nothing written"))
        }
        r => r.with_context(|| format!("{}: cannot pack", args.source.input.display()))?,
    }
    let sizes = sizes.expect("written");
    outln!(
        "packed      {} bytes of .cgc into {} ({:.2}×)",
        sizes.cgc,
        sizes.packed,
        sizes.cgc as f64 / sizes.packed as f64
    );
    outln!("wrote       {}", args.output.display());
    Ok(())
}

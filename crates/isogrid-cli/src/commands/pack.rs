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
    isogrid::fs::write_atomic_file(&args.output, |f| {
        sizes = Some(isogrid::cgc::pack_into(&grid, f)?);
        Ok(())
    })
    .with_context(|| format!("{}: cannot pack", args.source.input.display()))?;
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

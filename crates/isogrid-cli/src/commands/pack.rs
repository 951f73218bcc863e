//! `isogrid pack`: the packed transfer form (`.cgcz`, `isogrid::cgc::pack`) of a `.cgc` file or of
//! a volume's surface, for the web viewer on a slow link or a static host.

use crate::grid_source::GridSource;
use crate::outputs::{self, Output};
use anyhow::{Context, Result};
use std::io::Write;
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
    let packed = isogrid::cgc::pack(&grid)
        .with_context(|| format!("{}: cannot pack", args.source.input.display()))?;
    isogrid::fs::write_atomic_file(&args.output, |f| {
        f.write_all(&packed)?;
        Ok(())
    })?;
    // The .cgc's length, from the packed head (bytes 16..24).
    let file = u64::from_le_bytes(packed[16..24].try_into().unwrap());
    outln!(
        "packed      {} bytes of .cgc into {} ({:.2}×)",
        file,
        packed.len(),
        file as f64 / packed.len() as f64
    );
    outln!("wrote       {}", args.output.display());
    Ok(())
}

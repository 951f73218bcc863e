//! `isogrid generate`: built-in procedural volumes (8-bit, surface at normalised isovalue 0.5).

use crate::outputs::{self, Output};
use anyhow::Result;
use isogrid::generate::{generate, Field};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Which volume: hairball, sphere, torus, gyroid or marschner-lobb.
    pub field: Field,
    /// Samples per axis.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(4..=4096))]
    pub size: u32,
    /// Seed of the random ones (hairball).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output volume (.nrrd). Default: FIELD-SIZE.nrrd.
    #[arg(short, long, value_name = "VOLUME.nrrd")]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let output = args
        .output
        .unwrap_or_else(|| PathBuf::from(format!("{}-{}.nrrd", args.field, args.size)));
    outputs::check(
        &[],
        &[Output {
            role: "the volume",
            path: &output,
            extensions: &[".nrrd"],
        }],
    )?;
    let n = args.size as u64;
    isogrid::memory::ensure_fits(&format!("a {n}³ u8 volume"), n * n * n)?;
    let start = Instant::now();
    let volume = generate(args.field, args.size as usize, args.seed);
    let seconds = start.elapsed().as_secs_f64();
    isogrid_io::write_nrrd(&output, &volume)?;
    outln!(
        "{}: {}³ u8 in {seconds:.2} s, wrote {}",
        args.field,
        args.size,
        output.display()
    );
    Ok(())
}

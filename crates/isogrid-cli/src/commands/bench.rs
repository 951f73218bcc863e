//! `isogrid bench rays`: closest-hit throughput of the CPU tracer (paper §3.6) on random rays.
//!
//! Rays: origins uniform in the grid's world box, directions uniform on the sphere, from a
//! SplitMix64 stream of `--seed` (or read from `--rays-file`, raw little-endian f32 records
//! `ox oy oz dx dy dz`, so another tracer can be given the very same rays). Only the tracing is
//! timed; memory is the grid's three buffers (blocks, metacells, cells).

use crate::args::{ThreadArgs, TraversalArg};
use crate::grid_source::GridSource;
use crate::outputs::{self, Output};
use crate::report::print_json;
use anyhow::{bail, Context, Result};
use isogrid::{GridStats, Ray};
use isogrid_trace::sample::{uniform_sphere, Rng};
use isogrid_trace::{Crossing, GridTracer, Hit};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Subcommand)]
pub enum Bench {
    /// Closest-hit rays per second on random rays through the grid's box.
    Rays(RaysArgs),
}

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub what: Bench,
}

/// Rays a benchmark may trace at once.
const MAX_RAYS: u64 = 1 << 28;

#[derive(clap::Args)]
pub struct RaysArgs {
    #[command(flatten)]
    pub source: GridSource,
    /// Number of random rays.
    #[arg(long, value_name = "N", default_value_t = 1_000_000,
          value_parser = clap::value_parser!(u64).range(1..=MAX_RAYS))]
    pub rays: u64,
    /// Seed of the random rays.
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Trace these rays instead: raw little-endian f32, 6 per ray (origin xyz, direction xyz).
    #[arg(long, value_name = "FILE", conflicts_with = "rays")]
    pub rays_file: Option<PathBuf>,
    /// Write the hit distance of every ray (f32 .npy, inf on a miss).
    #[arg(long, value_name = "T.npy")]
    pub t_out: Option<PathBuf>,
    /// Solve the exact crossing (cubic roots) instead of three samples per cell.
    #[arg(long)]
    pub exact: bool,
    /// How rays find candidate metacells: the paper's block walk over the grid's clusters, or a
    /// hierarchy over the metacells regrouped into leaf clusters. Same hits either way.
    #[arg(long, value_enum, default_value_t = TraversalArg::Blocks)]
    pub traversal: TraversalArg,
    #[command(flatten)]
    pub threads: ThreadArgs,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct RaysReport {
    crossing: &'static str,
    traversal: &'static str,
    /// SIMD set of the box tests: "avx2" where the CPU has AVX2 and FMA, else "baseline".
    simd: &'static str,
    threads: usize,
    rays: u64,
    hits: u64,
    seconds: f64,
    rays_per_second: f64,
    /// CPU time of the whole process while tracing (Unix only), and rays per CPU second: on a
    /// core shared with other work these are steadier than the wall-clock figures.
    #[serde(skip_serializing_if = "Option::is_none")]
    cpu_seconds: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rays_per_cpu_second: Option<f64>,
    /// Memory the tracer reads: blocks + metacell slots + corner records + what the traversal
    /// adds (the block walk's empty-space map and packed cluster bounds, or the hierarchy).
    bytes: u64,
    active_cells: u64,
    /// World box the random rays start in: [lo, hi].
    world_bounds: [[f64; 3]; 2],
}

pub fn run(args: Args) -> Result<()> {
    match args.what {
        Bench::Rays(a) => rays(a),
    }
}

fn read_rays(path: &PathBuf) -> Result<Vec<Ray>> {
    let len = std::fs::metadata(path)
        .with_context(|| format!("{}: cannot read", path.display()))?
        .len();
    if len % 24 != 0 || len / 24 > MAX_RAYS || len == 0 {
        bail!(
            "{}: {len} bytes are not whole rays of 6 f32 (at most {MAX_RAYS})",
            path.display()
        );
    }
    isogrid::fs::ensure_regular(path)?;
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64;
    let mut rays = Vec::with_capacity(bytes.len() / 24);
    for r in bytes.chunks_exact(24) {
        let v: [f64; 6] = std::array::from_fn(|i| f(&r[4 * i..]));
        let d = [v[3], v[4], v[5]];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !(n > 0.0 && n.is_finite() && v.iter().all(|x| x.is_finite())) {
            bail!(
                "{}: ray {} is not finite with a non-zero direction",
                path.display(),
                rays.len()
            );
        }
        rays.push(Ray {
            origin: [v[0], v[1], v[2]],
            direction: d.map(|c| c / n),
        });
    }
    Ok(rays)
}

/// Nanoseconds all threads of this process have run (`CLOCK_PROCESS_CPUTIME_ID`, which brings the
/// running threads' totals up to date when read), or `None` off Unix. The per-thread counts in
/// `/proc/self/task/*/schedstat` read earlier could lag a busy thread by its whole run (0 ns for
/// a 0.4 s trace on a tickless kernel).
fn process_cpu_ns() -> Option<u64> {
    #[cfg(unix)]
    {
        let mut now = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `now` is a valid timespec to write; the call only writes it.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut now) } != 0 {
            return None;
        }
        Some(now.tv_sec as u64 * 1_000_000_000 + now.tv_nsec as u64)
    }
    #[cfg(not(unix))]
    None
}

/// Checks the outputs and the memory the rays take before the grid is loaded.
fn check_request(args: &RaysArgs) -> Result<()> {
    let mut inputs = vec![args.source.input.as_path()];
    inputs.extend(args.rays_file.as_deref());
    let output = args.t_out.as_deref().map(|path| Output {
        role: "the hit distances",
        path,
        extensions: &[".npy"],
    });
    outputs::check(&inputs, output.as_slice())?;
    let (rays, file_bytes) = match &args.rays_file {
        // A file that is not whole rays is refused by `read_rays`; here only its size matters.
        Some(path) => match std::fs::metadata(path) {
            Ok(m) => (m.len() / 24, m.len()),
            Err(_) => return Ok(()),
        },
        None => (args.rays, 0),
    };
    let per_ray = std::mem::size_of::<Ray>()
        + std::mem::size_of::<Option<Hit>>()
        + if args.t_out.is_some() { 4 } else { 0 };
    isogrid::memory::ensure_fits(
        &format!("{rays} rays"),
        rays.saturating_mul(per_ray as u64)
            .saturating_add(file_bytes),
    )?;
    Ok(())
}

fn rays(args: RaysArgs) -> Result<()> {
    check_request(&args)?;
    let grid = args.threads.install(|| args.source.load())??;
    let rays = match &args.rays_file {
        Some(path) => read_rays(path)?,
        None => {
            let (lo, hi) = grid.info().world_bounds();
            let mut rng = Rng::for_sample(args.seed, 0, 0);
            (0..args.rays)
                .map(|_| {
                    let origin = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * rng.unit());
                    Ray {
                        origin,
                        direction: uniform_sphere(&mut rng),
                    }
                })
                .collect()
        }
    };
    let crossing = if args.exact {
        Crossing::Exact
    } else {
        Crossing::Samples3
    };
    let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
    let mut cpu_start = None;
    // Built before the clock starts, as the grid is.
    let tracer = args
        .threads
        .install(|| GridTracer::new(&grid, crossing, args.traversal.into()))?;
    let (seconds, threads) = args.threads.install(|| {
        cpu_start = process_cpu_ns();
        let start = Instant::now();
        tracer.closest_hits(&rays, &mut hits);
        (start.elapsed().as_secs_f64(), rayon::current_num_threads())
    })?;
    let (extra_bytes, simd) = (tracer.extra_bytes(), tracer.simd());
    let cpu_seconds = cpu_start
        .zip(process_cpu_ns())
        .map(|(a, b)| b.saturating_sub(a) as f64 * 1e-9);
    if let Some(out) = &args.t_out {
        let t: Vec<f32> = hits
            .iter()
            .map(|h| h.map_or(f32::INFINITY, |h| h.t as f32))
            .collect();
        isogrid_io::image::write_npy(out, &[t.len()], &t)?;
    }
    let stats = GridStats::of(&grid);
    let report = RaysReport {
        crossing: if args.exact { "exact" } else { "samples3" },
        traversal: tracer.traversal().name(),
        simd,
        threads,
        rays: rays.len() as u64,
        hits: hits.iter().filter(|h| h.is_some()).count() as u64,
        seconds,
        rays_per_second: rays.len() as f64 / seconds.max(1e-9),
        cpu_seconds,
        rays_per_cpu_second: cpu_seconds.map(|c| rays.len() as f64 / c.max(1e-9)),
        bytes: stats.bytes.blocks + stats.bytes.paper_total + extra_bytes as u64,
        active_cells: stats.active_cells,
        world_bounds: {
            let (lo, hi) = grid.info().world_bounds();
            [lo, hi]
        },
    };
    if args.json {
        print_json(&report)
    } else {
        outln!(
            "traced        {} rays ({} hits) in {:.3} s on {} threads, {} crossing, {} traversal, {} box tests",
            report.rays,
            report.hits,
            report.seconds,
            report.threads,
            report.crossing,
            report.traversal,
            report.simd
        );
        outln!("rays/second   {:.0}", report.rays_per_second);
        outln!(
            "memory        {:.2} MB (blocks + metacells + cells + traversal)",
            report.bytes as f64 / 1e6
        );
        Ok(())
    }
}

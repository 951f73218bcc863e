//! `isogrid`: extract, inspect and compare clustered grid cell isosurfaces from the command line.

mod args;
mod commands;
mod input;
mod outputs;
mod progress;
mod report;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Isosurfaces as clustered grid cells (Nysjö, "Clustered Grid Cell Data Structure for Isosurface Rendering").
#[derive(Parser)]
#[command(name = "isogrid", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Extract the active cells of a volume into a .cgc file and print their statistics.
    Extract(commands::extract::Args),
    /// Print the statistics of a .cgc file.
    Info(commands::info::Args),
    /// Extract the Marching Cubes mesh the paper compares with (indexed, snorm16 positions).
    Mc(commands::mc::Args),
    /// Voxelise a triangle mesh (PLY, OBJ, STL) into an 8-bit coverage volume, as the paper made its datasets.
    Voxelize(commands::voxelize::Args),
    /// Write a built-in procedural volume (hairball, sphere, gyroid, ...).
    Generate(commands::generate::Args),
    /// Build a built-in volume, extract it and compare with Marching Cubes.
    Demo(commands::demo::Args),
    /// Render the isosurface to a PNG on the GPU (CPU fallback), with optional AOVs and pass timings.
    Render(commands::render::Args),
    /// Benchmarks: `bench rays` measures closest-hit rays per second.
    Bench(commands::bench::Args),
    /// Open the interactive viewer (orbit, isovalue slider, modes, measurements); --frames N renders N frames and exits.
    View(commands::view::Args),
}

/// The error and its causes joined by ": ", each cause once: a library error whose message is
/// its source's own text (an I/O error's) would otherwise print that text twice.
fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Ctrl-C, SIGTERM and SIGHUP still end the process as they would, but first the temporary files
/// of unfinished writes are removed: the signals are blocked in every thread (a mask set before
/// any other thread exists is inherited) and taken by one thread that waits for them.
#[cfg(unix)]
fn remove_temporaries_when_interrupted() {
    // SAFETY: plain libc signal-set calls on a local set; the mask is set before other threads.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            libc::sigaddset(&mut set, signal);
        }
        if libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return;
        }
        let spawned = std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                let mut signal = 0;
                if libc::sigwait(&set, &mut signal) == 0 {
                    isogrid::fs::remove_unfinished();
                    // End as the signal's default action does, so the exit status says so.
                    libc::signal(signal, libc::SIG_DFL);
                    libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
                    libc::raise(signal);
                }
            });
        if spawned.is_err() {
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        }
    }
}

fn main() -> ExitCode {
    // A file-size limit (`ulimit -f`) then makes a write fail with EFBIG, which the atomic writer
    // reports and cleans up after, instead of killing the process with its temporary file left.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to SIG_IGN before any other thread exists.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    #[cfg(unix)]
    remove_temporaries_when_interrupted();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Extract(a) => commands::extract::run(a),
        Command::Info(a) => commands::info::run(a),
        Command::Mc(a) => commands::mc::run(a),
        Command::Voxelize(a) => commands::voxelize::run(a),
        Command::Generate(a) => commands::generate::run(a),
        Command::Demo(a) => commands::demo::run(a),
        Command::Render(a) => commands::render::run(a),
        Command::Bench(a) => commands::bench::run(a),
        Command::View(a) => commands::view::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            // One line: the outermost context and its causes, never a backtrace.
            eprintln!("isogrid: error: {}", one_line(&err));
            ExitCode::FAILURE
        }
    }
}

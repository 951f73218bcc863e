//! `isogrid`: extract, inspect and compare clustered grid cell isosurfaces from the command line.

// First: the `outln!` macro is used by the modules below.
#[macro_use]
mod stdout;
mod args;
mod color_by;
mod commands;
mod grid_source;
mod input;
mod interrupt;
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
// One value, parsed once per run: boxing the larger arguments would buy nothing.
#[allow(clippy::large_enum_variant)]
enum Command {
    /// Extract the active cells of a volume into a .cgc file and print their statistics.
    Extract(commands::extract::Args),
    /// Print the statistics of a .cgc file, or describe a volume: grid, type, values, world place.
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
    /// Write the packed transfer form (.cgcz) of a .cgc file or a volume's surface: each corner sample once, range-coded, for the web viewer.
    Pack(commands::pack::Args),
    /// Serve the web viewer and one .cgc file over HTTP (Range requests), and print the URL to open.
    Serve(commands::serve::Args),
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

/// Whether the command stopped because it was asked to (Ctrl-C during a cancellable step).
fn was_cancelled(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<isogrid::Error>()
            .is_some_and(|e| e.kind() == isogrid::ErrorKind::Cancelled)
    })
}

/// Mesa's Vulkan device-selection layer asks a Wayland compositor which GPU is the default, and
/// where no session exists, libwayland prints `error: XDG_RUNTIME_DIR is invalid or not set in the
/// environment.` once per adapter enumeration. On such headless machines there is no default to
/// ask for, so the layer is turned off (`NODEVICE_SELECT=1`, its documented switch) unless the
/// user steers device selection (`DRI_PRIME`, `MESA_VK_DEVICE_SELECT`) or a display exists.
fn quiet_vulkan_device_select() {
    let set = |name: &str| std::env::var_os(name).is_some();
    let headless = !set("XDG_RUNTIME_DIR") && !set("WAYLAND_DISPLAY") && !set("DISPLAY");
    let steered = set("NODEVICE_SELECT") || set("DRI_PRIME") || set("MESA_VK_DEVICE_SELECT");
    if headless && !steered {
        // At the start of main: the only other thread (signals) reads no variables.
        std::env::set_var("NODEVICE_SELECT", "1");
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
    interrupt::install();
    quiet_vulkan_device_select();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version text on a terminal: clap's own printing keeps its colours.
        Err(e) if e.use_stderr() || std::io::IsTerminal::is_terminal(&std::io::stdout()) => {
            e.exit()
        }
        Err(e) => return finish(stdout::write_text(&e.render().to_string()).map_err(Into::into)),
    };
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
        Command::Pack(a) => commands::pack::run(a),
        Command::Serve(a) => commands::serve::run(a),
    };
    finish(result)
}

/// The exit code of a command's result, after its output is flushed; the error, if any, on stderr.
fn finish(result: anyhow::Result<()>) -> ExitCode {
    let result = result.and_then(|()| Ok(stdout::flush()?));
    let stdout_error = |err: &anyhow::Error| {
        err.chain()
            .find_map(|cause| cause.downcast_ref::<stdout::StdoutError>())
            .is_some_and(stdout::StdoutError::reader_went_away)
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the output closed the pipe (`isogrid info x.cgc | head -1`): nothing is
        // wrong and nobody is left to tell, so the command ends quietly, as ripgrep does.
        Err(err) if stdout_error(&err) => ExitCode::SUCCESS,
        Err(err) if was_cancelled(&err) => {
            eprintln!("isogrid: {}", one_line(&err));
            // 128 + SIGINT, as shells report a command that Ctrl-C ended.
            ExitCode::from(130)
        }
        Err(err) => {
            // One line: the outermost context and its causes, never a backtrace.
            eprintln!("isogrid: error: {}", one_line(&err));
            ExitCode::FAILURE
        }
    }
}

//! Log messages of eframe, egui-wgpu and wgpu on stderr, so that window and surface problems
//! (a surface format that cannot be captured, a lost device) are visible. `ISOGRID_VIEW_LOG`
//! sets the level (`error`, `warn` (default), `info`, `debug`, `trace`, `off`); without it,
//! wgpu-hal's messages are hidden.

use log::{Level, LevelFilter, Log, Metadata, Record};
use std::sync::atomic::{AtomicBool, Ordering};

/// `ISOGRID_VIEW_LOG` was set: show everything at its level, wgpu-hal included.
static VERBOSE: AtomicBool = AtomicBool::new(false);

struct Stderr;

impl Log for Stderr {
    fn enabled(&self, metadata: &Metadata) -> bool {
        // wgpu-hal logs probing of absent backends (the Vulkan loader without a driver, EGL
        // without DRI) as errors although nothing fails; shown only when asked for.
        let quiet = !VERBOSE.load(Ordering::Relaxed) && metadata.target().starts_with("wgpu_hal");
        metadata.level() <= log::max_level() && !quiet
    }
    fn log(&self, record: &Record) {
        if !self.enabled(record.metadata()) {
            return;
        }
        // wgpu reports every validation message at warn level with multi-line context; keep the
        // first line so that the terminal stays readable.
        let message = record.args().to_string();
        let first = message.lines().next().unwrap_or_default();
        let level = match record.level() {
            Level::Error => "error",
            Level::Warn => "warning",
            Level::Info => "info",
            Level::Debug => "debug",
            Level::Trace => "trace",
        };
        eprintln!("isogrid view: {level}: {}: {first}", record.target());
    }
    fn flush(&self) {}
}

/// Installs the logger once; later calls (a second viewer in one process) keep the first.
pub fn init() {
    let setting = std::env::var("ISOGRID_VIEW_LOG");
    VERBOSE.store(setting.is_ok(), Ordering::Relaxed);
    let level = match setting.as_deref() {
        Ok("off") => LevelFilter::Off,
        Ok("error") => LevelFilter::Error,
        Ok("info") => LevelFilter::Info,
        Ok("debug") => LevelFilter::Debug,
        Ok("trace") => LevelFilter::Trace,
        _ => LevelFilter::Warn,
    };
    if log::set_logger(&Stderr).is_ok() {
        log::set_max_level(level);
    }
}

//! Progress bars and spinners, drawn only when stderr is a terminal (never in pipes, logs or CI),
//! and [`watched`], which runs a computation that reports through an [`isogrid::Progress`] under
//! a bar that follows it, with Ctrl-C cancelling it.

use crate::interrupt::cancel_on_interrupt;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use isogrid::Progress;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

fn target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    }
}

pub fn spinner(message: String) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(None, target());
    bar.set_style(ProgressStyle::with_template("{spinner} {msg} {elapsed}").unwrap());
    bar.set_message(message);
    bar.enable_steady_tick(Duration::from_millis(120));
    bar
}

pub fn bar(message: &str, total: u64) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), target());
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent}% eta {eta}")
            .unwrap()
            .progress_chars("=> "),
    );
    bar.set_message(message.to_string());
    bar
}

/// Runs `work` while a bar labelled `message` follows `progress` (read every 100 ms from another
/// thread) and Ctrl-C cancels it (see [`cancel_on_interrupt`]); `work` is expected to honour the
/// cancel and return an error of kind `Cancelled`.
pub fn watched<T>(message: &str, progress: &Arc<Progress>, work: impl FnOnce() -> T) -> T {
    let _cancel = cancel_on_interrupt(progress.clone());
    let bar = bar(message, 0);
    let finished = AtomicBool::new(false);
    let out = std::thread::scope(|scope| {
        let watcher = scope.spawn(|| {
            while !finished.load(Ordering::Relaxed) {
                let (done, total) = progress.counts();
                bar.set_length(total);
                bar.set_position(done);
                std::thread::park_timeout(Duration::from_millis(100));
            }
        });
        let out = work();
        finished.store(true, Ordering::Relaxed);
        // Woken, so that the command does not wait out its sleep (a cancel ends at once).
        watcher.thread().unpark();
        out
    });
    bar.finish_and_clear();
    out
}

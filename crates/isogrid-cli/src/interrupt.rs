//! Ctrl-C, SIGTERM and SIGHUP. By default they end the process as they would, after removing the
//! temporary files of unfinished writes. While a cancellable computation runs
//! ([`cancel_on_interrupt`]), the first Ctrl-C instead asks it to stop through its [`Progress`],
//! so that the command can end cleanly with a message and write nothing; a second Ctrl-C ends
//! the process at once.
//!
//! The signals are blocked in every thread (a mask set before any other thread exists is
//! inherited) and taken by one thread that waits for them, so no code runs in a signal handler.

use isogrid::Progress;
use std::sync::{Arc, Mutex};

/// The computation the next Ctrl-C cancels, if any.
static CANCELLABLE: Mutex<Option<Arc<Progress>>> = Mutex::new(None);

/// While the returned guard lives, Ctrl-C cancels `progress` instead of ending the process.
pub fn cancel_on_interrupt(progress: Arc<Progress>) -> CancelGuard {
    if let Ok(mut slot) = CANCELLABLE.lock() {
        *slot = Some(progress);
    }
    CancelGuard
}

/// Restores Ctrl-C's default when dropped.
pub struct CancelGuard;

impl Drop for CancelGuard {
    fn drop(&mut self) {
        if let Ok(mut slot) = CANCELLABLE.lock() {
            *slot = None;
        }
    }
}

/// Cancels the registered computation if there is one not yet cancelled; whether it did.
fn cancel_registered() -> bool {
    let Ok(slot) = CANCELLABLE.lock() else {
        return false;
    };
    match slot.as_ref() {
        Some(p) if !p.is_cancelled() => {
            p.cancel();
            true
        }
        _ => false,
    }
}

/// Blocks the signals and starts the thread that takes them; call before any other thread exists.
#[cfg(unix)]
pub fn install() {
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
            .spawn(move || loop {
                let mut signal = 0;
                if libc::sigwait(&set, &mut signal) != 0 {
                    return;
                }
                if signal == libc::SIGINT && cancel_registered() {
                    continue;
                }
                isogrid::fs::remove_unfinished();
                // End as the signal's default action does, so the exit status says so.
                libc::signal(signal, libc::SIG_DFL);
                libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
                libc::raise(signal);
                return;
            });
        if spawned.is_err() {
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        }
    }
}

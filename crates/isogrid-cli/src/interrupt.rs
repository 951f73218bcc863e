//! Ctrl-C, SIGTERM and SIGHUP. By default they end the process as they would, after removing the
//! temporary files of unfinished writes. While a cancellable computation runs
//! ([`cancel_on_interrupt`]), the first Ctrl-C instead asks it to stop through its [`Progress`],
//! so that the command can end cleanly with a message and write nothing; a second Ctrl-C ends
//! the process at once.
//!
//! The signals are blocked in every thread (a mask set before any other thread exists is
//! inherited) and taken by one thread that waits for them, so no code runs in a signal handler.
//!
//! Two signals cannot wait for that thread: SIGABRT, raised by the allocator's abort when an
//! allocation fails (under `ulimit -v` or a cgroup limit the memory checks did not foresee), and
//! SIGBUS, when a memory-mapped input is truncated under a reader. They arrive in the failing
//! thread and end the process, so a real handler ([`on_fatal_signal`]) unlinks the unfinished
//! writes' temporary files there, without allocating or waiting on a lock, and lets the signal
//! end the process as it would have.

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
        for signal in [libc::SIGABRT, libc::SIGBUS] {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_fatal_signal as extern "C" fn(libc::c_int) as usize;
            // One shot: the default action is back by the time the handler raises it again.
            action.sa_flags = libc::SA_RESETHAND;
            libc::sigemptyset(&mut action.sa_mask);
            libc::sigaction(signal, &action, std::ptr::null_mut());
        }
    }
}

/// Handler of SIGABRT and SIGBUS: unlinks the temporary files of unfinished writes, each path
/// copied onto the stack (the heap may be what failed), and raises the signal again, which the
/// default action (restored on entry) takes once the handler returns: the process ends as the
/// signal would have ended it, whether it came from abort, a fault or `kill`.
#[cfg(unix)]
extern "C" fn on_fatal_signal(signal: libc::c_int) {
    use std::os::unix::ffi::OsStrExt;
    isogrid::fs::for_each_unfinished_without_waiting(|path| {
        let bytes = path.as_os_str().as_bytes();
        let mut name = [0u8; 4096];
        if bytes.len() < name.len() && !bytes.contains(&0) {
            name[..bytes.len()].copy_from_slice(bytes);
            // SAFETY: a NUL-terminated path on the stack; unlink is async-signal-safe. A staged
            // folder is not unlinked (it fails with EISDIR), which is harmless.
            unsafe { libc::unlink(name.as_ptr().cast()) };
        }
    });
    // SAFETY: raise is async-signal-safe; the signal stays blocked until the handler returns.
    unsafe { libc::raise(signal) };
}

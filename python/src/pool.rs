//! Running work without the GIL on a rayon pool of the caller's size, optionally watched for
//! progress and Ctrl-C.

use pyo3::prelude::*;

/// A fresh pool of `threads` workers, or `None` for rayon's global pool (all cores).
fn pool(threads: Option<usize>) -> PyResult<Option<rayon::ThreadPool>> {
    match threads {
        None => Ok(None),
        Some(0) => Err(crate::errors::invalid("threads must be at least 1")),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(Some)
            .map_err(|e| crate::errors::invalid(format!("cannot start {n} threads: {e}"))),
    }
}

/// Runs `work` with the GIL released, on a fresh pool of `threads` workers, or on rayon's global
/// pool (all cores) when `threads` is `None`. Results do not depend on the thread count.
pub fn run_detached<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let pool = pool(threads)?;
    Ok(py.detach(move || match pool {
        Some(pool) => pool.install(work),
        None => work(),
    }))
}

/// Fails unless `callback` (a `progress=` argument) is absent or callable.
pub fn check_callback(callback: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
    match callback {
        Some(f) if !f.is_callable() => Err(crate::errors::invalid(
            "progress must be a callable taking (done, total)",
        )),
        _ => Ok(()),
    }
}

/// How often a watched computation's caller looks for Ctrl-C and new progress.
const WATCH_INTERVAL: std::time::Duration = std::time::Duration::from_millis(100);

/// Runs `work` like [`run_detached`], on its own thread, while this thread watches it: every
/// [`WATCH_INTERVAL`] it takes the GIL, checks for Ctrl-C (`py.check_signals`) and calls
/// `callback(done, total)` when `progress` moved (and once at the end). Ctrl-C or an exception
/// from the callback cancels `progress`, waits for `work` to stop (within a tile or a frame) and
/// is raised; otherwise `work`'s own error is.
pub fn run_watched<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    progress: &isogrid::Progress,
    callback: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce() -> isogrid::Result<T> + Send,
) -> PyResult<T> {
    let pool = pool(threads)?;
    let (tx, mut rx) = std::sync::mpsc::channel();
    std::thread::scope(|scope| {
        scope.spawn(move || {
            let out = match pool {
                Some(pool) => pool.install(work),
                None => work(),
            };
            let _ = tx.send(out);
        });
        let mut reported = None;
        let mut raised: Option<PyErr> = None;
        let out = loop {
            let (got, back) = py.detach(move || (rx.recv_timeout(WATCH_INTERVAL), rx));
            rx = back;
            let finished = match got {
                Ok(out) => Some(out),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => None,
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    break Err(crate::errors::invalid("the render thread stopped"))
                }
            };
            if raised.is_none() {
                let counts = progress.counts();
                let call = match callback {
                    Some(f) if counts.1 > 0 && reported != Some(counts) => {
                        reported = Some(counts);
                        f.call1(counts).err()
                    }
                    _ => None,
                };
                raised = call.or_else(|| py.check_signals().err());
                if raised.is_some() {
                    progress.cancel();
                }
            }
            if let Some(out) = finished {
                break match (raised.take(), out) {
                    (Some(e), _) => Err(e),
                    (None, out) => out.map_err(crate::errors::to_py),
                };
            }
        };
        out
    })
}

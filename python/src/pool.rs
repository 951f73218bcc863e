//! Running work without the GIL on a rayon pool of the caller's size.

use pyo3::prelude::*;

/// Runs `work` with the GIL released, on a fresh pool of `threads` workers, or on rayon's global
/// pool (all cores) when `threads` is `None`. Results do not depend on the thread count.
pub fn run_detached<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let pool = match threads {
        None => None,
        Some(0) => return Err(crate::errors::invalid("threads must be at least 1")),
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| crate::errors::invalid(format!("cannot start {n} threads: {e}")))?,
        ),
    };
    Ok(py.detach(move || match pool {
        Some(pool) => pool.install(work),
        None => work(),
    }))
}

//! [`Progress`]: how far a long computation has come, and the flag that asks it to stop.
//!
//! The worker advances `done` out of `total` and checks [`Progress::is_cancelled`] between units of
//! work that are short (an image tile, a GPU frame); the caller reads the counts from another
//! thread (a progress bar, a Python callback) and may [`Progress::cancel`] at any time, e.g. on
//! Ctrl-C. Atomics only, so either side may be on any thread.

use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Counts of finished units and a cancel flag, shared between a worker and its caller.
#[derive(Debug, Default)]
pub struct Progress {
    done: AtomicU64,
    total: AtomicU64,
    cancelled: AtomicBool,
}

impl Progress {
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts a stage of `total` units with none done.
    pub fn start(&self, total: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(0, Ordering::Relaxed);
    }

    /// Adds `units` finished units.
    pub fn advance(&self, units: u64) {
        self.done.fetch_add(units, Ordering::Relaxed);
    }

    /// (done, total) of the current stage.
    pub fn counts(&self) -> (u64, u64) {
        (
            self.done.load(Ordering::Relaxed),
            self.total.load(Ordering::Relaxed),
        )
    }

    /// Asks the worker to stop at its next check.
    pub fn cancel(&self) {
        self.cancelled.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancelled.load(Ordering::Relaxed)
    }

    /// `Err` of kind [`crate::ErrorKind::Cancelled`] once [`Progress::cancel`] was called.
    pub fn check(&self) -> Result<()> {
        if self.is_cancelled() {
            let (done, total) = self.counts();
            return Err(Error::cancelled(format!(
                "interrupted after {done} of {total} steps"
            )));
        }
        Ok(())
    }
}

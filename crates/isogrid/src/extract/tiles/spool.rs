//! A scratch file that holds output until its place in the file being written is known: a
//! one-pass tiled extraction gets each tile's metacells and corner records before the tiles in
//! front of it have been counted.
//!
//! The file is made beside the output (same filesystem, where the output's space is) and, on
//! Unix, unlinked as soon as it is open, so that nothing is left behind whatever way the process
//! ends; elsewhere it is removed when dropped.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Appended bytes, read back by offset.
#[derive(Debug)]
pub(in crate::extract) struct Spool {
    file: File,
    /// The file's name while it still has one.
    path: Option<PathBuf>,
    len: u64,
}

impl Spool {
    /// A new, empty spool in the folder `dir`.
    pub(in crate::extract) fn create(dir: &Path) -> Result<Self> {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let path = dir.join(format!(
            ".isogrid-spool-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let file = File::options()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| Error::io(e).with_path(&path))?;
        let mut spool = Spool {
            file,
            path: Some(path),
            len: 0,
        };
        #[cfg(unix)]
        if let Some(path) = spool.path.take() {
            std::fs::remove_file(&path).map_err(|e| Error::io(e).with_path(&path))?;
        }
        Ok(spool)
    }

    /// Appends `bytes`; returns their offset.
    pub(in crate::extract) fn append(&mut self, bytes: &[u8]) -> Result<u64> {
        let at = self.len;
        self.file.seek(SeekFrom::Start(at))?;
        self.file.write_all(bytes)?;
        self.len += bytes.len() as u64;
        Ok(at)
    }

    /// Reads `out.len()` bytes from `offset`.
    pub(in crate::extract) fn read(&self, offset: u64, out: &mut [u8]) -> Result<()> {
        let mut file = &self.file;
        file.seek(SeekFrom::Start(offset))?;
        file.read_exact(out)?;
        Ok(())
    }
}

impl Drop for Spool {
    fn drop(&mut self) {
        if let Some(path) = &self.path {
            let _ = std::fs::remove_file(path);
        }
    }
}

//! Atomic file writes: write a temporary file beside the target, flush it to disk, then rename.
//!
//! A crash or a failed write never leaves a half-written file under the target name, and an
//! existing file is replaced only once the new one is complete. Inputs are opened with
//! [`open_regular`], which refuses what is not a regular file before a read can block on it.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files of writes in progress, for [`remove_unfinished`].
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporary files of every write in progress. For a program's interrupt handler
/// (Ctrl-C, SIGTERM), called just before it exits: the writes cannot finish, and their files
/// would stay behind.
pub fn remove_unfinished() {
    let mut unfinished = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
    for tmp in unfinished.drain(..) {
        remove_temporary(&tmp);
    }
}

/// Calls `f` with the temporary file of every write in progress, without waiting for the list:
/// for a handler of a fatal signal (SIGABRT when an allocation fails, SIGBUS), which may run while
/// another thread holds it and must then do without. `f` must not allocate either (the heap may be
/// what failed): see the CLI's `interrupt` module.
pub fn for_each_unfinished_without_waiting(mut f: impl FnMut(&Path)) {
    let unfinished = match UNFINISHED.try_lock() {
        Ok(list) => list,
        Err(std::sync::TryLockError::Poisoned(e)) => e.into_inner(),
        Err(std::sync::TryLockError::WouldBlock) => return,
    };
    for tmp in unfinished.iter() {
        f(tmp);
    }
}

/// Lists `path` among the temporary files of writes in progress.
fn list_unfinished(path: &Path) {
    UNFINISHED
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(path.to_path_buf());
}

/// Takes `path` off the list of [`list_unfinished`].
fn unlist_unfinished(path: &Path) {
    let mut unfinished = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(at) = unfinished.iter().position(|p| p == path) {
        unfinished.swap_remove(at);
    }
}

/// Removes a temporary file, or a staged folder with what it holds.
fn remove_temporary(path: &Path) {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir()) {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

/// Writes `path` atomically with the bytes `write` produces. On error the target is untouched and
/// the temporary file is removed. Errors name `path`.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    write_atomic_file(path, |file| {
        let mut out = BufWriter::with_capacity(1 << 20, file);
        write(&mut out)?;
        out.flush()?;
        Ok(())
    })
}

/// Like [`write_atomic`], handing `write` the temporary file itself, for writers that place
/// sections at offsets (positioned writes) instead of streaming them in order.
pub fn write_atomic_file<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut File) -> Result<()>,
{
    stage_file(path, write)?.commit()
}

/// Writes the complete new content of `path` into a temporary file beside it, flushed to disk,
/// without touching `path` yet: [`Staged::commit`] renames it into place, dropping it removes it.
/// A command with several outputs stages them all and commits only when every one was written,
/// so that a failure (a full disk) leaves all of them as they were. Errors name `path`.
pub fn stage<F>(path: &Path, write: F) -> Result<Staged>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    stage_file(path, |file| {
        let mut out = BufWriter::with_capacity(1 << 20, file);
        write(&mut out)?;
        out.flush()?;
        Ok(())
    })
}

/// [`stage`], handing `write` the temporary file itself (see [`write_atomic_file`]).
pub fn stage_file<F>(path: &Path, write: F) -> Result<Staged>
where
    F: FnOnce(&mut File) -> Result<()>,
{
    // Removes the temporary file on every way out of this function that runs code: an error, or
    // a panic in `write` unwinding through here. (A file-size limit must reach us as an error,
    // EFBIG: programs ignore SIGXFSZ, whose default action kills without running anything.)
    let staged = Staged::beside(path)?;
    let result = (|| -> Result<()> {
        let mut file = File::create(&staged.tmp)?;
        write(&mut file)?;
        file.sync_all()?;
        Ok(())
    })();
    result.map_err(|e| e.with_path(path))?;
    Ok(staged)
}

/// [`stage`] for an output that is a folder of files (neuroglancer's precomputed meshes):
/// `write` fills a new temporary folder beside `path`, and [`Staged::commit`] renames it into
/// place. A `path` that already exists is refused before anything is written: a folder is never
/// merged into or replaced. Errors name `path`.
pub fn stage_dir<F>(path: &Path, write: F) -> Result<Staged>
where
    F: FnOnce(&Path) -> Result<()>,
{
    if std::fs::symlink_metadata(path).is_ok() {
        return Err(Error::invalid(
            "already exists; a folder output is written only where nothing is",
        )
        .with_path(path));
    }
    let staged = Staged::beside(path)?;
    let result = (|| -> Result<()> {
        std::fs::create_dir(&staged.tmp)?;
        write(&staged.tmp)?;
        File::open(&staged.tmp)?.sync_all()?;
        Ok(())
    })();
    result.map_err(|e| e.with_path(path))?;
    Ok(staged)
}

/// `.NAME.ROLEPID` in the folder of `target` (NAME its file name, PID this process's), listed
/// among the unfinished writes that an interrupt removes; nothing is created. Beside the target,
/// so a later rename or copy stays on one disk.
fn unfinished_path_beside(target: &Path, role: &str) -> Result<PathBuf> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = target
        .file_name()
        .ok_or_else(|| Error::invalid("output path has no file name").with_path(target))?;
    let path = dir.join(format!(
        ".{}.{role}{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    list_unfinished(&path);
    Ok(path)
}

/// A file a program writes for its own use and removes when done: removed when the guard is
/// dropped (an error, a panic) and by [`remove_unfinished`] (an interrupt).
#[derive(Debug)]
pub struct ScratchFile {
    path: PathBuf,
}

impl ScratchFile {
    /// A scratch path beside `target` (same folder, so a later rename or copy stays on one disk),
    /// named after it and this process; nothing is created yet.
    pub fn beside(target: &Path, role: &str) -> Result<Self> {
        Ok(ScratchFile {
            path: unfinished_path_beside(target, role)?,
        })
    }
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
        unlist_unfinished(&self.path);
    }
}

/// A folder a program fills for its own use (`isogrid serve`'s extracted `.cgc`) and removes with
/// what it holds when done: when the guard is dropped and by [`remove_unfinished`] (Ctrl-C,
/// SIGTERM), so that no run leaves one behind.
#[derive(Debug)]
pub struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    /// Creates a new folder in `parent` (made if missing) named `prefix` and this process's id,
    /// with a count after it where a folder of that name is there already (left by a process
    /// that was killed outright, whose id came round again): an existing folder is never taken
    /// over, as it is not this program's to remove.
    pub fn create_in(parent: &Path, prefix: &str) -> Result<Self> {
        std::fs::create_dir_all(parent).map_err(|e| Error::io(e).with_path(parent))?;
        let pid = std::process::id();
        for n in 0..1000u32 {
            let name = match n {
                0 => format!("{prefix}-{pid}"),
                n => format!("{prefix}-{pid}-{n}"),
            };
            let path = parent.join(name);
            match std::fs::create_dir(&path) {
                Ok(()) => {
                    list_unfinished(&path);
                    return Ok(ScratchDir { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io(e).with_path(&path)),
            }
        }
        Err(Error::invalid(format!(
            "a thousand scratch folders named {prefix}-{pid}-N are there already"
        ))
        .with_path(parent))
    }
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        remove_temporary(&self.path);
        unlist_unfinished(&self.path);
    }
}

/// A complete temporary file waiting to replace its target; removed when dropped uncommitted.
/// Either way it leaves the list of unfinished writes.
#[must_use = "a staged file is removed unless committed"]
pub struct Staged {
    tmp: PathBuf,
    path: PathBuf,
    renamed: bool,
}

impl Staged {
    /// A temporary path beside `path` (same folder, so the rename stays on one disk), named after
    /// it and this process, listed among the unfinished writes; nothing is created yet.
    fn beside(path: &Path) -> Result<Staged> {
        let tmp = unfinished_path_beside(path, "tmp")?;
        Ok(Staged {
            tmp,
            path: path.to_path_buf(),
            renamed: false,
        })
    }

    /// Renames the temporary file onto the target. Errors name the target.
    pub fn commit(mut self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(e).with_path(&self.path))?;
        self.renamed = true;
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.renamed {
            remove_temporary(&self.tmp);
        }
        unlist_unfinished(&self.tmp);
    }
}

/// Opens `path` for reading if it is a regular file (after following links). A directory, FIFO,
/// socket or device is refused with an error saying which: reading a FIFO blocks until a writer
/// comes, a device may never end, and a directory cannot be read as a file. Errors name `path`.
pub fn open_regular(path: &Path) -> Result<File> {
    ensure_regular(path)?;
    File::open(path).map_err(|e| Error::io(e).with_path(path))
}

/// Fails unless `path` is a regular file (after following links); see [`open_regular`].
pub fn ensure_regular(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(e).with_path(path))?;
    if meta.is_file() {
        return Ok(());
    }
    let what = if meta.is_dir() {
        "a directory"
    } else {
        special_kind(&meta)
    };
    Err(Error::invalid(format!("is {what}, not a regular file")).with_path(path))
}

#[cfg(unix)]
fn special_kind(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_fifo() {
        "a pipe or FIFO (reading it could wait forever for a writer)"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_char_device() || t.is_block_device() {
        "a device"
    } else {
        "not a file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::Metadata) -> &'static str {
    "a special file"
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scratch folder goes with what it holds when dropped; one already there under its name is
    /// left alone, and the next name is taken. (That an interrupt removes it is tested through
    /// `isogrid serve`, as `remove_unfinished` here would also take other tests' files.)
    #[test]
    fn scratch_folders_are_removed_when_done_and_never_taken_over() {
        let base = std::env::temp_dir().join(format!("isogrid-scratch-{}", std::process::id()));
        let stale = base.join(format!("serve-{}", std::process::id()));
        std::fs::create_dir_all(&stale).unwrap();
        std::fs::write(stale.join("old.cgc"), b"x").unwrap();
        let dir = ScratchDir::create_in(&base, "serve").unwrap();
        assert_eq!(
            dir.path(),
            base.join(format!("serve-{}-1", std::process::id()))
        );
        std::fs::write(dir.path().join("f.cgc"), b"x").unwrap();
        let path = dir.path().to_path_buf();
        drop(dir);
        assert!(!path.exists());
        assert!(
            stale.join("old.cgc").is_file(),
            "a folder not its own was removed"
        );
        std::fs::remove_dir_all(&base).unwrap();
    }

    #[test]
    fn failed_write_keeps_the_old_file() {
        let dir = std::env::temp_dir().join(format!("isogrid-fs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("out.bin");
        std::fs::write(&target, b"old").unwrap();
        let err = write_atomic(&target, |w| {
            w.write_all(b"partial")?;
            Err(Error::invalid("simulated failure"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("out.bin"), "{err}");
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "temporary file left behind"
        );
        write_atomic(&target, |w| Ok(w.write_all(b"new")?)).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        // A panic inside the writer unwinds through the guard, which removes the temporary file.
        let panicked = std::panic::catch_unwind(|| {
            let _ = write_atomic(&target, |w| {
                w.write_all(b"partial")?;
                w.flush()?;
                panic!("writer panics");
            });
        });
        assert!(panicked.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "temporary file left behind by a panic"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

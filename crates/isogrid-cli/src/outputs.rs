//! The files a request will write, checked together before any work so that nothing is lost:
//! each output's extension names the format written into it, no output is one of the inputs
//! (same path, link or hard link) or a file an input reads (a header's data file, a slice of a
//! folder), no output is a folder, each output's folder exists, and no two outputs are the same
//! file.
//!
//! Every subcommand that writes calls [`check`] once with all its inputs and outputs.

use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// One file a request writes.
pub struct Output<'a> {
    /// What it holds, for messages: "the grid", "the image", "the depth AOV".
    pub role: &'static str,
    pub path: &'a Path,
    /// Accepted name endings, lowercase with the dot (".cgc"); the first is named in errors.
    pub extensions: &'static [&'static str],
}

/// Checks `outputs` against each other and against `inputs` (see the module doc).
pub fn check(inputs: &[&Path], outputs: &[Output]) -> Result<()> {
    // Inputs first: "would overwrite the input" says more than a wrong extension would.
    for out in outputs {
        for input in inputs {
            if same_file(out.path, input) {
                bail!(
                    "{}: {} would overwrite the input {}; choose another name",
                    out.path.display(),
                    out.role,
                    input.display()
                );
            }
            // The data file of a header, a slice of a folder.
            if let Some(file) = isogrid_io::files_read(input)
                .into_iter()
                .find(|f| same_file(out.path, f))
            {
                bail!(
                    "{}: {} would overwrite {}, which the input {} reads; choose another name",
                    out.path.display(),
                    out.role,
                    file.display(),
                    input.display()
                );
            }
        }
    }
    for out in outputs {
        check_folder(out.role, out.path)?;
        // Found before any work: the write would fail only after the others had been written.
        if out.path.is_dir() {
            bail!(
                "{}: {} is to be written there, but it is a folder; name a file",
                out.path.display(),
                out.role
            );
        }
        let name = out
            .path
            .file_name()
            .map(|n| n.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if !out.extensions.iter().any(|e| name.ends_with(e)) {
            bail!(
                "{}: {} is written as {}, so its name must end in {}",
                out.path.display(),
                out.role,
                format_name(out.extensions[0]),
                out.extensions.join(" or ")
            );
        }
    }
    for (i, a) in outputs.iter().enumerate() {
        for b in &outputs[..i] {
            if same_file(a.path, b.path) {
                bail!(
                    "{}: named for both {} and {}; each output needs its own file",
                    a.path.display(),
                    b.role,
                    a.role
                );
            }
        }
    }
    Ok(())
}

/// Checks that the folder `path` is to be written into exists, so that a long extraction does not
/// end in "No such file or directory". `role` names what is written there, for the message.
pub fn check_folder(role: &str, path: &Path) -> Result<()> {
    let Some(folder) = path.parent().filter(|d| !d.as_os_str().is_empty()) else {
        return Ok(());
    };
    match std::fs::metadata(folder) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => bail!(
            "{}: {role} cannot be written there: {} is not a folder",
            path.display(),
            folder.display()
        ),
        Err(_) => bail!(
            "{}: {role} cannot be written there: the folder {} does not exist; create it first",
            path.display(),
            folder.display()
        ),
    }
}

fn format_name(extension: &str) -> &'static str {
    match extension {
        ".cgc" => "a .cgc grid",
        ".nrrd" => "NRRD",
        ".png" => "PNG",
        ".npy" => "NumPy .npy",
        ".ply" | ".obj" | ".stl" | ".vtp" | ".glb" => "a mesh file",
        _ => "its format",
    }
}

/// Whether `a` and `b` name the same file: equal canonical paths (links resolved; for a file not
/// yet written, its folder's), or the same device and inode when both exist (hard links).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    match (identity(a), identity(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

/// The canonical path of `p`, or of its folder joined with its name when `p` does not exist yet.
fn identity(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(dir.canonicalize().ok()?.join(p.file_name()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_differ_only_by_dots_are_the_same_file() {
        let dir = std::env::temp_dir().join(format!("isogrid-outputs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = dir.join("x.npy");
        let b = dir.join(".").join("x.npy");
        assert!(same_file(&a, &b), "not yet written");
        std::fs::write(&a, b"1").unwrap();
        assert!(same_file(&a, &b), "written");
        assert!(!same_file(&a, &dir.join("y.npy")));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

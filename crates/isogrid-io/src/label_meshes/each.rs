//! One mesh file per label, named from a template: `organs/{name}.stl` (3D printing, and what 3D
//! Slicer's "export to files" gives) or `segments/{value}.ply`. `{name}` is the label's name made
//! safe as a file name (path separators, control characters and `:*?"<>|` become `_`, leading
//! dots go), `{value}` its value. The format is the template's extension: .stl, .obj, .ply, .vtp (`mesh_write`) or
//! .glb (one label's glTF). Positions as the caller placed the meshes (world or index space).
//!
//! All or nothing: into a folder that does not exist yet, the files are written into a new
//! temporary folder that is then renamed into place; into an existing folder, each file is staged
//! beside its name and all are renamed into place only once every one is written.

use super::gltf::glb_bytes;
use super::label_mesh::LabelMesh;
use crate::mesh_write::MeshFileFormat;
use isogrid::fs::{stage, stage_dir, Staged};
use isogrid::{Error, Result};
use std::path::{Path, PathBuf};

/// Whether `path` is a template of one file per label (its file name holds `{name}` or
/// `{value}`).
pub fn is_template(path: &Path) -> bool {
    path.file_name()
        .map(|n| n.to_string_lossy())
        .is_some_and(|n| n.contains("{name}") || n.contains("{value}"))
}

/// What a template's files are written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EachFormat {
    Mesh(MeshFileFormat),
    Glb,
}

impl EachFormat {
    /// The format the template's extension names; errors name `template`, and refuse `{name}`
    /// or `{value}` in its folder.
    pub fn of(template: &Path) -> Result<Self> {
        let folder = template.parent().map(|d| d.to_string_lossy());
        if folder.is_some_and(|d| d.contains("{name}") || d.contains("{value}")) {
            return Err(Error::invalid(
                "{name} and {value} fill in the file name, not a folder: write organs/{name}.stl",
            )
            .with_path(template));
        }
        let glb = template
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
        match glb {
            true => Ok(EachFormat::Glb),
            false => MeshFileFormat::of(template)
                .map(EachFormat::Mesh)
                .map_err(|_| {
                    Error::invalid("one file per label ends in .stl, .obj, .ply, .vtp or .glb")
                        .with_path(template)
                }),
        }
    }

    /// Whether the format holds a value per vertex.
    pub fn holds_values(self) -> bool {
        match self {
            EachFormat::Mesh(format) => format.holds_values(),
            EachFormat::Glb => true,
        }
    }
}

/// A label's name as a piece of a file name: path separators, control characters and characters
/// Windows refuses become `_`, and leading dots go (no hidden files); an empty name becomes `_`.
fn safe_name(name: &str) -> String {
    let safe: String = name
        .chars()
        .map(|c| match c {
            '/' | '\\' | ':' | '*' | '?' | '"' | '<' | '>' | '|' => '_',
            c if c.is_control() => '_',
            c => c,
        })
        .collect();
    match safe.trim().trim_start_matches('.').trim() {
        "" => "_".to_string(),
        kept => kept.to_string(),
    }
}

/// `pattern` with each `{name}` and `{value}` replaced, in one pass (a name holding `{value}`
/// stays as it is).
fn filled(pattern: &str, name: &str, value: &str) -> String {
    let mut out = String::with_capacity(pattern.len() + name.len());
    let mut rest = pattern;
    while let Some(at) = rest.find('{') {
        out.push_str(&rest[..at]);
        rest = &rest[at..];
        let (text, skip) = match () {
            _ if rest.starts_with("{name}") => (name, "{name}".len()),
            _ if rest.starts_with("{value}") => (value, "{value}".len()),
            _ => ("{", 1),
        };
        out.push_str(text);
        rest = &rest[skip..];
    }
    out.push_str(rest);
    out
}

/// The file of each of `meshes` under `template`, in their order. Two labels given one file (the
/// same name under `{name}`, in any case, as case-insensitive file systems see them) are refused
/// naming both.
pub fn file_names(template: &Path, meshes: &[LabelMesh]) -> Result<Vec<PathBuf>> {
    let pattern = template
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut seen = std::collections::HashMap::new();
    meshes
        .iter()
        .map(|m| {
            let name = filled(&pattern, &safe_name(&m.label.name), m.value);
            if let Some(other) = seen.insert(name.to_lowercase(), m.value) {
                return Err(Error::invalid(format!(
                    "labels {other} and {} would both be written as {name}; name the files by \
                     {{value}}",
                    m.value
                ))
                .with_path(template));
            }
            Ok(template.with_file_name(name))
        })
        .collect()
}

/// Writes each of `meshes` (those with triangles) as its own file under `template`, with
/// `attribute`'s name over the meshes' values where they carry them and the format holds them;
/// all or nothing (see the module docs). Returns the files written. Errors name the file.
pub fn write_each(
    template: &Path,
    meshes: &[LabelMesh],
    attribute: Option<&str>,
) -> Result<Vec<PathBuf>> {
    let format = EachFormat::of(template)?;
    let written: Vec<LabelMesh> = meshes
        .iter()
        .filter(|m| !m.mesh.triangles.is_empty())
        .copied()
        .collect();
    if written.is_empty() {
        return Err(Error::invalid("no label has a surface to write").with_path(template));
    }
    let files = file_names(template, &written)?;
    let write_one = |m: &LabelMesh, out: &mut dyn std::io::Write| -> Result<()> {
        match format {
            EachFormat::Glb => Ok(out.write_all(&glb_bytes(std::slice::from_ref(m), attribute)?)?),
            EachFormat::Mesh(f) => {
                let values = attribute.zip(m.values).filter(|_| f.holds_values());
                f.write_to(m.mesh, out, values)
            }
        }
    };
    let folder = match template.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if folder.symlink_metadata().is_err() {
        // A new folder: filled under a temporary name, then renamed into place whole.
        stage_dir(&folder, |tmp| {
            for (m, file) in written.iter().zip(&files) {
                let name = file.file_name().expect("a file name");
                let path = tmp.join(name);
                let mut out = std::io::BufWriter::new(std::fs::File::create(&path)?);
                write_one(m, &mut out).map_err(|e| e.with_path(file))?;
                std::io::Write::flush(&mut out)?;
            }
            Ok(())
        })?
        .commit()?;
        return Ok(files);
    }
    let staged: Vec<Staged> = written
        .iter()
        .zip(&files)
        .map(|(m, file)| stage(file, |out| write_one(m, out)))
        .collect::<Result<_>>()?;
    for s in staged {
        s.commit()?;
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::{filled, safe_name};

    #[test]
    fn names_become_file_names_and_fill_the_template_once() {
        assert_eq!(safe_name("left/right: a*b?"), "left_right_ a_b_");
        assert_eq!(safe_name("..hidden"), "hidden");
        assert_eq!(safe_name(" .. "), "_");
        assert_eq!(safe_name("tab\there"), "tab_here");
        assert_eq!(
            filled("{name}-{value}.stl", "{value}", "7"),
            "{value}-7.stl"
        );
        assert_eq!(filled("a{b}{name}", "x", "1"), "a{b}x");
    }
}

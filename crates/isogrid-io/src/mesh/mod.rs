//! Triangle mesh readers: PLY, OBJ and STL, each optionally gzip-compressed.
//!
//! Meshes are the input of the voxeliser (paper §4: the non-CT datasets are voxelised meshes).
//! Only geometry is read: vertex positions and faces, polygons fan-triangulated. Coordinates are
//! kept in the file's own units and axes.
//!
//! Every reader checks declared counts against the bytes actually present before allocating, and
//! checks that every face index names an existing vertex, so a hostile or truncated file yields
//! an `Err` with a one-line message and never a panic or a huge allocation.

mod obj;
mod ply;
mod stl;

use isogrid::{Error, Result, ResultExt};
use std::io::Read;
use std::path::Path;

/// An indexed triangle mesh in the file's coordinates (no unit conversion, no reorientation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    pub vertices: Vec<[f32; 3]>,
    /// Indices into `vertices`, three per triangle, in the file's winding order.
    pub triangles: Vec<[u32; 3]>,
}

/// The mesh file formats [`read_mesh`] understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Stanford PLY: `ascii`, `binary_little_endian` and `binary_big_endian`.
    Ply,
    /// Wavefront OBJ: `v` and `f` statements (negative indices allowed); the rest is ignored.
    Obj,
    /// STL, ASCII or binary.
    Stl,
}

impl MeshFormat {
    /// The format named by a file extension (case-insensitive, without the dot).
    pub fn from_extension(ext: &str) -> Option<Self> {
        match ext.to_ascii_lowercase().as_str() {
            "ply" => Some(MeshFormat::Ply),
            "obj" => Some(MeshFormat::Obj),
            "stl" => Some(MeshFormat::Stl),
            _ => None,
        }
    }

    /// Guesses the format from the first bytes of an (uncompressed) file.
    fn sniff(bytes: &[u8]) -> Option<Self> {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            Some(MeshFormat::Ply)
        } else if stl::looks_like_stl(bytes) {
            Some(MeshFormat::Stl)
        } else if bytes
            .split(|&b| b == b'\n')
            .take(10_000)
            .any(|line| line.starts_with(b"v ") || line.starts_with(b"f "))
        {
            Some(MeshFormat::Obj)
        } else {
            None
        }
    }
}

/// Reads a triangle mesh. The format comes from the extension (`.ply`, `.obj`, `.stl`, each
/// optionally followed by `.gz`), or from the content when the extension is unknown. Gzip is
/// recognised by its magic bytes. Errors name `path`.
pub fn read_mesh(path: &Path) -> Result<TriMesh> {
    let mut file = isogrid::fs::open_regular(path)?;
    let len = file.metadata().at_path(path)?.len();
    let mut raw =
        isogrid::memory::try_vec::<u8>("reading the mesh file", len as usize).at_path(path)?;
    file.read_to_end(&mut raw).at_path(path)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let bytes = if raw.starts_with(&[0x1f, 0x8b]) {
        match inflate(&raw) {
            Ok(out) => out,
            // A binary STL header may begin with the gzip magic by chance.
            Err(_) if !name.ends_with(".gz") => raw,
            Err(e) => return Err(e.with_path(path)),
        }
    } else {
        raw
    };
    let stem = name.strip_suffix(".gz").unwrap_or(&name);
    let format = Path::new(stem)
        .extension()
        .and_then(|e| MeshFormat::from_extension(&e.to_string_lossy()))
        .or_else(|| MeshFormat::sniff(&bytes))
        .ok_or_else(|| {
            Error::unsupported("unknown mesh format (expected .ply, .obj or .stl, optionally .gz)")
        })
        .at_path(path)?;
    parse_mesh(&bytes, format).at_path(path)
}

/// Decompresses a gzip mesh, never past what its content allows: for a binary PLY, the header's
/// elements at their largest records; otherwise the memory there is. A stream with more is
/// refused before the excess is held, so a small file that inflates to gigabytes fails early.
fn inflate(raw: &[u8]) -> Result<Vec<u8>> {
    let damaged = |e: std::io::Error| Error::corrupt(format!("gzip stream is damaged: {e}"));
    let mut decoder = flate2::read::MultiGzDecoder::new(raw);
    let mut out = Vec::new();
    // Enough for any PLY header the reader accepts.
    (&mut decoder)
        .take(ply::MAX_HEADER_BYTES as u64)
        .read_to_end(&mut out)
        .map_err(damaged)?;
    let (limit, why) = match ply::max_file_bytes(&out) {
        Some(n) => (n, format!("{n} bytes the PLY header allows")),
        None => match isogrid::memory::available() {
            Some((n, source)) => (n, format!("{} ({source})", isogrid::memory::show_bytes(n))),
            None => (u64::MAX, String::new()),
        },
    };
    let more = limit.saturating_sub(out.len() as u64).saturating_add(1);
    (&mut decoder)
        .take(more)
        .read_to_end(&mut out)
        .map_err(damaged)?;
    if out.len() as u64 > limit {
        return Err(Error::corrupt(format!(
            "gzip data inflates to more than the {why}"
        )));
    }
    Ok(out)
}

/// Parses an uncompressed mesh held in memory. Fails when the mesh has no triangle.
pub fn parse_mesh(bytes: &[u8], format: MeshFormat) -> Result<TriMesh> {
    let mesh = match format {
        MeshFormat::Ply => ply::parse(bytes)?,
        MeshFormat::Obj => obj::parse(bytes)?,
        MeshFormat::Stl => stl::parse(bytes)?,
    };
    if mesh.triangles.is_empty() {
        return Err(Error::corrupt("mesh has no triangles"));
    }
    Ok(mesh)
}

/// Appends the fan triangulation `(p0, p_i, p_i+1)` of a polygon; fewer than 3 corners add nothing.
fn push_fan(polygon: &[u32], triangles: &mut Vec<[u32; 3]>) {
    for pair in polygon.get(1..).unwrap_or(&[]).windows(2) {
        triangles.push([polygon[0], pair[0], pair[1]]);
    }
}

/// Checks the invariants every reader promises: finite coordinates, indices in range.
fn validate(mesh: &TriMesh) -> Result<()> {
    if let Some(i) = mesh
        .vertices
        .iter()
        .position(|v| v.iter().any(|c| !c.is_finite()))
    {
        return Err(Error::corrupt(format!(
            "vertex {i} has a non-finite coordinate"
        )));
    }
    let n = mesh.vertices.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Err(Error::corrupt(format!(
            "triangle {t} refers to a vertex beyond the {n} vertices"
        )));
    }
    Ok(())
}

/// Splits `bytes` into whitespace-separated tokens, remembering the 1-based line of each.
struct Tokens<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Tokens<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Tokens {
            bytes,
            pos: 0,
            line: 1,
        }
    }

    fn next_token(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            self.line += (b == b'\n') as usize;
            self.pos += 1;
        }
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.bytes[start..self.pos])
    }
}

/// Parses an ASCII number token.
fn parse_number<T: std::str::FromStr>(token: &[u8]) -> Option<T> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// Shows a token in an error message, shortened and without control characters.
fn show(token: &[u8]) -> String {
    String::from_utf8_lossy(&token[..token.len().min(32)])
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Two triangles forming a unit square plus a tetrahedron tip: small but not symmetric, so
    /// index or axis mix-ups show.
    pub(crate) fn sample_mesh() -> TriMesh {
        TriMesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.25, 0.5, -1.5],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 4, 1], [1, 4, 2]],
        }
    }

    #[test]
    fn read_mesh_by_extension_and_gzip() {
        let dir = std::env::temp_dir().join(format!("isogrid-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let expected = TriMesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        };
        let plain = dir.join("tri.OBJ");
        std::fs::write(&plain, obj).unwrap();
        assert_eq!(read_mesh(&plain).unwrap(), expected);

        let gz = dir.join("tri.obj.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut enc, obj).unwrap();
        std::fs::write(&gz, enc.finish().unwrap()).unwrap();
        assert_eq!(read_mesh(&gz).unwrap(), expected);

        // Unknown extension: recognised from the content.
        let unknown = dir.join("tri.mesh");
        std::fs::write(&unknown, obj).unwrap();
        assert_eq!(read_mesh(&unknown).unwrap(), expected);

        let missing = dir.join("missing.ply");
        let err = read_mesh(&missing).unwrap_err();
        assert!(err.to_string().contains("missing.ply"), "{err}");

        // A binary STL whose free-form header happens to start with the gzip magic.
        let mut stl = vec![0x1f, 0x8b];
        stl.resize(80, b' ');
        stl.extend(1u32.to_le_bytes());
        stl.extend([0u8; 12]);
        for v in &expected.vertices {
            stl.extend(v.iter().flat_map(|c| c.to_le_bytes()));
        }
        stl.extend([0u8; 2]);
        let stl_path = dir.join("magic.stl");
        std::fs::write(&stl_path, stl).unwrap();
        assert_eq!(read_mesh(&stl_path).unwrap(), expected);

        let broken_gz = dir.join("broken.ply.gz");
        std::fs::write(&broken_gz, [0x1f, 0x8b, 8, 0, 1, 2, 3]).unwrap();
        let err = read_mesh(&broken_gz).unwrap_err();
        assert!(err.to_string().contains("broken.ply.gz"), "{err}");
        assert!(err.to_string().contains("gzip"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn empty_mesh_is_an_error() {
        let err = parse_mesh(b"v 0 0 0\n", MeshFormat::Obj).unwrap_err();
        assert!(err.message().contains("no triangles"), "{err}");
    }

    #[test]
    fn fan_triangulation() {
        let mut t = Vec::new();
        push_fan(&[7, 8, 9, 10, 11], &mut t);
        assert_eq!(t, vec![[7, 8, 9], [7, 9, 10], [7, 10, 11]]);
        push_fan(&[1, 2], &mut t);
        assert_eq!(t.len(), 3);
    }
}

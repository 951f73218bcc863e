//! VTK XML PolyData (`.vtp`, VTK's "VTK File Formats" document), the one writer of the format:
//! triangle meshes with arrays per point, per triangle and per file (field data), which ParaView
//! and PyVista read with the arrays that VTK's PLY reader drops.
//!
//! The file holds one piece: the meshes given are concatenated, each one's vertices after the
//! last's. Every array follows as raw little-endian bytes in the appended-data section, after its
//! UInt64 byte count. Positions are written as stored (the frame [`McMesh::place`] put them in).

use super::mesh::McMesh;
use crate::error::Result;
use crate::fs::write_atomic;
use std::io::Write;
use std::path::Path;

/// Bytes gathered before each write call.
const CHUNK: usize = 1 << 20;

/// The values of one array: one tuple per point, per triangle or (field data) per entry.
#[derive(Debug, Clone, Copy)]
pub enum VtkValues<'a> {
    /// Float32, one component, one value per tuple (point data: per vertex of the concatenation).
    Float32(&'a [f32]),
    /// Int64, one value per tuple.
    Int64(&'a [i64]),
    /// UInt64, one value per tuple.
    UInt64(&'a [u64]),
    /// Int64, one value per mesh, repeated for each of its points or triangles.
    Int64PerMesh(&'a [i64]),
    /// UInt64, one value per mesh, repeated for each of its points or triangles.
    UInt64PerMesh(&'a [u64]),
    /// UInt8 × 3 (an sRGB colour, which ParaView shows as is with "Map Scalars" off), one per
    /// mesh, repeated for each of its points or triangles.
    RgbPerMesh(&'a [[u8; 3]]),
    /// VTK's String type (field data): each string's bytes and a NUL. A NUL inside a string
    /// would end it early, so it is written as a space.
    Strings(&'a [String]),
}

impl VtkValues<'_> {
    fn vtk_type(&self) -> &'static str {
        match self {
            VtkValues::Float32(_) => "Float32",
            VtkValues::Int64(_) | VtkValues::Int64PerMesh(_) => "Int64",
            VtkValues::UInt64(_) | VtkValues::UInt64PerMesh(_) => "UInt64",
            VtkValues::RgbPerMesh(_) => "UInt8",
            VtkValues::Strings(_) => "String",
        }
    }

    fn components(&self) -> u32 {
        match self {
            VtkValues::RgbPerMesh(_) => 3,
            _ => 1,
        }
    }

    /// Tuples, given each mesh's count of the array's elements (points or triangles).
    fn tuples(&self, per_mesh: &[u64]) -> u64 {
        match self {
            VtkValues::Float32(v) => v.len() as u64,
            VtkValues::Int64(v) => v.len() as u64,
            VtkValues::UInt64(v) => v.len() as u64,
            VtkValues::Strings(v) => v.len() as u64,
            VtkValues::Int64PerMesh(_) | VtkValues::UInt64PerMesh(_) | VtkValues::RgbPerMesh(_) => {
                per_mesh.iter().sum()
            }
        }
    }

    fn per_mesh_len(&self) -> Option<usize> {
        match self {
            VtkValues::Int64PerMesh(v) => Some(v.len()),
            VtkValues::UInt64PerMesh(v) => Some(v.len()),
            VtkValues::RgbPerMesh(v) => Some(v.len()),
            _ => None,
        }
    }

    /// Byte count of the appended block.
    fn bytes(&self, per_mesh: &[u64]) -> u64 {
        match self {
            VtkValues::Strings(v) => v.iter().map(|s| s.len() as u64 + 1).sum(),
            VtkValues::RgbPerMesh(_) => 3 * self.tuples(per_mesh),
            VtkValues::Float32(_) => 4 * self.tuples(per_mesh),
            _ => 8 * self.tuples(per_mesh),
        }
    }

    /// Writes the values' bytes through `sink`.
    fn write(&self, per_mesh: &[u64], sink: &mut Sink) -> std::io::Result<()> {
        fn repeated<T: Copy>(
            values: &[T],
            per_mesh: &[u64],
            sink: &mut Sink,
            bytes: impl Fn(T) -> Vec<u8>,
        ) -> std::io::Result<()> {
            for (&v, &n) in values.iter().zip(per_mesh) {
                let b = bytes(v);
                for _ in 0..n {
                    sink.put(&b)?;
                }
            }
            Ok(())
        }
        match *self {
            VtkValues::Float32(v) => v.iter().try_for_each(|x| sink.put(&x.to_le_bytes())),
            VtkValues::Int64(v) => v.iter().try_for_each(|x| sink.put(&x.to_le_bytes())),
            VtkValues::UInt64(v) => v.iter().try_for_each(|x| sink.put(&x.to_le_bytes())),
            VtkValues::Int64PerMesh(v) => repeated(v, per_mesh, sink, |x| x.to_le_bytes().into()),
            VtkValues::UInt64PerMesh(v) => repeated(v, per_mesh, sink, |x| x.to_le_bytes().into()),
            VtkValues::RgbPerMesh(v) => repeated(v, per_mesh, sink, |x| x.into()),
            VtkValues::Strings(v) => v.iter().try_for_each(|s| {
                let bytes: Vec<u8> = s.bytes().map(|b| if b == 0 { b' ' } else { b }).collect();
                sink.put(&bytes)?;
                sink.put(&[0])
            }),
        }
    }
}

/// A named array of a `.vtp` file.
#[derive(Debug, Clone, Copy)]
pub struct VtkArray<'a> {
    pub name: &'a str,
    pub values: VtkValues<'a>,
}

/// What a `.vtp` file holds besides its meshes: arrays per point (the first is the active
/// scalars), per triangle (the first is the active scalars) and per file.
#[derive(Debug, Clone, Copy, Default)]
pub struct VtpArrays<'a> {
    pub point: &'a [VtkArray<'a>],
    pub cell: &'a [VtkArray<'a>],
    pub field: &'a [VtkArray<'a>],
}

/// Buffers bytes into writes of about [`CHUNK`].
struct Sink<'w> {
    out: &'w mut dyn Write,
    buf: Vec<u8>,
}

impl Sink<'_> {
    fn put(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.buf.extend_from_slice(bytes);
        if self.buf.len() >= CHUNK {
            self.out.write_all(&self.buf)?;
            self.buf.clear();
        }
        Ok(())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.write_all(&self.buf)?;
        self.buf.clear();
        Ok(())
    }
}

/// Writes `meshes`, concatenated, with `arrays` as one VTK XML PolyData piece at `path`,
/// atomically: `Points` (Float32 x, y, z), `Polys` (`connectivity` UInt32, or UInt64 past 2³²−1
/// vertices in all; `offsets` UInt64). Errors name `path`.
///
/// # Panics
/// When an array's length does not match what it is per: the points or triangles of all meshes,
/// or the number of meshes for the per-mesh kinds.
pub fn write_vtp(path: &Path, meshes: &[&McMesh], arrays: VtpArrays) -> Result<()> {
    write_atomic(path, |out| write_vtp_to(out, meshes, arrays))
}

/// [`write_vtp`] into `out`.
///
/// # Panics
/// As [`write_vtp`].
pub fn write_vtp_to(out: &mut dyn Write, meshes: &[&McMesh], arrays: VtpArrays) -> Result<()> {
    let points: Vec<u64> = meshes.iter().map(|m| m.positions.len() as u64).collect();
    let triangles: Vec<u64> = meshes.iter().map(|m| m.triangles.len() as u64).collect();
    let (n, t) = (points.iter().sum::<u64>(), triangles.iter().sum::<u64>());
    let wide = n > u32::MAX as u64;
    for (list, per_mesh, total, what) in [
        (arrays.point, &points, n, "point"),
        (arrays.cell, &triangles, t, "triangle"),
    ] {
        for a in list {
            match a.values.per_mesh_len() {
                Some(len) => assert_eq!(len, meshes.len(), "{}: one value per mesh", a.name),
                None => assert_eq!(
                    a.values.tuples(per_mesh),
                    total,
                    "{}: one per {what}",
                    a.name
                ),
            }
        }
    }
    // The appended blocks in file order: point, cell and field arrays, then points,
    // connectivity and offsets; each is its byte count (8 B) and its bytes.
    let mut offset = 0u64;
    let mut next = |bytes: u64| {
        let at = offset;
        offset += 8 + bytes;
        at
    };
    let at = |list: &[VtkArray], per_mesh: &[u64], next: &mut dyn FnMut(u64) -> u64| -> Vec<u64> {
        list.iter()
            .map(|a| next(a.values.bytes(per_mesh)))
            .collect()
    };
    let point_at = at(arrays.point, &points, &mut next);
    let cell_at = at(arrays.cell, &triangles, &mut next);
    let field_at = at(arrays.field, &[], &mut next);
    let index_bytes = if wide { 8 } else { 4 };
    let [points_at, connectivity_at, offsets_at] =
        [12 * n, 3 * index_bytes * t, 8 * t].map(&mut next);

    let declare = |out: &mut dyn Write,
                   tag: &str,
                   list: &[VtkArray],
                   at: &[u64],
                   per_mesh: &[u64]|
     -> std::io::Result<()> {
        if list.is_empty() {
            return writeln!(out, "      <{tag}/>");
        }
        match tag {
            "FieldData" => writeln!(out, "    <{tag}>")?,
            _ => writeln!(
                out,
                "      <{tag} Scalars=\"{}\">",
                xml_escaped(list[0].name)
            )?,
        }
        for (a, at) in list.iter().zip(at) {
            let (element, indent) = match tag {
                "FieldData" => ("Array", "      "),
                _ => ("DataArray", "        "),
            };
            writeln!(
                out,
                "{indent}<{element} type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" \
                 NumberOfTuples=\"{}\" format=\"appended\" offset=\"{at}\"/>",
                a.values.vtk_type(),
                xml_escaped(a.name),
                a.values.components(),
                a.values.tuples(per_mesh),
            )?;
        }
        match tag {
            "FieldData" => writeln!(out, "    </{tag}>"),
            _ => writeln!(out, "      </{tag}>"),
        }
    };
    writeln!(out, "<?xml version=\"1.0\"?>")?;
    writeln!(
        out,
        "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n  <PolyData>"
    )?;
    if !arrays.field.is_empty() {
        declare(out, "FieldData", arrays.field, &field_at, &[])?;
    }
    writeln!(
        out,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{t}\">"
    )?;
    declare(out, "PointData", arrays.point, &point_at, &points)?;
    declare(out, "CellData", arrays.cell, &cell_at, &triangles)?;
    writeln!(
        out,
        "      <Points>\n        <DataArray type=\"Float32\" NumberOfComponents=\"3\" \
         format=\"appended\" offset=\"{points_at}\"/>\n      </Points>\n      <Polys>\n        \
         <DataArray type=\"{}\" Name=\"connectivity\" format=\"appended\" offset=\"{connectivity_at}\"/>\n        \
         <DataArray type=\"UInt64\" Name=\"offsets\" format=\"appended\" offset=\"{offsets_at}\"/>\n      \
         </Polys>\n    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">",
        if wide { "UInt64" } else { "UInt32" },
    )?;
    out.write_all(b"   _")?;
    let mut sink = Sink {
        out,
        buf: Vec::with_capacity(CHUNK + 64),
    };
    for (list, per_mesh) in [
        (arrays.point, &points[..]),
        (arrays.cell, &triangles[..]),
        (arrays.field, &[][..]),
    ] {
        for a in list {
            sink.put(&a.values.bytes(per_mesh).to_le_bytes())?;
            a.values.write(per_mesh, &mut sink)?;
        }
    }
    sink.put(&(12 * n).to_le_bytes())?;
    for m in meshes {
        for c in m.positions.iter().flatten() {
            sink.put(&c.to_le_bytes())?;
        }
    }
    sink.put(&(3 * index_bytes * t).to_le_bytes())?;
    let mut first = 0u64;
    for m in meshes {
        for &i in m.triangles.iter().flatten() {
            match wide {
                true => sink.put(&(first + i as u64).to_le_bytes())?,
                false => sink.put(&((first + i as u64) as u32).to_le_bytes())?,
            }
        }
        first += m.positions.len() as u64;
    }
    sink.put(&(8 * t).to_le_bytes())?;
    for k in 1..=t {
        sink.put(&(3 * k).to_le_bytes())?;
    }
    sink.flush()?;
    writeln!(out, "\n  </AppendedData>\n</VTKFile>")?;
    Ok(())
}

/// `text` with XML's five special characters escaped, for an attribute value.
fn xml_escaped(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => escaped.push_str("&amp;"),
            '<' => escaped.push_str("&lt;"),
            '>' => escaped.push_str("&gt;"),
            '"' => escaped.push_str("&quot;"),
            '\'' => escaped.push_str("&apos;"),
            c => escaped.push(c),
        }
    }
    escaped
}

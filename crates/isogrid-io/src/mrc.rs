//! MRC / CCP4 density maps (`.mrc`, `.map`, `.ccp4`, `.mrcs`), the volume format of cryo-EM and
//! crystallography (EMDB, RELION, cryoSPARC, IMOD, ChimeraX).
//!
//! Spec: MRC2014 (Cheng et al., *J. Struct. Biol.* 192:146, 2015) and the CCP4 map format. Where
//! the spec leaves room, the reader matches mrcfile (the CCP-EM reference library) and ChimeraX:
//!
//! - Layout: a 1024-byte header, `NSYMBT` bytes of extended header (skipped), then the samples,
//!   columns fastest, then rows, then sections.
//! - Byte order: from the machine stamp (`44 44`/`44 41` little, `11 11` big), as mrcfile. When
//!   the stamp is unknown or contradicts the header (a mode or sizes that only make sense swapped,
//!   which mrcfile's permissive mode also corrects), the order in which the header is plausible.
//! - Modes: 0 int8, signed as MRC2014 and mrcfile read it (kept as i16), except when an IMOD
//!   header marks its bytes unsigned (IMOD stamp, flag bit 0 clear), as ChimeraX reads it (u8);
//!   1 int16; 2 float32; 6 uint16; 12 float16 (exact as f32). Complex modes 3 and 4, packed
//!   4-bit mode 101 and RGB mode 16 are `Unsupported`.
//! - Axis order: `MAPC`, `MAPR`, `MAPS` say which of x, y, z the columns, rows and sections run
//!   along. The samples are permuted into x-fastest order, as ChimeraX does: this is the one reader
//!   that does not keep the file's storage order, because rendering ignores directions and a map
//!   stored (z, y, x) would otherwise be drawn mirrored. All three 0 (unset, in old files) means
//!   1, 2, 3; anything else that is not a permutation of 1, 2, 3 is `Corrupt`.
//! - Voxel size: `CELLA / (MX, MY, MZ)` along x, y, z (mrcfile's `voxel_size`); 1 where a cell
//!   length or sampling is 0.
//! - Origin: the MRC2014 `ORIGIN` fields (x, y, z) when the file has the `MAP ` stamp and any of
//!   them is non-zero; otherwise `NXSTART, NYSTART, NZSTART` (given per column, row, section and
//!   permuted to x, y, z) times the voxel size. This is ChimeraX's rule; mrcfile exposes both
//!   fields without choosing. Both conventions are in use: mrcfile and RELION write `ORIGIN`, while
//!   EMDB maps and crystallographic CCP4 maps leave it 0 and place the box with the start indices,
//!   so reading either alone would misplace one kind of file.
//! - Cell angles other than 90° (valid ones): axis directions are the skewed cell axes, and the
//!   start-index origin follows them, as ChimeraX does.
//! - Stacks: an image stack (`.mrcs`, ISPG 0) reads as a volume whose k is the image index; a
//!   stack of volumes (ISPG 401 and up with NZ > MZ) is `Unsupported`.
//! - Sizes: checked against the file before allocating. Bytes after the data are ignored (mrcfile
//!   only warns). A file shorter than its header, `NSYMBT` bytes of extended header and the data
//!   is refused, as mrcfile does: whether the extended header or the data is short cannot be told,
//!   and reading from byte 1024 would take extended-header bytes for samples.

use crate::data_file::open_regular;
use crate::geometry::{geometry, normalized, Vec3};
use crate::samples::{byte_count, read_samples, sample_count, ElemType};
use isogrid::{Error, Result, ResultExt, Volume, VolumeData};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

const HEADER_SIZE: usize = 1024;

/// Reads an MRC or CCP4 map. Errors name `path`.
pub fn read_mrc(path: &Path) -> Result<Volume> {
    read(path).at_path(path)
}

/// What the samples are stored as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Int8,
    UInt8,
    Int16,
    Float32,
    UInt16,
    Float16,
}

impl Mode {
    fn elem(self) -> ElemType {
        match self {
            Mode::Int8 => ElemType::I8,
            Mode::UInt8 => ElemType::U8,
            Mode::Int16 => ElemType::I16,
            Mode::Float32 => ElemType::F32,
            Mode::UInt16 | Mode::Float16 => ElemType::U16,
        }
    }
}

/// The header fields a volume needs, in file (column, row, section) terms where noted.
struct Header {
    big_endian: bool,
    /// Columns, rows, sections.
    crs: [usize; 3],
    mode: Mode,
    /// Spatial axis (0 = x) that the columns, rows and sections run along.
    axis_of: [usize; 3],
    /// Extended header bytes between the header and the data.
    nsymbt: u64,
    spacing: [f64; 3],
    origin: Vec3,
    direction: Option<[Vec3; 3]>,
}

fn read(path: &Path) -> Result<Volume> {
    let file = open_regular(path)?;
    let file_len = file.metadata()?.len();
    let mut reader = BufReader::new(file);
    let mut raw = [0u8; HEADER_SIZE];
    reader.read_exact(&mut raw).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => Error::corrupt(format!(
            "file of {file_len} bytes is shorter than the 1024-byte MRC header"
        )),
        _ => Error::io(e),
    })?;
    let header = parse_header(&raw)?;
    let count = sample_count(header.crs)?;
    let needed = byte_count(count, header.mode.elem())?;
    let offset = HEADER_SIZE as u64 + header.nsymbt;
    if offset.saturating_add(needed) > file_len {
        let [nc, nr, ns] = header.crs;
        // Where the samples would start is unknown: after the declared extended header the file
        // is short; from byte 1024 the extended header's bytes would be taken as samples if the
        // data is what is short. mrcfile refuses such files too.
        return Err(Error::corrupt(format!(
            "file is truncated: {nc}x{nr}x{ns} samples need {needed} bytes after {offset} header \
             bytes (1024 + an extended header of NSYMBT = {}), but the file has {file_len}",
            header.nsymbt
        )));
    }
    reader.seek(SeekFrom::Start(offset))?;
    let mut data = read_samples(&mut reader, header.mode.elem(), header.big_endian, count)?;
    if header.mode == Mode::Float16 {
        if let VolumeData::U16(bits) = data {
            data = VolumeData::F32(bits.into_iter().map(f16_to_f32).collect());
        }
    }
    let data = permute(data, header.crs, header.axis_of);
    let mut dims = [0usize; 3];
    for f in 0..3 {
        dims[header.axis_of[f]] = header.crs[f];
    }
    // MRC coordinates are the map's own (Å), not a patient's.
    let g = geometry(
        dims,
        header.spacing,
        header.origin,
        header.direction,
        isogrid::WorldFrame::Unknown,
    )?;
    Volume::with_geometry(g, data)
}

fn parse_header(raw: &[u8; HEADER_SIZE]) -> Result<Header> {
    let big_endian = byte_order(raw);
    let h = Fields { raw, big_endian };
    let (nc, nr, ns) = (h.i32(0), h.i32(4), h.i32(8));
    if nc <= 0 || nr <= 0 || ns <= 0 {
        return Err(Error::corrupt(format!(
            "MRC sizes NX, NY, NZ = {nc}, {nr}, {ns} are not all positive"
        )));
    }
    let crs = [nc as usize, nr as usize, ns as usize];
    let mode = match h.i32(12) {
        0 if unsigned_imod_bytes(&h) => Mode::UInt8,
        0 => Mode::Int8,
        1 => Mode::Int16,
        2 => Mode::Float32,
        6 => Mode::UInt16,
        12 => Mode::Float16,
        m @ (3 | 4) => {
            return Err(Error::unsupported(format!(
                "MRC mode {m} holds complex (Fourier transform) values; only real maps are read"
            )))
        }
        m @ (16 | 101) => {
            return Err(Error::unsupported(format!(
                "MRC mode {m} ({}) is not supported; modes 0, 1, 2, 6 and 12 are",
                if m == 16 { "RGB" } else { "packed 4-bit" }
            )))
        }
        m => {
            return Err(Error::corrupt(format!(
                "MRC mode {m} is not a known mode (0, 1, 2, 3, 4, 6, 12, 16, 101)"
            )))
        }
    };
    let axis_of = match [h.i32(64), h.i32(68), h.i32(72)] {
        [0, 0, 0] => [0, 1, 2],
        m if is_permutation(m) => m.map(|a| a as usize - 1),
        [c, r, s] => {
            return Err(Error::corrupt(format!(
                "MRC axis order MAPC, MAPR, MAPS = {c}, {r}, {s} is not a permutation of 1, 2, 3"
            )))
        }
    };
    let nsymbt = h.i32(92);
    if nsymbt < 0 {
        return Err(Error::corrupt(format!(
            "MRC extended header size NSYMBT = {nsymbt} is negative"
        )));
    }
    let ispg = h.i32(88);
    let mz = h.i32(36);
    if (401..=630).contains(&ispg) && mz > 0 && ns > mz {
        return Err(Error::unsupported(format!(
            "MRC file is a stack of {} volumes (ISPG {ispg}); only single volumes are read",
            ns / mz
        )));
    }
    // Voxel size along x, y, z: cell length over its sampling.
    let sampling = [h.i32(28), h.i32(32), mz];
    let cell = [h.f32(40), h.f32(44), h.f32(48)];
    let spacing: [f64; 3] = std::array::from_fn(|a| {
        let step = cell[a] as f64 / sampling[a] as f64;
        if sampling[a] > 0 && step.is_finite() && step > 0.0 {
            step
        } else {
            1.0
        }
    });
    let axes = cell_axes([h.f32(52), h.f32(56), h.f32(60)].map(f64::from));
    let origin_fields = [h.f32(196), h.f32(200), h.f32(204)].map(f64::from);
    let origin = if &raw[208..211] == b"MAP"
        && origin_fields.iter().all(|o| o.is_finite())
        && origin_fields.iter().any(|&o| o != 0.0)
    {
        origin_fields
    } else {
        let start_crs = [h.i32(16), h.i32(20), h.i32(24)];
        let mut start = [0.0; 3];
        for f in 0..3 {
            start[axis_of[f]] = start_crs[f] as f64;
        }
        let axes = axes.unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        std::array::from_fn(|c| (0..3).map(|a| start[a] * spacing[a] * axes[a][c]).sum())
    };
    Ok(Header {
        big_endian,
        crs,
        mode,
        axis_of,
        nsymbt: nsymbt as u64,
        spacing,
        origin,
        direction: axes,
    })
}

/// The file's byte order: the machine stamp's, unless the header only makes sense the other way.
fn byte_order(raw: &[u8; HEADER_SIZE]) -> bool {
    let stamped = match raw[212..214] {
        [0x44, 0x44] | [0x44, 0x41] => Some(false),
        [0x11, 0x11] => Some(true),
        _ => None,
    };
    let plausible = |big_endian| {
        let h = Fields { raw, big_endian };
        let sizes_ok = [0, 4, 8]
            .iter()
            .all(|&at| (1..=isogrid::MAX_DIM as i64).contains(&(h.i32(at) as i64)));
        sizes_ok && matches!(h.i32(12), 0..=4 | 6 | 12 | 16 | 101)
    };
    let first = stamped.unwrap_or(false);
    if !plausible(first) && plausible(!first) {
        !first
    } else {
        first
    }
}

/// IMOD writes mode-0 bytes unsigned unless bit 0 of its flags (after its `IMOD` stamp) is set.
fn unsigned_imod_bytes(h: &Fields) -> bool {
    const IMOD_STAMP: i32 = 1_146_047_817; // "IMOD" read as a 32-bit integer
    h.i32(152) == IMOD_STAMP && h.i32(156) & 1 == 0
}

fn is_permutation(m: [i32; 3]) -> bool {
    let mut seen = [false; 3];
    for a in m {
        if !(1..=3).contains(&a) || seen[a as usize - 1] {
            return false;
        }
        seen[a as usize - 1] = true;
    }
    true
}

/// Unit directions of the unit cell's a, b, c axes for cell angles (α, β, γ) in degrees, with a
/// along x and b in the xy plane (the usual crystallographic frame). `None` for a rectangular
/// cell, and for angles that do not make a cell (unset zeros included), which are read as 90°.
fn cell_axes(angles: [f64; 3]) -> Option<[Vec3; 3]> {
    let [alpha, beta, gamma] = angles;
    let sum = alpha + beta + gamma;
    let valid = angles.iter().all(|&a| a > 0.0 && a < 180.0)
        && sum < 360.0
        && alpha.max(beta).max(gamma) < 0.5 * sum;
    if !valid || angles.iter().all(|&a| (a - 90.0).abs() < 1e-6) {
        return None;
    }
    let [ca, cb, cg] = angles.map(|a| a.to_radians().cos());
    let sg = gamma.to_radians().sin();
    let a = [1.0, 0.0, 0.0];
    let b = [cg, sg, 0.0];
    let cy = (ca - cb * cg) / sg;
    let c = [cb, cy, (1.0 - cb * cb - cy * cy).max(0.0).sqrt()];
    Some([a, normalized(b)?, normalized(c)?])
}

/// Moves samples stored columns-fastest along spatial axes `axis_of` into x-fastest order.
fn permute(data: VolumeData, crs: [usize; 3], axis_of: [usize; 3]) -> VolumeData {
    if axis_of == [0, 1, 2] {
        return data;
    }
    fn apply<T: Copy + Default>(v: Vec<T>, crs: [usize; 3], axis_of: [usize; 3]) -> Vec<T> {
        let mut dims = [0usize; 3];
        for f in 0..3 {
            dims[axis_of[f]] = crs[f];
        }
        let strides = [1, dims[0], dims[0] * dims[1]];
        let [sc, sr, ss] = axis_of.map(|a| strides[a]);
        let mut out = vec![T::default(); v.len()];
        let mut from = v.iter();
        for s in 0..crs[2] {
            for r in 0..crs[1] {
                let row = s * ss + r * sr;
                for c in 0..crs[0] {
                    out[row + c * sc] = *from.next().expect("sample count matches the sizes");
                }
            }
        }
        out
    }
    match data {
        VolumeData::U8(v) => VolumeData::U8(apply(v, crs, axis_of)),
        VolumeData::U16(v) => VolumeData::U16(apply(v, crs, axis_of)),
        VolumeData::I16(v) => VolumeData::I16(apply(v, crs, axis_of)),
        VolumeData::F32(v) => VolumeData::F32(apply(v, crs, axis_of)),
        VolumeData::U32(v) => VolumeData::U32(apply(v, crs, axis_of)),
        VolumeData::I32(v) => VolumeData::I32(apply(v, crs, axis_of)),
        VolumeData::U64(v) => VolumeData::U64(apply(v, crs, axis_of)),
        VolumeData::I64(v) => VolumeData::I64(apply(v, crs, axis_of)),
        VolumeData::F64(v) => VolumeData::F64(apply(v, crs, axis_of)),
    }
}

/// IEEE 754 half precision to single, exactly (every f16 is an f32).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0f32 } else { 1.0 };
    let exponent = (h >> 10) & 0x1f;
    let mantissa = (h & 0x3ff) as u32;
    match exponent {
        // Zero and subnormals: mantissa · 2⁻²⁴.
        0 => sign * mantissa as f32 * f32::powi(2.0, -24),
        0x1f => f32::from_bits(((h as u32 & 0x8000) << 16) | 0x7f80_0000 | (mantissa << 13)),
        _ => f32::from_bits(
            ((h as u32 & 0x8000) << 16) | ((exponent as u32 + 112) << 23) | (mantissa << 13),
        ),
    }
}

/// Typed access to header fields in the file's byte order.
struct Fields<'a> {
    raw: &'a [u8; HEADER_SIZE],
    big_endian: bool,
}

impl Fields<'_> {
    fn word(&self, at: usize) -> [u8; 4] {
        let mut b = [0u8; 4];
        b.copy_from_slice(&self.raw[at..at + 4]);
        if self.big_endian {
            b.reverse();
        }
        b
    }
    fn i32(&self, at: usize) -> i32 {
        i32::from_le_bytes(self.word(at))
    }
    fn f32(&self, at: usize) -> f32 {
        f32::from_le_bytes(self.word(at))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_convert_exactly() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0001), f32::powi(2.0, -24));
        assert_eq!(f16_to_f32(0x8000).to_bits(), (-0.0f32).to_bits());
        assert!(f16_to_f32(0x7e00).is_nan());
        assert_eq!(f16_to_f32(0xfc00), f32::NEG_INFINITY);
    }

    #[test]
    fn permutation_puts_x_fastest() {
        // Columns along z, rows along y, sections along x (MAPC, MAPR, MAPS = 3, 2, 1):
        // file sample (c, r, s) = 100c + 10r + s sits at x = s, y = r, z = c.
        let crs = [4, 3, 2];
        let mut v = Vec::new();
        for s in 0..2 {
            for r in 0..3 {
                for c in 0..4 {
                    v.push((100 * c + 10 * r + s) as f32);
                }
            }
        }
        let VolumeData::F32(out) = permute(VolumeData::F32(v), crs, [2, 1, 0]) else {
            unreachable!()
        };
        let dims = [2, 3, 4];
        for z in 0..4 {
            for y in 0..3 {
                for x in 0..2 {
                    let at = x + dims[0] * (y + dims[1] * z);
                    assert_eq!(out[at], (100 * z + 10 * y + x) as f32);
                }
            }
        }
    }

    #[test]
    fn cell_axes_follow_the_angles() {
        assert!(cell_axes([90.0, 90.0, 90.0]).is_none());
        assert!(cell_axes([0.0, 0.0, 0.0]).is_none());
        let axes = cell_axes([90.0, 90.0, 120.0]).unwrap();
        assert!((axes[1][0] + 0.5).abs() < 1e-12 && (axes[1][1] - 0.75f64.sqrt()).abs() < 1e-12);
        assert!((axes[2][2] - 1.0).abs() < 1e-12);
    }
}

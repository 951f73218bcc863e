//! NIfTI-1 and NIfTI-2 single-file volumes (`.nii`, and gzip-compressed `.nii.gz`).
//!
//! Spec: the NIfTI-1 header `nifti1.h` (348 bytes, magic `n+1`, data at `vox_offset`) and the
//! NIfTI-2 header `nifti2.h` (540 bytes, magic `n+2`: the same fields with 64-bit sizes and
//! doubles, in another order, for volumes beyond 32,767 samples per axis). The header is parsed
//! here directly: it is small and fixed, and a hand parser lets every size be checked against the
//! file before anything is allocated (the `nifti` crate would bring nalgebra and ndarray for no
//! gain here). Either version and byte order is accepted (detected from `sizeof_hdr`).
//!
//! - Grid: voxel (i, j, k) in file order, i fastest; no reorientation.
//! - Spacing: `|pixdim[1..=3]|`; 0 is what tools write when they leave the field unset and
//!   becomes 1, while NaN or an infinity is an error (no voxel has that size).
//! - Origin and direction, in NIfTI world space (RAS+, usually mm): from the **sform** when
//!   `sform_code > 0` (as nibabel's best affine does), else from the **qform** when
//!   `qform_code > 0`, else origin 0 and identity directions (NIfTI "method 1").
//! - Intensity scaling: when `scl_slope` is non-zero and not exactly (1, 0), values become
//!   `slope·v + inter` stored as f32.
//! - 4-D files (fMRI, diffusion, multi-echo: dimension 4 is time, `t`): `--index t=N` reads volume
//!   `N` (from 0); without it a file of several volumes is an error naming them rather than a
//!   silent pick of the first. Only volume `N` is read: an uncompressed file by region, a gzip
//!   file decompressed up to its end. Dimensions 5 to 7 above 1 (vector data) are `Unsupported`.
//! - Header/image pairs (magic `ni1`, `ni2`; SPM's and older FSL's output): the header `.hdr` and
//!   the samples `.img` from byte `vox_offset`, each gzip-compressed or not; either name may be
//!   given. An Analyze 7.5 header (no magic) is `Unsupported`: Analyze leaves the orientation
//!   undefined, and tools disagree on it.
//! - Types: u8, i8, u16, i16, u32, i32, u64, i64, f32, f64 (converted as in the crate docs);
//!   complex, RGB and binary are `Unsupported`.

use crate::data_file::{open_maybe_gzip, uncompressed_head, MaybeGzip};
use crate::four_d::{pick_volume, PickedVolume};
use crate::geometry::{cross, geometry, normalized, Vec3};
use crate::read_options::AxisPick;
use crate::samples::{
    check_available, check_deflate_budget, expect_end, gzip_error, read_samples, rescaled,
    skip_bytes, ElemType,
};
use isogrid::{Error, Result, ResultExt, Volume, VolumeData, WorldFrame};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Whether a file name is a single NIfTI file's (`.nii` or `.nii.gz`, any case).
pub(crate) fn is_nifti_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".nii") || lower.ends_with(".nii.gz")
}

/// Whether a file name is one of a NIfTI header/image pair's (`.hdr`, `.img`, either
/// gzip-compressed; any case): either names the pair.
pub(crate) fn is_nifti_pair_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    [".hdr", ".hdr.gz", ".img", ".img.gz"]
        .iter()
        .any(|e| lower.ends_with(e))
}

/// `path` with its name's ending `from` (matched in any case) replaced by `to`, letter for letter
/// in the same case: `brain.IMG` → `brain.HDR`. `None` when the name does not end so.
fn with_ending(path: &Path, from: &str, to: &str) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?;
    let cut = name.len().checked_sub(from.len())?;
    let ending = name.get(cut..)?;
    if !ending.eq_ignore_ascii_case(from) {
        return None;
    }
    let replaced: String = ending
        .chars()
        .zip(to.chars())
        .map(|(old, new)| {
            if old.is_ascii_uppercase() {
                new.to_ascii_uppercase()
            } else {
                new
            }
        })
        .collect();
    Some(path.with_file_name(format!("{}{replaced}", &name[..cut])))
}

/// The header to read for `path`: the `.hdr` of a pair's `.img` (which must exist), else `path`
/// itself.
fn header_path(path: &Path) -> Result<PathBuf> {
    match with_ending(path, ".img.gz", ".hdr.gz").or_else(|| with_ending(path, ".img", ".hdr")) {
        Some(header) if !header.is_file() => Err(Error::corrupt(format!(
            "the header file {} of this NIfTI pair is missing",
            header.display()
        ))),
        Some(header) => Ok(header),
        None => Ok(path.to_path_buf()),
    }
}

/// The image file of the pair whose header is `header` (`.hdr` → `.img`, `.hdr.gz` → `.img.gz`).
fn image_path(header: &Path) -> Result<PathBuf> {
    let image = with_ending(header, ".hdr.gz", ".img.gz")
        .or_else(|| with_ending(header, ".hdr", ".img"))
        .ok_or_else(|| {
            Error::corrupt(
                "the header says its samples are in a separate .img file (magic ni1/ni2), but it \
                 is not named .hdr",
            )
        })?;
    if !image.is_file() {
        return Err(Error::corrupt(format!(
            "the image file {} of this NIfTI pair is missing",
            image.display()
        )));
    }
    Ok(image)
}

/// Reads a `.nii` or `.nii.gz` file (gzip is detected from the content). Errors name `path`.
pub fn read_nifti(path: &Path) -> Result<Volume> {
    read_nifti_indexed(path, AxisPick::NONE)
}

/// [`read_nifti`] of the volume `pick` (`--index t=N`) chooses of a 4-D file.
pub fn read_nifti_indexed(path: &Path, pick: AxisPick) -> Result<Volume> {
    read(path, pick).at_path(path)
}

/// The header fields a volume needs.
struct Header {
    dims: [usize; 3],
    /// Volumes along dimension 4 (time): 1 for a 3-D file.
    times: usize,
    elem: ElemType,
    big_endian: bool,
    vox_offset: u64,
    spacing: [f64; 3],
    origin: Vec3,
    direction: Option<[Vec3; 3]>,
    frame: WorldFrame,
    scale: Option<(f64, f64)>,
    /// The header's size: 348 (NIfTI-1) or 540 (NIfTI-2) bytes.
    size: usize,
    /// A `.hdr`/`.img` pair's header: the samples are in the `.img` file.
    pair: bool,
}

impl Header {
    /// The volume `pick` chooses, with its sample count and bytes.
    fn picked(&self, pick: AxisPick) -> Result<PickedVolume> {
        pick_volume(pick, "NIfTI file", self.dims, self.times, self.elem)
    }

    /// The volume's geometry (world coordinates RAS+ when the file gives an sform or qform).
    fn geometry(&self) -> Result<isogrid::Geometry> {
        geometry(
            self.dims,
            self.spacing,
            self.origin,
            self.direction,
            self.frame,
        )
    }
}

/// A NIfTI file open at the first sample of the volume its pick chose.
struct Opened {
    reader: Box<dyn Read>,
    header: Header,
    gzipped: bool,
    /// The volume read (0 for a 3-D file) and its sample count.
    t: usize,
    count: usize,
    /// Its grid, from the header (checked before any sample is read).
    geometry: isogrid::Geometry,
}

impl Opened {
    fn open(path: &Path, pick: AxisPick) -> Result<Opened> {
        let header_file = header_path(path)?;
        let MaybeGzip {
            mut reader,
            gzipped,
            file_len,
        } = open_maybe_gzip(&header_file)?;
        let header =
            read_header(reader.as_mut()).map_err(|e| if gzipped { gzip_error(e) } else { e })?;
        // A pair keeps its samples in the .img file, from its byte vox_offset.
        let (reader, gzipped, file_len, read) = if header.pair {
            let image = open_maybe_gzip(&image_path(&header_file)?)?;
            (image.reader, image.gzipped, image.file_len, 0)
        } else {
            (reader, gzipped, file_len, header.size as u64)
        };
        let picked = header.picked(pick)?;
        let (t, count, volume_bytes) = (picked.t, picked.count, picked.volume_bytes);
        let before = picked.bytes_before();
        if gzipped {
            // Decompressed up to the end of volume t, and on to the end when it is the last.
            check_deflate_budget(header.vox_offset + before + volume_bytes, file_len)?;
        } else {
            check_available(picked.all_bytes, file_len.saturating_sub(header.vox_offset))?;
        }
        let geometry = header.geometry()?;
        let mut opened = Opened {
            reader,
            header,
            gzipped,
            t,
            count,
            geometry,
        };
        let skip = opened.header.vox_offset - read + before;
        opened.gzip_errors(|reader| skip_bytes(reader, skip))?;
        Ok(opened)
    }

    /// The next `count` samples, rescaled where the header says.
    fn samples(&mut self, count: usize) -> Result<VolumeData> {
        let (elem, big_endian) = (self.header.elem, self.header.big_endian);
        let data = self.gzip_errors(|reader| read_samples(reader, elem, big_endian, count))?;
        Ok(match self.header.scale {
            Some((slope, inter)) => rescaled(&data, elem, slope, inter),
            None => data,
        })
    }

    /// After the volume's last sample: nothing may follow the file's last volume, as more data
    /// means the header is wrong (checked where the stream ends, in a gzip file).
    fn finish(mut self) -> Result<isogrid::Geometry> {
        if self.gzipped && self.t + 1 == self.header.times {
            self.gzip_errors(|reader| expect_end(reader))?;
        }
        Ok(self.geometry)
    }

    /// `read` on the stream, its errors described as a gzip stream's where the file is one.
    fn gzip_errors<T>(&mut self, read: impl FnOnce(&mut dyn Read) -> Result<T>) -> Result<T> {
        let gzipped = self.gzipped;
        read(self.reader.as_mut()).map_err(|e| if gzipped { gzip_error(e) } else { e })
    }
}

fn read(path: &Path, pick: AxisPick) -> Result<Volume> {
    let mut opened = Opened::open(path, pick)?;
    let data = opened.samples(opened.count)?;
    Volume::with_geometry(opened.finish()?, data)
}

/// The volume `pick` chooses of a NIfTI file, handed to `each` in order, `chunk` samples at a
/// time (the last chunk may be shorter), so that a caller reducing the samples (a mask to its
/// bits) never holds the volume. Returns the volume's grid. Errors name `path`.
pub(crate) fn read_nifti_in_chunks(
    path: &Path,
    pick: AxisPick,
    chunk: usize,
    mut each: impl FnMut(&VolumeData) -> Result<()>,
) -> Result<isogrid::Geometry> {
    (|| {
        let mut opened = Opened::open(path, pick)?;
        let mut left = opened.count;
        while left > 0 {
            let n = left.min(chunk.max(1));
            each(&opened.samples(n)?)?;
            left -= n;
        }
        opened.finish()
    })()
    .at_path(path)
}

/// Where an uncompressed `.nii` keeps the samples of the volume `pick` chooses, for reading by
/// region; `None` for a gzip file (which has to be decompressed from its start). Errors name
/// `path`.
pub(crate) fn region_layout(
    path: &Path,
    pick: AxisPick,
) -> Result<Option<crate::mapped_layout::MappedLayout>> {
    (|| -> Result<Option<crate::mapped_layout::MappedLayout>> {
        let header_file = header_path(path)?;
        let Some((raw, file_len)) = uncompressed_head(&header_file, Version::Two.size())? else {
            return Ok(None);
        };
        let header = parse_header(&raw)?;
        let (data_path, file_len) = if header.pair {
            let image = image_path(&header_file)?;
            match uncompressed_head(&image, 2)? {
                Some((_, len)) => (image, len),
                None => return Ok(None),
            }
        } else {
            (path.to_path_buf(), file_len)
        };
        let picked = header.picked(pick)?;
        check_available(picked.all_bytes, file_len.saturating_sub(header.vox_offset))?;
        Ok(Some(crate::mapped_layout::MappedLayout {
            data_path,
            data_offset: header.vox_offset + picked.bytes_before(),
            elem: header.elem,
            big_endian: header.big_endian,
            geometry: header.geometry()?,
            scale: header.scale,
        }))
    })()
    .at_path(path)
}

/// The two header layouts: NIfTI-1 (348 bytes, 16-bit sizes, 32-bit floats) and NIfTI-2 (540
/// bytes, 64-bit sizes and floats), with the offset of each field this reader uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Version {
    One,
    Two,
}

impl Version {
    /// The header's size, its `sizeof_hdr`.
    fn size(self) -> usize {
        match self {
            Version::One => 348,
            Version::Two => 540,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Version::One => "NIfTI-1",
            Version::Two => "NIfTI-2",
        }
    }
    /// Where the magic (`n+1`, `n+2`; `ni1`, `ni2` for a header/image pair) lies.
    fn magic(self) -> usize {
        match self {
            Version::One => 344,
            Version::Two => 4,
        }
    }
}

/// The header's version and byte order, from its first four bytes (`sizeof_hdr`).
fn version_of(first: [u8; 4]) -> Result<(Version, bool)> {
    match (i32::from_le_bytes(first), i32::from_be_bytes(first)) {
        (348, _) => Ok((Version::One, false)),
        (_, 348) => Ok((Version::One, true)),
        (540, _) => Ok((Version::Two, false)),
        (_, 540) => Ok((Version::Two, true)),
        _ => Err(Error::corrupt(
            "not a NIfTI file: sizeof_hdr is neither 348 (NIfTI-1) nor 540 (NIfTI-2)",
        )),
    }
}

/// Reads a whole header from the start of `reader`: its first four bytes say how long it is.
fn read_header(reader: &mut dyn Read) -> Result<Header> {
    let short = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => Error::corrupt("file is shorter than a NIfTI header"),
        _ => Error::corrupt(format!("cannot read the NIfTI header: {e}")),
    };
    let mut first = [0u8; 4];
    reader.read_exact(&mut first).map_err(short)?;
    let (version, _) = version_of(first)?;
    let mut raw = vec![0u8; version.size()];
    raw[..4].copy_from_slice(&first);
    reader
        .read_exact(&mut raw[4..])
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => {
                Error::corrupt(format!("file is shorter than a {} header", version.name()))
            }
            _ => short(e),
        })?;
    parse_header(&raw)
}

/// Parses a header: `raw` holds at least its `sizeof_hdr` bytes.
fn parse_header(raw: &[u8]) -> Result<Header> {
    if raw.len() < 4 {
        return Err(Error::corrupt("file is shorter than a NIfTI header"));
    }
    let (version, big_endian) = version_of(field(raw, 0))?;
    if raw.len() < version.size() {
        return Err(Error::corrupt(format!(
            "file is shorter than a {} header",
            version.name()
        )));
    }
    let h = Fields {
        raw,
        big_endian,
        version,
    };
    let at = version.magic();
    let pair = match (&raw[at..at + 4], version) {
        (b"n+1\0", Version::One) | (b"n+2\0", Version::Two) => false,
        (b"ni1\0", Version::One) | (b"ni2\0", Version::Two) => true,
        ([0, 0, 0, 0], Version::One) => {
            return Err(Error::unsupported(
                "an Analyze 7.5 header (no NIfTI magic) is not read: Analyze leaves the axes' \
                 orientation undefined; convert the file to NIfTI",
            ))
        }
        _ => {
            return Err(Error::corrupt(format!(
                "not a {} file: bad magic",
                version.name()
            )))
        }
    };
    let ndim = h.dim(0);
    if !(1..=7).contains(&ndim) {
        return Err(Error::corrupt(format!("dim[0] = {ndim} is outside 1..=7")));
    }
    let mut dims = [1usize; 3];
    let mut times = 1;
    for d in 1..=7usize {
        let n = if d <= ndim as usize { h.dim(d) } else { 1 };
        if n < 1 {
            return Err(Error::corrupt(format!("dim[{d}] = {n} is not positive")));
        }
        if n > isogrid::MAX_DIM as i64 && d <= 4 {
            return Err(Error::too_large(format!(
                "dim[{d}] = {n} is more than the {} samples per axis isogrid reads",
                isogrid::MAX_DIM
            )));
        }
        match d {
            1..=3 => dims[d - 1] = n as usize,
            4 => times = n as usize,
            _ if n > 1 => {
                return Err(Error::unsupported(format!(
                    "dimension {d} has {n} entries (vector data); a 3-D volume, or one volume of \
                     a 4-D file (--index t=N), is read"
                )))
            }
            _ => {}
        }
    }
    let datatype = h.i16(if version == Version::One { 70 } else { 12 });
    let elem = match datatype {
        2 => ElemType::U8,
        4 => ElemType::I16,
        8 => ElemType::I32,
        16 => ElemType::F32,
        64 => ElemType::F64,
        256 => ElemType::I8,
        512 => ElemType::U16,
        768 => ElemType::U32,
        1024 => ElemType::I64,
        1280 => ElemType::U64,
        _ => {
            return Err(Error::unsupported(format!(
                "NIfTI datatype {datatype} is not supported"
            )))
        }
    };
    let vox_offset = match version {
        Version::One => h.f32(108) as f64,
        Version::Two => h.i64(168) as f64,
    };
    // A single file's samples follow its header; a pair's start anywhere in its .img.
    let first = if pair { 0.0 } else { version.size() as f64 };
    if !(vox_offset.is_finite() && vox_offset >= first && vox_offset < 1e12) {
        return Err(Error::corrupt(format!(
            "vox_offset {vox_offset} is not a valid data offset"
        )));
    }
    let pixdim = |d: usize| h.float(76 + 4 * d, 104 + 8 * d);
    let spacing = [pixdim(1), pixdim(2), pixdim(3)];
    if let Some(axis) = (0..3).find(|&a| !spacing[a].is_finite()) {
        return Err(Error::corrupt(format!(
            "pixdim[{}] is {}, not a voxel size",
            axis + 1,
            spacing[axis]
        )));
    }
    let (slope, inter) = (h.float(112, 176), h.float(116, 184));
    let scale = (slope != 0.0 && slope.is_finite() && (slope, inter) != (1.0, 0.0))
        .then_some((slope, if inter.is_finite() { inter } else { 0.0 }));
    // sform or qform: RAS+ world coordinates; neither: index × spacing, no frame.
    let (qform_code, sform_code) = match version {
        Version::One => (h.i16(252) as i32, h.i16(254) as i32),
        Version::Two => (h.i32(344), h.i32(348)),
    };
    let (origin, direction, frame) = if sform_code > 0 {
        let (origin, direction) = sform(&h);
        (origin, direction, WorldFrame::Ras)
    } else if qform_code > 0 {
        let (origin, direction) = qform(&h, pixdim(0));
        (origin, direction, WorldFrame::Ras)
    } else {
        ([0.0; 3], None, WorldFrame::Unknown)
    };
    Ok(Header {
        dims,
        times,
        elem,
        big_endian,
        vox_offset: vox_offset as u64,
        // 0 = unset: unknown (NaN) for `geometry`, which makes it 1.
        spacing: spacing.map(|s| if s == 0.0 { f64::NAN } else { s.abs() }),
        origin,
        direction,
        frame,
        scale,
        size: version.size(),
        pair,
    })
}

/// Origin and axis directions from the sform rows `srow_x/y/z` (world = S · (i, j, k, 1)).
fn sform(h: &Fields) -> (Vec3, Option<[Vec3; 3]>) {
    let row = |r: usize| [0, 1, 2, 3].map(|c| h.float(280 + 16 * r + 4 * c, 400 + 32 * r + 8 * c));
    let rows = [row(0), row(1), row(2)];
    let origin = [rows[0][3], rows[1][3], rows[2][3]];
    let column = |c: usize| normalized([rows[0][c], rows[1][c], rows[2][c]]);
    let direction = match (column(0), column(1), column(2)) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    (origin, direction)
}

/// Origin and axis directions from the qform quaternion; `qfac` (pixdim[0]) flips k when negative.
fn qform(h: &Fields, qfac: f64) -> (Vec3, Option<[Vec3; 3]>) {
    // quatern_b, c, d, then qoffset_x, y, z.
    let q = |n: usize| h.float(256 + 4 * n, 352 + 8 * n);
    let (b, c, d) = (q(0), q(1), q(2));
    let origin = [q(3), q(4), q(5)];
    let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
    // Columns of the rotation matrix of nifti1.h are the world directions of i, j, k.
    let i_dir = [
        a * a + b * b - c * c - d * d,
        2.0 * (b * c + a * d),
        2.0 * (b * d - a * c),
    ];
    let j_dir = [
        2.0 * (b * c - a * d),
        a * a + c * c - b * b - d * d,
        2.0 * (c * d + a * b),
    ];
    let mut k_dir = cross(i_dir, j_dir);
    if qfac < 0.0 {
        k_dir = k_dir.map(|x| -x);
    }
    (origin, Some([i_dir, j_dir, k_dir]))
}

/// Typed access to header fields in the file's byte order and layout.
struct Fields<'a> {
    raw: &'a [u8],
    big_endian: bool,
    version: Version,
}

/// `fn NAME(&self, at) -> TYPE` for each field type: the bytes at `at` in the file's order.
macro_rules! field_readers {
    ($($name:ident: $t:ty),*) => {
        $(fn $name(&self, at: usize) -> $t {
            let b = field(self.raw, at);
            if self.big_endian {
                <$t>::from_be_bytes(b)
            } else {
                <$t>::from_le_bytes(b)
            }
        })*
    };
}

impl Fields<'_> {
    field_readers!(i16: i16, i32: i32, i64: i64, f32: f32, f64: f64);

    /// A float field: f32 at `one` in NIfTI-1, f64 at `two` in NIfTI-2.
    fn float(&self, one: usize, two: usize) -> f64 {
        match self.version {
            Version::One => self.f32(one) as f64,
            Version::Two => self.f64(two),
        }
    }
    /// `dim[d]`: i16 in NIfTI-1, i64 in NIfTI-2.
    fn dim(&self, d: usize) -> i64 {
        match self.version {
            Version::One => self.i16(40 + 2 * d) as i64,
            Version::Two => self.i64(16 + 8 * d),
        }
    }
}

fn field<const N: usize>(raw: &[u8], at: usize) -> [u8; N] {
    let mut out = [0u8; N];
    out.copy_from_slice(&raw[at..at + N]);
    out
}

//! FreeSurfer MGH volumes (`.mgh`, and gzip-compressed `.mgz`): FreeSurfer's own format for its
//! images (`T1.mgz`), segmentations (`aseg.mgz`, `aparc+aseg.mgz`) and maps.
//!
//! Layout, big-endian throughout, as FreeSurfer's `mghRead` and nibabel's `MGHHeader` read it:
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | version, 1 |
//! | 4 | 16 | width, height, depth, frames (i32) |
//! | 20 | 4 | type: 0 u8, 1 i32, 3 f32, 4 i16, 10 u16 |
//! | 24 | 4 | degrees of freedom (not used here) |
//! | 28 | 2 | `goodRASFlag`: the next three fields are set |
//! | 30 | 12 | `delta`: voxel size along i, j, k (f32) |
//! | 42 | 36 | `Mdc`: the RAS direction of i, then of j, then of k (f32 × 3 each) |
//! | 78 | 12 | `Pxyz_c`: the RAS position of the volume's centre (f32) |
//! | 284 | | samples, i fastest, then j, k, frame; then an optional footer (scan parameters, tags), not read |
//!
//! - Geometry, in FreeSurfer's scanner RAS (world coordinates RAS+): voxel (i, j, k) lies at
//!   `Pxyz_c + Σₐ Mdc[a]·delta[a]·(index[a] − dims[a]/2)`. The centre is index `dims/2`, a
//!   half-integer for an odd size, not `(dims − 1)/2`: FreeSurfer's definition, which nibabel's
//!   affine follows too. Spacing and direction are the lengths and directions of the columns
//!   `Mdc[a]·delta[a]`, so the grid is the file's affine even where `Mdc` is not of unit length.
//! - `goodRASFlag` ≤ 0 means the three fields are unset. FreeSurfer then takes voxel size 1, centre
//!   0 and its coronal default, i → left, j → inferior, k → anterior (LIA), and so does this
//!   reader. (nibabel takes i → L, j → S, k → P there; FreeSurfer's own tools write the flag set.)
//! - Frames (time points, or the contrasts of a multi-frame file) are a fourth axis, `t`:
//!   `--index t=N` reads frame `N`, and a file of several frames without it is an error naming
//!   them ([`crate::four_d`]). Only frame `N` is read: an uncompressed file by region, a gzip file
//!   decompressed up to its end, and on to the end of the stream (its checksum) when it is the
//!   last frame.
//! - Types 2 (long), 5 (bitmap), 6 (tensor), 7, 8 (complex) and 9 (RGB) are `Unsupported`; sizes
//!   are checked against the file before anything is allocated; the footer after the samples is
//!   not read (in a gzip file it is decompressed, up to 16 MiB, to reach the checksum).

use crate::data_file::{open_maybe_gzip, uncompressed_head, MaybeGzip};
use crate::four_d::{pick_volume, PickedVolume};
use crate::geometry::{geometry, norm, Vec3};
use crate::read_options::AxisPick;
use crate::samples::{
    check_available, check_deflate_budget, gzip_error, read_samples, skip_bytes, ElemType,
};
use isogrid::{Error, Result, ResultExt, Volume, WorldFrame};
use std::io::Read;
use std::path::Path;

/// Where the samples start: the header and the space FreeSurfer leaves unused after it.
const DATA_OFFSET: u64 = 284;
/// The header fields this reader uses (`version` to `Pxyz_c`).
const HEADER_SIZE: usize = 90;
/// The most bytes a gzip file may hold after its last frame's samples: the footer (scan
/// parameters and tags such as the command lines that made the file, a few KiB).
const MAX_FOOTER: u64 = 16 << 20;

/// Whether a file name is an MGH file's (`.mgh` or `.mgz`, any case).
pub(crate) fn is_mgh_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".mgh") || lower.ends_with(".mgz")
}

/// Reads a `.mgh` or `.mgz` file (gzip is detected from the content). Errors name `path`.
pub fn read_mgh(path: &Path) -> Result<Volume> {
    read_mgh_indexed(path, AxisPick::NONE)
}

/// [`read_mgh`] of the frame `pick` (`--index t=N`) chooses of a file of several.
pub fn read_mgh_indexed(path: &Path, pick: AxisPick) -> Result<Volume> {
    read(path, pick).at_path(path)
}

/// The header fields a volume needs.
struct Header {
    dims: [usize; 3],
    frames: usize,
    elem: ElemType,
    geometry: isogrid::Geometry,
}

fn read(path: &Path, pick: AxisPick) -> Result<Volume> {
    let MaybeGzip {
        mut reader,
        gzipped,
        file_len,
    } = open_maybe_gzip(path)?;
    let gzip_errors = |e: Error| if gzipped { gzip_error(e) } else { e };
    let mut raw = [0u8; HEADER_SIZE];
    reader.read_exact(&mut raw).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => Error::corrupt("file is shorter than an MGH header"),
        _ => gzip_errors(Error::corrupt(format!("cannot read the MGH header: {e}"))),
    })?;
    let header = parse_header(&raw)?;
    let picked = header.picked(pick)?;
    let end_of_picked = DATA_OFFSET + picked.bytes_before() + picked.volume_bytes;
    if gzipped {
        check_deflate_budget(end_of_picked, file_len)?;
    } else {
        check_available(picked.all_bytes, file_len.saturating_sub(DATA_OFFSET))?;
    }
    skip_bytes(
        reader.as_mut(),
        DATA_OFFSET - HEADER_SIZE as u64 + picked.bytes_before(),
    )
    .map_err(gzip_errors)?;
    let data =
        read_samples(reader.as_mut(), header.elem, true, picked.count).map_err(gzip_errors)?;
    if gzipped && picked.t + 1 == header.frames {
        // On to the end of the stream, where its checksum is checked: a damaged sample is an
        // error, not a wrong value.
        let footer = std::io::copy(&mut reader.take(MAX_FOOTER + 1), &mut std::io::sink())
            .map_err(|e| gzip_errors(e.into()))?;
        if footer > MAX_FOOTER {
            return Err(Error::corrupt(format!(
                "more than {} MiB follow the samples, where an MGH file has a short footer",
                MAX_FOOTER >> 20
            )));
        }
    }
    Volume::with_geometry(header.geometry, data)
}

/// Where an uncompressed `.mgh` keeps the samples of the frame `pick` chooses, for reading by
/// region; `None` for a gzip file (which has to be decompressed from its start). Errors name
/// `path`.
pub(crate) fn region_layout(
    path: &Path,
    pick: AxisPick,
) -> Result<Option<crate::mapped_layout::MappedLayout>> {
    (|| -> Result<Option<crate::mapped_layout::MappedLayout>> {
        let Some((raw, file_len)) = uncompressed_head(path, HEADER_SIZE)? else {
            return Ok(None);
        };
        let raw: &[u8; HEADER_SIZE] = raw
            .as_slice()
            .try_into()
            .map_err(|_| Error::corrupt("file is shorter than an MGH header"))?;
        let header = parse_header(raw)?;
        let picked = header.picked(pick)?;
        check_available(picked.all_bytes, file_len.saturating_sub(DATA_OFFSET))?;
        Ok(Some(crate::mapped_layout::MappedLayout {
            data_path: path.to_path_buf(),
            data_offset: DATA_OFFSET + picked.bytes_before(),
            elem: header.elem,
            big_endian: true,
            geometry: header.geometry,
            scale: None,
        }))
    })()
    .at_path(path)
}

impl Header {
    /// The frame `pick` chooses, with its sample count and bytes.
    fn picked(&self, pick: AxisPick) -> Result<PickedVolume> {
        pick_volume(pick, "MGH file", self.dims, self.frames, self.elem)
    }
}

fn parse_header(raw: &[u8; HEADER_SIZE]) -> Result<Header> {
    let i32_at = |at: usize| i32::from_be_bytes(raw[at..at + 4].try_into().expect("4 bytes"));
    let f32_at = |at: usize| f32::from_be_bytes(raw[at..at + 4].try_into().expect("4 bytes"));
    let version = i32_at(0);
    if version != 1 {
        return Err(Error::corrupt(format!(
            "not an MGH file: version {version}, where FreeSurfer writes 1"
        )));
    }
    let sizes = [4, 8, 12, 16].map(i32_at);
    if let Some(bad) = sizes.iter().position(|&n| n < 1) {
        let field = ["width", "height", "depth", "frames"][bad];
        return Err(Error::corrupt(format!(
            "MGH {field} {} is not positive",
            sizes[bad]
        )));
    }
    let dims = [0, 1, 2].map(|a| sizes[a] as usize);
    let elem = match i32_at(20) {
        0 => ElemType::U8,
        1 => ElemType::I32,
        3 => ElemType::F32,
        4 => ElemType::I16,
        10 => ElemType::U16,
        t @ (2 | 5..=9) => {
            let name = match t {
                2 => "long",
                5 => "bitmap",
                6 => "tensor",
                7 | 8 => "complex",
                _ => "RGB",
            };
            return Err(Error::unsupported(format!(
                "MGH type {t} ({name}) is not supported; types 0 (u8), 1 (i32), 3 (f32), 4 (i16) \
                 and 10 (u16) are"
            )));
        }
        t => {
            return Err(Error::corrupt(format!(
                "MGH type {t} is not a FreeSurfer data type (0 to 10)"
            )))
        }
    };
    let good_ras = i16::from_be_bytes([raw[28], raw[29]]) > 0;
    let (delta, mdc, centre): (Vec3, [Vec3; 3], Vec3) = if good_ras {
        (
            [30, 34, 38].map(|at| f32_at(at) as f64),
            [42, 54, 66].map(|row| [0, 4, 8].map(|c| f32_at(row + c) as f64)),
            [78, 82, 86].map(|at| f32_at(at) as f64),
        )
    } else {
        // FreeSurfer's coronal default (LIA), unit voxels, centred on 0.
        (
            [1.0; 3],
            [[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
            [0.0; 3],
        )
    };
    if let Some(bad) = delta
        .iter()
        .chain(mdc.iter().flatten())
        .chain(centre.iter())
        .find(|x| !x.is_finite())
    {
        return Err(Error::corrupt(format!(
            "MGH geometry holds {bad}: voxel size, directions and centre must be finite"
        )));
    }
    // The affine's columns, Mdc[a]·delta[a]: their lengths are the spacing.
    let columns: [Vec3; 3] = std::array::from_fn(|a| mdc[a].map(|x| x * delta[a]));
    let spacing = columns.map(norm);
    if let Some(axis) = (0..3).find(|&a| !(spacing[a] > 0.0 && spacing[a].is_finite())) {
        return Err(Error::corrupt(format!(
            "MGH voxel size {} and direction {:?} of axis {axis} give no voxel",
            delta[axis], mdc[axis]
        )));
    }
    let direction: [Vec3; 3] = std::array::from_fn(|a| columns[a].map(|x| x / spacing[a]));
    let origin: Vec3 = std::array::from_fn(|c| {
        centre[c]
            - (0..3)
                .map(|a| columns[a][c] * dims[a] as f64 / 2.0)
                .sum::<f64>()
    });
    Ok(Header {
        dims,
        frames: sizes[3] as usize,
        elem,
        geometry: geometry(dims, spacing, origin, Some(direction), WorldFrame::Ras)?,
    })
}

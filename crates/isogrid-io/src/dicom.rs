//! DICOM series: a folder of single-frame slices read as one volume.
//!
//! Files are parsed with dicom-rs (`dicom-object`); pixel data is decoded here from the native
//! (uncompressed) little-endian transfer syntaxes, implicit or explicit VR. Compressed transfer
//! syntaxes (JPEG, JPEG 2000, RLE, deflate) are `Unsupported`: decompress first (e.g.
//! `gdcmconv --raw`). Spec references are to DICOM PS3.3 C.7.6.2 (Image Plane) and C.7.6.3
//! (Image Pixel).
//!
//! - Files: every regular file of the folder (not its subfolders) with the `DICM` marker at byte
//!   128; other files are ignored, and so are DICOM files without PixelData (e.g. DICOMDIR).
//!   All slices must belong to one series, have the same size and pixel format, and be
//!   single-frame grayscale (MONOCHROME1/2; MONOCHROME1 values are kept, not inverted).
//! - Order: by position along the slice normal, `ImagePositionPatient · (row × column)` of
//!   `ImageOrientationPatient`, when every slice has both; else by `InstanceNumber`; else by file
//!   name. Two slices at the same position are an error (usually two series mixed in a folder).
//! - Grid: i along a row (Columns samples), j down the columns (Rows samples), k = slice.
//! - Spacing: i = `PixelSpacing[1]` (column spacing), j = `PixelSpacing[0]` (row spacing),
//!   k = mean step between sorted slice positions (else `SpacingBetweenSlices`, else
//!   `SliceThickness`, else 1), in mm. Origin = `ImagePositionPatient` of the first slice, in the
//!   patient coordinate system (LPS, mm). Direction rows: row cosine, column cosine, normal.
//! - Values: `RescaleSlope`/`RescaleIntercept` applied per slice. When every slope is 1 and every
//!   intercept an integer, values stay integers: u8 (8-bit data that fits), else i16 (signed data
//!   that fits), else u16, else i16 if they fit; otherwise, and for any other rescale, f32.

use crate::geometry::{cross, dot, normalized, Vec3};
use crate::samples::sample_count;
use dicom_core::value::{PrimitiveValue, Value};
use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_object::{DefaultDicomObject, OpenFileOptions};
use isogrid::{Error, Geometry, Result, ResultExt, Volume, VolumeData};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Reads the DICOM slices in folder `dir` as one volume (see the module doc). Errors name the
/// folder, or the file at fault.
pub fn read_dicom_series(dir: &Path) -> Result<Volume> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).at_path(dir)? {
        let path = entry.at_path(dir)?.path();
        if path.is_file() && has_dicom_marker(&path) {
            files.push(path);
        }
    }
    files.sort();
    let mut slices = Vec::new();
    for path in files {
        if let Some(slice) = read_slice(&path).at_path(&path)? {
            slices.push(slice);
        }
    }
    assemble(slices).at_path(dir)
}

fn has_dicom_marker(path: &Path) -> bool {
    let mut head = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && &head[128..] == b"DICM"
}

/// One slice: its metadata and its stored pixel values as little-endian bytes.
struct Slice {
    path: PathBuf,
    rows: usize,
    cols: usize,
    bits_allocated: u16,
    bits_stored: u16,
    signed: bool,
    slope: f64,
    intercept: f64,
    position: Option<Vec3>,
    orientation: Option<(Vec3, Vec3)>,
    instance: Option<i64>,
    pixel_spacing: Option<[f64; 2]>,
    series: Option<String>,
    slice_step: Option<f64>,
    pixels: Vec<u8>,
    /// Smallest and largest stored value.
    range: (i64, i64),
}

/// Native transfer syntaxes whose pixel data is plain little-endian samples.
const NATIVE_LE: [&str; 2] = ["1.2.840.10008.1.2", "1.2.840.10008.1.2.1"];

fn read_slice(path: &Path) -> Result<Option<Slice>> {
    let obj = OpenFileOptions::new()
        .open_file(path)
        .map_err(|e| Error::corrupt(format!("invalid DICOM file: {}", one_line(&e.to_string()))))?;
    let Some(pixel_data) = element(&obj, tags::PIXEL_DATA) else {
        return Ok(None);
    };
    let ts = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches(['\0', ' '])
        .to_string();
    if !NATIVE_LE.contains(&ts.as_str()) {
        return Err(Error::unsupported(format!(
            "transfer syntax {ts} (compressed or big endian) is not supported; decompress the series first"
        )));
    }
    let int = |tag: Tag| element(&obj, tag).and_then(|e| e.to_int::<i64>().ok());
    let floats = |tag: Tag| element(&obj, tag).and_then(|e| e.to_multi_float64().ok());
    let float = |tag: Tag| {
        floats(tag)
            .and_then(|v| v.first().copied())
            .filter(|x| x.is_finite())
    };
    let text = |tag: Tag| {
        element(&obj, tag)
            .and_then(|e| e.to_str().ok())
            .map(|s| s.trim().to_string())
    };

    let rows = int(tags::ROWS).ok_or_else(|| Error::corrupt("slice has no Rows"))?;
    let cols = int(tags::COLUMNS).ok_or_else(|| Error::corrupt("slice has no Columns"))?;
    let bits_allocated = int(tags::BITS_ALLOCATED).unwrap_or(16);
    let bits_stored = int(tags::BITS_STORED).unwrap_or(bits_allocated);
    if int(tags::SAMPLES_PER_PIXEL).unwrap_or(1) != 1 {
        return Err(Error::unsupported(
            "colour DICOM images are not supported (SamplesPerPixel != 1)",
        ));
    }
    let photometric = text(tags::PHOTOMETRIC_INTERPRETATION).unwrap_or_default();
    if !photometric.is_empty() && !photometric.starts_with("MONOCHROME") {
        return Err(Error::unsupported(format!(
            "photometric interpretation {photometric} is not grayscale"
        )));
    }
    if int(tags::NUMBER_OF_FRAMES).unwrap_or(1) > 1 {
        return Err(Error::unsupported(
            "multi-frame DICOM files are not supported",
        ));
    }
    if !matches!(bits_allocated, 8 | 16 | 32) || !(1..=bits_allocated).contains(&bits_stored) {
        return Err(Error::unsupported(format!(
            "{bits_stored} of {bits_allocated} allocated bits per sample is not supported"
        )));
    }
    let (rows, cols) = (
        usize::try_from(rows).unwrap_or(0),
        usize::try_from(cols).unwrap_or(0),
    );
    let count = sample_count([cols, rows, 1])?;
    let pixels = le_bytes(pixel_data.value())?;
    let needed = count as u64 * (bits_allocated as u64 / 8);
    if (pixels.len() as u64) < needed {
        return Err(Error::corrupt(format!(
            "PixelData holds {} bytes but {cols}x{rows} samples of {bits_allocated} bits need {needed}",
            pixels.len()
        )));
    }
    let mut pixels = pixels;
    pixels.truncate(needed as usize);

    let vec3 = |v: &[f64]| [v[0], v[1], v[2]];
    let position = floats(tags::IMAGE_POSITION_PATIENT)
        .filter(|v| v.len() == 3)
        .map(|v| vec3(&v));
    let orientation = floats(tags::IMAGE_ORIENTATION_PATIENT)
        .filter(|v| v.len() == 6)
        .and_then(|v| Some((normalized(vec3(&v[..3]))?, normalized(vec3(&v[3..]))?)));
    let mut slice = Slice {
        path: path.to_path_buf(),
        rows,
        cols,
        bits_allocated: bits_allocated as u16,
        bits_stored: bits_stored as u16,
        signed: int(tags::PIXEL_REPRESENTATION).unwrap_or(0) == 1,
        slope: float(tags::RESCALE_SLOPE)
            .filter(|&s| s != 0.0)
            .unwrap_or(1.0),
        intercept: float(tags::RESCALE_INTERCEPT).unwrap_or(0.0),
        position,
        orientation,
        instance: int(tags::INSTANCE_NUMBER),
        pixel_spacing: floats(tags::PIXEL_SPACING)
            .filter(|v| v.len() == 2 && v.iter().all(|x| x.is_finite() && *x > 0.0))
            .map(|v| [v[0], v[1]]),
        series: text(tags::SERIES_INSTANCE_UID),
        slice_step: float(tags::SPACING_BETWEEN_SLICES)
            .or_else(|| float(tags::SLICE_THICKNESS))
            .filter(|&s| s > 0.0),
        pixels,
        range: (0, 0),
    };
    slice.range = stored_range(&slice);
    Ok(Some(slice))
}

fn element(obj: &DefaultDicomObject, tag: Tag) -> Option<&dicom_object::mem::InMemElement> {
    obj.element_opt(tag).ok().flatten()
}

/// Native pixel data as little-endian bytes, however the parser typed the values.
fn le_bytes(
    value: &Value<dicom_object::InMemDicomObject, dicom_core::value::InMemFragment>,
) -> Result<Vec<u8>> {
    match value {
        Value::Primitive(PrimitiveValue::U8(v)) => Ok(v.to_vec()),
        Value::Primitive(PrimitiveValue::U16(v)) => {
            Ok(v.iter().flat_map(|x| x.to_le_bytes()).collect())
        }
        Value::Primitive(PrimitiveValue::I16(v)) => {
            Ok(v.iter().flat_map(|x| x.to_le_bytes()).collect())
        }
        Value::Primitive(PrimitiveValue::U32(v)) => {
            Ok(v.iter().flat_map(|x| x.to_le_bytes()).collect())
        }
        Value::Primitive(PrimitiveValue::I32(v)) => {
            Ok(v.iter().flat_map(|x| x.to_le_bytes()).collect())
        }
        Value::PixelSequence(_) => Err(Error::unsupported(
            "encapsulated (compressed) PixelData is not supported",
        )),
        _ => Err(Error::corrupt("PixelData has an unexpected value type")),
    }
}

/// Stored value `index` of a slice: masked to BitsStored, sign-extended when signed.
fn stored(slice: &Slice, index: usize) -> i64 {
    let p = &slice.pixels;
    let raw: u32 = match slice.bits_allocated {
        8 => p[index] as u32,
        16 => u16::from_le_bytes([p[2 * index], p[2 * index + 1]]) as u32,
        _ => u32::from_le_bytes([
            p[4 * index],
            p[4 * index + 1],
            p[4 * index + 2],
            p[4 * index + 3],
        ]),
    };
    let bits = slice.bits_stored as u32;
    let mask = if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    };
    let v = raw & mask;
    if slice.signed && (v >> (bits - 1)) & 1 == 1 {
        v as i64 - (1i64 << bits)
    } else {
        v as i64
    }
}

fn stored_range(slice: &Slice) -> (i64, i64) {
    let n = slice.rows * slice.cols;
    (0..n)
        .map(|i| stored(slice, i))
        .fold((i64::MAX, i64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

fn assemble(mut slices: Vec<Slice>) -> Result<Volume> {
    let Some(first) = slices.first() else {
        return Err(Error::invalid("folder holds no DICOM image slices"));
    };
    for s in &slices[1..] {
        if (s.rows, s.cols) != (first.rows, first.cols) {
            return Err(Error::corrupt(format!(
                "slices differ in size: {} is {}x{} but {} is {}x{}",
                name(&s.path),
                s.cols,
                s.rows,
                name(&first.path),
                first.cols,
                first.rows
            )));
        }
        if (s.bits_allocated, s.signed) != (first.bits_allocated, first.signed) {
            return Err(Error::corrupt(format!(
                "slices differ in pixel format: {} and {}",
                name(&s.path),
                name(&first.path)
            )));
        }
        if s.series != first.series {
            return Err(Error::invalid(
                "folder holds slices of more than one series; use a folder per series",
            ));
        }
    }
    let normal = match (
        first.orientation,
        slices.iter().all(|s| s.position.is_some()),
    ) {
        (Some((row, col)), true) => normalized(cross(row, col)),
        _ => None,
    };
    let key = |s: &Slice| normal.and_then(|n| s.position.map(|p| dot(p, n)));
    if normal.is_some() {
        slices.sort_by(|a, b| {
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        for pair in slices.windows(2) {
            if (key(&pair[1]).unwrap_or(0.0) - key(&pair[0]).unwrap_or(0.0)).abs() < 1e-6 {
                return Err(Error::corrupt(format!(
                    "slices {} and {} are at the same position",
                    name(&pair[0].path),
                    name(&pair[1].path)
                )));
            }
        }
    } else if slices.iter().all(|s| s.instance.is_some()) {
        slices.sort_by_key(|s| s.instance);
    }

    let first = &slices[0];
    let n = slices.len();
    let dims = [first.cols, first.rows, n];
    let total = sample_count(dims)?;
    let step = match (key(first), slices.last().and_then(key)) {
        (Some(a), Some(b)) if n > 1 => Some((b - a) / (n - 1) as f64),
        _ => first.slice_step,
    };
    let [row_spacing, col_spacing] = first.pixel_spacing.unwrap_or([1.0, 1.0]);
    let mut geometry = Geometry::new(dims);
    geometry.spacing = [col_spacing, row_spacing, step.unwrap_or(1.0)];
    geometry.origin = first.position.unwrap_or([0.0; 3]);
    if let (Some((row, col)), Some(normal)) = (first.orientation, normal) {
        geometry.direction = [row, col, normal];
    }
    let data = values(&slices, total);
    Volume::with_geometry(geometry, data)
}

/// Rescaled samples of all slices in order, in the narrowest type that holds them exactly.
fn values(slices: &[Slice], total: usize) -> VolumeData {
    let integral = slices
        .iter()
        .all(|s| s.slope == 1.0 && s.intercept.fract() == 0.0 && s.intercept.abs() < 1e9);
    if integral {
        let lo = slices
            .iter()
            .map(|s| s.range.0 + s.intercept as i64)
            .min()
            .unwrap_or(0);
        let hi = slices
            .iter()
            .map(|s| s.range.1 + s.intercept as i64)
            .max()
            .unwrap_or(0);
        let fits = |a: i64, b: i64| lo >= a && hi <= b;
        let shifted = |s: &Slice, i: usize| stored(s, i) + s.intercept as i64;
        if slices[0].bits_allocated == 8 && fits(0, 255) {
            return VolumeData::U8(gather(slices, total, |s, i| shifted(s, i) as u8));
        }
        if slices[0].signed && fits(-32768, 32767) {
            return VolumeData::I16(gather(slices, total, |s, i| shifted(s, i) as i16));
        }
        if fits(0, 65535) {
            return VolumeData::U16(gather(slices, total, |s, i| shifted(s, i) as u16));
        }
        if fits(-32768, 32767) {
            return VolumeData::I16(gather(slices, total, |s, i| shifted(s, i) as i16));
        }
    }
    VolumeData::F32(gather(slices, total, |s, i| {
        (stored(s, i) as f64 * s.slope + s.intercept) as f32
    }))
}

/// Every sample of every slice, in slice order, through `convert`.
fn gather<T>(slices: &[Slice], total: usize, convert: impl Fn(&Slice, usize) -> T) -> Vec<T> {
    let mut out = Vec::with_capacity(total);
    for s in slices {
        out.extend((0..s.rows * s.cols).map(|i| convert(s, i)));
    }
    out
}

fn name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

fn one_line(s: &str) -> String {
    s.lines().next().unwrap_or("").to_string()
}

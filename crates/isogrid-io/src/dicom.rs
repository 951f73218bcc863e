//! DICOM images read as one volume: a folder of slices, a single file, or multi-frame files.
//!
//! Files are parsed with dicom-rs (`dicom-object`) and compressed pixel data is decoded by
//! `dicom-pixeldata` and its transfer-syntax registry; no codec is written here. Spec
//! references are to DICOM PS3.3 C.7.6.2 (Image Plane), C.7.6.3 (Image Pixel), C.11.1 (Modality
//! LUT) and C.7.6.16 (multi-frame functional groups).
//!
//! - **Transfer syntaxes:** implicit and explicit VR little endian, explicit VR big endian,
//!   deflated explicit VR little endian; RLE Lossless (8- and 16-bit samples); JPEG Baseline
//!   (8-bit), JPEG Extended with 8-bit samples and JPEG Lossless (processes 14 and 14 SV1) via
//!   `jpeg-decoder`; JPEG Extended with 12-bit samples via libjpeg-turbo (`jpeg12`); JPEG-LS
//!   lossless and near-lossless via CharLS; JPEG 2000 lossless and lossy via OpenJPEG (the C
//!   library, `openjpeg-sys`). RLE with 32-bit samples is refused with an error naming the syntax (the
//!   registry's decoder lacks it).
//! - **Files:** a path that is a file is read alone; a folder contributes every regular file
//!   (not subfolders) that looks like DICOM: `DICM` at byte 128, or at byte 0 (no preamble), the
//!   file meta group at byte 0 without `DICM`, or a bare implicit- or explicit-VR little-endian
//!   data set (no file meta group), as pydicom reads them with `force=True`. Group-0000
//!   (command) elements in the data set are read like any other. Zero bytes after the data set
//!   (padding) are ignored, as pydicom and GDCM do. Names and extensions do not matter.
//!   Files without Rows (DICOMDIR, reports, RT plans) are skipped; an image file without
//!   PixelData, or one that does not parse, is an error naming it.
//! - **Series:** files are grouped by SeriesInstanceUID. [`ReadOptions::series`] picks one;
//!   by default the series with the most frames is read and a notice lists the others.
//! - **Frames:** a multi-frame file contributes every frame. Enhanced files take each frame's
//!   position, orientation, pixel spacing and rescale from its PerFrameFunctionalGroupsSequence
//!   item, else the SharedFunctionalGroupsSequence, else the top level. Classic multi-frame files
//!   place frame k at ImagePositionPatient + offset_k · normal, the offsets from
//!   GridFrameOffsetVector, else k · SpacingBetweenSlices, else k · SliceThickness.
//! - **Order and spacing:** frames are sorted by their position projected on the slice normal
//!   (row × column of ImageOrientationPatient); the k spacing is the mean step. A step of 1.5×
//!   the median step or more (a gap, a missing slice) or of 1/1.5 of it or less (an extra
//!   slice), a stack whose positions do not follow the normal (gantry tilt), mixed orientations
//!   or two frames at one position are errors naming the slices: a regular grid cannot hold
//!   them. Smaller unevenness (positions rounded by the scanner, e.g. to 0.1 mm) is read on the
//!   grid of the mean step with a notice giving the largest distance that moves a slice; a slice
//!   more than a quarter of a step off that grid is an error. Without positions, frames are ordered by InstanceNumber and
//!   the k spacing is SpacingBetweenSlices, else SliceThickness, else 1.
//! - **Grid:** i along a row (Columns samples), j down the columns (Rows samples), k = frame.
//!   Spacing i = PixelSpacing[1], j = PixelSpacing[0] (mm), the same in every frame; a
//!   PixelSpacing of 0, NaN or a negative size, or frames that differ in it, are errors. Origin =
//!   position of the first frame (patient LPS, mm). Direction rows: row cosine, column cosine,
//!   normal.
//! - **Values:** stored values are masked to BitsStored and sign-extended when
//!   PixelRepresentation is 1, then RescaleSlope and RescaleIntercept are applied per frame.
//!   When every slope is 1 and every intercept an integer, values stay integers in the narrowest
//!   of u8, i16, u16 that holds the rescaled range; otherwise (and for any other rescale) f32.
//!   MONOCHROME1 values are kept, not inverted; colour images are refused.

mod file;
mod jpeg12;
mod jpeg_header;
mod lengths;

use crate::geometry::{cross, dot, normalized, Vec3};
use crate::read_options::ReadOptions;
use crate::samples::sample_count;
pub(crate) use file::{is_dicom_head, looks_like_dicom};
use file::{Frame, Header};
use isogrid::{Error, Geometry, Result, ResultExt, Volume, VolumeData};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Reads the DICOM folder or file `path` as one volume, ignoring notices (see the module doc).
pub fn read_dicom_series(path: &Path) -> Result<Volume> {
    read_dicom(path, &ReadOptions::default()).map(|(volume, _)| volume)
}

/// Reads the DICOM folder or file `path` as one volume (see the module doc), honouring
/// `opts.series`. Also returns notices for the user (other series left out). Errors name the
/// folder, or the file at fault.
pub fn read_dicom(path: &Path, opts: &ReadOptions) -> Result<(Volume, Vec<String>)> {
    let files = if path.is_dir() {
        folder_files(path)?
    } else {
        vec![path.to_path_buf()]
    };
    let mut headers = Vec::new();
    for p in &files {
        if let Some(h) = file::read_header(p).at_path(p)? {
            headers.push(h);
        }
    }
    let (chosen, mut notices) = pick_series(headers, opts.series.as_deref()).at_path(path)?;
    let mut frames = Vec::new();
    for p in &chosen {
        frames.extend(file::read_frames(p).at_path(p)?);
    }
    let (volume, notice) = stack(frames).at_path(path)?;
    notices.extend(notice);
    Ok((volume, notices))
}

/// Whether `path` is a DICOM file holding an image (its header read, not its pixels): a file that
/// only starts like a bare data set (a file of zero bytes does) is not.
pub(crate) fn is_dicom_image(path: &Path) -> bool {
    looks_like_dicom(path) && matches!(file::read_header(path), Ok(Some(_)))
}

/// The files of the folder `path` that look like DICOM (see the module doc), sorted.
pub(crate) fn folder_files(path: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(path).at_path(path)? {
        let p = entry.at_path(path)?.path();
        if p.is_file() && looks_like_dicom(&p) {
            files.push(p);
        }
    }
    files.sort();
    Ok(files)
}

/// The files of the requested series, or of the one with the most frames, and a notice naming
/// the others.
fn pick_series(headers: Vec<Header>, wanted: Option<&str>) -> Result<(Vec<PathBuf>, Vec<String>)> {
    if headers.is_empty() {
        return Err(Error::invalid("holds no DICOM image slices"));
    }
    let mut series: BTreeMap<String, (usize, Vec<PathBuf>)> = BTreeMap::new();
    for h in headers {
        let entry = series.entry(h.series).or_default();
        entry.0 += h.frames;
        entry.1.push(h.path);
    }
    let label = |uid: &str| {
        if uid.is_empty() {
            "(no SeriesInstanceUID)".to_string()
        } else {
            uid.to_string()
        }
    };
    let listing = |skip: &str| {
        series
            .iter()
            .filter(|(uid, _)| uid.as_str() != skip)
            .map(|(uid, (n, _))| format!("{} ({n} slices)", label(uid)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let uid = match wanted {
        Some(w) => {
            if !series.contains_key(w) {
                return Err(Error::invalid(format!(
                    "has no series {w}; its series are {}",
                    listing("")
                )));
            }
            w.to_string()
        }
        None => series
            .iter()
            .max_by(|a, b| a.1 .0.cmp(&b.1 .0).then_with(|| b.0.cmp(a.0)))
            .map(|(uid, _)| uid.clone())
            .unwrap_or_default(),
    };
    let mut notices = Vec::new();
    if wanted.is_none() && series.len() > 1 {
        notices.push(format!(
            "{} DICOM series found; reading {} ({} slices), the one with the most slices; \
             also present: {} (pick one with --series UID)",
            series.len(),
            label(&uid),
            series[&uid].0,
            listing(&uid)
        ));
    }
    let files = series.remove(&uid).map(|(_, f)| f).unwrap_or_default();
    Ok((files, notices))
}

/// Relative tolerance on the alignment of the stack with the normal (gantry tilt).
const SHEAR_TOLERANCE: f64 = 0.01;

/// A step this many times the median or more is a gap (a missing slice gives 2×); one this
/// many times smaller or less is an extra slice. Steps in between are scanner rounding of the
/// positions (0.1 mm in a GE MR series: 1 % of a 7 mm step) and are read as even, with a notice.
const GAP_RATIO: f64 = 1.5;

/// Slice positions that leave the regular grid by less than this fraction of the step are read
/// without a notice (decimal rounding of exactly even positions).
const QUIET_DEVIATION: f64 = 1e-3;

/// Slice positions that leave the regular grid by more than this fraction of the step are an
/// error: rounding moves a slice by a few percent of a step (1 % in the GE series), not by a
/// quarter of one.
const MAX_DEVIATION: f64 = 0.25;

/// Sorts the frames into a regular stack and builds the volume (see the module doc), with a
/// notice when the slice positions are not exactly even.
fn stack(mut frames: Vec<Frame>) -> Result<(Volume, Option<String>)> {
    let Some(first) = frames.first() else {
        return Err(Error::invalid("holds no DICOM image slices"));
    };
    for f in &frames[1..] {
        if (f.rows, f.cols) != (first.rows, first.cols) {
            return Err(Error::corrupt(format!(
                "slices differ in size: {} is {}x{} but {} is {}x{}",
                f.describe(),
                f.cols,
                f.rows,
                first.describe(),
                first.cols,
                first.rows
            )));
        }
        if (f.bits_allocated, f.signed) != (first.bits_allocated, first.signed) {
            return Err(Error::corrupt(format!(
                "slices differ in pixel format: {} and {}",
                f.describe(),
                first.describe()
            )));
        }
    }
    check_pixel_spacing(&frames)?;
    let positioned = frames
        .iter()
        .all(|f| f.position.is_some() && f.orientation.is_some());
    let normal = if positioned {
        let (row, col) = first.orientation.unwrap_or_default();
        for f in &frames[1..] {
            let (r, c) = f.orientation.unwrap_or_default();
            if dot(r, row) < 1.0 - 1e-4 || dot(c, col) < 1.0 - 1e-4 {
                return Err(Error::invalid(format!(
                    "slices differ in orientation: {} and {}",
                    f.describe(),
                    first.describe()
                )));
            }
        }
        normalized(cross(row, col))
    } else {
        None
    };
    let key = |f: &Frame| normal.and_then(|n| f.position.map(|p| dot(p, n)));
    if normal.is_some() {
        frames.sort_by(|a, b| {
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    } else if frames.iter().all(|f| f.instance.is_some()) {
        frames.sort_by_key(|f| f.instance);
    }
    let (step, notice) = match normal {
        Some(n) => {
            let (step, notice) = regular_step(&frames, n)?;
            (Some(step), notice)
        }
        None => (None, None),
    };

    let first = &frames[0];
    let dims = [first.cols, first.rows, frames.len()];
    let total = sample_count(dims)?;
    let [row_spacing, col_spacing] = first.pixel_spacing.unwrap_or([1.0, 1.0]);
    let mut geometry = Geometry::new(dims);
    geometry.spacing = [
        col_spacing,
        row_spacing,
        step.or(first.slice_step).unwrap_or(1.0),
    ];
    geometry.origin = first.position.unwrap_or([0.0; 3]);
    // Image Position (Patient) places the series in patient space: LPS.
    if first.position.is_some() {
        geometry.frame = isogrid::WorldFrame::Lps;
    }
    if let (Some((row, col)), Some(normal)) = (first.orientation, normal) {
        geometry.direction = [row, col, normal];
    }
    let data = values(&frames, total);
    Ok((Volume::with_geometry(geometry, data)?, notice))
}

/// Every frame's PixelSpacing is two positive sizes, the same in every frame: a regular grid has
/// one spacing, and 0, NaN or a negative size is no spacing at all (NRRD, MetaImage and NIfTI
/// refuse such spacings too).
fn check_pixel_spacing(frames: &[Frame]) -> Result<()> {
    let first = &frames[0];
    for f in frames {
        if let Some([r, c]) = f.pixel_spacing {
            if !(r.is_finite() && c.is_finite() && r > 0.0 && c > 0.0) {
                return Err(Error::corrupt(format!(
                    "{}: PixelSpacing {r}\\{c} is not two positive sizes in mm",
                    f.describe()
                )));
            }
        }
        let same = match (f.pixel_spacing, first.pixel_spacing) {
            (Some(a), Some(b)) => a
                .iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 1e-6 * y.abs()),
            (a, b) => a == b,
        };
        if !same {
            let show =
                |s: Option<[f64; 2]>| s.map_or("none".to_string(), |[r, c]| format!("{r}\\{c} mm"));
            return Err(Error::invalid(format!(
                "slices differ in PixelSpacing: {} has {}, {} has {}; a regular grid cannot hold \
                 them",
                first.describe(),
                show(first.pixel_spacing),
                f.describe(),
                show(f.pixel_spacing)
            )));
        }
    }
    Ok(())
}

/// The even step between sorted frames along `normal` and a notice when positions leave that
/// grid, or an error for duplicates, gaps and a stack sheared off the normal (gantry tilt).
fn regular_step(frames: &[Frame], normal: Vec3) -> Result<(f64, Option<String>)> {
    let n = frames.len();
    let pos = |f: &Frame| f.position.unwrap_or_default();
    let along = |f: &Frame| dot(pos(f), normal);
    for pair in frames.windows(2) {
        if (along(&pair[1]) - along(&pair[0])).abs() < 1e-6 {
            return Err(Error::corrupt(format!(
                "slices {} and {} are at the same position (two series mixed, or a duplicate)",
                pair[0].describe(),
                pair[1].describe()
            )));
        }
    }
    if n < 2 {
        return Ok((frames[0].slice_step.unwrap_or(1.0), None));
    }
    let mean = (along(&frames[n - 1]) - along(&frames[0])) / (n - 1) as f64;
    let mut steps: Vec<f64> = frames
        .windows(2)
        .map(|pair| along(&pair[1]) - along(&pair[0]))
        .collect();
    steps.sort_by(f64::total_cmp);
    let median = steps[steps.len() / 2];
    // A gap or an extra slice: a step far from the median (the mean would be pulled by it).
    let irregular = frames.windows(2).find_map(|pair| {
        let d = along(&pair[1]) - along(&pair[0]);
        (d >= GAP_RATIO * median || d * GAP_RATIO <= median).then_some((d, pair))
    });
    if let Some((d, pair)) = irregular {
        return Err(Error::invalid(format!(
            "slices are unevenly spaced: {:.4} mm from {} to {}, {:.4} mm between most slices \
             (a gap or a missing slice); a regular grid cannot hold them",
            d,
            pair[0].describe(),
            pair[1].describe(),
            median
        )));
    }
    // Steps that vary less: rounded positions, read on the grid of the mean step. The notice
    // says how far the grid moves a slice.
    let (deviation, worst) = frames
        .iter()
        .enumerate()
        .map(|(k, f)| ((along(f) - along(&frames[0]) - k as f64 * mean).abs(), f))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((0.0, &frames[0]));
    // Steps that vary within 1.5x of each other can still add up (a series reconstructed at two
    // pitches): a slice this far off the grid is misplaced, not rounded.
    if deviation > MAX_DEVIATION * mean {
        return Err(Error::invalid(format!(
            "slices are unevenly spaced: {} is {deviation:.4} mm from where a regular grid of \
             {mean:.4} mm steps puts it (steps {:.4} to {:.4} mm); a regular grid cannot hold them",
            worst.describe(),
            steps[0],
            steps[steps.len() - 1]
        )));
    }
    let notice = (deviation > QUIET_DEVIATION * mean).then(|| {
        format!(
            "slice positions are not evenly spaced (steps {:.4} to {:.4} mm): read on a regular \
             grid of {:.4} mm steps, which moves a slice by at most {:.4} mm ({})",
            steps[0],
            steps[steps.len() - 1],
            mean,
            deviation,
            worst.describe()
        )
    });
    // The stack's direction: from the first to the last position, per slice.
    let (a, b) = (pos(&frames[0]), pos(&frames[n - 1]));
    let walk = [
        (b[0] - a[0]) / (n - 1) as f64,
        (b[1] - a[1]) / (n - 1) as f64,
        (b[2] - a[2]) / (n - 1) as f64,
    ];
    let sideways = [
        walk[0] - mean * normal[0],
        walk[1] - mean * normal[1],
        walk[2] - mean * normal[2],
    ];
    let shear = dot(sideways, sideways).sqrt();
    if shear > SHEAR_TOLERANCE * mean {
        return Err(Error::unsupported(format!(
            "slices are stacked {:.2}° off their normal (gantry tilt); a regular grid cannot hold \
             them, resample the series first",
            shear.atan2(mean).to_degrees()
        )));
    }
    Ok((mean, notice))
}

/// Rescaled samples of all frames in order, in the narrowest type that holds them exactly: with
/// slope 1 and integral intercepts (of magnitude below 2^53) an integer type chosen by the
/// shifted values' range (u8, i16, u16, i32, i64: an intercept of 2e9 stays exact); otherwise
/// f32 where every value is below 2^24 in magnitude and f64 beyond (where f32 would merge
/// neighbouring values).
fn values(frames: &[Frame], total: usize) -> VolumeData {
    let integral = frames
        .iter()
        .all(|f| f.slope == 1.0 && f.intercept.fract() == 0.0 && f.intercept.abs() < 9.007e15);
    if integral {
        let lo = frames
            .iter()
            .map(|f| f.range.0 + f.intercept as i64)
            .min()
            .unwrap_or(0);
        let hi = frames
            .iter()
            .map(|f| f.range.1 + f.intercept as i64)
            .max()
            .unwrap_or(0);
        let fits = |a: i64, b: i64| lo >= a && hi <= b;
        let shifted = |f: &Frame, i: usize| f.stored(i) + f.intercept as i64;
        if frames[0].bits_allocated == 8 && fits(0, 255) {
            return VolumeData::U8(gather(frames, total, |f, i| shifted(f, i) as u8));
        }
        if frames[0].signed && fits(-32768, 32767) {
            return VolumeData::I16(gather(frames, total, |f, i| shifted(f, i) as i16));
        }
        if fits(0, 65535) {
            return VolumeData::U16(gather(frames, total, |f, i| shifted(f, i) as u16));
        }
        if fits(-32768, 32767) {
            return VolumeData::I16(gather(frames, total, |f, i| shifted(f, i) as i16));
        }
        if fits(i32::MIN as i64, i32::MAX as i64) {
            return VolumeData::I32(gather(frames, total, |f, i| shifted(f, i) as i32));
        }
        return VolumeData::I64(gather(frames, total, shifted));
    }
    let value = |f: &Frame, i: usize| f.stored(i) as f64 * f.slope + f.intercept;
    let bound = frames
        .iter()
        .flat_map(|f| [f.range.0, f.range.1].map(|s| (s as f64 * f.slope + f.intercept).abs()))
        .fold(0.0, f64::max);
    if bound < 16_777_216.0 {
        return VolumeData::F32(gather(frames, total, |f, i| value(f, i) as f32));
    }
    VolumeData::F64(gather(frames, total, value))
}

/// Every sample of every frame, in frame order, through `convert`.
fn gather<T>(frames: &[Frame], total: usize, convert: impl Fn(&Frame, usize) -> T) -> Vec<T> {
    let mut out = Vec::with_capacity(total);
    for f in frames {
        out.extend((0..f.rows * f.cols).map(|i| convert(f, i)));
    }
    out
}

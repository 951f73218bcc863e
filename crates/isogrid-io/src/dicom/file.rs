//! One DICOM file → its image frames: opening (with or without preamble or file meta group),
//! the attributes of DICOM PS3.3 C.7.6.2 (Image Plane), C.7.6.3 (Image Pixel), C.11.1 (Modality
//! LUT) and the enhanced multi-frame functional groups (C.7.6.16), and pixel data decoded by
//! dicom-rs (`dicom-pixeldata` and its transfer-syntax registry).

use super::jpeg12;
use crate::geometry::{cross, normalized, Vec3};
use crate::samples::sample_count;
use dicom_core::value::{PrimitiveValue, Value};
use dicom_core::{Tag, VR};
use dicom_dictionary_std::tags;
use dicom_encoding::transfer_syntax::{Endianness, TransferSyntaxIndex};
use dicom_object::{
    file::ReadPreamble, DefaultDicomObject, FileMetaTableBuilder, InMemDicomObject, OpenFileOptions,
};
use dicom_pixeldata::PixelDecoder;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use isogrid::{Error, Result};
use std::io::Read;
use std::path::{Path, PathBuf};

/// What the series grouping needs from a file, read without its pixel data.
pub(super) struct Header {
    pub path: PathBuf,
    pub series: String,
    /// Image frames the file declares (NumberOfFrames, 1 when absent).
    pub frames: usize,
}

/// One 2-D image: its metadata and its stored values as little-endian samples.
pub(super) struct Frame {
    pub path: PathBuf,
    /// Index of the frame in its file (0 for single-frame files).
    pub index: usize,
    pub rows: usize,
    pub cols: usize,
    pub bits_allocated: u16,
    pub bits_stored: u16,
    pub signed: bool,
    pub slope: f64,
    pub intercept: f64,
    pub position: Option<Vec3>,
    pub orientation: Option<(Vec3, Vec3)>,
    pub instance: Option<i64>,
    pub pixel_spacing: Option<[f64; 2]>,
    /// SpacingBetweenSlices, else SliceThickness: the k spacing when positions are missing.
    pub slice_step: Option<f64>,
    pub pixels: Vec<u8>,
    /// Smallest and largest stored value.
    pub range: (i64, i64),
}

impl Frame {
    /// Stored value `index`: masked to BitsStored, sign-extended when signed.
    pub fn stored(&self, index: usize) -> i64 {
        let p = &self.pixels;
        let raw: u32 = match self.bits_allocated {
            8 => p[index] as u32,
            16 => u16::from_le_bytes([p[2 * index], p[2 * index + 1]]) as u32,
            _ => u32::from_le_bytes([
                p[4 * index],
                p[4 * index + 1],
                p[4 * index + 2],
                p[4 * index + 3],
            ]),
        };
        let bits = self.bits_stored as u32;
        let v = if bits >= 32 {
            raw
        } else {
            raw & ((1u32 << bits) - 1)
        };
        if self.signed && (v >> (bits - 1)) & 1 == 1 {
            v as i64 - (1i64 << bits)
        } else {
            v as i64
        }
    }

    /// "FILE" or "FILE frame N".
    pub fn describe(&self) -> String {
        let file = file_name(&self.path);
        if self.index == 0 {
            file
        } else {
            format!("{file} frame {}", self.index + 1)
        }
    }
}

/// How a DICOM file begins, from its first 132 bytes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Layout {
    /// `DICM` at byte 128 (standard) or at byte 0 (preamble missing): dicom-rs finds it.
    Standard,
    /// The file meta group (group 0002) at byte 0, without preamble or `DICM` (pydicom reads
    /// these with `force=True`).
    MetaWithoutMagic,
    /// A bare little-endian data set without file meta group (old ACR-NEMA style files), its
    /// first element (group 0000, 0008, …) explicit VR when bytes 4–5 are a VR, else implicit.
    BareDataSet {
        explicit: bool,
    },
    NotDicom,
}

/// Whether `DICM` follows a 128-byte preamble (PS3.10 §7.1).
fn has_magic_after_preamble(head: &[u8]) -> bool {
    head.len() >= 132 && &head[128..132] == b"DICM"
}

fn layout(head: &[u8]) -> Layout {
    if has_magic_after_preamble(head) || head.starts_with(b"DICM") {
        return Layout::Standard;
    }
    if head.len() < 8 {
        return Layout::NotDicom;
    }
    let group = u16::from_le_bytes([head[0], head[1]]);
    let element = u16::from_le_bytes([head[2], head[3]]);
    let explicit = VR::from_binary([head[4], head[5]]).is_some();
    let implicit_length = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if !matches!(group, 0x0000 | 0x0002 | 0x0008) || element >= 0x0100 {
        return Layout::NotDicom;
    }
    if group == 0x0002 && explicit {
        Layout::MetaWithoutMagic
    } else if explicit || implicit_length < 1024 {
        Layout::BareDataSet { explicit }
    } else {
        Layout::NotDicom
    }
}

/// The first 132 bytes of `path` (fewer when the file is shorter).
fn head(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut head = Vec::with_capacity(132);
    std::fs::File::open(path)?
        .take(132)
        .read_to_end(&mut head)?;
    Ok(head)
}

/// Whether `path` looks like a DICOM file (any [`Layout`] but `NotDicom`).
pub(crate) fn looks_like_dicom(path: &Path) -> bool {
    head(path).is_ok_and(|head| is_dicom_head(&head))
}

/// Whether a file starting with `head` (its first 132 bytes or more) looks like DICOM.
pub(crate) fn is_dicom_head(head: &[u8]) -> bool {
    layout(head) != Layout::NotDicom
}

/// Opens `path`, reading up to (not including) PixelData when `header_only`.
fn open(path: &Path, header_only: bool) -> Result<DefaultDicomObject> {
    let head = head(path).map_err(|e| Error::from(e).with_path(path))?;
    // Declared lengths are checked against the file before dicom-rs reserves them.
    let (meta_at, bare_explicit) = match layout(&head) {
        // dicom-object's preamble detection looks at byte 128 first: a file with `DICM` there
        // and at byte 0 too is read after a preamble, so it is walked from there.
        Layout::Standard if has_magic_after_preamble(&head) => (Some(132), false),
        Layout::Standard => (Some(4), false),
        Layout::MetaWithoutMagic => (Some(0), false),
        Layout::BareDataSet { explicit } => (None, explicit),
        // Read as a part-10 file below, but walked here as the bare implicit data set a `.dcm`
        // without any header is most likely to be: a lying length is then refused up front.
        Layout::NotDicom => (None, false),
    };
    // Zero bytes padding the file after the data set are left out, as pydicom and GDCM read
    // such files.
    let data_set_end = super::lengths::check_declared_lengths(path, meta_at, bare_explicit)
        .map_err(|e| e.with_path(path))?;
    let invalid = |e: &dyn std::fmt::Display| {
        Error::corrupt(format!("invalid DICOM file: {}", one_line(&e.to_string())))
    };
    let reader = || {
        std::fs::File::open(path)
            .map(|f| std::io::BufReader::new(f).take(data_set_end.unwrap_or(u64::MAX)))
            .map_err(|e| Error::from(e).with_path(path))
    };
    let mut options = OpenFileOptions::new();
    if header_only {
        options = options.read_until(tags::PIXEL_DATA);
    }
    match layout(&head) {
        Layout::BareDataSet { explicit } => {
            // No file meta group: the data set in little-endian VR as its first element shows
            // (implicit is the PS3.5 A.1 default).
            let uid = if explicit {
                dicom_dictionary_std::uids::EXPLICIT_VR_LITTLE_ENDIAN
            } else {
                dicom_dictionary_std::uids::IMPLICIT_VR_LITTLE_ENDIAN
            };
            let ts = TransferSyntaxRegistry
                .get(uid)
                .expect("the registry knows the little-endian uncompressed syntaxes");
            let obj =
                InMemDicomObject::read_dataset_with_ts(reader()?, ts).map_err(|e| invalid(&e))?;
            obj.with_meta(
                FileMetaTableBuilder::new()
                    .transfer_syntax(uid)
                    .media_storage_sop_class_uid("1.2.840.10008.5.1.4.1.1.7")
                    .media_storage_sop_instance_uid("2.25.0"),
            )
            .map_err(|e| invalid(&e))
        }
        Layout::MetaWithoutMagic => {
            // dicom-rs's meta reader starts at the magic code: give it one.
            options
                .read_preamble(ReadPreamble::Never)
                .from_reader(std::io::Read::chain(&b"DICM"[..], reader()?))
                .map_err(|e| invalid(&e))
        }
        Layout::Standard if data_set_end.is_some() => {
            let preamble = if has_magic_after_preamble(&head) {
                ReadPreamble::Always
            } else {
                ReadPreamble::Never
            };
            options
                .read_preamble(preamble)
                .from_reader(reader()?)
                .map_err(|e| invalid(&e))
        }
        // The default preamble detection also reads files that start with `DICM`.
        Layout::Standard | Layout::NotDicom => options.open_file(path).map_err(|e| invalid(&e)),
    }
}

/// The header of an image file, or `None` for a DICOM file that holds no image (DICOMDIR,
/// structured report, RT plan: no Rows).
pub(super) fn read_header(path: &Path) -> Result<Option<Header>> {
    let obj = open(path, true)?;
    let attrs = Attributes(&obj);
    if attrs.int(tags::ROWS).is_none() && attrs.int(tags::COLUMNS).is_none() {
        return Ok(None);
    }
    Ok(Some(Header {
        path: path.to_path_buf(),
        series: attrs.text(tags::SERIES_INSTANCE_UID).unwrap_or_default(),
        frames: number_of_frames(&attrs).unwrap_or(1).max(1),
    }))
}

fn number_of_frames(attrs: &Attributes) -> Option<usize> {
    attrs
        .int(tags::NUMBER_OF_FRAMES)
        .map(|n| usize::try_from(n).unwrap_or(0))
}

/// Attribute lookup in a data set (or a functional-group item).
#[derive(Clone, Copy)]
struct Attributes<'a>(&'a InMemDicomObject);

impl<'a> Attributes<'a> {
    fn element(self, tag: Tag) -> Option<&'a dicom_object::mem::InMemElement> {
        self.0.element_opt(tag).ok().flatten()
    }
    fn int(self, tag: Tag) -> Option<i64> {
        self.element(tag).and_then(|e| e.to_int::<i64>().ok())
    }
    fn floats(self, tag: Tag) -> Option<Vec<f64>> {
        self.element(tag).and_then(|e| e.to_multi_float64().ok())
    }
    fn float(self, tag: Tag) -> Option<f64> {
        self.floats(tag)
            .and_then(|v| v.first().copied())
            .filter(|x| x.is_finite())
    }
    fn text(self, tag: Tag) -> Option<String> {
        self.element(tag)
            .and_then(|e| e.to_str().ok())
            .map(|s| s.trim_end_matches(['\0', ' ']).trim().to_string())
    }
    /// The first item of sequence `tag`.
    fn item(self, tag: Tag) -> Option<Attributes<'a>> {
        self.element(tag)
            .and_then(|e| e.items())
            .and_then(|items| items.first())
            .map(Attributes)
    }
    fn position(self) -> Option<Vec3> {
        self.floats(tags::IMAGE_POSITION_PATIENT)
            .filter(|v| v.len() == 3 && v.iter().all(|x| x.is_finite()))
            .map(|v| [v[0], v[1], v[2]])
    }
    fn orientation(self) -> Option<(Vec3, Vec3)> {
        let v = self
            .floats(tags::IMAGE_ORIENTATION_PATIENT)
            .filter(|v| v.len() == 6)?;
        Some((
            normalized([v[0], v[1], v[2]])?,
            normalized([v[3], v[4], v[5]])?,
        ))
    }
    /// PixelSpacing as given, checked by the stack; a value that is not two numbers reads as
    /// two NaNs, which the check refuses too.
    fn pixel_spacing(self) -> Option<[f64; 2]> {
        self.element(tags::PIXEL_SPACING)
            .map(|e| match e.to_multi_float64() {
                Ok(v) if v.len() == 2 => [v[0], v[1]],
                _ => [f64::NAN; 2],
            })
    }
    fn rescale(self) -> Option<(f64, f64)> {
        let slope = self.float(tags::RESCALE_SLOPE).filter(|&s| s != 0.0);
        let intercept = self.float(tags::RESCALE_INTERCEPT);
        (slope.is_some() || intercept.is_some())
            .then(|| (slope.unwrap_or(1.0), intercept.unwrap_or(0.0)))
    }
}

/// Per-frame metadata of an enhanced multi-frame file (C.7.6.16): the frame's own functional
/// group item, then the shared one, then the top-level data set.
struct FrameGroups<'a> {
    top: Attributes<'a>,
    shared: Option<Attributes<'a>>,
    per_frame: Option<Attributes<'a>>,
}

impl<'a> FrameGroups<'a> {
    /// The first answer of `get` applied to the functional group `macro_tag` of this frame,
    /// of the shared groups, then to the top level.
    fn find<T>(&self, macro_tag: Tag, get: impl Fn(Attributes<'a>) -> Option<T>) -> Option<T> {
        [self.per_frame, self.shared]
            .into_iter()
            .flatten()
            .filter_map(|g| g.item(macro_tag))
            .find_map(&get)
            .or_else(|| get(self.top))
    }
}

/// Reads every frame of the image file `path` (see the module doc of `dicom`). Errors do not
/// name the file; the caller adds it.
pub(super) fn read_frames(path: &Path) -> Result<Vec<Frame>> {
    let obj = open(path, false)?;
    let top = Attributes(&obj);
    let Some(pixel_data) = top.element(tags::PIXEL_DATA) else {
        return Err(Error::corrupt("image file has no PixelData"));
    };
    let ts_uid = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches(['\0', ' '])
        .to_string();
    let ts = TransferSyntaxRegistry
        .get(&ts_uid)
        .ok_or_else(|| Error::unsupported(format!("unknown transfer syntax {ts_uid}")))?;
    let syntax = format!("{} ({ts_uid})", ts.name());

    let rows = top
        .int(tags::ROWS)
        .ok_or_else(|| Error::corrupt("image has no Rows"))?;
    let cols = top
        .int(tags::COLUMNS)
        .ok_or_else(|| Error::corrupt("image has no Columns"))?;
    let bits_allocated = top.int(tags::BITS_ALLOCATED).unwrap_or(16);
    let bits_stored = top.int(tags::BITS_STORED).unwrap_or(bits_allocated);
    if top.int(tags::SAMPLES_PER_PIXEL).unwrap_or(1) != 1 {
        return Err(Error::unsupported(
            "colour DICOM images are not supported (SamplesPerPixel is not 1)",
        ));
    }
    let photometric = top
        .text(tags::PHOTOMETRIC_INTERPRETATION)
        .unwrap_or_default();
    if !photometric.is_empty() && !photometric.starts_with("MONOCHROME") {
        return Err(Error::unsupported(format!(
            "photometric interpretation {photometric} is not grayscale"
        )));
    }
    if !matches!(bits_allocated, 8 | 16 | 32) || !(1..=bits_allocated).contains(&bits_stored) {
        return Err(Error::unsupported(format!(
            "{bits_stored} of {bits_allocated} allocated bits per sample is not supported"
        )));
    }
    // jpeg-decoder (the registry's JPEG codec) reads lossy JPEG of 8-bit precision only; 12-bit
    // JPEG Extended goes to libjpeg-turbo instead.
    let jpeg12 = ts_uid == JPEG_EXTENDED && bits_stored > 8;
    if jpeg12 && bits_allocated != 16 {
        return Err(Error::unsupported(format!(
            "{syntax} with {bits_stored} of {bits_allocated} allocated bits per sample is not \
             supported (12-bit JPEG needs 16 allocated bits)"
        )));
    }
    if ts_uid == RLE_LOSSLESS && bits_allocated == 32 {
        return Err(Error::unsupported(format!(
            "{syntax} with 32-bit samples is not supported: the RLE decoder \
             (dicom-transfer-syntax-registry) reads 8- and 16-bit samples only"
        )));
    }
    if !ts.can_decode_all() {
        return Err(Error::unsupported(format!(
            "transfer syntax {syntax} cannot be decoded by this build"
        )));
    }
    let (rows, cols) = (
        usize::try_from(rows).unwrap_or(0),
        usize::try_from(cols).unwrap_or(0),
    );
    let frame_samples = sample_count([cols, rows, 1])?;
    let frame_bytes = frame_samples * (bits_allocated as usize / 8);
    let frames = number_of_frames(&top).unwrap_or(1);
    if frames == 0 {
        return Err(Error::corrupt("NumberOfFrames is 0"));
    }

    let frame_pixels: Vec<Vec<u8>> = match pixel_data.value() {
        Value::PixelSequence(seq) => {
            let fragments = seq.fragments().len();
            let offsets = seq.offset_table().len();
            if frames > 1 && fragments < frames && offsets < frames {
                return Err(Error::corrupt(format!(
                    "NumberOfFrames says {frames} but the encapsulated PixelData holds {fragments} \
                     fragments and {offsets} frame offsets"
                )));
            }
            let fragment_list = seq.fragments();
            (0..frames)
                .map(|k| {
                    let fails = |why: String| {
                        Error::corrupt(format!("{syntax} frame {} does not decode: {why}", k + 1))
                    };
                    if ts_uid == RLE_LOSSLESS {
                        let fragment = fragment_list.get(k).map_or(&[][..], |f| &f[..]);
                        check_rle(fragment, bits_allocated as usize / 8, frame_samples)
                            .map_err(fails)?;
                    }
                    if jpeg12 {
                        let stream =
                            jpeg12::frame_stream(fragment_list, seq.offset_table(), frames, k)
                                .map_err(fails)?;
                        return jpeg12::decode_frame(&stream, cols, rows).map_err(fails);
                    }
                    // The codec's stream checked before the codec sees it (jpeg_header.rs).
                    let syntax_uid = ts_uid.as_str();
                    let check: Option<fn(&[u8], usize, usize, u16) -> Result<(), String>> =
                        if JPEG_DECODER_SYNTAXES.contains(&syntax_uid) {
                            Some(super::jpeg_header::check_frame)
                        } else if JPEG_LS_SYNTAXES.contains(&syntax_uid) {
                            Some(|stream, _, _, _| super::jpeg_header::check_jpeg_ls_end(stream))
                        } else if JPEG_2000_SYNTAXES.contains(&syntax_uid) {
                            Some(super::jpeg_header::check_j2k)
                        } else {
                            None
                        };
                    if let Some(check) = check {
                        let stream =
                            jpeg12::frame_stream(fragment_list, seq.offset_table(), frames, k)
                                .map_err(fails)?;
                        check(&stream, cols, rows, bits_allocated as u16).map_err(fails)?;
                    }
                    // The codecs are third-party code on hostile input: a panic in one becomes
                    // this frame's error instead of taking the process down.
                    let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        obj.decode_pixel_data_frame(k as u32)
                            .map(|d| d.data().to_vec())
                    }))
                    .map_err(|_| fails("the decoder failed on this data".into()))?
                    .map_err(|e| fails(error_chain(&e)))?;
                    let data = decoded;
                    if data.len() < frame_bytes {
                        return Err(Error::corrupt(format!(
                            "{syntax} frame {} decodes to {} bytes but {cols}x{rows} samples of \
                             {bits_allocated} bits need {frame_bytes}",
                            k + 1,
                            data.len()
                        )));
                    }
                    Ok(data[..frame_bytes].to_vec())
                })
                .collect::<Result<_>>()?
        }
        value => {
            let big_endian = ts.endianness() == Endianness::Big;
            let all = native_le_bytes(value, bits_allocated as usize / 8, big_endian)?;
            let needed = frames as u64 * frame_bytes as u64;
            if (all.len() as u64) < needed {
                return Err(Error::corrupt(format!(
                    "PixelData holds {} bytes but {frames} frame(s) of {cols}x{rows} samples of \
                     {bits_allocated} bits need {needed}",
                    all.len()
                )));
            }
            all.chunks_exact(frame_bytes.max(1))
                .take(frames)
                .map(<[u8]>::to_vec)
                .collect()
        }
    };

    let shared = top.item(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE);
    let per_frame_items = top
        .element(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .and_then(|e| e.items());
    let enhanced = per_frame_items.is_some();
    if let Some(items) = per_frame_items {
        if items.len() != frames {
            return Err(Error::corrupt(format!(
                "PerFrameFunctionalGroupsSequence has {} items for {frames} frames",
                items.len()
            )));
        }
    }
    let classic_offsets = (!enhanced && frames > 1)
        .then(|| classic_frame_offsets(top, frames))
        .flatten();
    let instance = top.int(tags::INSTANCE_NUMBER);
    let slice_step = top
        .float(tags::SPACING_BETWEEN_SLICES)
        .or_else(|| top.float(tags::SLICE_THICKNESS))
        .filter(|&s| s > 0.0);

    let mut out = Vec::with_capacity(frames);
    for (index, pixels) in frame_pixels.into_iter().enumerate() {
        let groups = FrameGroups {
            top,
            shared,
            per_frame: per_frame_items.map(|items| Attributes(&items[index])),
        };
        let orientation = groups.find(tags::PLANE_ORIENTATION_SEQUENCE, Attributes::orientation);
        let mut position = groups.find(tags::PLANE_POSITION_SEQUENCE, Attributes::position);
        if !enhanced && frames > 1 {
            // Classic multi-frame: one position for the first frame, frames stacked along the
            // normal (GridFrameOffsetVector or SpacingBetweenSlices); without offsets the frames
            // have no positions of their own and keep their order.
            position = match (&classic_offsets, position, orientation) {
                (Some(offsets), Some(p), Some((row, col))) => {
                    normalized(cross(row, col)).map(|n| {
                        let d = offsets[index];
                        [p[0] + d * n[0], p[1] + d * n[1], p[2] + d * n[2]]
                    })
                }
                _ => None,
            };
        }
        let (slope, intercept) = groups
            .find(
                tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
                Attributes::rescale,
            )
            .unwrap_or((1.0, 0.0));
        let mut frame = Frame {
            path: path.to_path_buf(),
            index,
            rows,
            cols,
            bits_allocated: bits_allocated as u16,
            bits_stored: bits_stored as u16,
            signed: top.int(tags::PIXEL_REPRESENTATION).unwrap_or(0) == 1,
            slope,
            intercept,
            position,
            orientation,
            instance: instance.map(|i| i * frames as i64 + index as i64),
            pixel_spacing: groups.find(tags::PIXEL_MEASURES_SEQUENCE, Attributes::pixel_spacing),
            slice_step: groups
                .find(tags::PIXEL_MEASURES_SEQUENCE, |g| {
                    g.float(tags::SPACING_BETWEEN_SLICES)
                        .or_else(|| g.float(tags::SLICE_THICKNESS))
                })
                .filter(|&s| s > 0.0)
                .or(slice_step),
            pixels,
            range: (0, 0),
        };
        frame.range = (0..frame_samples)
            .map(|i| frame.stored(i))
            .fold((i64::MAX, i64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
        out.push(frame);
    }
    Ok(out)
}

/// JPEG Extended (processes 2 and 4): 8-bit or 12-bit lossy.
const JPEG_EXTENDED: &str = "1.2.840.10008.1.2.4.51";
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";
/// The syntaxes jpeg-decoder reads (baseline, extended 8-bit, lossless process 14 and SV1).
const JPEG_DECODER_SYNTAXES: [&str; 4] = [
    "1.2.840.10008.1.2.4.50",
    JPEG_EXTENDED,
    "1.2.840.10008.1.2.4.57",
    "1.2.840.10008.1.2.4.70",
];

/// JPEG-LS lossless and near-lossless (PS3.5 A.4.3), decoded by CharLS.
const JPEG_LS_SYNTAXES: [&str; 2] = ["1.2.840.10008.1.2.4.80", "1.2.840.10008.1.2.4.81"];

/// JPEG 2000 lossless only and lossy (PS3.5 A.4.4).
const JPEG_2000_SYNTAXES: [&str; 2] = ["1.2.840.10008.1.2.4.90", "1.2.840.10008.1.2.4.91"];

/// Checks an RLE Lossless frame's layout before the decoder sees it (PS3.5 G.3.1, G.5): a
/// 64-byte header with one segment per sample byte, offsets inside the fragment and in order, and
/// every segment's PackBits runs covering at least `samples` bytes. (The registry's decoder
/// indexes past short segments instead of failing.)
fn check_rle(
    fragment: &[u8],
    bytes_per_sample: usize,
    samples: usize,
) -> std::result::Result<(), String> {
    if fragment.len() < 64 {
        return Err(format!("RLE header is {} bytes, not 64", fragment.len()));
    }
    let word = |i: usize| {
        u32::from_le_bytes([
            fragment[4 * i],
            fragment[4 * i + 1],
            fragment[4 * i + 2],
            fragment[4 * i + 3],
        ]) as usize
    };
    let segments = word(0);
    if segments != bytes_per_sample {
        return Err(format!(
            "RLE header lists {segments} segments, not {bytes_per_sample}"
        ));
    }
    for s in 0..segments {
        let start = word(1 + s);
        let end = if s + 1 < segments {
            word(2 + s)
        } else {
            fragment.len()
        };
        if start < 64 || start > end || end > fragment.len() {
            return Err(format!(
                "RLE segment {} lies outside the fragment ({} bytes)",
                s + 1,
                fragment.len()
            ));
        }
        // Decoded length of the PackBits runs: n >= 0 copies n + 1 bytes, -127..=-1 repeats one
        // byte 1 - n times, -128 is a no-op.
        let (mut at, mut out) = (start, 0usize);
        while at < end && out < samples {
            let n = fragment[at] as i8;
            match n {
                0..=127 => {
                    out += n as usize + 1;
                    at += n as usize + 2;
                }
                -127..=-1 => {
                    out += (1 - n as isize) as usize;
                    at += 2;
                }
                _ => at += 1,
            }
        }
        if out < samples || at > end {
            return Err(format!("RLE segment {} is truncated", s + 1));
        }
    }
    Ok(())
}

/// Offsets along the normal of the frames of a classic multi-frame file: GridFrameOffsetVector
/// (RT Dose, C.8.8.3.2; relative to the first frame when it starts at 0, else absolute along
/// the normal from ImagePositionPatient's projection, which this turns relative), else
/// k × SpacingBetweenSlices, else k × SliceThickness.
fn classic_frame_offsets(top: Attributes, frames: usize) -> Option<Vec<f64>> {
    if let Some(v) = top
        .floats(tags::GRID_FRAME_OFFSET_VECTOR)
        .filter(|v| v.len() == frames && v.iter().all(|x| x.is_finite()))
    {
        let first = v[0];
        return Some(v.iter().map(|x| x - first).collect());
    }
    let step = top
        .float(tags::SPACING_BETWEEN_SLICES)
        .or_else(|| top.float(tags::SLICE_THICKNESS))
        .filter(|&s| s > 0.0)?;
    Some((0..frames).map(|k| k as f64 * step).collect())
}

/// Native pixel data as little-endian samples of `width` bytes, however the parser typed the
/// values. Big-endian files are parsed into typed values word by word (OW as u16), so samples
/// wider than a word are rebuilt from the file's byte order.
fn native_le_bytes(
    value: &Value<InMemDicomObject, dicom_core::value::InMemFragment>,
    width: usize,
    big_endian: bool,
) -> Result<Vec<u8>> {
    let Value::Primitive(primitive) = value else {
        return Err(Error::corrupt("PixelData has an unexpected value type"));
    };
    let to_file_order = |bytes: [u8; 2]| {
        if big_endian {
            [bytes[1], bytes[0]]
        } else {
            bytes
        }
    };
    // The bytes as they are in the file.
    let file_bytes: Vec<u8> = match primitive {
        PrimitiveValue::U8(v) => v.to_vec(),
        PrimitiveValue::U16(v) => v
            .iter()
            .flat_map(|x| to_file_order(x.to_le_bytes()))
            .collect(),
        PrimitiveValue::I16(v) => v
            .iter()
            .flat_map(|x| to_file_order(x.to_le_bytes()))
            .collect(),
        PrimitiveValue::U32(v) => v
            .iter()
            .flat_map(|x| {
                if big_endian {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect(),
        PrimitiveValue::I32(v) => v
            .iter()
            .flat_map(|x| {
                if big_endian {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect(),
        PrimitiveValue::F32(v) => v
            .iter()
            .flat_map(|x| {
                if big_endian {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect(),
        _ => return Err(Error::corrupt("PixelData has an unexpected value type")),
    };
    if !big_endian || width == 1 {
        return Ok(file_bytes);
    }
    let mut le = file_bytes;
    for sample in le.chunks_exact_mut(width) {
        sample.reverse();
    }
    Ok(le)
}

/// An error and its sources on one line (the decoders' detail sits in the sources).
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = one_line(&e.to_string());
    let mut source = e.source();
    while let Some(s) = source {
        let more = one_line(&s.to_string());
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}

pub(super) fn one_line(s: &str) -> String {
    s.lines().next().unwrap_or("").to_string()
}

/// The file's name for messages (the whole path when it has none).
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

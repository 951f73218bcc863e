//! Multi-page TIFF stacks: page n is z slice n (k = n), its columns i and rows j.
//!
//! Decoded with the `tiff` crate (baseline TIFF 6.0 plus BigTIFF; uncompressed, LZW, deflate and
//! PackBits). Only single-channel grayscale pages are volumes: 8/16-bit unsigned, 16-bit signed
//! and 32-bit float are kept; 8-bit signed becomes i16, 32/64-bit integers and 64-bit floats
//! become f32, as in the crate docs. RGB, palette, alpha and bilevel pages are `Unsupported`.
//! Every page must have the size and type of the first. TIFF has no standard voxel spacing for
//! stacks, so spacing is 1 and origin 0.

use isogrid::{Error, Result, ResultExt, Volume, VolumeData, MAX_DIM};
use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;
use tiff::ColorType;

/// The most a compressed page could expand per stored byte (LZW at its most; deflate is ~1032).
const MAX_EXPANSION: u64 = 4096;

/// Reads every page of a grayscale TIFF as one volume. Errors name `path`.
pub fn read_tiff(path: &Path) -> Result<Volume> {
    read(path).at_path(path)
}

fn read(path: &Path) -> Result<Volume> {
    let file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata()?.len();
    let mut decoder = Decoder::new(BufReader::new(file)).map_err(tiff_error)?;
    let mut slices: Option<VolumeData> = None;
    let mut first_size = None;
    let mut pages = 0usize;
    loop {
        let (w, h) = decoder.dimensions().map_err(tiff_error)?;
        match decoder.colortype().map_err(tiff_error)? {
            ColorType::Gray(8 | 16 | 32 | 64) => {}
            other => {
                return Err(Error::unsupported(format!(
                "page {pages} is {other:?}; only single-channel grayscale TIFF stacks are volumes"
            )))
            }
        }
        if *first_size.get_or_insert((w, h)) != (w, h) {
            return Err(Error::corrupt(format!(
                "page {pages} is {w}x{h} but page 0 is {}x{}",
                first_size.map_or(0, |s| s.0),
                first_size.map_or(0, |s| s.1)
            )));
        }
        let page_bytes = check_page_fits(&mut decoder, w, h, file_len)?;
        // The stack so far and this page, with room for the stack's growth as pages join it.
        isogrid::memory::ensure_fits(
            &format!("a stack of {} {w}x{h} pages", pages + 1),
            (pages as u64 + 2).saturating_mul(page_bytes),
        )?;
        let page = decoder.read_image().map_err(tiff_error)?;
        slices = Some(append(slices, page, pages)?);
        pages += 1;
        if pages > MAX_DIM {
            return Err(Error::too_large(format!("more than {MAX_DIM} pages")));
        }
        if !decoder.more_images() {
            break;
        }
        decoder.next_image().map_err(tiff_error)?;
    }
    let (w, h) = first_size.unwrap_or((0, 0));
    let data = slices.ok_or_else(|| Error::corrupt("TIFF has no pages"))?;
    Volume::new([w as usize, h as usize, pages], data)
}

/// Reads the first page of a grayscale TIFF as one slice: (width, height, samples), converted as
/// the stack reader converts them. Errors name `path`.
pub(crate) fn read_page(path: &Path) -> Result<(usize, usize, VolumeData)> {
    (|| {
        let file = isogrid::fs::open_regular(path)?;
        let file_len = file.metadata()?.len();
        let mut decoder = Decoder::new(BufReader::new(file)).map_err(tiff_error)?;
        let (w, h) = decoder.dimensions().map_err(tiff_error)?;
        match decoder.colortype().map_err(tiff_error)? {
            ColorType::Gray(8 | 16 | 32 | 64) => {}
            other => {
                return Err(Error::unsupported(format!(
                    "the image is {other:?}; only single-channel grayscale TIFF slices are volumes"
                )))
            }
        }
        check_page_fits(&mut decoder, w, h, file_len)?;
        let page = decoder.read_image().map_err(tiff_error)?;
        Ok((w as usize, h as usize, append(None, page, 0)?))
    })()
    .at_path(path)
}

/// Rejects a page whose declared pixels the file cannot hold, before the decoder allocates them;
/// returns the page's decoded bytes.
fn check_page_fits(
    decoder: &mut Decoder<BufReader<File>>,
    w: u32,
    h: u32,
    file_len: u64,
) -> Result<u64> {
    let bits: u64 = decoder
        .find_tag_unsigned::<u64>(Tag::BitsPerSample)
        .ok()
        .flatten()
        .unwrap_or(8);
    let compression = decoder
        .find_tag_unsigned::<u64>(Tag::Compression)
        .ok()
        .flatten()
        .unwrap_or(1);
    let bytes = (w as u64) * (h as u64) * bits.div_ceil(8);
    let most = if compression == 1 {
        file_len
    } else {
        file_len.saturating_mul(MAX_EXPANSION)
    };
    if bytes > most {
        return Err(Error::corrupt(format!(
            "a {w}x{h} page of {bits}-bit samples cannot fit in a {file_len}-byte file"
        )));
    }
    Ok(bytes)
}

/// Appends a decoded page to the stack as its own type (i8 widened to i16, f16 to f32, both
/// exactly); all pages must share a type.
fn append(stack: Option<VolumeData>, page: DecodingResult, index: usize) -> Result<VolumeData> {
    let page = match page {
        DecodingResult::U8(v) => VolumeData::U8(v),
        DecodingResult::U16(v) => VolumeData::U16(v),
        DecodingResult::I16(v) => VolumeData::I16(v),
        DecodingResult::F32(v) => VolumeData::F32(v),
        DecodingResult::I8(v) => VolumeData::I16(v.into_iter().map(i16::from).collect()),
        DecodingResult::U32(v) => VolumeData::U32(v),
        DecodingResult::I32(v) => VolumeData::I32(v),
        DecodingResult::U64(v) => VolumeData::U64(v),
        DecodingResult::I64(v) => VolumeData::I64(v),
        DecodingResult::F64(v) => VolumeData::F64(v),
        DecodingResult::F16(v) => VolumeData::F32(v.into_iter().map(|x| x.to_f32()).collect()),
    };
    let Some(stack) = stack else { return Ok(page) };
    crate::samples::append(stack, page).map_err(|(a, b)| {
        Error::corrupt(format!(
            "page {index} holds {} samples but page 0 holds {}",
            b.scalar_type().name(),
            a.scalar_type().name()
        ))
    })
}

fn tiff_error(e: tiff::TiffError) -> Error {
    match e {
        tiff::TiffError::IoError(io) => Error::io(io),
        tiff::TiffError::UnsupportedError(u) => {
            Error::unsupported(format!("unsupported TIFF: {u}"))
        }
        tiff::TiffError::LimitsExceeded => {
            Error::too_large("TIFF page exceeds the decoder's memory limit")
        }
        other => Error::corrupt(format!("invalid TIFF: {other}")),
    }
}

//! Multi-page TIFF stacks: page n is z slice n (k = n), its columns i and rows j.
//!
//! Decoded with the `tiff` crate (baseline TIFF 6.0 plus BigTIFF; uncompressed, LZW, deflate and
//! PackBits). Only single-channel grayscale pages are volumes: 8 to 64-bit integers and 32/64-bit
//! floats are kept as they are, 8-bit signed is widened to i16 and 16-bit float to f32 (both
//! exactly). RGB, palette, alpha and bilevel pages are `Unsupported`. Every page must have the
//! size and type of the first. An ImageJ hyperstack or OME-TIFF with several channels or time
//! points is read one channel and time point at a time, picked with `--index c=N,t=N`
//! ([`hyperstack`]). TIFF has no standard voxel spacing for stacks, so spacing is 1 and origin 0.

mod hyperstack;

use crate::read_options::AxisPick;
use hyperstack::Hyperstack;
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
    read_tiff_indexed(path, AxisPick::NONE)
}

/// Reads the z slices of a grayscale TIFF: every page of a plain stack, or of a hyperstack the
/// pages of the channel and time point `pick` chooses (`--index c=N,t=N`). Errors name `path`.
pub fn read_tiff_indexed(path: &Path, pick: AxisPick) -> Result<Volume> {
    read(path, pick).at_path(path)
}

fn read(path: &Path, pick: AxisPick) -> Result<Volume> {
    let file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata()?.len();
    let mut decoder = Decoder::new(BufReader::new(file)).map_err(tiff_error)?;
    let stack = decoder
        .get_tag_ascii_string(Tag::ImageDescription)
        .ok()
        .and_then(|d| Hyperstack::parse(&d));
    // The pages to read, in z order: all of a plain stack, one channel and time of a hyperstack.
    let wanted: Option<Vec<usize>> = match &stack {
        Some(h) => {
            let (c, t) = h.pick(pick)?;
            Some((0..h.sizes[1]).map(|z| h.page([c, z, t])).collect())
        }
        None if !pick.indices.is_empty() => {
            return Err(Error::invalid(format!(
                "{} picks a channel or time point, but this TIFF is a plain stack (its ImageJ or \
                 OME metadata declares neither)",
                pick.flag
            )))
        }
        None => None,
    };
    let keep = |page: usize| wanted.as_ref().is_none_or(|w| w.contains(&page));
    let mut stacked: Vec<(usize, VolumeData)> = Vec::new();
    let mut slices: Option<VolumeData> = None;
    let mut first_size = None;
    let mut pages = 0usize;
    let mut page_index = 0usize;
    loop {
        if !keep(page_index) {
            if !decoder.more_images() {
                break;
            }
            decoder.next_image().map_err(tiff_error)?;
            page_index += 1;
            continue;
        }
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
        match &wanted {
            None => slices = Some(append(slices, kept(page), pages)?),
            // A hyperstack's pages may come in another order than z (OME's XYCTZ).
            Some(_) => stacked.push((page_index, kept(page))),
        }
        pages += 1;
        if pages > MAX_DIM {
            return Err(Error::too_large(format!("more than {MAX_DIM} pages")));
        }
        if !decoder.more_images() || wanted.as_ref().is_some_and(|w| pages == w.len()) {
            break;
        }
        decoder.next_image().map_err(tiff_error)?;
        page_index += 1;
    }
    if let (Some(w), Some(h)) = (&wanted, &stack) {
        if pages < w.len() {
            return Err(Error::corrupt(format!(
                "the {} declares {} pages ({} channels x {} slices x {} time points) but the \
                 file has {}",
                h.source,
                h.pages(),
                h.sizes[0],
                h.sizes[1],
                h.sizes[2],
                page_index + 1
            )));
        }
        stacked.sort_by_key(|(page, _)| w.iter().position(|p| p == page));
        for (page, data) in stacked {
            slices = Some(append(slices, data, page)?);
        }
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
        Ok((w as usize, h as usize, kept(page)))
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

/// A decoded page as its own type (i8 widened to i16, f16 to f32, both exactly).
fn kept(page: DecodingResult) -> VolumeData {
    match page {
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
    }
}

/// Appends page `index` to the stack; all pages must share a type.
fn append(stack: Option<VolumeData>, page: VolumeData, index: usize) -> Result<VolumeData> {
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

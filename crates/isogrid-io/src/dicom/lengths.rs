//! Declared value lengths checked against the file before dicom-rs parses it (DICOM PS3.5 §7.1).
//!
//! dicom-parser, and dicom-object's file meta group reader, reserve and zero-fill an element's
//! declared length before reading its bytes, so a file of a few kilobytes that declares a value
//! of 4 GiB allocates 4 GiB before failing (found by the `dicom` fuzz target, docs/fuzzing.md).
//! Walking the element headers first, without reading any value (dicom-parser's lazy reader for
//! the data set, a few lines for the explicit little-endian meta group), finds such a length
//! and names it. Anything else the walk cannot parse is left to the real parser and its own
//! error. A deflated data set is inflated first (within [`isogrid::memory`]'s limit): its
//! lengths count inflated bytes.
//!
//! The same walk finds where the data set ends in a file padded with zero bytes after its last
//! element (a GE MR series does this): dicom-rs reads those bytes as empty (0000,0000) elements
//! and fails on the last, partial one, while pydicom and GDCM ignore them.

use dicom_core::header::{DataElementHeader, HasLength as _, Header as _};
use dicom_encoding::transfer_syntax::{Codec, TransferSyntax, TransferSyntaxIndex};
use dicom_parser::dataset::lazy_read::{LazyDataSetReader, LazyDataSetReaderOptions};
use dicom_parser::dataset::read::OddLengthStrategy;
use dicom_parser::dataset::LazyDataToken;
use dicom_parser::StatefulDecode;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use isogrid::{Error, Result};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Fails when an element of the file declares more bytes than the file has after its header.
/// `meta_at`: where the file meta group starts (after `DICM`, or at byte 0 in a file without
/// it), or `None` for a bare little-endian data set, explicit VR when `bare_explicit`.
/// Returns where the data set ends when only zero bytes follow it (padding to be ignored).
pub(super) fn check_declared_lengths(
    path: &Path,
    meta_at: Option<u64>,
    bare_explicit: bool,
) -> Result<Option<u64>> {
    let file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata().map_err(Error::from)?.len();
    let mut file = BufReader::new(file);
    let (data_set_at, ts_uid) = match meta_at {
        Some(at) => match walk_meta_group(&mut file, at, file_len)? {
            Some(found) => found,
            None => return Ok(None),
        },
        None if bare_explicit => (
            0,
            dicom_dictionary_std::uids::EXPLICIT_VR_LITTLE_ENDIAN.to_string(),
        ),
        None => (
            0,
            dicom_dictionary_std::uids::IMPLICIT_VR_LITTLE_ENDIAN.to_string(),
        ),
    };
    let Some(ts) = TransferSyntaxRegistry.get(&ts_uid) else {
        return Ok(None);
    };
    if !matches!(ts.codec(), Codec::Dataset(_)) {
        let zeros_from = zero_tail_start(&mut file, file_len).map_err(Error::from)?;
        if file.seek(SeekFrom::Start(data_set_at)).is_err() {
            return Ok(None);
        }
        return walk_data_set(file, ts, file_len, zeros_from);
    }
    if file.seek(SeekFrom::Start(data_set_at)).is_err() {
        return Ok(None);
    }
    // Deflated: the lengths count inflated bytes, so walk the inflated data set, itself held
    // to the memory there is.
    let limit = isogrid::memory::available().map_or(u64::MAX, |(bytes, _)| bytes);
    let mut inflated = Vec::new();
    // A damaged stream is walked as far as it inflates: dicom-rs reads it as far, too.
    let _ = flate2::read::DeflateDecoder::new(file)
        .take(limit.saturating_add(1))
        .read_to_end(&mut inflated);
    isogrid::memory::ensure_fits("the inflated DICOM data set", inflated.len() as u64)?;
    let explicit_le = TransferSyntaxRegistry
        .get(dicom_dictionary_std::uids::EXPLICIT_VR_LITTLE_ENDIAN)
        .expect("the registry knows explicit VR little endian");
    let len = inflated.len() as u64;
    // Zero bytes after a deflated data set are not looked for: the inflater stops at the end of
    // the stream and never hands them to dicom-rs.
    walk_data_set(std::io::Cursor::new(inflated), explicit_le, len, u64::MAX).map(|_| None)
}

/// Where the run of zero bytes that ends the file starts (`file_len` when the last byte is not
/// zero).
fn zero_tail_start<S: Read + Seek>(file: &mut S, file_len: u64) -> std::io::Result<u64> {
    let mut start = file_len;
    let mut chunk = vec![0u8; 64 * 1024];
    while start > 0 {
        let n = chunk.len().min(start as usize);
        file.seek(SeekFrom::Start(start - n as u64))?;
        file.read_exact(&mut chunk[..n])?;
        match chunk[..n].iter().rposition(|&b| b != 0) {
            Some(i) => return Ok(start - n as u64 + i as u64 + 1),
            None => start -= n as u64,
        }
    }
    Ok(0)
}

/// Walks the data set from the source's position to `end` without reading values, failing on
/// the first declared length that passes `end`. Returns where the data set ends when an empty
/// (0000,0000) element starts at or after `zeros_from`, the start of the zero bytes that end the
/// file: that element and all after it are padding.
fn walk_data_set<S: Read + Seek>(
    source: S,
    ts: &TransferSyntax,
    end: u64,
    zeros_from: u64,
) -> Result<Option<u64>> {
    // All-zero bytes read as tag (0000,0000), in explicit VR with the unknown VR "\0\0" (read as
    // UN: 2 reserved bytes and a 4-byte length follow) or implicit VR (a 4-byte length).
    let implicit = ts.uid() == dicom_dictionary_std::uids::IMPLICIT_VR_LITTLE_ENDIAN;
    let zero_header_len = if implicit { 8 } else { 12 };
    // Odd lengths are walked as declared: the lazy reader's default refuses them, which would
    // end the walk where dicom-object's reader goes on.
    let mut options = LazyDataSetReaderOptions::default();
    options.odd_length = OddLengthStrategy::Accept;
    let Ok(mut reader) = LazyDataSetReader::new_with_ts_options(source, ts, options) else {
        return Ok(None);
    };
    while let Some(Ok(token)) = reader.advance() {
        let (tag, len, at) = match &token {
            LazyDataToken::LazyValue { header, decoder } => (
                Some(header.tag()),
                header.length().get(),
                decoder.position(),
            ),
            LazyDataToken::LazyItemValue { len, decoder } => (None, Some(*len), decoder.position()),
            _ => continue,
        };
        if tag == Some(dicom_core::Tag(0, 0)) && len == Some(0) {
            let header_at = at.saturating_sub(zero_header_len);
            if header_at >= zeros_from && header_at < end {
                return Ok(Some(header_at));
            }
        }
        if let Some(len) = len {
            check_fits(tag, len, at, end)?;
        }
        if let LazyDataToken::LazyValue { header, .. } = &token {
            check_whole_values(header)?;
        }
        if token.skip().is_err() {
            break;
        }
    }
    Ok(None)
}

/// Walks the file meta group from `at` as dicom-object reads it: the group length element
/// (0002,0000) first, then explicit VR little-endian elements, of any group, until that many
/// bytes are read. Returns where the data set starts and the transfer syntax UID, or `None` when
/// the group does not parse (left to dicom-rs).
fn walk_meta_group(
    file: &mut BufReader<std::fs::File>,
    mut at: u64,
    file_len: u64,
) -> Result<Option<(u64, String)>> {
    let Some((tag, len, value_at)) = element_header(file, at) else {
        return Ok(None);
    };
    let mut group_len = [0u8; 4];
    if tag != (0x0002, 0x0000) || len != 4 || file.read_exact(&mut group_len).is_err() {
        return Ok(None);
    }
    let group_len = u32::from_le_bytes(group_len);
    at = value_at + 4;
    let (mut read, mut ts_uid) = (0u32, None);
    while read < group_len {
        let Some((tag, len, value_at)) = element_header(file, at) else {
            return Ok(None);
        };
        if len == u32::MAX {
            return Ok(None);
        }
        check_fits(Some(tag.into()), len, value_at, file_len)?;
        if tag == (0x0002, 0x0010) {
            let mut uid = vec![0u8; len as usize];
            file.read_exact(&mut uid).map_err(Error::from)?;
            let uid = String::from_utf8_lossy(&uid);
            ts_uid = Some(uid.trim_end_matches(['\0', ' ']).to_string());
        }
        read = read
            .saturating_add((value_at - at) as u32)
            .saturating_add(len);
        at = value_at + u64::from(len);
    }
    Ok(ts_uid.map(|uid| (at, uid)))
}

/// The explicit VR little-endian element header at `at` (PS3.5 §7.1.2): its tag, its value
/// length and where its value starts; `None` past the end of the file.
fn element_header(file: &mut BufReader<std::fs::File>, at: u64) -> Option<((u16, u16), u32, u64)> {
    let mut head = [0u8; 8];
    file.seek(SeekFrom::Start(at)).ok()?;
    file.read_exact(&mut head).ok()?;
    let tag = (
        u16::from_le_bytes([head[0], head[1]]),
        u16::from_le_bytes([head[2], head[3]]),
    );
    let short_form = matches!(
        &head[4..6],
        b"AE"
            | b"AS"
            | b"AT"
            | b"CS"
            | b"DA"
            | b"DS"
            | b"DT"
            | b"FL"
            | b"FD"
            | b"IS"
            | b"LO"
            | b"LT"
            | b"PN"
            | b"SH"
            | b"SL"
            | b"SS"
            | b"ST"
            | b"TM"
            | b"UI"
            | b"UL"
            | b"US"
    );
    if tag.0 == 0xFFFE {
        // Item and delimiter tags carry no VR: a 4-byte length follows the tag.
        return Some((
            tag,
            u32::from_le_bytes([head[4], head[5], head[6], head[7]]),
            at + 8,
        ));
    }
    if short_form {
        return Some((
            tag,
            u32::from(u16::from_le_bytes([head[6], head[7]])),
            at + 8,
        ));
    }
    let mut len = [0u8; 4];
    file.read_exact(&mut len).ok()?;
    Some((tag, u32::from_le_bytes(len), at + 12))
}

/// A numeric value must hold a whole number of values (PS3.5 §6.2): dicom-parser reads the whole
/// values of a partial length and goes on short of the value's end, out of step with the data set
/// from there on, so the walk above would no longer see what dicom-rs reads.
fn check_whole_values(header: &DataElementHeader) -> Result<()> {
    use dicom_core::VR;
    let size = match header.vr() {
        VR::US | VR::SS | VR::OW => 2,
        VR::UL | VR::SL | VR::FL | VR::OL | VR::OF | VR::AT => 4,
        VR::FD | VR::OD | VR::SV | VR::UV | VR::OV => 8,
        _ => return Ok(()),
    };
    // 8-bit pixel data of odd size in an implicit VR file is OW by rule (PS3.5 A.1) and is
    // usually the last element: nothing is read out of step after it.
    if header.tag() == dicom_dictionary_std::tags::PIXEL_DATA {
        return Ok(());
    }
    match header.length().get() {
        Some(len) if len % size != 0 => {
            let tag = header.tag();
            Err(Error::corrupt(format!(
                "invalid DICOM file: element ({:04X},{:04X}) of VR {} declares {len} bytes, not a whole number of {size}-byte values",
                tag.group(),
                tag.element(),
                header.vr().to_string()
            )))
        }
        _ => Ok(()),
    }
}

fn check_fits(tag: Option<dicom_core::Tag>, len: u32, at: u64, file_len: u64) -> Result<()> {
    let left = file_len.saturating_sub(at);
    if u64::from(len) > left {
        let what = tag.map_or("a pixel data fragment".to_string(), |t| {
            format!("element ({:04X},{:04X})", t.group(), t.element())
        });
        return Err(Error::corrupt(format!(
            "invalid DICOM file: {what} declares {len} bytes but only {left} follow it"
        )));
    }
    Ok(())
}

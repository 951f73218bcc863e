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

use dicom_core::header::{HasLength as _, Header as _};
use dicom_encoding::transfer_syntax::{Codec, TransferSyntax, TransferSyntaxIndex};
use dicom_parser::dataset::lazy_read::LazyDataSetReader;
use dicom_parser::dataset::LazyDataToken;
use dicom_parser::StatefulDecode;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use isogrid::{Error, Result};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Fails when an element of the file declares more bytes than the file has after its header.
/// `meta_at`: where the file meta group starts (after `DICM`), or `None` for a bare implicit
/// VR little-endian data set.
pub(super) fn check_declared_lengths(path: &Path, meta_at: Option<u64>) -> Result<()> {
    let file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata().map_err(Error::from)?.len();
    let mut file = BufReader::new(file);
    let (data_set_at, ts_uid) = match meta_at {
        Some(at) => match walk_meta_group(&mut file, at, file_len)? {
            Some(found) => found,
            None => return Ok(()),
        },
        None => (
            0,
            dicom_dictionary_std::uids::IMPLICIT_VR_LITTLE_ENDIAN.to_string(),
        ),
    };
    let Some(ts) = TransferSyntaxRegistry.get(&ts_uid) else {
        return Ok(());
    };
    if file.seek(SeekFrom::Start(data_set_at)).is_err() {
        return Ok(());
    }
    if !matches!(ts.codec(), Codec::Dataset(_)) {
        return walk_data_set(file, ts, file_len);
    }
    // Deflated: the lengths count inflated bytes, so walk the inflated data set, itself held
    // to the memory there is.
    let limit = isogrid::memory::available().map_or(u64::MAX, |(bytes, _)| bytes);
    let mut inflated = Vec::new();
    let inflate = flate2::read::DeflateDecoder::new(file)
        .take(limit.saturating_add(1))
        .read_to_end(&mut inflated);
    if inflate.is_err() {
        return Ok(());
    }
    isogrid::memory::ensure_fits("the inflated DICOM data set", inflated.len() as u64)?;
    let explicit_le = TransferSyntaxRegistry
        .get(dicom_dictionary_std::uids::EXPLICIT_VR_LITTLE_ENDIAN)
        .expect("the registry knows explicit VR little endian");
    let len = inflated.len() as u64;
    walk_data_set(std::io::Cursor::new(inflated), explicit_le, len)
}

/// Walks the data set from the source's position to `end` without reading values, failing on
/// the first declared length that passes `end`.
fn walk_data_set<S: Read + Seek>(source: S, ts: &TransferSyntax, end: u64) -> Result<()> {
    let Ok(mut reader) = LazyDataSetReader::new_with_ts(source, ts) else {
        return Ok(());
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
        if let Some(len) = len {
            check_fits(tag, len, at, end)?;
        }
        if token.skip().is_err() {
            break;
        }
    }
    Ok(())
}

/// Walks the explicit VR little-endian group-0002 elements from `at`; returns where the data set
/// starts and the transfer syntax UID, or `None` when the group does not parse (left to dicom-rs).
fn walk_meta_group(
    file: &mut BufReader<std::fs::File>,
    mut at: u64,
    file_len: u64,
) -> Result<Option<(u64, String)>> {
    let mut ts_uid = None;
    loop {
        let mut head = [0u8; 8];
        if file.seek(SeekFrom::Start(at)).is_err() || file.read_exact(&mut head).is_err() {
            return Ok(None);
        }
        let group = u16::from_le_bytes([head[0], head[1]]);
        let element = u16::from_le_bytes([head[2], head[3]]);
        if group != 0x0002 {
            return Ok(ts_uid.map(|uid| (at, uid)));
        }
        let long_form = matches!(
            &head[4..6],
            b"OB"
                | b"OD"
                | b"OF"
                | b"OL"
                | b"OV"
                | b"OW"
                | b"SQ"
                | b"SV"
                | b"UC"
                | b"UN"
                | b"UR"
                | b"UT"
                | b"UV"
        );
        let (len, header_len) = if long_form {
            let mut n = [0u8; 4];
            if file.read_exact(&mut n).is_err() {
                return Ok(None);
            }
            (u32::from_le_bytes(n), 12)
        } else {
            (u16::from_le_bytes([head[6], head[7]]) as u32, 8)
        };
        if len == u32::MAX {
            return Ok(None);
        }
        let value_at = at + header_len;
        check_fits(Some((group, element).into()), len, value_at, file_len)?;
        if (group, element) == (0x0002, 0x0010) {
            let mut uid = vec![0u8; len as usize];
            file.read_exact(&mut uid).map_err(Error::from)?;
            let uid = String::from_utf8_lossy(&uid);
            ts_uid = Some(uid.trim_end_matches(['\0', ' ']).to_string());
        }
        at = value_at + u64::from(len);
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

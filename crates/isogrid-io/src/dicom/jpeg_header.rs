//! The frame header (SOF, ITU T.81 B.2.2) of a JPEG stream, and the image and tile size marker
//! (SIZ, ITU T.800 A.5.1) of a JPEG 2000 codestream, checked against the DICOM image before the
//! decoder sees the stream: dicom-transfer-syntax-registry copies whatever the decoder returns
//! into a buffer sized from Rows × Columns and panics (a slice index out of range) when the
//! stream declares a larger image, more components or 16-bit samples in an 8-bit image. A
//! JPEG-LS stream must end with its EOI marker (ITU T.87 C.1.2) before CharLS sees it.

/// Precision, lines, samples per line and component count of the stream's first frame header;
/// `None` when no header comes before the first scan (the decoder then reports the damage).
fn frame_header(stream: &[u8]) -> Option<(u8, u16, u16, u8)> {
    let mut at = 0;
    while at + 4 <= stream.len() {
        if stream[at] != 0xFF {
            return None;
        }
        let marker = stream[at + 1];
        match marker {
            0xFF => at += 1,                      // fill byte
            0xD8 | 0x01 | 0xD0..=0xD7 => at += 2, // SOI, TEM, RSTn: no length
            0xDA => return None,                  // a scan before any frame header
            _ => {
                let len = u16::from_be_bytes([stream[at + 2], stream[at + 3]]) as usize;
                let sof = matches!(marker, 0xC0..=0xCF) && !matches!(marker, 0xC4 | 0xC8 | 0xCC);
                if sof {
                    let h = stream.get(at + 4..at + 10)?;
                    let lines = u16::from_be_bytes([h[1], h[2]]);
                    let samples = u16::from_be_bytes([h[3], h[4]]);
                    return Some((h[0], lines, samples, h[5]));
                }
                at += 2 + len;
            }
        }
    }
    None
}

/// Checks that a JPEG frame of a grayscale image is `cols` × `rows`, one component, of samples
/// that fit `bits_allocated`; the message says what differs.
pub(super) fn check_frame(
    stream: &[u8],
    cols: usize,
    rows: usize,
    bits_allocated: u16,
) -> Result<(), String> {
    let Some((precision, lines, samples, components)) = frame_header(stream) else {
        return Ok(());
    };
    if (samples as usize, lines as usize) != (cols, rows) {
        return Err(format!(
            "the JPEG stream is {samples}x{lines} but the image is {cols}x{rows}"
        ));
    }
    if components != 1 {
        return Err(format!(
            "the JPEG stream has {components} components but the image is grayscale"
        ));
    }
    if precision > 8 && bits_allocated < 16 {
        return Err(format!(
            "{precision}-bit JPEG samples do not fit {bits_allocated} allocated bits"
        ));
    }
    Ok(())
}

/// Width, height, component count and the first component's bit depth of a JPEG 2000
/// codestream (SOC, then SIZ); `None` for anything else (a JP2 file, a damaged stream), which the
/// decoder then judges.
fn j2k_size(stream: &[u8]) -> Option<(u64, u64, u16, u8)> {
    if !stream.starts_with(&[0xFF, 0x4F, 0xFF, 0x51]) {
        return None;
    }
    // After SOC, the SIZ marker and Lsiz: Rsiz (2 bytes); Xsiz, Ysiz, XOsiz, YOsiz and the tile
    // sizes and offsets (4 each); Csiz (2); then Ssiz, XRsiz, YRsiz per component.
    let siz = stream.get(6..43)?;
    let be32 = |at: usize| {
        u64::from(u32::from_be_bytes([
            siz[at],
            siz[at + 1],
            siz[at + 2],
            siz[at + 3],
        ]))
    };
    let width = be32(2).checked_sub(be32(10))?;
    let height = be32(6).checked_sub(be32(14))?;
    let components = u16::from_be_bytes([siz[34], siz[35]]);
    let depth = (siz[36] & 0x7F) + 1;
    Some((width, height, components, depth))
}

/// Checks that a JPEG 2000 codestream of a grayscale image is `cols` × `rows`, one component,
/// of samples that fit `bits_allocated`; the message says what differs.
pub(super) fn check_j2k(
    stream: &[u8],
    cols: usize,
    rows: usize,
    bits_allocated: u16,
) -> Result<(), String> {
    let Some((width, height, components, depth)) = j2k_size(stream) else {
        return Ok(());
    };
    if (width, height) != (cols as u64, rows as u64) {
        return Err(format!(
            "the JPEG 2000 stream is {width}x{height} but the image is {cols}x{rows}"
        ));
    }
    if components != 1 {
        return Err(format!(
            "the JPEG 2000 stream has {components} components but the image is grayscale"
        ));
    }
    if u16::from(depth) > bits_allocated {
        return Err(format!(
            "{depth}-bit JPEG 2000 samples do not fit {bits_allocated} allocated bits"
        ));
    }
    Ok(())
}

/// Checks that a JPEG-LS stream ends with its EOI marker (`FF D9`), after the zero bytes that pad
/// a DICOM fragment to even length. CharLS 2.4 reads a scan up to the next marker; a scan that
/// runs to the end of the buffer instead leaves its bit reader counting down past zero, so a
/// damaged 1 KB stream took seconds to fail (an `int` wrapping around) rather than failing at once.
pub(super) fn check_jpeg_ls_end(stream: &[u8]) -> Result<(), String> {
    let end = stream
        .iter()
        .rposition(|&b| b != 0)
        .map_or(0, |last| last + 1);
    if stream[..end].ends_with(&[0xFF, 0xD9]) {
        Ok(())
    } else {
        Err("the JPEG-LS stream does not end with an EOI marker (FF D9): it is truncated or damaged".into())
    }
}

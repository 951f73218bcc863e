//! The frame header (SOF, ITU T.81 B.2.2) of a JPEG stream, checked against the DICOM image
//! before jpeg-decoder sees the stream: dicom-transfer-syntax-registry copies whatever the decoder
//! returns into a buffer sized from Rows × Columns and panics (a slice index out of range) when
//! the stream declares a larger image, more components or 16-bit samples in an 8-bit image.

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

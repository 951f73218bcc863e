//! JPEG Extended (ITU-T T.81 processes 2 and 4, DICOM transfer syntax 1.2.840.10008.1.2.4.51)
//! frames with 12-bit samples, decoded by libjpeg-turbo's TurboJPEG 3 API (`tj3Decompress12`,
//! through `turbojpeg-sys`). No Rust JPEG decoder reads lossy JPEG of 12-bit precision
//! (jpeg-decoder and zune-jpeg stop at 8 bits), so dicom-rs's registry cannot decode these.
//! A stream of 8-bit precision in such a file is decoded with `tj3Decompress8`.

use std::ffi::{c_int, CStr};
use turbojpeg_sys as tj;

/// Frees the TurboJPEG instance on every exit path.
struct Handle(tj::tjhandle);

impl Drop for Handle {
    fn drop(&mut self) {
        // SAFETY: the handle came from tj3Init and is destroyed once.
        unsafe { tj::tj3Destroy(self.0) }
    }
}

impl Handle {
    /// The library's message for the last failure on this handle.
    fn error(&self) -> String {
        // SAFETY: tj3GetErrorStr returns a NUL-terminated string owned by the library.
        unsafe {
            let text = tj::tj3GetErrorStr(self.0);
            if text.is_null() {
                "libjpeg-turbo failed".to_string()
            } else {
                CStr::from_ptr(text).to_string_lossy().into_owned()
            }
        }
    }

    fn get(&self, param: tj::TJPARAM) -> c_int {
        // SAFETY: a valid handle and a parameter id from the bindings.
        unsafe { tj::tj3Get(self.0, param as c_int) }
    }

    /// `pixels` samples written by `call` (a tj3Decompress* call given the destination), or the
    /// library's message when it fails.
    fn decompress<T: Copy + Default>(
        &self,
        pixels: usize,
        call: impl FnOnce(*mut T) -> c_int,
    ) -> Result<Vec<T>, String> {
        let mut samples = vec![T::default(); pixels];
        match call(samples.as_mut_ptr()) {
            0 => Ok(samples),
            _ => Err(self.error()),
        }
    }

    fn set(&self, param: tj::TJPARAM, value: c_int) -> Result<(), String> {
        // SAFETY: as above.
        match unsafe { tj::tj3Set(self.0, param as c_int, value) } {
            0 => Ok(()),
            _ => Err(self.error()),
        }
    }
}

/// libjpeg's warning for a sequential scan whose SOS header does not say Ss = 0, Se = 63,
/// Ah = Al = 0 (JWRN_NOT_SEQUENTIAL).
const NOT_SEQUENTIAL: &str = "Invalid SOS parameters for sequential JPEG";

/// Decodes one grayscale JPEG stream of `cols` × `rows` samples into little-endian 16-bit
/// samples. The stream's own size must be exactly that (libjpeg-turbo is told to refuse larger
/// images before it allocates for them), and any libjpeg warning (a truncated or damaged
/// stream, which libjpeg would otherwise fill with grey) is an error, with one exception: some
/// encoders write other values in the SOS header's spectral-selection fields of a sequential
/// scan (pydicom's `JPEG-lossy.dcm` is one). T.81 fixes those fields for sequential DCT
/// (Table B.3), so a decoder has nothing to read in them; such a stream is decoded again with
/// the fixed values written in, and must then decode without any warning.
pub(super) fn decode_frame(stream: &[u8], cols: usize, rows: usize) -> Result<Vec<u8>, String> {
    match decode_strictly(stream, cols, rows) {
        Err(e) if e == NOT_SEQUENTIAL => {
            let fixed = with_sequential_sos(stream).ok_or(e)?;
            decode_strictly(&fixed, cols, rows)
        }
        result => result,
    }
}

/// A copy of `stream` whose SOS headers say Ss = 0, Se = 63, Ah = Al = 0 (T.81 B.2.3), or `None`
/// when its marker segments do not parse. Walks the marker segments (B.1.1.4) and skips each
/// scan's entropy-coded data, in which 0xFF is followed only by 0x00 or a restart marker.
fn with_sequential_sos(stream: &[u8]) -> Option<Vec<u8>> {
    let mut out = stream.to_vec();
    let mut at = 2; // after SOI
    loop {
        while *out.get(at)? == 0xFF && *out.get(at + 1)? == 0xFF {
            at += 1; // fill bytes
        }
        if *out.get(at)? != 0xFF {
            return None;
        }
        let marker = *out.get(at + 1)?;
        if marker == 0xD9 {
            return Some(out); // EOI
        }
        let length = u16::from_be_bytes([*out.get(at + 2)?, *out.get(at + 3)?]) as usize;
        let end = at + 2 + length;
        if end > out.len() || length < 2 {
            return None;
        }
        if marker != 0xDA {
            at = end;
            continue;
        }
        let components = *out.get(at + 4)? as usize;
        let fields = at + 5 + 2 * components;
        if fields + 3 > end {
            return None;
        }
        out[fields..fields + 3].copy_from_slice(&[0, 63, 0]);
        at = end;
        while at + 1 < out.len()
            && !(out[at] == 0xFF && out[at + 1] != 0 && !(0xD0..=0xD7).contains(&out[at + 1]))
        {
            at += 1;
        }
    }
}

fn decode_strictly(stream: &[u8], cols: usize, rows: usize) -> Result<Vec<u8>, String> {
    let pixels = cols
        .checked_mul(rows)
        .filter(|&n| n > 0 && n <= c_int::MAX as usize)
        .ok_or_else(|| format!("{cols}x{rows} samples are too many for one JPEG frame"))?;
    // SAFETY: tj3Init has no preconditions; a null handle is checked.
    let raw = unsafe { tj::tj3Init(tj::TJINIT_TJINIT_DECOMPRESS as c_int) };
    if raw.is_null() {
        return Err("libjpeg-turbo could not start a decompressor".into());
    }
    let handle = Handle(raw);
    handle.set(tj::TJPARAM_TJPARAM_STOPONWARNING, 1)?;
    handle.set(tj::TJPARAM_TJPARAM_MAXPIXELS, pixels as c_int)?;
    // SAFETY: the stream pointer and length describe a live slice.
    if unsafe { tj::tj3DecompressHeader(handle.0, stream.as_ptr(), stream.len() as tj::size_t) }
        != 0
    {
        return Err(handle.error());
    }
    let (width, height) = (
        handle.get(tj::TJPARAM_TJPARAM_JPEGWIDTH),
        handle.get(tj::TJPARAM_TJPARAM_JPEGHEIGHT),
    );
    if (width as usize, height as usize) != (cols, rows) {
        return Err(format!(
            "the JPEG stream is {width}x{height} samples, the header says {cols}x{rows}"
        ));
    }
    let (src, len, gray) = (
        stream.as_ptr(),
        stream.len() as tj::size_t,
        tj::TJPF_TJPF_GRAY as c_int,
    );
    // SAFETY (both calls): the destination holds width × height samples of one channel
    // (TJPF_GRAY, pitch 0 = unpadded rows) of the precision's type, which is what the call writes.
    match handle.get(tj::TJPARAM_TJPARAM_PRECISION) {
        12 => handle
            .decompress(pixels, |dst: *mut i16| unsafe {
                tj::tj3Decompress12(handle.0, src, len, dst, 0, gray)
            })
            .map(|samples| samples.iter().flat_map(|s| s.to_le_bytes()).collect()),
        8 => handle
            .decompress(pixels, |dst: *mut u8| unsafe {
                tj::tj3Decompress8(handle.0, src, len, dst, 0, gray)
            })
            .map(|samples| {
                samples
                    .iter()
                    .flat_map(|&s| u16::from(s).to_le_bytes())
                    .collect()
            }),
        other => Err(format!(
            "JPEG sample precision {other} is not 8 or 12 (lossy JPEG)"
        )),
    }
}

/// The bytes of frame `index` of an encapsulated pixel data sequence of `frames` frames (PS3.5
/// A.4): one fragment per frame when the counts agree (or a single frame), else the fragments
/// from the frame's Basic Offset Table entry up to the next frame's.
pub(super) fn frame_stream(
    fragments: &[Vec<u8>],
    offset_table: &[u32],
    frames: usize,
    index: usize,
) -> Result<Vec<u8>, String> {
    if frames == 1 {
        return Ok(fragments.concat());
    }
    if fragments.len() == frames {
        return Ok(fragments[index].clone());
    }
    let start = *offset_table.get(index).ok_or_else(|| {
        format!(
            "the Basic Offset Table has no entry for frame {}",
            index + 1
        )
    })? as usize;
    let end = offset_table.get(index + 1).map(|&o| o as usize);
    // Offsets count each fragment's 8-byte item header.
    let (mut at, mut out) = (0usize, Vec::new());
    for fragment in fragments {
        if at >= start && end.is_none_or(|e| at < e) {
            out.extend_from_slice(fragment);
        }
        at += fragment.len() + 8;
    }
    if out.is_empty() {
        return Err(format!(
            "no fragment starts at frame {}'s offset",
            index + 1
        ));
    }
    Ok(out)
}

//! Image outputs of the renderers and environment maps as their input.
//!
//! * PNG (8-bit RGB or RGBA, via the `png` crate).
//! * NumPy `.npy` version 1.0 arrays (the format of numpy's `lib.format`): little-endian float32
//!   `H×W` (depth) and `H×W×3` (normals), uint32 `H×W` (cluster ids), C order, rows from the top.
//! * Equirectangular environment maps from Radiance `.hdr` or OpenEXR `.exr` (via `image`).
//!
//! Every writer goes through [`isogrid::fs::stage`]: `write_*` writes and commits at once, `stage_*`
//! leaves the commit to the caller, who commits once every output of a command is staged.

use isogrid::fs::{stage, Staged};
use isogrid::EnvMap;
use isogrid::{Error, Result};
use std::path::Path;

/// Writes an 8-bit PNG of `width × height` pixels with `channels` (3 = RGB, 4 = RGBA) bytes each.
pub fn write_png(path: &Path, width: u32, height: u32, channels: u8, pixels: &[u8]) -> Result<()> {
    stage_png(path, width, height, channels, pixels)?.commit()
}

/// [`write_png`] staged, not yet committed.
pub fn stage_png(
    path: &Path,
    width: u32,
    height: u32,
    channels: u8,
    pixels: &[u8],
) -> Result<Staged> {
    let color = match channels {
        3 => png::ColorType::Rgb,
        4 => png::ColorType::Rgba,
        _ => return Err(Error::invalid("PNG needs 3 or 4 channels").with_path(path)),
    };
    if pixels.len() as u64 != width as u64 * height as u64 * channels as u64
        || width == 0
        || height == 0
    {
        return Err(Error::invalid(format!(
            "{} bytes are not a {width}x{height} image with {channels} channels",
            pixels.len()
        ))
        .with_path(path));
    }
    stage(path, |out| {
        let mut encoder = png::Encoder::new(out, width, height);
        encoder.set_color(color);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder
            .write_header()
            .map_err(|e| Error::invalid(format!("PNG: {e}")))?;
        writer
            .write_image_data(pixels)
            .map_err(|e| Error::invalid(format!("PNG: {e}")))?;
        writer
            .finish()
            .map_err(|e| Error::invalid(format!("PNG: {e}")))?;
        Ok(())
    })
}

/// Element types the `.npy` writer knows.
pub trait NpyElement: Copy {
    /// numpy dtype descriptor, e.g. `<f4`.
    const DESCR: &'static str;
    fn write_le(self, out: &mut Vec<u8>);
}
impl NpyElement for f32 {
    const DESCR: &'static str = "<f4";
    fn write_le(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}
impl NpyElement for u32 {
    const DESCR: &'static str = "<u4";
    fn write_le(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}
impl NpyElement for u64 {
    const DESCR: &'static str = "<u8";
    fn write_le(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

/// The `.npy` 1.0 header for a C-order array of `shape`, padded so the data starts at a multiple
/// of 64 bytes.
fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// Writes `data` (C order) as a `.npy` array of `shape`.
pub fn write_npy<T: NpyElement>(path: &Path, shape: &[usize], data: &[T]) -> Result<()> {
    stage_npy(path, shape, data)?.commit()
}

/// [`write_npy`] staged, not yet committed.
pub fn stage_npy<T: NpyElement>(path: &Path, shape: &[usize], data: &[T]) -> Result<Staged> {
    if shape.iter().product::<usize>() != data.len() {
        return Err(Error::invalid(format!(
            "{} values do not fill an array of shape {shape:?}",
            data.len()
        ))
        .with_path(path));
    }
    stage(path, |out| {
        out.write_all(&npy_header(T::DESCR, shape))?;
        let mut buf = Vec::with_capacity(1 << 16);
        for chunk in data.chunks(1 << 14) {
            buf.clear();
            for &v in chunk {
                v.write_le(&mut buf);
            }
            out.write_all(&buf)?;
        }
        Ok(())
    })
}

/// float32 `height × width` (e.g. a depth buffer).
pub fn write_npy_f32_hw(path: &Path, width: u32, height: u32, data: &[f32]) -> Result<()> {
    stage_npy_f32_hw(path, width, height, data)?.commit()
}

/// float32 `height × width × 3` (e.g. normals).
pub fn write_npy_f32_hw3(path: &Path, width: u32, height: u32, data: &[[f32; 3]]) -> Result<()> {
    stage_npy_f32_hw3(path, width, height, data)?.commit()
}

/// uint32 `height × width` (e.g. cluster ids).
pub fn write_npy_u32_hw(path: &Path, width: u32, height: u32, data: &[u32]) -> Result<()> {
    stage_npy_u32_hw(path, width, height, data)?.commit()
}

/// float32 `height × width` (e.g. a depth buffer), staged.
pub fn stage_npy_f32_hw(path: &Path, width: u32, height: u32, data: &[f32]) -> Result<Staged> {
    stage_npy(path, &[height as usize, width as usize], data)
}

/// float32 `height × width × 3` (e.g. normals), staged.
pub fn stage_npy_f32_hw3(
    path: &Path,
    width: u32,
    height: u32,
    data: &[[f32; 3]],
) -> Result<Staged> {
    stage_npy(
        path,
        &[height as usize, width as usize, 3],
        data.as_flattened(),
    )
}

/// uint32 `height × width` (e.g. cluster ids), staged.
pub fn stage_npy_u32_hw(path: &Path, width: u32, height: u32, data: &[u32]) -> Result<Staged> {
    stage_npy(path, &[height as usize, width as usize], data)
}

/// Largest environment map accepted, in texels (16K × 8K).
pub const MAX_ENV_TEXELS: u64 = 1 << 27;

/// Reads an equirectangular environment map (`.hdr` or `.exr`, linear radiance) for the path
/// tracer; errors name `path`.
pub fn read_env_map(path: &Path) -> Result<EnvMap> {
    let format = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("hdr") => ::image::ImageFormat::Hdr,
        Some("exr") => ::image::ImageFormat::OpenExr,
        _ => {
            return Err(Error::unsupported(
                "environment maps must be .hdr (Radiance) or .exr (OpenEXR)",
            )
            .with_path(path))
        }
    };
    let file = isogrid::fs::open_regular(path)?;
    let mut reader = ::image::ImageReader::with_format(std::io::BufReader::new(file), format);
    let mut limits = ::image::Limits::default();
    limits.max_alloc = Some(MAX_ENV_TEXELS * 16);
    limits.max_image_width = Some(1 << 15);
    limits.max_image_height = Some(1 << 15);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| {
        Error::corrupt(format!("cannot decode environment map: {e}")).with_path(path)
    })?;
    let rgb = decoded.into_rgb32f();
    let (w, h) = rgb.dimensions();
    let texels = rgb
        .pixels()
        .map(|p| p.0.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 }))
        .collect();
    EnvMap::new(w, h, texels).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_describes_the_array() {
        let h = npy_header("<f4", &[3, 5, 3]);
        assert_eq!(h.len() % 64, 0);
        assert_eq!(&h[..8], b"\x93NUMPY\x01\x00");
        let text = std::str::from_utf8(&h[10..]).unwrap();
        assert!(text.starts_with("{'descr': '<f4', 'fortran_order': False, 'shape': (3, 5, 3), }"));
        assert!(text.ends_with('\n'));
        assert_eq!(u16::from_le_bytes([h[8], h[9]]) as usize, h.len() - 10);
    }

    #[test]
    fn png_and_npy_round_trip() {
        let dir = std::env::temp_dir().join(format!("isogrid-io-image-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png_path = dir.join("a.png");
        let pixels: Vec<u8> = (0..2 * 3 * 3).map(|i| (i * 13) as u8).collect();
        write_png(&png_path, 2, 3, 3, &pixels).unwrap();
        let decoder = png::Decoder::new(std::io::BufReader::new(
            std::fs::File::open(&png_path).unwrap(),
        ));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (2, 3));
        assert_eq!(&buf[..info.buffer_size()], &pixels[..]);
        assert!(write_png(&png_path, 2, 2, 3, &pixels).is_err());

        let npy_path = dir.join("d.npy");
        write_npy_u32_hw(&npy_path, 3, 2, &[1, 2, 3, 4, 5, u32::MAX]).unwrap();
        let bytes = std::fs::read(&npy_path).unwrap();
        let data = 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((data % 64, bytes.len()), (0, data + 24));
        assert_eq!(&bytes[data..data + 4], &1u32.to_le_bytes());
        assert_eq!(&bytes[data + 20..], &u32::MAX.to_le_bytes());
        assert!(write_npy_f32_hw(&npy_path, 3, 3, &[0.0; 6]).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn env_maps_read_back_from_hdr_and_exr() {
        let dir = std::env::temp_dir().join(format!("isogrid-io-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = ::image::Rgb32FImage::new(4, 2);
        for (i, p) in img.pixels_mut().enumerate() {
            *p = ::image::Rgb([i as f32 * 0.5, 1.0, 2.0]);
        }
        for (name, format) in [
            ("e.hdr", ::image::ImageFormat::Hdr),
            ("e.exr", ::image::ImageFormat::OpenExr),
        ] {
            let path = dir.join(name);
            img.save_with_format(&path, format).unwrap();
            let map = read_env_map(&path).unwrap();
            assert_eq!((map.width(), map.height()), (4, 2));
            // Rows from the top, columns left to right: texel 2's centre direction reads texel 2.
            let v = map.radiance(isogrid::EnvMap::texel_direction(4, 2, 2, 0));
            assert!(
                (v[0] - 1.0).abs() < 0.02 && (v[2] - 2.0).abs() < 0.05,
                "{name}: {v:?}"
            );
        }
        std::fs::write(dir.join("bad.hdr"), b"not an hdr").unwrap();
        let err = read_env_map(&dir.join("bad.hdr")).unwrap_err().to_string();
        assert!(err.contains("bad.hdr") && !err.contains('\n'), "{err}");
        assert!(read_env_map(&dir.join("x.png")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! Screenshots as 8-bit RGB PNG files (written atomically with `isogrid::fs::write_atomic`), and
//! the next free `isogrid-view-NNN.png` name for the S key.

use isogrid::{Error, ResultExt};
use std::path::{Path, PathBuf};

/// Writes `width × height` pixels of sRGB `rgb` (3 bytes per pixel, rows from the top) to `path`.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> isogrid::Result<()> {
    if rgb.len() != width as usize * height as usize * 3 {
        return Err(Error::invalid(format!(
            "screenshot has {} bytes, not {width}x{height}x3",
            rgb.len()
        ))
        .with_path(path));
    }
    isogrid::fs::write_atomic(path, |w| {
        let mut encoder = png::Encoder::new(w, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder
            .write_header()
            .map_err(|e| Error::invalid(format!("PNG header: {e}")))?;
        writer
            .write_image_data(rgb)
            .map_err(|e| Error::invalid(format!("PNG data: {e}")))?;
        writer
            .finish()
            .map_err(|e| Error::invalid(format!("PNG end: {e}")))
    })
    .at_path(path)
}

/// Drops the alpha of RGBA pixels. egui's window pixels are premultiplied, so this is the image
/// over black; the viewer's window is opaque wherever it draws.
pub fn rgba_to_rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// `dir/isogrid-view-NNN.png` with the smallest NNN not taken yet.
pub fn next_free_name(dir: &Path) -> PathBuf {
    (1..)
        .map(|n| dir.join(format!("isogrid-view-{n:03}.png")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| dir.join("isogrid-view.png"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trips_through_the_decoder() {
        let dir = std::env::temp_dir().join(format!("isogrid-viewer-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = next_free_name(&dir);
        let rgb: Vec<u8> = (0..5 * 3 * 3).map(|i| (i * 7) as u8).collect();
        write_png(&path, 5, 3, &rgb).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (5, 3));
        assert_eq!(&buf[..info.buffer_size()], &rgb[..]);
        assert_ne!(next_free_name(&dir), path);
        assert!(write_png(&path, 5, 4, &rgb).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

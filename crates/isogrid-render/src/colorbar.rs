//! A labelled colour bar drawn into a finished image (`isogrid render --colorbar`): the colour
//! table of a [`Coloring`] as a vertical gradient at the image's right edge, low values at the
//! bottom, with the low, middle and high values of its range written beside it
//! (`embedded-graphics`' built-in 6×10 font, so no font file is needed).
//!
//! Coordinates are pixels of the image, row 0 at the top.

use embedded_graphics::mono_font::ascii::FONT_6X10;
use embedded_graphics::mono_font::MonoTextStyle;
use embedded_graphics::pixelcolor::Rgb888;
use embedded_graphics::prelude::*;
use embedded_graphics::text::{Alignment, Baseline, Text, TextStyleBuilder};
use isogrid::colormap::{Coloring, TABLE_SIZE};
use isogrid::{Error, Result};

/// Bar width and the margin between it and the image's right edge, pixels.
const BAR_WIDTH: u32 = 14;
const MARGIN: u32 = 10;
/// Width kept for the labels left of the bar: ten 6-pixel characters and a gap.
const LABEL_WIDTH: u32 = 64;
/// The smallest image a bar and its labels fit: the labels need three text rows.
pub const MIN_SIZE: (u32, u32) = (LABEL_WIDTH + BAR_WIDTH + 2 * MARGIN, 60);

/// Where the bar of a `width × height` image lies: (left column, top row, bottom row), the
/// bottom row showing the range's low end.
pub fn bar_box(width: u32, height: u32) -> (u32, u32, u32) {
    let left = width - MARGIN - BAR_WIDTH;
    let top = height / 5;
    (left, top, height - 1 - height / 5)
}

/// The table entry row `y` of the bar shows (rows `top..=bottom` of [`bar_box`]).
pub fn entry_of_row(top: u32, bottom: u32, y: u32) -> usize {
    let t = (bottom - y) as f64 / (bottom - top) as f64;
    (t * (TABLE_SIZE - 1) as f64).round() as usize
}

/// An sRGB image to draw on (row-major, 3 bytes per pixel).
struct Canvas<'a> {
    rgb8: &'a mut [u8],
    width: u32,
    height: u32,
}

impl OriginDimensions for Canvas<'_> {
    fn size(&self) -> Size {
        Size::new(self.width, self.height)
    }
}

impl DrawTarget for Canvas<'_> {
    type Color = Rgb888;
    type Error = std::convert::Infallible;
    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb888>>>(
        &mut self,
        pixels: I,
    ) -> Result<(), Self::Error> {
        for Pixel(p, c) in pixels {
            if p.x >= 0 && p.y >= 0 && (p.x as u32) < self.width && (p.y as u32) < self.height {
                let at = 3 * (p.x as usize + self.width as usize * p.y as usize);
                self.rgb8[at..at + 3].copy_from_slice(&[c.r(), c.g(), c.b()]);
            }
        }
        Ok(())
    }
}

/// Draws the bar of `coloring` and its labels into the `width × height` sRGB image `rgb8`. Fails
/// when the image is smaller than [`MIN_SIZE`].
pub fn draw(rgb8: &mut [u8], width: u32, height: u32, coloring: &Coloring) -> Result<()> {
    if width < MIN_SIZE.0 || height < MIN_SIZE.1 {
        return Err(Error::invalid(format!(
            "a colour bar needs an image of at least {}x{} pixels, not {width}x{height}",
            MIN_SIZE.0, MIN_SIZE.1
        )));
    }
    let (left, top, bottom) = bar_box(width, height);
    let table = coloring.table();
    let mut canvas = Canvas {
        rgb8,
        width,
        height,
    };
    let white = Rgb888::new(255, 255, 255);
    // A one-pixel frame, then each row the table entry it shows.
    let frame = (left - 1..left + BAR_WIDTH + 1).flat_map(|x| [(x, top - 1), (x, bottom + 1)]);
    let sides = (top - 1..=bottom + 1).flat_map(|y| [(left - 1, y), (left + BAR_WIDTH, y)]);
    let _ = canvas.draw_iter(
        frame
            .chain(sides)
            .map(|(x, y)| Pixel(Point::new(x as i32, y as i32), white)),
    );
    for y in top..=bottom {
        let [r, g, b] = table[entry_of_row(top, bottom, y)];
        let _ = canvas.draw_iter(
            (left..left + BAR_WIDTH)
                .map(|x| Pixel(Point::new(x as i32, y as i32), Rgb888::new(r, g, b))),
        );
    }
    let font = MonoTextStyle::new(&FONT_6X10, white);
    let right = TextStyleBuilder::new()
        .alignment(Alignment::Right)
        .baseline(Baseline::Middle)
        .build();
    let [lo, mid, hi] = coloring.bar_labels();
    for (text, y) in [(hi, top), (mid, (top + bottom) / 2), (lo, bottom)] {
        let at = Point::new(left as i32 - 4, y as i32);
        let _ = Text::with_text_style(&text, at, font, right).draw(&mut canvas);
    }
    Ok(())
}

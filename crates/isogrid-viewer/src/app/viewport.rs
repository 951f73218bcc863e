//! The image area: where the frame sits (one texel per pixel where possible), and what it shows
//! instead before the first frame or when the input cannot be opened or drawn.

use super::state::App;
use eframe::egui;

impl App {
    /// The image area: mouse interaction and the frame texture.
    pub(super) fn viewport(&mut self, ui: &mut egui::Ui, full_size: [u32; 2]) {
        let area = ui.available_rect_before_wrap();
        let response = ui.interact(
            area,
            ui.scope_id().with("view"),
            egui::Sense::click_and_drag(),
        );
        let ppp = ui.ctx().pixels_per_point();
        let rect = image_rect(area, full_size, self.options.size.is_some(), ppp);
        self.image_rect_px = Some(egui::Rect::from_min_max(
            (rect.min.to_vec2() * ppp).to_pos2(),
            (rect.max.to_vec2() * ppp).to_pos2(),
        ));

        self.orbit_with_pointer(ui, &response, rect);
        let hover = response.hover_pos();
        self.color.under_cursor = hover.and_then(|pos| self.value_at(pos, rect));
        self.labels.under_cursor = hover
            .and_then(|pos| self.pixel_at(pos, rect))
            .and_then(|(x, y)| self.labels.at_pixel(x, y));
        // A click (not a drag) names the label there; off the surface it clears.
        if response.clicked() && self.labels.list.is_some() {
            self.labels.picked = self.labels.under_cursor;
        }
        // The label's value and name beside the pointer, while it rests on the surface.
        if let (Some(value), Some(list), false) = (
            self.labels.under_cursor,
            &self.labels.list,
            response.dragged(),
        ) {
            if let Some(i) = list.find(value) {
                let text = format!("{} {}", list.value_text(i), list.labels().table()[i].name);
                response.clone().on_hover_text_at_pointer(text);
            }
        }

        let painter = ui.painter_at(area);
        painter.rect_filled(area, 0.0, background());
        if let Some(texture) = &self.texture {
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            painter.image(texture.id(), rect, uv, egui::Color32::WHITE);
        } else {
            let error = self.renderer_error.as_ref().or(self.open_error.as_ref());
            let text = if let Some(e) = error {
                e.clone()
            } else if self.source.is_none() && self.busy.is_none() {
                "Drop a volume or .cgc file here, or type its path on the left".to_string()
            } else if let Some(task) = &self.busy {
                match task.fraction() {
                    Some(f) => format!("{}… {:.0}%", task.what, f * 100.0),
                    None => format!("{}…", task.what),
                }
            } else {
                "waiting for the first frame…".to_string()
            };
            let colour = match error {
                Some(_) => ui.visuals().error_fg_color,
                None => ui.visuals().text_color(),
            };
            // Wrapped, because an error names a path of any length.
            let galley = painter.layout(
                text,
                egui::FontId::proportional(16.0),
                colour,
                (area.width() - 32.0).max(64.0),
            );
            let corner = area.center() - galley.size() * 0.5;
            painter.galley(corner, galley, colour);
        }
    }

    /// The attribute value of the frame on screen at `pos` (points) in the image `rect`; `None`
    /// off the image or off the surface.
    fn value_at(&self, pos: egui::Pos2, rect: egui::Rect) -> Option<f32> {
        let (width, values) = self.shown_values.as_ref()?;
        let (x, y) = self.pixel_at(pos, rect)?;
        *values.get((x + width * y) as usize)?
    }

    /// The pixel of the frame on screen at `pos` (points) in the image `rect`; `None` off the
    /// image.
    fn pixel_at(&self, pos: egui::Pos2, rect: egui::Rect) -> Option<(u32, u32)> {
        let (width, height, _) = self.shown_pixels.as_ref()?;
        pixel_of(pos, rect, [*width, *height])
    }

    /// Render size in pixels: fixed, or the image area of the last frame.
    pub(super) fn full_size(&self, ctx: &egui::Context) -> [u32; 2] {
        if let Some(size) = self.options.size {
            return size;
        }
        let ppp = ctx.pixels_per_point();
        let area: Option<egui::Rect> =
            ctx.data(|d| d.get_temp(egui::Id::unique("isogrid-view-area")));
        match area {
            Some(a) => [
                ((a.width() * ppp).floor() as u32).clamp(1, 4096),
                ((a.height() * ppp).floor() as u32).clamp(1, 4096),
            ],
            None => [640, 480],
        }
    }
}

/// The pixel of a `size` image shown in `rect` that `pos` (both in points) falls on; `None` off
/// the image.
fn pixel_of(pos: egui::Pos2, rect: egui::Rect, [width, height]: [u32; 2]) -> Option<(u32, u32)> {
    if !rect.contains(pos) || width == 0 || height == 0 {
        return None;
    }
    let u = (pos - rect.min) / rect.size();
    let x = ((u.x * width as f32) as u32).min(width - 1);
    let y = ((u.y * height as f32) as u32).min(height - 1);
    Some((x, y))
}

/// The renderer's background, so that the image blends with the area around it.
fn background() -> egui::Color32 {
    let [r, g, b] = isogrid::shading::BACKGROUND_SRGB;
    egui::Color32::from_rgb(r, g, b)
}

/// Where the image goes in `area` (points): at one texel per pixel for a fixed render size when
/// it fits (scaled down to fit otherwise), centred, with its corner on the pixel grid.
fn image_rect(area: egui::Rect, size: [u32; 2], fixed: bool, ppp: f32) -> egui::Rect {
    if !fixed {
        // The render size is the area's size floored to whole pixels: show it texel for pixel.
        let min = (area.min.to_vec2() * ppp).round() / ppp;
        let size = egui::vec2(size[0] as f32, size[1] as f32) / ppp;
        return egui::Rect::from_min_size(min.to_pos2(), size);
    }
    let natural = egui::vec2(size[0] as f32, size[1] as f32) / ppp;
    let scale = (area.width() / natural.x)
        .min(area.height() / natural.y)
        .min(1.0);
    let shown = natural * scale;
    let min = area.center() - shown * 0.5;
    let min = (min.to_vec2() * ppp).round() / ppp;
    egui::Rect::from_min_size(min.to_pos2(), shown)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pointer's pixel and the label named there: a frame's label AOV is row-major from the
    /// top-left, and an image scaled down to fit still maps each point to the pixel under it.
    #[test]
    fn the_pointer_names_the_label_of_the_pixel_under_it() {
        use super::super::state::LabelState;
        let (w, h) = (40u32, 30u32);
        // Each pixel's label: its own index; a miss in the top-left corner.
        let mut aov: Vec<u64> = (0..(w * h) as u64).collect();
        aov[0] = u64::MAX;
        let labels = LabelState {
            frame_labels: Some((w, aov)),
            ..Default::default()
        };
        // Shown at half size, from (100, 50).
        let rect = egui::Rect::from_min_size(egui::pos2(100.0, 50.0), egui::vec2(20.0, 15.0));
        for (x, y) in [(0, 0), (39, 0), (0, 29), (17, 11), (39, 29)] {
            let centre = rect.min + egui::vec2(x as f32 + 0.5, y as f32 + 0.5) * 0.5;
            assert_eq!(pixel_of(centre, rect, [w, h]), Some((x, y)));
            let named = labels.at_pixel(x, y);
            let expected = (x + w * y) as u64;
            assert_eq!(named, (expected != 0).then_some(expected), "pixel {x},{y}");
        }
        assert_eq!(pixel_of(egui::pos2(99.0, 60.0), rect, [w, h]), None);
        assert_eq!(pixel_of(egui::pos2(121.0, 60.0), rect, [w, h]), None);
    }

    #[test]
    fn fixed_images_sit_on_the_pixel_grid_at_one_texel_per_pixel() {
        let area = egui::Rect::from_min_size(egui::pos2(300.5, 0.0), egui::vec2(700.0, 600.0));
        let r = image_rect(area, [320, 240], true, 1.0);
        assert_eq!(r.size(), egui::vec2(320.0, 240.0));
        assert_eq!(r.min.x, r.min.x.round());
        assert!(area.contains_rect(r));
        // Too big: scaled down to fit, aspect kept.
        let r = image_rect(area, [1400, 600], true, 1.0);
        assert!((r.width() / r.height() - 1400.0 / 600.0).abs() < 1e-3);
        assert!(r.width() <= 700.0 + 1e-3);
    }
}

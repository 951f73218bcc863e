//! The left panel: input path, isovalue and precision, mode switch, views, screenshots, status
//! and messages.

use super::state::{App, PANEL_WIDTH};
use crate::panel;
use crate::screenshot;
use crate::Mode;
use eframe::egui;
use isogrid::colormap::{check_clim, ColorMap, Coloring};
use isogrid::{Iso, Precision};
use std::path::PathBuf;

impl App {
    pub(super) fn controls(&mut self, ui: &mut egui::Ui, ctx: &egui::Context, full_size: [u32; 2]) {
        ui.heading("isogrid view");
        ui.add_space(4.0);

        ui.label("Input (or drop a file on the window)");
        ui.horizontal(|ui| {
            let field = ui.add(
                egui::TextEdit::singleline(&mut self.path_text)
                    .desired_width(PANEL_WIDTH - 70.0)
                    .hint_text("volume or .cgc path"),
            );
            let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Open").clicked() || enter) && !self.path_text.trim().is_empty() {
                let path = PathBuf::from(self.path_text.trim());
                let iso = self.current_normalized_iso();
                self.open(path, Default::default(), iso);
            }
        });
        if let Some(s) = &self.source {
            ui.label(
                egui::RichText::new(format!(
                    "{}×{}×{} {} samples",
                    s.dims[0],
                    s.dims[1],
                    s.dims[2],
                    s.scalar_type.name()
                ))
                .small(),
            );
        }
        ui.separator();

        self.iso_controls(ui);
        ui.separator();

        ui.label("Mode");
        let has_volume = self.source.as_ref().is_none_or(|s| s.has_volume());
        ui.horizontal_wrapped(|ui| {
            for mode in Mode::ALL {
                let label_grid = self.labels.list.is_some();
                let reason = match mode {
                    Mode::Cr if label_grid => Some(super::CR_OF_LABELS),
                    Mode::Mc if label_grid => None,
                    _ if mode.needs_volume() && !has_volume => Some(super::NEEDS_VOLUME),
                    _ => None,
                };
                let button = egui::Button::selectable(self.mode == mode, mode.name());
                let response = ui.add_enabled(reason.is_none(), button);
                let response = match reason {
                    Some(r) => response.on_disabled_hover_text(r),
                    None => response,
                };
                if response.clicked() && self.mode != mode {
                    self.mode = mode;
                    let mesh = self.wants_mesh();
                    self.extractor.update(|w| w.mesh = mesh);
                }
            }
        });
        if self.mode == Mode::Mc && self.measurements.mesh.is_none() {
            ui.label("Marching Cubes mesh: extracting…");
        }
        let label_grid = self.labels.list.is_some();
        let compare = ui
            .add_enabled(
                has_volume || label_grid,
                egui::Checkbox::new(&mut self.compare_mc, "extract MC too (memory comparison)"),
            )
            .on_hover_text("Runs Marching Cubes in the background after each extraction")
            .on_disabled_hover_text("needs the original volume");
        if compare.changed() {
            let mesh = self.wants_mesh();
            self.extractor.update(|w| w.mesh = mesh);
            self.ask_for_label_meshes();
        }
        self.color_controls(ui);
        self.label_controls(ui);
        self.frame_clicked_label(full_size);
        ui.separator();

        ui.label("View (drag: orbit, right/middle drag: pan, wheel: zoom)");
        ui.horizontal(|ui| {
            if ui.button("1 front").on_hover_text("key 1").clicked() {
                self.set_view(1, full_size);
            }
            if ui.button("2 oblique").on_hover_text("key 2").clicked() {
                self.set_view(2, full_size);
            }
            if ui.button("Reset").on_hover_text("key R").clicked() {
                self.set_view(self.options.view, full_size);
            }
        });
        ui.horizontal(|ui| {
            if ui
                .button("Screenshot")
                .on_hover_text("key S: the whole window")
                .clicked()
            {
                self.request_capture(ctx, None);
            }
            if ui
                .button("Save render")
                .on_hover_text("the rendered image alone")
                .clicked()
            {
                let path = screenshot::next_free_name(&std::env::current_dir().unwrap_or_default());
                self.save_render(path);
            }
        });
        ui.separator();

        ui.horizontal(|ui| {
            if let Some(task) = &self.busy {
                match task.fraction() {
                    Some(f) => {
                        let bar = egui::ProgressBar::new(f)
                            .desired_width(PANEL_WIDTH - 24.0)
                            .text(format!("{} {:.0}%", task.what, f * 100.0));
                        ui.add(bar);
                    }
                    None => {
                        ui.spinner();
                        ui.label(&task.what);
                    }
                }
            } else if self.in_flight.is_some() {
                ui.spinner();
                ui.label("rendering");
            } else {
                ui.label("idle");
            }
        });
        ui.checkbox(&mut self.full_when_idle, "full resolution when idle")
            .on_hover_text(
                "Off: stay at the preview resolution (about 0.5 s per frame); \
                 useful on CPU adapters, where large images take seconds",
            );
        if !self.messages.is_empty() {
            ui.separator();
            for m in self.messages.iter().rev() {
                let text = egui::RichText::new(&m.text).small();
                ui.label(if m.error {
                    text.color(ui.visuals().error_fg_color)
                } else {
                    text
                });
            }
            if ui.small_button("clear messages").clicked() {
                self.messages.clear();
            }
        }
    }

    /// Colour by the grid's attribute: on/off, map, range (auto follows the surface), the colour
    /// bar and the value under the pointer.
    fn color_controls(&mut self, ui: &mut egui::Ui) {
        let Some(info) = self.color.attribute.clone() else {
            return;
        };
        ui.separator();
        ui.checkbox(&mut self.color.on, format!("Colour by {:?}", info.name));
        if !self.color.on {
            return;
        }
        egui::ComboBox::from_label("colour map")
            .selected_text(self.color.map.name())
            .show_ui(ui, |ui| {
                for map in ColorMap::ALL {
                    ui.selectable_value(&mut self.color.map, map, map.name());
                }
            });
        let Some([lo, hi]) = self.color.effective_clim() else {
            return;
        };
        let (mut new_lo, mut new_hi) = (lo, hi);
        let speed = (hi - lo) / 200.0;
        ui.horizontal(|ui| {
            ui.label("range");
            let changed = ui
                .add(egui::DragValue::new(&mut new_lo).speed(speed))
                .changed()
                | ui.add(egui::DragValue::new(&mut new_hi).speed(speed))
                    .changed();
            if changed && check_clim([new_lo, new_hi]).is_ok() {
                self.color.clim = Some([new_lo, new_hi]);
            }
            if ui
                .selectable_label(self.color.clim.is_none(), "auto")
                .on_hover_text("the attribute's range on the surface")
                .clicked()
            {
                self.color.clim = None;
            }
        });
        if let Ok(coloring) = Coloring::new(self.color.map, [lo, hi]) {
            color_bar(ui, &coloring);
        }
        let under = match self.color.under_cursor {
            Some(v) if v.is_nan() => "NaN".to_string(),
            Some(v) => panel::fmt_value(v as f64),
            None => "–".to_string(),
        };
        ui.label(format!("value under the pointer: {under}"));
    }

    fn iso_controls(&mut self, ui: &mut egui::Ui) {
        let Some(source) = &self.source else {
            ui.label("Isovalue: open a volume first");
            return;
        };
        if self.labels.list.is_some() {
            ui.label(
                egui::RichText::new(
                    "A label grid: each label's surface at ½ of its indicator; no isovalue \
                     applies.",
                )
                .small(),
            );
            return;
        }
        if let Some(grid) = &source.grid_info {
            ui.label(format!(
                "Isovalue {} ({}-bit corners)",
                panel::fmt_value(grid.iso),
                grid.precision.bits()
            ));
            ui.label(
                egui::RichText::new(
                    "A .cgc file holds one extracted isosurface and no volume: open the volume \
                     to change the isovalue or precision.",
                )
                .small(),
            );
            return;
        }
        let Some((lo, hi)) = source.value_range else {
            ui.label("Isovalue: the volume has no finite sample");
            return;
        };
        ui.label("Isovalue (data units)");
        let slider = egui::Slider::new(&mut self.iso_value, lo..=hi.max(lo))
            .clamping(egui::SliderClamping::Never);
        if ui.add(slider).changed() {
            let iso = self.iso_value;
            self.extractor.update(|w| w.iso = Iso::Value(iso));
        }
        if let Some(t) = self.normalized(self.iso_value) {
            ui.label(format!("normalised {t:.4}"));
        }
        ui.horizontal(|ui| {
            ui.label("Precision");
            let mut changed = false;
            changed |= ui
                .selectable_value(&mut self.precision, None, "auto")
                .on_hover_text("the default for the sample type")
                .changed();
            for p in Precision::ALL {
                changed |= ui
                    .selectable_value(&mut self.precision, Some(p), p.bits().to_string())
                    .changed();
            }
            if changed {
                let p = self.precision;
                self.extractor.update(|w| w.precision = p);
            }
        });
    }
}

/// The colour map's table as a horizontal bar, labelled with its range.
fn color_bar(ui: &mut egui::Ui, coloring: &Coloring) {
    let width = PANEL_WIDTH - 24.0;
    let (rect, _) = ui.allocate_exact_size(egui::vec2(width, 14.0), egui::Sense::hover());
    let table = coloring.table();
    let step = rect.width() / table.len() as f32;
    let painter = ui.painter_at(rect);
    for (i, [r, g, b]) in table.iter().enumerate() {
        let x = rect.left() + i as f32 * step;
        let cell = egui::Rect::from_min_max(
            egui::pos2(x, rect.top()),
            egui::pos2(x + step + 0.5, rect.bottom()),
        );
        painter.rect_filled(cell, 0.0, egui::Color32::from_rgb(*r, *g, *b));
    }
    ui.horizontal(|ui| {
        let [lo, _, hi] = coloring.bar_labels();
        ui.label(egui::RichText::new(lo).small());
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.label(egui::RichText::new(hi).small());
        });
    });
}

//! The label list of a label grid in the panel (docs/design/labels.md, "The viewer"): search by
//! name or value, a colour swatch, value, name, cell count and visibility checkbox per label, show
//! all / hide all / only matches, and the label under the pointer or last clicked. A change of the
//! flags goes to the render worker, which uploads the grid of the shown labels (nothing is
//! extracted again) while the window goes on showing the last frame.

use super::state::{App, PANEL_WIDTH};
use crate::label_list::{LabelList, MAX_ROWS};
use crate::orbit::Orbit;
use crate::render_worker::RenderMsg;
use eframe::egui;
use isogrid::labels::signed_labels;
use isogrid::GridLabels;

impl App {
    /// A grid of input `generation` is shown: list its labels, with the flags of the previous
    /// list of the same input, or else those `--show` / `--hide` choose.
    pub(super) fn on_labels(&mut self, generation: u64, labels: Option<GridLabels>) {
        let Some(labels) = labels else {
            self.labels.list = None;
            let chooses = self.options.show.is_some() || self.options.hide.is_some();
            if chooses && self.options.input == self.source.as_ref().map(|s| s.path.clone()) {
                self.fail_or_note(
                    "--show / --hide choose labels of a label grid, and this grid has none".into(),
                );
            }
            return;
        };
        let signed = self
            .source
            .as_ref()
            .is_some_and(|s| signed_labels(s.scalar_type));
        let mut list = LabelList::new(labels, signed);
        list.search(&self.labels.query);
        match self.labels.list.take() {
            Some(old) => list.keep_flags_of(&old),
            None => {
                let (show, hide) = (self.options.show.clone(), self.options.hide.clone());
                if let Err(e) = list.choose(show.as_ref(), hide.as_ref()) {
                    self.fail_or_note(format!("--show / --hide: {e}"));
                }
            }
        }
        self.labels.list = Some(list);
        // The worker uploaded every label of the new grid.
        if self
            .labels
            .list
            .as_ref()
            .is_some_and(|l| l.shown_count() < l.len())
        {
            self.send_label_choice(generation);
        } else {
            self.ask_for_label_meshes();
        }
    }

    /// With the memory comparison on, asks the render worker for the meshes of the labels it
    /// draws (made once per choice of labels; MC mode makes them itself).
    pub(super) fn ask_for_label_meshes(&mut self) {
        if self.compare_mc && self.labels.list.is_some() {
            let msg = RenderMsg::LabelMesh {
                generation: self.generation,
            };
            let _ = self.render.sender().send(msg);
        }
    }

    /// Tells the render worker which labels to draw; frames asked for from now on show them.
    fn send_label_choice(&mut self, generation: u64) {
        let Some(list) = &self.labels.list else {
            return;
        };
        let msg = RenderMsg::ShowLabels {
            generation,
            shown: list.shown().to_vec(),
        };
        if self.render.sender().send(msg).is_ok() {
            self.labels.version += 1;
        }
        self.ask_for_label_meshes();
    }

    /// Frames the label whose name was clicked, at the current preset view, in a `size` frame.
    pub(super) fn frame_clicked_label(&mut self, size: [u32; 2]) {
        let (Some(i), Some(list), Some(source)) =
            (self.labels.frame.take(), &self.labels.list, &self.source)
        else {
            return;
        };
        let (lo, hi) = list.labels().index()[i].world_box(source.spacing);
        if let Some(orbit) =
            Orbit::preset(self.options.view, lo, hi, size[0], size[1], source.mirrored)
        {
            self.orbit = orbit;
            self.has_view = true;
        }
    }

    /// The label list's panel section.
    pub(super) fn label_controls(&mut self, ui: &mut egui::Ui) {
        let generation = self.generation;
        let state = &mut self.labels;
        let Some(list) = &mut state.list else {
            return;
        };
        ui.separator();
        ui.label(format!(
            "Labels: {} of {} shown",
            list.shown_count(),
            list.len()
        ));
        let mut changed = false;
        ui.horizontal(|ui| {
            if ui.button("show all").clicked() {
                list.set_all(true);
                changed = true;
            }
            if ui.button("hide all").clicked() {
                list.set_all(false);
                changed = true;
            }
            if ui
                .button("only matches")
                .on_hover_text("show the labels the search matches and hide the others")
                .clicked()
            {
                list.show_only_matches();
                changed = true;
            }
        });
        ui.add(
            egui::TextEdit::singleline(&mut state.query)
                .desired_width(PANEL_WIDTH - 24.0)
                .hint_text("search: name, or values such as 5 or 1,5-9"),
        );
        list.search(&state.query);
        let matches = list.matches().len();
        let listed = matches.min(MAX_ROWS);
        ui.label(
            egui::RichText::new(if listed < matches {
                format!("{matches} match; the first {listed} listed")
            } else {
                format!("{matches} match")
            })
            .small(),
        );
        // Always two lines, so that the list below does not jump as the pointer moves.
        for (what, value) in [
            ("under the pointer", state.under_cursor),
            ("clicked", state.picked),
        ] {
            ui.horizontal(|ui| {
                ui.label(format!("{what}:"));
                match value.map(|v| (v, list.find(v))) {
                    Some((_, Some(i))) => changed |= label_row(ui, list, i, &mut state.frame),
                    Some((v, None)) => {
                        ui.label(format!("label {v} (not in the list)"));
                    }
                    None => {
                        ui.label("–");
                    }
                }
            });
        }
        let row_height = ui.text_style_height(&egui::TextStyle::Body) + 4.0;
        egui::ScrollArea::vertical()
            .id_salt("labels")
            .max_height(320.0)
            .auto_shrink([false, true])
            .show_rows(ui, row_height, listed, |ui, rows| {
                for r in rows {
                    let i = list.matches()[r];
                    ui.horizontal(|ui| changed |= label_row(ui, list, i, &mut state.frame));
                }
            });
        if changed {
            self.send_label_choice(generation);
        }
    }
}

/// One label: visibility checkbox, colour swatch, value, name (a click on it sets `frame` to the
/// label, as in the web viewer) and cell count; whether the checkbox changed.
fn label_row(ui: &mut egui::Ui, list: &mut LabelList, i: usize, frame: &mut Option<usize>) -> bool {
    let label = &list.labels().table()[i];
    let [r, g, b, _] = label.rgba;
    let (name, cells) = (label.name.clone(), list.labels().index()[i].cell_count);
    let mut shown = list.shown()[i];
    let changed = ui.checkbox(&mut shown, "").changed();
    if changed {
        list.set_shown(i, shown);
    }
    let (swatch, _) = ui.allocate_exact_size(egui::vec2(14.0, 14.0), egui::Sense::hover());
    ui.painter()
        .rect_filled(swatch, 2.0, egui::Color32::from_rgb(r, g, b));
    ui.label(egui::RichText::new(list.value_text(i)).monospace());
    let clicked = ui
        .add(egui::Label::new(name).sense(egui::Sense::click()))
        .on_hover_text(format!("{cells} active cells; click to frame it"))
        .clicked();
    if clicked && cells > 0 {
        *frame = Some(i);
    }
    ui.label(egui::RichText::new(format!("{cells}")).small().weak());
    changed
}

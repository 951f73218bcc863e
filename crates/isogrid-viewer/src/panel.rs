//! The measurement panel: what the paper reports for a view (Table 3's cells, clusters and
//! memory against the MC mesh, Table 4's per-pass GPU times), formatted for the side panel.

use eframe::egui;
use isogrid::{GridStats, Precision};
use isogrid_gpu::PassTimings;

/// The grid being drawn.
#[derive(Debug, Clone, Copy)]
pub struct GridFacts {
    pub iso: f64,
    pub precision: Precision,
    pub stats: GridStats,
    pub extract_seconds: f64,
}

/// The MC mesh last extracted for this input.
#[derive(Debug, Clone, Copy)]
pub struct MeshFacts {
    pub iso: f64,
    pub triangles: u64,
    pub vertices: u64,
    pub bytes: u64,
    pub seconds: f64,
}

/// The frame on screen.
#[derive(Debug, Clone, Copy)]
pub struct FrameFacts {
    pub width: u32,
    pub height: u32,
    pub timings: PassTimings,
    pub drawn_cells: u64,
    pub probed_cells: u64,
    /// Wall time of the render call, read-back included.
    pub seconds: f64,
}

#[derive(Debug, Clone, Default)]
pub struct Measurements {
    pub adapter: Option<String>,
    pub grid: Option<GridFacts>,
    pub mesh: Option<MeshFacts>,
    pub frame: Option<FrameFacts>,
}

/// Decimal megabytes, as the paper's tables.
pub fn fmt_bytes(bytes: u64) -> String {
    let mb = bytes as f64 / 1e6;
    if mb >= 100.0 {
        format!("{mb:.0} MB")
    } else if mb >= 0.1 {
        format!("{mb:.2} MB")
    } else {
        format!("{:.1} kB", bytes as f64 / 1e3)
    }
}

/// A pass time in milliseconds, "n/a" where the adapter could not measure it.
pub fn fmt_ms(ms: Option<f64>) -> String {
    match ms {
        Some(ms) if ms.is_finite() => format!("{ms:.2} ms"),
        _ => "n/a".to_string(),
    }
}

/// A CPU-side duration: milliseconds, one decimal below 10 ms.
pub fn fmt_seconds(s: f64) -> String {
    let ms = s * 1e3;
    if ms < 10.0 {
        format!("{ms:.1} ms")
    } else {
        format!("{ms:.0} ms")
    }
}

/// A data value with enough digits to tell slider steps apart.
pub fn fmt_value(v: f64) -> String {
    if v != 0.0 && (v.abs() >= 1e5 || v.abs() < 1e-3) {
        format!("{v:.4e}")
    } else {
        format!("{}", (v * 1e4).round() / 1e4)
    }
}

/// Thousands separated by thin spaces, for cell counts.
pub fn fmt_count(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

fn row(ui: &mut egui::Ui, label: &str, value: impl Into<egui::WidgetText>) -> egui::Response {
    let response = ui.label(label) | ui.add(egui::Label::new(value).extend());
    ui.end_row();
    response
}

/// Draws the measurements as a two-column grid.
pub fn show(ui: &mut egui::Ui, m: &Measurements, ui_frame_ms: f64) {
    ui.add(
        egui::Label::new(
            egui::RichText::new(m.adapter.as_deref().unwrap_or("adapter: starting…")).small(),
        )
        .wrap(),
    );
    egui::Grid::new("measurements")
        .num_columns(2)
        .striped(true)
        .show(ui, |ui| {
            match &m.grid {
                Some(g) => {
                    let s = &g.stats;
                    row(ui, "isovalue", fmt_value(g.iso));
                    row(ui, "precision", format!("{} bit", g.precision.bits()));
                    row(ui, "active cells", fmt_count(s.active_cells));
                    row(ui, "clusters", fmt_count(s.clusters));
                    row(ui, "metacell slots", fmt_count(s.metacell_slots));
                    row(ui, "CGC memory", fmt_bytes(s.bytes.paper_total))
                        .on_hover_text("Table 3: metacell slots × 12 B + cell corners");
                    row(ui, "+ blocks", fmt_bytes(s.bytes.blocks));
                    row(ui, "bytes / cell", format!("{:.2}", s.bytes_per_cell()));
                    if g.extract_seconds > 0.0 {
                        row(ui, "extraction", fmt_seconds(g.extract_seconds));
                    }
                }
                None => {
                    row(ui, "cells", "(none yet)");
                }
            }
            match (&m.mesh, &m.grid) {
                (Some(mesh), grid) => {
                    let stale = grid.is_some_and(|g| g.iso.to_bits() != mesh.iso.to_bits());
                    let note = if stale { " (older isovalue)" } else { "" };
                    row(ui, "MC memory", format!("{}{note}", fmt_bytes(mesh.bytes)))
                        .on_hover_text("Table 3: 6 B per vertex (snorm16) + 12 B per triangle");
                    row(ui, "MC triangles", fmt_count(mesh.triangles));
                    row(ui, "MC vertices", fmt_count(mesh.vertices));
                    if let (Some(g), false) = (grid, stale) {
                        let cgc = g.stats.bytes.paper_total as f64;
                        if cgc > 0.0 {
                            row(ui, "MC / CGC", format!("{:.2}×", mesh.bytes as f64 / cgc));
                        }
                    }
                    row(ui, "MC extraction", fmt_seconds(mesh.seconds));
                }
                (None, _) => {
                    row(ui, "MC memory", "n/a");
                }
            }
            match &m.frame {
                Some(f) => {
                    let t = &f.timings;
                    row(ui, "image", format!("{}×{} px", f.width, f.height));
                    row(ui, "GPU raster", fmt_ms(t.raster_ms)).on_hover_text(
                        "Table 4: cell raster (both visibility passes) + EWA, or the MC mesh pass",
                    );
                    row(ui, "GPU EWA", fmt_ms(t.ewa_ms));
                    row(ui, "GPU shade", fmt_ms(t.shade_ms));
                    row(ui, "GPU culling", fmt_ms(t.cull_ms));
                    row(ui, "GPU frame", fmt_ms(t.frame_ms));
                    row(ui, "render call", fmt_seconds(f.seconds))
                        .on_hover_text("Wall time of one render, read-back to the CPU included");
                    row(ui, "drawn cells", fmt_count(f.drawn_cells));
                    row(ui, "probe cells", fmt_count(f.probed_cells));
                }
                None => {
                    row(ui, "GPU times", "n/a");
                }
            }
            row(ui, "UI frame", format!("{ui_frame_ms:.1} ms"));
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(fmt_ms(None), "n/a");
        assert_eq!(fmt_ms(Some(f64::NAN)), "n/a");
        assert_eq!(fmt_ms(Some(1.234)), "1.23 ms");
        assert_eq!(fmt_bytes(12_345_678), "12.35 MB");
        assert_eq!(fmt_bytes(1_500), "1.5 kB");
        assert_eq!(fmt_bytes(250_000_000), "250 MB");
        assert_eq!(fmt_count(1234567), "1\u{2009}234\u{2009}567");
        assert_eq!(fmt_count(12), "12");
        assert_eq!(fmt_value(127.5), "127.5");
        assert_eq!(fmt_value(0.0), "0");
        assert_eq!(fmt_seconds(0.0042), "4.2 ms");
        assert_eq!(fmt_seconds(1.5), "1500 ms");
    }
}

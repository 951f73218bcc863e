//! Applying the extraction and render workers' reports to the window's state: opened inputs,
//! new grids and meshes, finished frames (shown as the texture) and errors.

use super::state::{App, ScriptState};
use crate::events::{Event, Failure, RenderedFrame, SourceInfo};
use crate::panel::{FrameFacts, GridFacts, MeshFacts};
use crate::Mode;
use eframe::egui;
use isogrid::Iso;

impl App {
    pub(super) fn handle_events(&mut self, ctx: &egui::Context, full_size: [u32; 2]) {
        while let Ok(event) = self.events.try_recv() {
            match event {
                Event::RendererReady { adapter } => self.measurements.adapter = Some(adapter),
                Event::Opened { generation, info } if generation == self.generation => {
                    self.on_opened(info, full_size)
                }
                Event::Opened { .. } => {}
                Event::Busy(what) => self.busy = what,
                Event::GridShown {
                    generation,
                    iso,
                    precision,
                    stats,
                    extract_seconds,
                    attribute,
                    labels,
                    empty_note,
                } if generation == self.generation => {
                    if let Some(note) = empty_note {
                        // On stdout too in scripted runs, where tests read it, as the CLI's note.
                        if self.script.is_some() {
                            println!("isogrid view: note: {note}");
                        }
                        self.note(note, false);
                    }
                    self.color.attribute = attribute;
                    self.on_labels(generation, labels);
                    let has_volume = self.source.as_ref().is_none_or(|s| s.has_volume());
                    if self.mode == Mode::Mc && !has_volume && self.labels.list.is_none() {
                        self.fail_or_note(format!("mode mc {}: showing cgc", super::NEEDS_VOLUME));
                        self.mode = Mode::Cgc;
                    }
                    self.measurements.grid = Some(GridFacts {
                        iso,
                        precision,
                        stats,
                        extract_seconds,
                    });
                    self.grid_version += 1;
                }
                Event::MeshShown {
                    generation,
                    iso,
                    triangles,
                    vertices,
                    bytes,
                    seconds,
                } if generation == self.generation => {
                    self.measurements.mesh = Some(MeshFacts {
                        iso,
                        triangles,
                        vertices,
                        bytes,
                        seconds,
                    });
                    self.mesh_version += 1;
                }
                Event::GridShown { .. } | Event::MeshShown { .. } => {}
                Event::Frame(frame) => self.on_frame(ctx, *frame, full_size),
                Event::NotRendered { request } => {
                    if let Some((id, key)) = self.in_flight {
                        if id == request {
                            self.in_flight = None;
                            self.refused = Some(key);
                        }
                    }
                }
                Event::Error { failure, message } => {
                    if failure == Failure::Renderer {
                        self.renderer_error = Some(message.clone());
                    }
                    if failure == Failure::Open {
                        self.on_open_failed(message.clone());
                    }
                    // Not fatal to a scripted run: without a mesh only the memory comparison is
                    // missing (MC mode needs it), and a dropped file's error is what a drop test
                    // expects to see.
                    let shown_only = (failure == Failure::Mesh && self.mode != Mode::Mc)
                        || (failure == Failure::Open && self.script_expects_open_error());
                    if shown_only {
                        self.note(message, true);
                    } else {
                        self.fail(message);
                    }
                }
            }
        }
    }

    fn on_opened(&mut self, info: SourceInfo, full_size: [u32; 2]) {
        self.iso_value = match (&info.grid_info, info.value_range) {
            (Some(grid), _) => grid.iso,
            (None, Some((lo, hi))) => match self.options.iso {
                Iso::Value(v) if self.generation == 1 => v,
                // Later inputs keep the normalised position of the slider.
                _ => {
                    let t = match self.options.iso {
                        Iso::Normalized(t) => t,
                        Iso::Value(_) => 0.5,
                    };
                    lo + t * (hi - lo)
                }
            },
            (None, None) => 0.0,
        };
        // MC of a label grid needs no volume: decided when its grid (and labels) arrive.
        if !info.has_volume() && self.mode.needs_volume() && self.mode != Mode::Mc {
            // Without a volume the grid came from a .cgc file, or is a label volume's labels.
            let why = if crate::source::is_cgc(&info.path) {
                super::NEEDS_VOLUME
            } else {
                super::CR_OF_LABELS
            };
            self.fail_or_note(format!("mode {} {why}: showing cgc", self.mode));
            self.mode = Mode::Cgc;
        }
        let colour = match &info.attribute {
            Some(name) => format!("; coloured by its attribute {name:?}"),
            None => String::new(),
        };
        self.note(format!("opened {}{colour}", info.path.display()), false);
        self.source = Some(info);
        self.texture = None;
        self.shown = None;
        self.shown_pixels = None;
        self.shown_values = None;
        self.labels = Default::default();
        self.set_view(self.options.view, full_size);
        self.script_on_opened();
    }

    /// The image of the previous input goes: it would pass for the file that failed.
    fn on_open_failed(&mut self, message: String) {
        self.open_error = Some(message);
        self.texture = None;
        self.shown = None;
        self.shown_pixels = None;
        self.shown_values = None;
        self.labels = Default::default();
    }

    fn on_frame(&mut self, ctx: &egui::Context, rendered: RenderedFrame, full_size: [u32; 2]) {
        let RenderedFrame {
            request,
            image,
            seconds,
        } = rendered;
        let Some((id, key)) = self.in_flight else {
            return;
        };
        if id != request {
            return;
        }
        self.in_flight = None;
        if self.cost_of != Some((key.mode, key.scene)) {
            self.cost.reset();
            self.cost_of = Some((key.mode, key.scene));
        }
        self.cost
            .record(image.width as u64 * image.height as u64, seconds * 1e3);
        let full = [image.width, image.height] == full_size;
        let texture =
            egui::ColorImage::from_rgb([image.width as usize, image.height as usize], &image.rgb8);
        // One texel per pixel at full size; smooth magnification of reduced frames.
        let filter = if full {
            egui::TextureOptions::NEAREST
        } else {
            egui::TextureOptions::LINEAR
        };
        match &mut self.texture {
            Some(t) => t.set(texture, filter),
            None => self.texture = Some(ctx.load_texture("isosurface", texture, filter)),
        }
        if let Some(gpu) = &image.gpu {
            self.measurements.frame = Some(FrameFacts {
                width: image.width,
                height: image.height,
                timings: gpu.timings,
                drawn_cells: gpu.drawn_cells,
                probed_cells: gpu.probed_cells,
                seconds,
            });
        }
        self.shown = Some(key);
        self.shown_samples = image.samples.unwrap_or(0);
        self.shown_pixels = Some((image.width, image.height, image.rgb8));
        self.shown_values = image.value.map(|values| {
            let hits = values.iter().zip(&image.cluster);
            let values = hits.map(|(&v, &c)| (c != u32::MAX).then_some(v));
            (image.width, values.collect())
        });
        self.labels.frame_labels = image.label.map(|labels| (image.width, labels));
        if let Some(script) = &mut self.script {
            if let ScriptState::Rendering { done } = &mut script.state {
                if full {
                    *done += 1;
                    if *done < script.frames {
                        // The same view again: the visibility buffer carries over (paper §3.3).
                        self.shown = None;
                    }
                }
            }
        }
    }
}

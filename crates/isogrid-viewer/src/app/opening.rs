//! Opening inputs, typed or dropped on the window: the extraction worker is told what to read,
//! and the isovalue carries over as the slider's normalised position.

use super::state::App;
use crate::extract_worker::OpenRequest;
use eframe::egui;
use isogrid::Iso;
use std::path::{Path, PathBuf};

/// What files dropped on the window in one frame ask for.
#[derive(Debug, PartialEq)]
pub(super) struct DroppedInput {
    /// The file to open: the first one, since the window shows one input at a time.
    pub(super) path: PathBuf,
    /// What to tell the user about the other files, which are not opened.
    pub(super) ignored: Option<String>,
}

/// Picks the input among dropped files (`None` when none was dropped). Readability and format
/// are left to the extraction worker, which reports a bad file in the window.
pub(super) fn dropped_input<'a>(paths: impl IntoIterator<Item = &'a Path>) -> Option<DroppedInput> {
    let mut paths = paths.into_iter();
    let first = paths.next()?;
    let others = paths.count();
    Some(DroppedInput {
        path: first.to_path_buf(),
        ignored: (others > 0).then(|| {
            format!(
                "{} files dropped: opening {}, one input at a time",
                others + 1,
                first.display()
            )
        }),
    })
}

impl App {
    /// Starts reading `path`; until it is open, nothing of the old input is shown or measured.
    pub(super) fn open(&mut self, path: PathBuf, read_options: isogrid_io::ReadOptions, iso: Iso) {
        self.generation += 1;
        self.path_text = path.display().to_string();
        self.source = None;
        self.measurements.grid = None;
        self.measurements.mesh = None;
        self.has_view = false;
        self.open_error = None;
        // A frame of the old input still rendering would otherwise be shown when it arrives,
        // over the new input's error or in place of its first frame.
        self.in_flight = None;
        let generation = self.generation;
        // `--color-by` belongs to the input it was given with, not to files opened later.
        let attribute = self
            .options
            .attribute
            .clone()
            .filter(|_| self.options.input.as_ref() == Some(&path));
        let labels = self
            .options
            .labels
            .clone()
            .filter(|_| self.options.input.as_ref() == Some(&path));
        self.extractor.update(|w| {
            w.open = Some(OpenRequest {
                generation,
                path,
                read_options,
                attribute,
                labels,
            });
            w.iso = iso;
        });
    }

    /// The isovalue as a fraction of the value range, when there is one.
    pub(super) fn normalized(&self, value: f64) -> Option<f64> {
        let (lo, hi) = self.source.as_ref()?.value_range?;
        (hi > lo).then(|| (value - lo) / (hi - lo))
    }

    /// Where the next input's isovalue starts: the slider's normalised position.
    pub(super) fn current_normalized_iso(&self) -> Iso {
        match self.normalized(self.iso_value) {
            Some(t) if self.source.as_ref().is_some_and(|s| s.has_volume()) => {
                Iso::Normalized(t.clamp(0.0, 1.0))
            }
            _ => Iso::Normalized(0.5),
        }
    }

    /// Opens a file dropped on the window this frame, keeping the isovalue's normalised position.
    pub(super) fn handle_drops(&mut self, ctx: &egui::Context) {
        let dropped = ctx.input(|i| dropped_input(i.raw.dropped_files.iter().map(|f| f.path())));
        let Some(DroppedInput { path, ignored }) = dropped else {
            return;
        };
        if let Some(text) = ignored {
            self.note(text, false);
        }
        if self.script.is_some() {
            println!("isogrid view: dropped {}", path.display());
        }
        self.script_on_drop();
        let iso = self.current_normalized_iso();
        self.open(path, Default::default(), iso);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_dropped_file_is_opened_and_the_others_are_named_as_ignored() {
        assert_eq!(dropped_input(std::iter::empty::<&Path>()), None);
        let one = [Path::new("/data/a.nrrd")];
        assert_eq!(
            dropped_input(one),
            Some(DroppedInput {
                path: PathBuf::from("/data/a.nrrd"),
                ignored: None
            })
        );
        let three = [
            Path::new("/data/b.cgc"),
            Path::new("/data/a.nrrd"),
            Path::new("/data/c"),
        ];
        let input = dropped_input(three).unwrap();
        assert_eq!(input.path, PathBuf::from("/data/b.cgc"));
        let note = input.ignored.unwrap();
        assert!(
            note.starts_with("3 files dropped: opening /data/b.cgc"),
            "{note}"
        );
    }
}

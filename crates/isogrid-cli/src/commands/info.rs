//! `isogrid info`: statistics of a `.cgc` file (validated on open), or what a volume holds and
//! where it lies (its grid, sample type, value range, spacing, origin and axes).

use crate::args::InputArgs;
use crate::report::{print_json, GridReport, Seconds, SourceReport, VolumeReport};
use anyhow::Result;
use isogrid::GridStats;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// A .cgc file written by `isogrid extract`, or a volume (any file, folder or Zarr URL
    /// `extract` reads) to describe: read by region within a quarter of the memory where its
    /// format allows, else whole.
    pub file: PathBuf,
    #[command(flatten)]
    pub input_args: InputArgs,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Whether `path` is a `.cgc` file: by its name, or by its first bytes.
fn is_cgc_file(path: &Path) -> bool {
    if crate::grid_source::is_cgc(path) {
        return true;
    }
    let mut head = [0u8; 8];
    path.is_file()
        && std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .is_ok()
        && isogrid::cgc::is_cgc_magic(&head)
}

pub fn run(args: Args) -> Result<()> {
    if !is_cgc_file(&args.file) {
        return describe_volume(&args);
    }
    let start = Instant::now();
    let grid = isogrid::cgc::open(&args.file)?;
    let read = start.elapsed().as_secs_f64();
    crate::report::note_if_empty(&args.file, &grid, None);
    crate::report::note_if_mirrored(&args.file, grid.info());
    let report = GridReport {
        opened_file: true,
        source: Some(SourceReport::new(grid.info())),
        ..GridReport::new(
            &GridStats::of(&grid),
            Seconds {
                read,
                ..Default::default()
            },
        )
    }
    .with_attribute(grid.attribute())
    .with_labels(&grid);
    if args.json {
        print_json(&report)
    } else {
        report.print_human(None, "")?;
        let info = grid.info();
        // The convention of the world coordinates, where the source file named one.
        let frame = match info.frame.axis_codes(&info.direction) {
            Some(axes) => format!(", world coordinates {}, axes {axes}", info.frame.name()),
            None => String::new(),
        };
        if grid.labels().is_some() {
            outln!(
                "source        {} label volume; the corners hold each label's indicator (0 to 1), spacing {:?}{frame}",
                info.scalar_type.name(),
                info.spacing
            );
            return Ok(());
        }
        outln!(
            "source        {} samples in [{}, {}], spacing {:?}{frame}",
            info.scalar_type.name(),
            info.scalar_type.display_value(info.value_range[0]),
            info.scalar_type.display_value(info.value_range[1]),
            info.spacing
        );
        Ok(())
    }
}

/// `info VOLUME`: the volume's grid, type, value range and place in the world, without extracting.
fn describe_volume(args: &Args) -> Result<()> {
    let path = &args.file;
    let options = args.input_args.read_options()?;
    let start = Instant::now();
    let (geometry, scalar_type, range) = match isogrid_io::open_region(path, &options)? {
        Some(mut source) => {
            let spinner = crate::progress::spinner(format!("reading {}", path.display()));
            let range = isogrid::extract::stream::source_value_range(
                source.as_mut(),
                crate::commands::extract::budget(None),
                &isogrid::Progress::new(),
            )
            .map_err(|e| e.with_path(path))?;
            spinner.finish_and_clear();
            (source.geometry(), source.scalar_type(), range)
        }
        None => {
            let (volume, _) = crate::input::read_volume(path, &options)?;
            let range = volume.value_range();
            (*volume.geometry(), volume.scalar_type(), range)
        }
    };
    let report = VolumeReport::new(&geometry, scalar_type, range, start.elapsed().as_secs_f64());
    if let Some(note) = geometry.mirrored_note() {
        eprintln!("isogrid: note: {}: {note}", path.display());
    }
    if args.json {
        print_json(&report)
    } else {
        Ok(report.print_human()?)
    }
}

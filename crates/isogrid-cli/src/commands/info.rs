//! `isogrid info`: statistics of a `.cgc` file (validated on open), or what a volume holds and
//! where it lies (its grid, sample type, value range, spacing, origin and axes), and with
//! `--labels` the labels of a label volume (each one's voxels, volume, box, name and colour).

use crate::args::{parse_labels_or_names, InputArgs};
use crate::report::{
    print_json, GridReport, LabelValue, Seconds, SourceReport, VolumeLabelReport, VolumeReport,
};
use anyhow::{bail, Context, Result};
use isogrid::{GridStats, LabelSelection};
use isogrid_io::label_statistics::GivenTable;
use std::path::{Path, PathBuf};
use std::sync::Arc;
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
    /// Read the volume as labels (as `extract --labels` does: a layered .seg.nrrd's layers, an
    /// OME-Zarr label image) and list the selected ones (`all`, or values, ranges and names such
    /// as `1,5-9,liver`) but the background 0: each one's voxels, volume (voxels × the voxel's
    /// volume, in the spacing's units cubed), box in sample indices, name and colour. Of a label
    /// grid's .cgc, list the selected labels only.
    #[arg(long, value_name = "all|1,5-9", value_parser = parse_labels_or_names)]
    pub labels: Option<LabelSelection>,
    /// With --labels: name and colour the labels from a colour table (as `extract --label-table`).
    #[arg(long, value_name = "FILE", requires = "labels")]
    pub label_table: Option<PathBuf>,
    /// With --labels and an OME-Zarr image: its label image NAME (`FILE/labels/NAME`).
    #[arg(long, value_name = "NAME", requires = "labels")]
    pub labels_of: Option<String>,
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
        return match &args.labels {
            Some(selection) => describe_labels(&args, selection),
            None => describe_volume(&args),
        };
    }
    if args.label_table.is_some() || args.labels_of.is_some() {
        bail!(
            "{}: --label-table and --labels-of read a label volume; a .cgc file keeps its labels' names and colours",
            args.file.display()
        );
    }
    let start = Instant::now();
    let grid = isogrid::cgc::open(&args.file)?;
    let read = start.elapsed().as_secs_f64();
    crate::report::note_if_empty(&args.file, &grid, None);
    // `--labels`: the labels listed, chosen by value or name as `render --show` chooses them.
    let shown = match (&args.labels, grid.labels()) {
        (None, _) => None,
        (Some(_), None) => bail!(
            "{}: --labels lists a label grid's labels, and this grid is an isosurface",
            args.file.display()
        ),
        (Some(selection), Some(labels)) => Some(
            selection
                .resolved(labels.table())
                .with_context(|| args.file.display().to_string())?,
        ),
    };
    let mut report = GridReport {
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
    if let (Some(selection), Some(labels), Some(reports)) =
        (&shown, grid.labels(), report.labels.as_mut())
    {
        let mut table = labels.table().iter();
        reports.retain(|_| selection.selects(table.next().expect("an entry per label").value));
    }
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
            // A bar over the blocks read; Ctrl-C stops the pass.
            let progress = Arc::new(isogrid::Progress::new());
            let message = format!("reading {}", path.display());
            let range = crate::progress::watched(&message, &progress, || {
                isogrid::extract::stream::source_value_range(
                    source.as_mut(),
                    crate::commands::extract::budget(None),
                    &progress,
                )
            })
            .map_err(|e| e.with_path(path))?;
            (source.geometry(), source.scalar_type(), range)
        }
        None => {
            let (volume, _) = crate::input::read_volume(path, &options)?;
            let range = volume.value_range();
            (*volume.geometry(), volume.scalar_type(), range)
        }
    };
    let report = VolumeReport::new(&geometry, scalar_type, range, start.elapsed().as_secs_f64());
    print_volume_report(args, &report)
}

/// `info VOLUME --labels SELECTION`: the volume's place in the world and its selected labels
/// ([`isogrid_io::label_statistics::file_label_statistics`]: counted in one pass, by region where
/// the format allows, under a bar that Ctrl-C stops; named and coloured as `extract --labels`
/// names them).
fn describe_labels(args: &Args, selection: &LabelSelection) -> Result<()> {
    let path = &args.file;
    // A malformed table fails before the volume is read, as in `extract`.
    let table = match &args.label_table {
        Some(table) => Some((table, isogrid_io::labels::read_label_table(table)?)),
        None => None,
    };
    let options = args.input_args.read_options()?;
    let start = Instant::now();
    // A bar over the blocks counted; Ctrl-C stops the count.
    let progress = Arc::new(isogrid::Progress::new());
    let message = format!("counting the labels of {}", path.display());
    let volume = crate::progress::watched(&message, &progress, || {
        isogrid_io::label_statistics::file_label_statistics(
            path,
            args.labels_of.as_deref(),
            &options,
            selection,
            table
                .as_ref()
                .map(|(path, labels)| GivenTable { path, labels }),
            None,
            crate::commands::extract::budget(None),
            &progress,
        )
    })?;
    for notice in &volume.notices {
        eprintln!("isogrid: note: {notice}");
    }
    let mut report = VolumeReport::new(
        &volume.geometry,
        volume.scalar_type,
        volume.range,
        start.elapsed().as_secs_f64(),
    );
    report.labels = Some(
        volume
            .labels
            .iter()
            .map(|l| VolumeLabelReport {
                value: LabelValue::of(l.label.value, volume.signed),
                name: l.label.name.clone(),
                color: l.label.color_hex(),
                voxels: l.voxels,
                volume: l.volume,
                lo: l.lo,
                hi: l.hi,
            })
            .collect(),
    );
    print_volume_report(args, &report)
}

/// Prints `report` as `args` ask.
fn print_volume_report(args: &Args, report: &VolumeReport) -> Result<()> {
    if args.json {
        print_json(report)
    } else {
        Ok(report.print_human()?)
    }
}

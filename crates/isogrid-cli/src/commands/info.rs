//! `isogrid info`: statistics of a `.cgc` file (validated on open), or what a volume holds and
//! where it lies (its grid, sample type, value range, spacing, origin and axes), and with
//! `--labels` the labels of a label volume (each one's voxels, volume, box, name and colour).

use crate::args::{parse_labels_or_names, InputArgs};
use crate::report::{
    print_json, GridReport, LabelValue, Seconds, SourceReport, VolumeLabelReport, VolumeReport,
};
use anyhow::{bail, Context, Result};
use isogrid::label_census::{label_census, LabelCount};
use isogrid::labels::{signed_labels, Label};
use isogrid::{GridStats, LabelSelection};
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
    print_volume_report(args, &report)
}

/// `info VOLUME --labels SELECTION`: the volume's place in the world and its selected labels,
/// counted in one pass ([`label_census`]), named and coloured as `extract --labels` names them
/// (the default palette, then the file's names, then the colour table's).
fn describe_labels(args: &Args, selection: &LabelSelection) -> Result<()> {
    let path = &args.file;
    // A malformed table fails before the volume is read, as in `extract`.
    let table = match &args.label_table {
        Some(table) => Some(isogrid_io::labels::read_label_table(table)?),
        None => None,
    };
    let options = args.input_args.read_options()?;
    let start = Instant::now();
    // By region within a quarter of the memory where the format allows (a connectomics volume
    // need not fit), else whole: each layer's census with the offset of its values.
    let (geometry, scalar_type, censuses, names) =
        match isogrid_io::labels::open_label_region(path, args.labels_of.as_deref(), &options)? {
            Some((mut source, names)) => {
                let spinner = crate::progress::spinner(format!("reading {}", path.display()));
                let census = isogrid::extract::stream::source_label_census(
                    source.as_mut(),
                    crate::commands::extract::budget(None),
                    &isogrid::Progress::new(),
                )
                .map_err(|e| e.with_path(path))?;
                spinner.finish_and_clear();
                let (geometry, scalar_type) = (source.geometry(), source.scalar_type());
                (geometry, scalar_type, vec![(census, 0)], names)
            }
            None => {
                let (source, _) =
                    crate::input::read_label_volume(path, args.labels_of.as_deref(), &options)?;
                let first = &source.layers[0].volume;
                let mut censuses = Vec::new();
                for layer in &source.layers {
                    let census =
                        label_census(&layer.volume.view()).map_err(|e| e.with_path(path))?;
                    censuses.push((census, layer.offset));
                }
                (
                    *first.geometry(),
                    first.scalar_type(),
                    censuses,
                    source.names,
                )
            }
        };
    let selection = isogrid_io::labels::resolve_label_names(selection, &names, table.as_deref())
        .with_context(|| path.display().to_string())?;
    let signed = signed_labels(scalar_type);
    // Each layer's values but 0 are the file's labels less the layer's offset.
    let mut counts: Vec<LabelCount> = Vec::new();
    let mut background = false;
    for (census, offset) in censuses {
        for count in census {
            match count.value {
                0 => background = true,
                v => counts.push(LabelCount {
                    value: v.wrapping_add(offset),
                    ..count
                }),
            }
        }
    }
    counts.sort_by_key(|c| c.value);
    let mut labels: Vec<Label> = counts
        .iter()
        .map(|c| Label::default_for(c.value, signed))
        .collect();
    isogrid_io::labels::name_labels(&mut labels, &names);
    if let (Some(table), Some(table_path)) = (&table, &args.label_table) {
        let absent = isogrid_io::labels::name_labels(&mut labels, table);
        if let Some(notice) =
            isogrid_io::labels::absent_labels_notice(table_path, &absent, &selection, signed)
        {
            eprintln!("isogrid: note: {notice}");
        }
    }
    // The labels' values, the background's among them where a sample holds it.
    let keys = counts
        .iter()
        .map(|c| c.value)
        .chain(background.then_some(0));
    let as_value = |k: u64| if signed { k as i64 as f64 } else { k as f64 };
    let range = keys.map(as_value).fold(None, |r: Option<(f64, f64)>, v| {
        Some(r.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))))
    });
    let voxel = geometry.spacing.iter().product::<f64>();
    let mut report =
        VolumeReport::new(&geometry, scalar_type, range, start.elapsed().as_secs_f64());
    report.labels = Some(
        counts
            .iter()
            .zip(&labels)
            .filter(|(c, _)| selection.selects(c.value))
            .map(|(c, label)| VolumeLabelReport {
                value: LabelValue::of(c.value, signed),
                name: label.name.clone(),
                color: label.color_hex(),
                voxels: c.voxels,
                volume: c.voxels as f64 * voxel,
                lo: c.lo,
                hi: c.hi,
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

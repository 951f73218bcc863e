//! `isogrid extract`: volume → clustered grid cells (paper §3.1) → `.cgc`.
//!
//! Inputs that can be read by region (Zarr, OME-Zarr, TIFF slice folders, raw, uncompressed NRRD
//! and NIfTI) are extracted slab by slab within `--max-memory` and written as they go
//! ([`isogrid::extract::stream`]; with `--labels`, [`isogrid::extract::label_stream`], a layered
//! Slicer segmentation aside); the others are read whole first. Both give the same bytes.

use crate::args::{parse_precision, parse_size, InputArgs, IsoArgs, LabelArgs, ThreadArgs};
use crate::color_by::{parse_attribute_precision, AttributeInput, ColorByArgs, DEFAULT_PRECISION};
use crate::outputs::{self, Output};
use crate::report::{print_json, AttributeReport, GridReport, Seconds};
use crate::{input, progress};
use anyhow::{Context, Result};
use isogrid::extract::stream::{self, RegionSource};
use isogrid::labels::{Label, LabelEntry};
use isogrid::{
    AttributePrecision, CellGrid, ExtractOptions, GridStats, LabelOptions, LabelSelection,
    Precision, Progress,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Volume: .nii/.nii.gz, .nrrd/.nhdr, .npy, .tif/.tiff, .mha/.mhd, .mgh/.mgz, .mrc/.map, .vti, a folder of
    /// TIFF slices, a Zarr or OME-Zarr store, a DICOM folder, or raw with --raw-shape.
    pub input: PathBuf,
    #[command(flatten)]
    pub iso: IsoArgs,
    /// Bits per stored corner value: 1 (the corners' sides alone), 4, 8, 16 or 32 (default: 8 for u8 volumes, 16 otherwise; 1 for labels without smoothing).
    #[arg(long, value_name = "BITS", value_parser = parse_precision)]
    pub precision: Option<Precision>,
    #[command(flatten)]
    pub threads: ThreadArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
    /// Peak memory for inputs read by region, e.g. 512M or 4G (default: a quarter of RAM).
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub max_memory: Option<u64>,
    #[command(flatten)]
    pub color: ColorByArgs,
    /// Bits per stored attribute value: 8 or 16 (codes over the attribute's range on the
    /// surface) or 32 (f32) [default: 16].
    #[arg(long, value_name = "BITS", value_parser = parse_attribute_precision, requires = "color_by")]
    pub attribute_precision: Option<AttributePrecision>,
    #[command(flatten)]
    pub label: LabelArgs,
    /// Write the grid to this .cgc file.
    #[arg(short, long, value_name = "OUT.cgc")]
    pub output: Option<PathBuf>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    if args.label.labels.is_some() {
        return run_labels(args);
    }
    if args.label.smooth.is_some() {
        anyhow::bail!("--smooth smooths label indicators, and needs --labels");
    }
    if args.label.label_table.is_some() || args.label.labels_of.is_some() {
        anyhow::bail!("--label-table and --labels-of name the labels of --labels, and need it");
    }
    let output = args.output.as_deref().map(|path| Output {
        role: "the grid",
        path,
        extensions: &[".cgc"],
    });
    let read_options = args.input_args.read_options()?;
    let attribute = args.color.attribute(&args.input, &read_options)?;
    outputs::check(
        &AttributeInput::inputs(&args.input, attribute.as_ref()),
        output.as_slice(),
    )?;
    let options = ExtractOptions {
        iso: args.iso.iso(),
        precision: args.precision,
    };
    // The pool is started before the clock: thread start-up is not extraction.
    let pool = args.threads.pool()?;
    let start = Instant::now();
    let region = isogrid_io::open_region(&args.input, &read_options)?;
    let read = start.elapsed().as_secs_f64();
    let (stats, attribute_report, seconds) = match region {
        Some(mut source) => {
            // What the whole-volume reader's notices would say (other files of a TIFF folder).
            if let Some(notice) = isogrid_io::region::slices::skipped_files_notice(&args.input) {
                eprintln!("isogrid: note: {notice}");
            }
            let (stats, attribute_report) = pool.install(|| {
                // In the pool: the budget keeps back address space for its threads' arenas.
                let max_memory = budget(args.max_memory);
                stream_to_file(
                    &args,
                    source.as_mut(),
                    &options,
                    max_memory,
                    attribute.as_ref(),
                )
            })?;
            (
                stats,
                attribute_report,
                Seconds {
                    read,
                    extract: start.elapsed().as_secs_f64() - read,
                    write: 0.0,
                },
            )
        }
        None => {
            let done = in_memory(&args, &read_options, &options, &pool, attribute.as_ref())?;
            note_read_whole(&args);
            done
        }
    };
    let mut report = GridReport::new(&stats, seconds);
    report.attribute = attribute_report;
    print_report(&args, &report)
}

/// Labels `extract` lists in its table: a segmentation of thousands of labels would otherwise
/// fill the terminal on every run (`--json` and `isogrid info` list them all).
const EXTRACT_LABEL_ROWS: usize = 200;

/// The report on stdout: JSON, or a table and where the grid went.
fn print_report(args: &Args, report: &GridReport) -> Result<()> {
    if args.json {
        print_json(report)
    } else {
        let more = match &args.output {
            Some(out) => format!(": `isogrid info {}` lists them all", out.display()),
            None => String::new(),
        };
        report.print_human(Some(EXTRACT_LABEL_ROWS), &more)?;
        if let Some(out) = &args.output {
            outln!("wrote         {}", out.display());
        }
        Ok(())
    }
}

/// `--labels`: every selected label's surface in one pass over the volume, then the file: slab
/// by slab within `--max-memory` where the input reads by region, else the whole volume in
/// memory. Both give the same bytes, named and coloured the same way.
fn run_labels(args: Args) -> Result<()> {
    let options = args
        .label
        .options(args.precision)
        .expect("called with --labels");
    let output = args.output.as_deref().map(|path| Output {
        role: "the grid",
        path,
        extensions: &[".cgc"],
    });
    let read_options = args.input_args.read_options()?;
    let attribute = args.color.attribute(&args.input, &read_options)?;
    let mut inputs = AttributeInput::inputs(&args.input, attribute.as_ref());
    inputs.extend(args.label.label_table.as_deref());
    outputs::check(&inputs, output.as_slice())?;
    let pool = args.threads.pool()?;
    let table = args.label.table()?;
    let start = Instant::now();
    let region = isogrid_io::labels::open_label_region(
        &args.input,
        args.label.labels_of.as_deref(),
        &read_options,
    )?;
    let (stats, labels, absent, attribute_report, seconds) = match region {
        Some((mut source, names)) => {
            let options =
                args.label
                    .resolve_names(&options, &args.input, &names, table.as_deref())?;
            let read = start.elapsed().as_secs_f64();
            let max_memory = budget(args.max_memory);
            let (summary, absent, attribute_report) = pool.install(|| {
                stream_labels(
                    &args,
                    source.as_mut(),
                    &options,
                    max_memory,
                    (&names, table.as_deref()),
                    attribute.as_ref(),
                )
            })?;
            let seconds = Seconds {
                read,
                extract: start.elapsed().as_secs_f64() - read,
                write: 0.0,
            };
            let labels = (summary.info, summary.table, summary.index);
            (summary.stats, labels, absent, attribute_report, seconds)
        }
        None => {
            let done = labels_in_memory(
                &args,
                &read_options,
                &options,
                &pool,
                table.as_deref(),
                attribute.as_ref(),
            )?;
            note_read_whole(&args);
            done
        }
    };
    let (info, table_written, index) = labels;
    let signed = isogrid::labels::signed_labels(info.scalar_type);
    args.label.note_absent(&absent, signed);
    if let LabelSelection::Values(ranges) = &options.selection {
        // A single value asked for and absent is worth a line; ranges may have gaps.
        let missing: Vec<String> = ranges
            .iter()
            .filter(|r| {
                r.start() == r.end()
                    && table_written
                        .binary_search_by_key(r.start(), |l| l.value)
                        .is_err()
            })
            .map(|r| isogrid::labels::display_value(*r.start(), signed))
            .collect();
        if !missing.is_empty() {
            eprintln!(
                "isogrid: note: {}: no label {} in the volume",
                args.input.display(),
                missing.join(", ")
            );
        }
    }
    crate::report::note_if_no_cells(
        &args.input,
        &info,
        stats.active_cells,
        Some(&table_written),
        || false,
    );
    let mut report =
        GridReport::new(&stats, seconds).with_label_table(&table_written, &index, signed);
    report.attribute = attribute_report;
    print_report(&args, &report)
}

/// A label extraction's statistics; its sample type, label table and index; the colour table's
/// labels it lacks; its attribute; and its times.
type LabelsDone = (
    GridStats,
    (isogrid::GridInfo, Vec<Label>, Vec<LabelEntry>),
    Vec<u64>,
    Option<AttributeReport>,
    Seconds,
);

/// The whole label volume in memory (any reader, a layered `.seg.nrrd` included), then the grid,
/// then the file.
fn labels_in_memory(
    args: &Args,
    read_options: &isogrid_io::ReadOptions,
    options: &LabelOptions,
    pool: &rayon::ThreadPool,
    table: Option<&[Label]>,
    attribute: Option<&AttributeInput>,
) -> Result<LabelsDone> {
    // In the pool: a folder of masks is read in parallel, on --threads threads.
    let (source, read) = pool.install(|| {
        input::read_label_volume(&args.input, args.label.labels_of.as_deref(), read_options)
    })?;
    let options = &args
        .label
        .resolve_names(options, &args.input, &source.names, table)?;
    let start = Instant::now();
    let progress = Arc::new(Progress::new());
    let grid = progress::watched("extracting labels", &progress, || {
        pool.install(|| {
            isogrid_io::labels::extract_label_volume_with_progress(&source, options, &progress)
        })
    });
    let mut grid = stopped_or(grid, args)?;
    let extract = start.elapsed().as_secs_f64();
    let absent = table.map_or(Vec::new(), |t| {
        isogrid_io::labels::apply_label_names(&mut grid, t)
    });
    if let Some(attribute) = attribute {
        grid = pool.install(|| with_attribute(args, grid, attribute))?;
    }
    let mut write = 0.0;
    if let Some(out) = &args.output {
        let start = Instant::now();
        isogrid::cgc::write(out, &grid)?;
        write = start.elapsed().as_secs_f64();
    }
    let labels = grid.labels().expect("a label grid has labels");
    Ok((
        GridStats::of(&grid),
        (
            grid.info().clone(),
            labels.table().to_vec(),
            labels.index().to_vec(),
        ),
        absent,
        grid.attribute().map(AttributeReport::new),
        Seconds {
            read,
            extract,
            write,
        },
    ))
}

/// Slab by slab into `--output` (or a scratch file that is removed, for the statistics alone),
/// under a progress bar that Ctrl-C stops, with nothing written. The labels get the file's names
/// (`names.0`), then the colour table's (`names.1`); returns the table's labels the grid lacks.
/// With an attribute, the grid goes to a scratch file first, which the attribute pass reads back
/// (memory-mapped), as for an isosurface; the output is then written whole, or not at all.
fn stream_labels(
    args: &Args,
    source: &mut dyn RegionSource,
    options: &LabelOptions,
    max_memory: u64,
    (names, table): (&[Label], Option<&[Label]>),
    attribute: Option<&AttributeInput>,
) -> Result<(
    isogrid::extract::label_stream::LabelSummary,
    Vec<u64>,
    Option<AttributeReport>,
)> {
    use isogrid::extract::label_stream;
    // Checked before the pass, so a budget too small fails at once.
    label_stream::plan_labels(source, options, max_memory)
        .with_context(|| format!("{}", args.input.display()))?;
    let (scratch, target) = streamed_output(args, attribute, "labels.tmp")?;
    let out: &Path = scratch.as_ref().map_or(target.as_path(), |s| s.path());
    let progress = Arc::new(Progress::new());
    let mut absent = Vec::new();
    let mut name = |labels: &mut [Label]| {
        isogrid_io::labels::name_labels(labels, names);
        if let Some(table) = table {
            absent = isogrid_io::labels::name_labels(labels, table);
        }
    };
    let result = progress::watched("extracting labels", &progress, || {
        label_stream::extract_labels_to_file(source, options, max_memory, out, &progress, &mut name)
    });
    let summary = stopped_or(result, args)?;
    let attribute_report = attach_streamed(args, out, attribute)?;
    Ok((summary, absent, attribute_report))
}

/// The whole volume in memory, then the grid, then the file.
fn in_memory(
    args: &Args,
    read_options: &isogrid_io::ReadOptions,
    options: &ExtractOptions,
    pool: &rayon::ThreadPool,
    attribute: Option<&AttributeInput>,
) -> Result<(GridStats, Option<AttributeReport>, Seconds)> {
    let (volume, read) = input::read_volume(&args.input, read_options)?;
    let start = Instant::now();
    let progress = Arc::new(Progress::new());
    let grid = progress::watched("extracting", &progress, || {
        pool.install(|| isogrid::extract_with_progress(&volume.view(), options, &progress))
    });
    let grid = stopped_or(grid, args)?;
    let extract_seconds = start.elapsed().as_secs_f64();
    crate::report::note_if_empty(&args.input, &grid, Some(&volume));
    let grid = match attribute {
        Some(attribute) => pool.install(|| with_attribute(args, grid, attribute))?,
        None => grid,
    };
    let mut write = 0.0;
    if let Some(out) = &args.output {
        let start = Instant::now();
        isogrid::cgc::write(out, &grid)?;
        write = start.elapsed().as_secs_f64();
    }
    Ok((
        GridStats::of(&grid),
        grid.attribute().map(AttributeReport::new),
        Seconds {
            read,
            extract: extract_seconds,
            write,
        },
    ))
}

/// Slab by slab into `--output` (or a scratch file that is removed, for statistics only), under
/// a progress bar; Ctrl-C stops it between reads, block rows or blocks, and nothing is written.
fn stream_to_file(
    args: &Args,
    source: &mut dyn RegionSource,
    options: &ExtractOptions,
    max_memory: u64,
    attribute: Option<&AttributeInput>,
) -> Result<(GridStats, Option<AttributeReport>)> {
    // Checked before any pass, so a budget too small fails at once.
    stream::plan(source, max_memory).with_context(|| format!("{}", args.input.display()))?;
    let (scratch, target) = streamed_output(args, attribute, "surface.tmp")?;
    let out: &Path = scratch.as_ref().map_or(target.as_path(), |s| s.path());
    let progress = Arc::new(Progress::new());
    let result = progress::watched("extracting", &progress, || {
        stream::extract_to_file(source, options, max_memory, out, &progress)
    });
    let summary = stopped_or(result, args)?;
    crate::report::note_if_no_cells(
        &args.input,
        &summary.info,
        summary.stats.active_cells,
        None,
        || {
            // Only a range of [0, 0] can hide a volume without finite samples.
            summary.info.value_range == [0.0, 0.0] && has_no_finite_sample(source).unwrap_or(false)
        },
    );
    let attribute_report = attach_streamed(args, out, attribute)?;
    Ok((summary.stats, attribute_report))
}

/// Where a streamed extraction writes, as (scratch, target): the target is `--output`, or a name
/// in the temporary folder without one. A scratch file beside it (named after `role`) takes the
/// grid instead when there is no output (the grid is read back for its statistics only) or an
/// attribute (the attribute pass reads the grid back, memory-mapped, and the output is then
/// written whole, or not at all). Scratch files go when dropped, and on a signal.
fn streamed_output(
    args: &Args,
    attribute: Option<&AttributeInput>,
    role: &str,
) -> Result<(Option<isogrid::fs::ScratchFile>, PathBuf)> {
    let target = args
        .output
        .clone()
        .unwrap_or_else(|| std::env::temp_dir().join("isogrid-extract.cgc"));
    let scratch = (attribute.is_some() || args.output.is_none())
        .then(|| isogrid::fs::ScratchFile::beside(&target, role))
        .transpose()?;
    Ok((scratch, target))
}

/// With an attribute, the streamed grid in the scratch file `scratch` read back (memory-mapped),
/// given the attribute and written whole to `--output`, if any; its report.
fn attach_streamed(
    args: &Args,
    scratch: &Path,
    attribute: Option<&AttributeInput>,
) -> Result<Option<AttributeReport>> {
    let Some(attribute) = attribute else {
        return Ok(None);
    };
    let grid = with_attribute(args, isogrid::cgc::open(scratch)?, attribute)?;
    if let Some(output) = &args.output {
        isogrid::cgc::write(output, &grid)?;
    }
    Ok(grid.attribute().map(AttributeReport::new))
}

/// An extraction's result, with the error a Ctrl-C (a cancel) or a failure makes.
fn stopped_or<T>(result: isogrid::Result<T>, args: &Args) -> Result<T> {
    match result {
        Err(e) if e.kind() == isogrid::ErrorKind::Cancelled => {
            Err(anyhow::Error::from(e).context("extraction stopped by Ctrl-C, nothing written"))
        }
        r => r.with_context(|| format!("{}: extraction failed", args.input.display())),
    }
}

/// `grid` with the attribute of `--color-by` sampled at its cells.
fn with_attribute(args: &Args, grid: CellGrid, attribute: &AttributeInput) -> Result<CellGrid> {
    let spinner = progress::spinner(format!("sampling {}", attribute.path.display()));
    let values = attribute.sample(
        &grid,
        &args.input,
        args.attribute_precision.unwrap_or(DEFAULT_PRECISION),
    );
    spinner.finish_and_clear();
    Ok(grid.with_attribute(values?)?)
}

/// Whether `source` holds no finite sample (every sample NaN), read one plane at a time.
fn has_no_finite_sample(source: &mut dyn RegionSource) -> isogrid::Result<bool> {
    if source.scalar_type() != isogrid::ScalarType::F32 {
        return Ok(false);
    }
    let [nx, ny, nz] = source.geometry().dims;
    let mut plane = vec![0f32; nx * ny];
    for z in 0..nz {
        source.read_planes(z..z + 1, isogrid::extract::stream::SlabMut::F32(&mut plane))?;
        if plane.iter().any(|v| v.is_finite()) {
            return Ok(false);
        }
    }
    Ok(true)
}

/// A `--max-memory` given for an input that was read whole did not bound it: say so (after the
/// extraction, so that a failure stays one line).
fn note_read_whole(args: &Args) {
    if let Some(budget) = args.max_memory {
        eprintln!(
            "isogrid: note: {}: read whole (its format or encoding has no reads by region), so \
             --max-memory {} did not bound it",
            args.input.display(),
            stream::format_bytes(budget)
        );
    }
}

/// The memory budget of a streamed extraction: `--max-memory`, else
/// [`isogrid::memory::streaming_budget`]'s default; a note says when a `--max-memory` given was
/// lowered to what the process may allocate now.
pub(crate) fn budget(max_memory: Option<u64>) -> u64 {
    let (budget, lowered_by) = isogrid::memory::streaming_budget(max_memory);
    if let (Some(source), Some(_)) = (lowered_by, max_memory) {
        eprintln!(
            "isogrid: note: --max-memory lowered to {}, {source}",
            stream::format_bytes(budget)
        );
    }
    budget
}

//! `isogrid info`: statistics of a `.cgc` file (validated on open).

use crate::report::{print_json, GridReport, Seconds, SourceReport};
use anyhow::Result;
use isogrid::GridStats;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// A .cgc file written by `isogrid extract`.
    pub file: PathBuf,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    if isogrid_io::region::is_url(&args.file) {
        // Without this the URL is taken for a local path: "No such file or directory".
        anyhow::bail!(
            "{}: info reads .cgc files, which are local; `isogrid extract URL -o FILE.cgc` reads a Zarr store at a URL",
            args.file.display()
        );
    }
    let start = Instant::now();
    let grid = isogrid::cgc::open(&args.file)?;
    let read = start.elapsed().as_secs_f64();
    crate::report::note_if_empty(&args.file, &grid, None);
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

//! Where the grid of a render, benchmark or served page comes from: a `.cgc` file, a volume
//! extracted at `--iso`/`--iso-normalized` with an optional `--precision`, or a label volume's
//! labels (`--labels`, as `extract --labels` extracts them).

use crate::args::{parse_precision, InputArgs, LabelArgs};
use crate::color_by::{ColorByArgs, DEFAULT_PRECISION};
use crate::{input, progress};
use anyhow::{bail, Context, Result};
use isogrid::{extract, CellGrid, ExtractOptions, Iso, Precision, Volume};
use std::path::{Path, PathBuf};

/// `--iso V | --iso-normalized V`, needed unless the input is a `.cgc` file or `--labels` is
/// given (which joins this group: one of the three at most).
#[derive(clap::Args, Debug, Clone)]
#[group(id = "IsoArgs", required = false, multiple = false)]
pub struct OptionalIso {
    /// Isovalue in data units: a sample is inside when value >= V.
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<f64>,
    /// Isovalue as a fraction of the volume's value range (the paper uses 0.5).
    #[arg(long, value_name = "V")]
    pub iso_normalized: Option<f64>,
}

/// Where the grid of a render or benchmark comes from.
#[derive(clap::Args, Debug, Clone)]
pub struct GridSource {
    /// A .cgc file, or a volume (.nii/.nii.gz, .nrrd, .npy, .tif, .mha, .mgz, .mrc, .vti, DICOM folder, raw) to
    /// extract.
    pub input: PathBuf,
    #[command(flatten)]
    pub iso: OptionalIso,
    /// Bits per stored corner value when extracting: 1, 4, 8, 16 or 32.
    #[arg(long, value_name = "BITS", value_parser = parse_precision)]
    pub precision: Option<Precision>,
    #[command(flatten)]
    pub input_args: InputArgs,
    #[command(flatten)]
    pub color: ColorByArgs,
    #[command(flatten)]
    pub label: LabelArgs,
}

/// A `.cgc` file, or its packed form (`.cgcz`), which the reader refuses naming what it is rather
/// than being taken for a volume.
pub(crate) fn is_cgc(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("cgc") || e.eq_ignore_ascii_case("cgcz"))
}

impl GridSource {
    /// Opens the `.cgc` file or reads and extracts the volume (on the current rayon pool).
    pub fn load(&self) -> Result<CellGrid> {
        Ok(self.load_with_volume()?.0)
    }

    /// Like [`GridSource::load`], also keeping the volume (absent for `.cgc` files), with the
    /// attribute of `--color-by` sampled onto the grid.
    pub fn load_with_volume(&self) -> Result<(CellGrid, Option<Volume>)> {
        let (grid, volume) = self.load_surface()?;
        let Some(attribute) = self
            .color
            .attribute(&self.input, &self.input_args.read_options()?)?
        else {
            return Ok((grid, volume));
        };
        let spinner = progress::spinner(format!("sampling {}", attribute.path.display()));
        let values = attribute.sample(&grid, &self.input, DEFAULT_PRECISION);
        spinner.finish_and_clear();
        Ok((grid.with_attribute(values?)?, volume))
    }

    fn load_surface(&self) -> Result<(CellGrid, Option<Volume>)> {
        if let Some(options) = self.label.options(self.precision) {
            return Ok((self.load_labels(&options)?, None));
        }
        if is_cgc(&self.input) {
            if self.iso.iso.is_some() || self.iso.iso_normalized.is_some() {
                bail!(
                    "{}: a .cgc file has its isovalue already; drop --iso/--iso-normalized",
                    self.input.display()
                );
            }
            if self.precision.is_some() {
                bail!(
                    "{}: a .cgc file has its precision already; drop --precision \
                     (or extract the volume again with it)",
                    self.input.display()
                );
            }
            let grid = isogrid::cgc::open(&self.input)?;
            crate::report::note_if_empty(&self.input, &grid, None);
            return Ok((grid, None));
        }
        let iso = match (self.iso.iso, self.iso.iso_normalized) {
            (Some(v), _) => Iso::Value(v),
            (_, Some(t)) => Iso::Normalized(t),
            _ => bail!(
                "{}: a volume needs --iso V or --iso-normalized V",
                self.input.display()
            ),
        };
        let (volume, _) = input::read_volume(&self.input, &self.input_args.read_options()?)?;
        let spinner = progress::spinner("extracting".into());
        let options = ExtractOptions {
            iso,
            precision: self.precision,
        };
        let grid = extract(&volume.view(), &options)
            .with_context(|| format!("{}: extraction failed", self.input.display()))?;
        spinner.finish_and_clear();
        crate::report::note_if_empty(&self.input, &grid, Some(&volume));
        Ok((grid, Some(volume)))
    }

    /// The label grid of `--labels`: the label volume read whole, its labels extracted, named from
    /// `--label-table` (or the file) as `extract --labels` names them.
    fn load_labels(&self, options: &isogrid::LabelOptions) -> Result<CellGrid> {
        if is_cgc(&self.input) {
            bail!(
                "--labels reads a label volume; {} is a .cgc file, whose labels (if any) are drawn as they are",
                self.input.display()
            );
        }
        let table = self.label.table()?;
        let (source, _) = input::read_label_volume(
            &self.input,
            self.label.labels_of.as_deref(),
            &self.input_args.read_options()?,
        )?;
        let options =
            self.label
                .resolve_names(options, &self.input, &source.names, table.as_deref())?;
        let spinner = progress::spinner("extracting labels".into());
        let mut grid = isogrid_io::labels::extract_label_volume(&source, &options)
            .with_context(|| format!("{}: extraction failed", self.input.display()))?;
        spinner.finish_and_clear();
        if let Some(table) = &table {
            let absent = isogrid_io::labels::apply_label_names(&mut grid, table);
            let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
            self.label.note_absent(&absent, signed);
        }
        crate::report::note_if_empty(&self.input, &grid, None);
        Ok(grid)
    }
}

//! Argument groups shared by several subcommands.

use anyhow::{bail, Context, Result};
use clap::Args;
use isogrid::{Iso, LabelSelection, Precision, ScalarType};
use isogrid_io::{RawSpec, ReadOptions};
use std::path::{Path, PathBuf};

/// `--labels` and how its labels are smoothed and named: the surface of each label of a label
/// volume, which `extract` stores and `mc` meshes.
#[derive(Args, Debug, Clone)]
pub struct LabelArgs {
    /// The surface of each label of a label volume instead of an isosurface: `all` (every label
    /// but 0, the background) or values, ranges and names such as `1,5-9,liver` (names those the
    /// file or --label-table gives, in any case). Each label's surface is the
    /// isosurface at 1/2 of its indicator; `extract` lists the labels in the file with names and
    /// colours, `mc` names and colours them in a .glb or .vtp and makes each a segment of a
    /// precomputed folder. A folder of NIfTI masks (TotalSegmentator's `segmentations/`) is one label volume:
    /// mask i in name order is label i+1, named after its file.
    // In the isovalue's group: one of --iso, --iso-normalized and --labels is required.
    #[arg(long, value_name = "all|1,5-9", value_parser = parse_labels_or_names, group = "IsoArgs")]
    pub labels: Option<LabelSelection>,
    /// With --labels: smooth each label's indicator by a Gaussian of SIGMA voxels before its
    /// surface is taken, so surfaces are not chamfered; 0 for none [default: 0].
    #[arg(long, value_name = "SIGMA", requires = "labels")]
    pub smooth: Option<f64>,
    /// With --labels: name and colour the labels from a colour table: FreeSurfer LUT
    /// (`FreeSurferColorLUT.txt`), 3D Slicer `.ctbl`, ITK-SNAP label description, or a CSV/TSV
    /// with a header naming its columns (BIDS `dseg.tsv`: index, name, color), told apart by
    /// content. It wins over names and colours the volume's file gives (a .seg.nrrd's
    /// segments, an OME-Zarr label image's metadata).
    #[arg(long, value_name = "FILE", requires = "labels")]
    pub label_table: Option<PathBuf>,
    /// With --labels and an OME-Zarr image: take its label image NAME (`INPUT/labels/NAME`).
    #[arg(long, value_name = "NAME", requires = "labels")]
    pub labels_of: Option<String>,
}

impl LabelArgs {
    /// The label options of `--labels` and `--smooth`, at `precision` (`None`: the default).
    pub fn options(&self, precision: Option<Precision>) -> Option<isogrid::LabelOptions> {
        Some(isogrid::LabelOptions {
            selection: self.labels.clone()?,
            smooth: self.smooth.unwrap_or(DEFAULT_SMOOTH),
            precision,
        })
    }

    /// `options` with the names of `--labels` (`liver,spleen`) resolved against those the label
    /// file of `input` gives (`file_names`) and the colour table's (`table`), which win.
    pub fn resolve_names(
        &self,
        options: &isogrid::LabelOptions,
        input: &Path,
        file_names: &[isogrid::Label],
        table: Option<&[isogrid::Label]>,
    ) -> Result<isogrid::LabelOptions> {
        let selection =
            isogrid_io::labels::resolve_label_names(&options.selection, file_names, table)
                .with_context(|| input.display().to_string())?;
        Ok(isogrid::LabelOptions {
            selection,
            ..options.clone()
        })
    }

    /// The `--label-table` file's labels, read before the volume so that a malformed table fails
    /// first.
    pub fn table(&self) -> Result<Option<Vec<isogrid::Label>>> {
        Ok(match &self.label_table {
            Some(path) => Some(isogrid_io::labels::read_label_table(path)?),
            None => None,
        })
    }

    /// Prints the notice naming the table's labels that `--labels` selects and the grid lacks
    /// (`absent`), if any.
    pub fn note_absent(&self, absent: &[u64], signed: bool) {
        if let Some(path) = &self.label_table {
            let selection = self.labels.as_ref().unwrap_or(&LabelSelection::All);
            if let Some(notice) =
                isogrid_io::labels::absent_labels_notice(path, absent, selection, signed)
            {
                eprintln!("isogrid: note: {notice}");
            }
        }
    }
}

/// `--smooth` when not given (docs/benchmarks-labels.md says why).
pub const DEFAULT_SMOOTH: f64 = 0.0;

/// A `--labels`, `--show` or `--hide` value: `all`, or values, ranges and labels' names such as
/// `1,5-9,liver` (names are looked up in the names the file gives, or the grid's table).
pub fn parse_labels_or_names(text: &str) -> Result<LabelSelection, String> {
    LabelSelection::parse_with_names(text).map_err(|e| e.message().to_string())
}

/// `--iso V | --iso-normalized V`, exactly one.
#[derive(Args, Debug, Clone)]
#[group(required = true, multiple = false)]
pub struct IsoArgs {
    /// Isovalue in data units: a sample is inside when value >= V.
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<f64>,
    /// Isovalue as a fraction of the volume's value range (the paper uses 0.5).
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso_normalized: Option<f64>,
}

impl IsoArgs {
    pub fn iso(&self) -> Iso {
        match (self.iso, self.iso_normalized) {
            (Some(v), _) => Iso::Value(v),
            (_, Some(t)) => Iso::Normalized(t),
            _ => unreachable!("clap requires one of --iso and --iso-normalized"),
        }
    }
}

/// How to read the input volume when its format needs telling.
#[derive(Args, Debug, Clone, Default)]
pub struct InputArgs {
    /// Read INPUT as raw samples of this shape (X,Y,Z; X varies fastest).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_shape)]
    pub raw_shape: Option<[usize; 3]>,
    /// Sample type of a raw file.
    #[arg(long, value_name = "TYPE", value_parser = ["u8", "u16", "i16", "f32", "u32", "i32", "u64", "i64", "f64"], requires = "raw_shape")]
    pub raw_type: Option<String>,
    /// Raw samples are big-endian.
    #[arg(long, requires = "raw_shape")]
    pub big_endian: bool,
    /// DICOM folder: read this SeriesInstanceUID (default: the series with the most slices).
    #[arg(long, value_name = "UID", conflicts_with = "raw_shape")]
    pub series: Option<String>,
    /// OME-Zarr resolution level to read (0 = full resolution).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub level: usize,
    /// Entry of each extra (non-x/y/z) axis of a Zarr array, e.g. `t=0,c=1`, the channel and time
    /// point of a TIFF hyperstack, or the volume `t` of a 4-D NIfTI or MGH file. Checked when the
    /// request is built, so a bad value gets the one-line error every other input error gets.
    #[arg(long, value_name = "AXIS=I,...")]
    pub index: Option<String>,
}

impl InputArgs {
    pub fn read_options(&self) -> Result<ReadOptions> {
        let mut options = ReadOptions {
            series: self.series.clone(),
            ..ReadOptions::default()
        };
        if let Some(shape) = &self.raw_shape {
            let Some(scalar) = self.raw_type.as_deref().and_then(ScalarType::named) else {
                let names: Vec<&str> = ScalarType::ALL.iter().map(|t| t.name()).collect();
                bail!("--raw-shape needs --raw-type {}", names.join("|"));
            };
            options.raw = Some(RawSpec {
                dims: *shape,
                scalar,
                big_endian: self.big_endian,
            });
        }
        options.zarr = isogrid_io::ZarrOptions {
            level: self.level,
            indices: match &self.index {
                Some(text) => parse_indices(text, "--index").map_err(anyhow::Error::msg)?,
                None => Vec::new(),
            },
            trusted_certificates: isogrid_io::ssl_cert_file_from_env(),
            ..isogrid_io::ZarrOptions::default()
        };
        Ok(options)
    }
}

/// Most worker threads `--threads` accepts: far above any core count the work scales to, and
/// below the per-user thread limits (`ulimit -u`) systems commonly set.
pub const MAX_THREADS: i64 = 1024;

/// `--threads N`.
#[derive(Args, Debug, Clone, Default)]
pub struct ThreadArgs {
    /// Worker threads, at most 1024 (default: all cores). Output is identical for any count.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS))]
    pub threads: Option<u16>,
}

impl ThreadArgs {
    /// A rayon pool of the requested size (build it before timing work that runs on it).
    pub fn pool(&self) -> Result<rayon::ThreadPool> {
        let mut builder = rayon::ThreadPoolBuilder::new();
        if let Some(n) = self.threads {
            builder = builder.num_threads(n as usize);
        }
        builder.build().map_err(|e| {
            let n = self
                .threads
                .map_or_else(|| "the default number of".to_string(), |n| n.to_string());
            anyhow::anyhow!(
                "cannot start {n} worker threads ({e}): the system allows fewer; use a smaller --threads"
            )
        })
    }

    /// Runs `f` on a rayon pool of the requested size.
    pub fn install<T: Send>(&self, f: impl FnOnce() -> T + Send) -> Result<T> {
        Ok(self.pool()?.install(f))
    }
}

pub fn parse_precision(s: &str) -> Result<Precision, String> {
    Precision::parse_bits(s)
}

/// "t=0,c=1" → [("t", 0), ("c", 1)]; errors name `flag`, which gave `s`.
pub(crate) fn parse_indices(s: &str, flag: &str) -> Result<Vec<(String, u64)>, String> {
    s.split(',')
        .map(|part| {
            let (axis, index) = part.split_once('=').ok_or_else(|| {
                format!("{flag} takes AXIS=I pairs such as t=0,c=1, not {part:?}")
            })?;
            let index = index
                .trim()
                .parse::<u64>()
                .map_err(|_| format!("{flag} {part:?}: the index must be a whole number"))?;
            match axis.trim() {
                "" => Err(format!("{flag} {part:?}: the axis name is missing")),
                axis => Ok((axis.to_string(), index)),
            }
        })
        .collect()
}

/// "512M", "4G", "1.5GiB", "1000000" → bytes (K, M, G, T are powers of 1024).
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let digits = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(digits);
    let value: f64 = number
        .parse()
        .map_err(|_| format!("size must be a number with an optional K, M, G or T, not {s:?}"))?;
    let scale: u64 = match unit.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 1,
        "K" | "KB" | "KIB" => 1 << 10,
        "M" | "MB" | "MIB" => 1 << 20,
        "G" | "GB" | "GIB" => 1 << 30,
        "T" | "TB" | "TIB" => 1 << 40,
        other => {
            return Err(format!(
                "unknown size unit {other:?} in {s:?} (use K, M, G or T)"
            ))
        }
    };
    let bytes = value * scale as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("size {s:?} is out of range"));
    }
    Ok(bytes as u64)
}

/// "X,Y,Z" → [X, Y, Z], each a positive integer.
fn parse_shape(s: &str) -> Result<[usize; 3], String> {
    let parts: Vec<usize> = s
        .split(',')
        .map(|p| p.trim().parse::<usize>().ok().filter(|&n| n > 0))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("shape must be three positive integers X,Y,Z, not {s:?}"))?;
    parts
        .try_into()
        .map_err(|_| format!("shape must have three values X,Y,Z, not {s:?}"))
}

/// `--traversal`: how CPU rays find candidate metacells ([`isogrid_trace::Traversal`]).
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TraversalArg {
    /// 3D DDA over the blocks with empty-space leaps (the paper's §3.6; isogrid_trace::Tracer).
    Blocks,
    /// 8-wide bounding volume hierarchy over the metacells regrouped into leaf clusters
    /// (isogrid_trace::BvhTracer): faster per ray, slower to build.
    Bvh,
}

impl From<TraversalArg> for isogrid_trace::Traversal {
    fn from(t: TraversalArg) -> Self {
        match t {
            TraversalArg::Blocks => isogrid_trace::Traversal::Blocks,
            TraversalArg::Bvh => isogrid_trace::Traversal::Bvh,
        }
    }
}

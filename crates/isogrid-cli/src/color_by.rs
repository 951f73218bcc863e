//! `--color-by ATTR`: the second volume a surface is coloured by, read and sampled at each active
//! cell's surface point ([`isogrid::extract::attribute`]).
//!
//! `ATTR` is any volume isogrid reads (read by region where the format allows, so a streamed
//! extraction keeps its memory bound), whose own extra axes `--color-index` picks from, or
//! `AXIS=I,...` for another entry of the input's own extra axes — another channel of the same
//! OME-Zarr image (`--index c=0 --color-by c=1`). An attribute on another grid is resampled in
//! world (patient) space, with a one-line notice.

use crate::args::parse_indices;
use anyhow::{anyhow, bail, Result};
use isogrid::extract::attribute::{
    alignment, grid_geometry, sample_attribute, sample_attribute_in_memory,
    sample_points_in_memory, Alignment,
};
use isogrid::{AttributePrecision, CellAttribute, CellGrid};
use isogrid_io::{IndexFlag, ReadOptions};
use std::path::{Path, PathBuf};

/// `--attribute-precision BITS`.
pub fn parse_attribute_precision(s: &str) -> Result<AttributePrecision, String> {
    s.parse::<u32>()
        .ok()
        .and_then(AttributePrecision::from_bits)
        .ok_or_else(|| format!("attribute precision must be 8, 16 or 32, not {s}"))
}

/// Stored attribute precision when none is asked for: 16-bit codes, within 0.001 % of the range.
pub const DEFAULT_PRECISION: AttributePrecision = AttributePrecision::Code16;

/// `--color-by ATTR [--color-index AXIS=I,...]`, the flags of every command that colours a surface.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ColorByArgs {
    /// Colour the surface by another volume: a file or folder isogrid reads (resampled in world
    /// space when its grid differs), or AXIS=I,... for another entry of INPUT's extra axes, e.g.
    /// `--index c=0 --color-by c=1` for a second channel. It is sampled at each active cell's
    /// surface point (`mc`: at every vertex: the PLY property `quality`, a .vtp point array or a
    /// .glb vertex attribute `_VALUE`); a .cgc file brings its own attribute.
    #[arg(long, value_name = "ATTR")]
    pub color_by: Option<String>,
    /// Entry of each extra axis of the --color-by file, as --index picks INPUT's: the volume t of
    /// a 4-D NIfTI or MGH file, a channel or time point of a Zarr image or TIFF hyperstack, e.g.
    /// `--color-by pet.nii.gz --color-index t=3`.
    #[arg(long, value_name = "AXIS=I,...", requires = "color_by")]
    pub color_index: Option<String>,
}

impl ColorByArgs {
    /// The attribute these flags ask for (`None` without `--color-by`) for a surface of `input`
    /// read with `input_options`.
    pub fn attribute(
        &self,
        input: &Path,
        input_options: &ReadOptions,
    ) -> Result<Option<AttributeInput>> {
        let Some(text) = self.color_by.as_deref() else {
            return Ok(None);
        };
        AttributeInput::new(text, self.color_index.as_deref(), input, input_options).map(Some)
    }
}

/// Where an attribute's samples come from.
#[derive(Debug, Clone)]
pub struct AttributeInput {
    pub path: PathBuf,
    pub options: ReadOptions,
    /// What the file's attribute section calls it.
    pub name: String,
}

impl AttributeInput {
    /// The files a command reads: `input`, and the attribute's file (which no output may be).
    pub fn inputs<'a>(input: &'a Path, attribute: Option<&'a AttributeInput>) -> Vec<&'a Path> {
        let mut inputs = vec![input];
        inputs.extend(attribute.map(|a| a.path.as_path()));
        inputs
    }

    /// `--color-by TEXT [--color-index INDEX]` for a surface of `input` read with
    /// `input_options`.
    fn new(
        text: &str,
        index: Option<&str>,
        input: &Path,
        input_options: &ReadOptions,
    ) -> Result<Self> {
        let as_path = PathBuf::from(text);
        if !as_path.exists() && text.contains('=') {
            if index.is_some() {
                bail!(
                    "--color-by {text} picks another entry of INPUT's own axes; --color-index picks \
                     from a --color-by file, and is not needed"
                );
            }
            let indices = parse_indices(text, "--color-by").map_err(anyhow::Error::msg)?;
            let mut options = input_options.clone();
            options.zarr.indices = indices;
            options.zarr.index_flag = IndexFlag::Cli("--color-by");
            return Ok(AttributeInput {
                path: input.to_path_buf(),
                options,
                name: text.to_string(),
            });
        }
        let mut options = ReadOptions::default();
        options.zarr.trusted_certificates = input_options.zarr.trusted_certificates.clone();
        options.zarr.index_flag = IndexFlag::Cli("--color-index");
        let mut name = as_path
            .file_name()
            .map_or_else(|| text.to_string(), |n| n.to_string_lossy().into_owned());
        if let Some(index) = index {
            options.zarr.indices =
                parse_indices(index, "--color-index").map_err(anyhow::Error::msg)?;
            name = format!("{name} {index}");
        }
        Ok(AttributeInput {
            path: as_path,
            options,
            name,
        })
    }

    /// The attribute at `points`, in the index space of `surface`'s volume of `geometry` (a
    /// mesh's vertices), the attribute read whole.
    pub fn sample_points(
        &self,
        geometry: &isogrid::Geometry,
        points: &[[f64; 3]],
        surface: &Path,
    ) -> Result<Vec<f32>> {
        let (volume, _) = crate::input::read_volume(&self.path, &self.options)?;
        sample_points_in_memory(geometry, points, &volume.view()).map_err(|e| {
            anyhow!(
                "{}: {} (the surface is {})",
                self.path.display(),
                e,
                surface.display()
            )
        })
    }

    /// Samples the attribute at every active cell of `grid` (the surface of `surface`).
    pub fn sample(
        &self,
        grid: &CellGrid,
        surface: &Path,
        precision: AttributePrecision,
    ) -> Result<CellAttribute> {
        let mut region = isogrid_io::open_region(&self.path, &self.options)?;
        let volume = match region {
            Some(_) => None,
            None => Some(crate::input::read_volume(&self.path, &self.options)?.0),
        };
        let geometry = match (&region, &volume) {
            (Some(region), _) => region.geometry(),
            (None, Some(volume)) => *volume.geometry(),
            (None, None) => unreachable!("one of the two is read"),
        };
        let name_both = |e: isogrid::Error| {
            anyhow!(
                "{}: {} (the surface is {})",
                self.path.display(),
                e,
                surface.display()
            )
        };
        let surface_frame = grid.info().frame;
        if geometry.frame.converts_to(surface_frame) {
            eprintln!(
                "isogrid: note: {}'s {} world coordinates are taken into {}'s {} ones",
                self.path.display(),
                geometry.frame.name(),
                surface.display(),
                surface_frame.name()
            );
        }
        if let Alignment::Resampled { .. } =
            alignment(&grid_geometry(grid.info()), &geometry).map_err(name_both)?
        {
            eprintln!(
                "isogrid: note: {} ({:?} samples, spacing {:?}) is resampled onto the surface of {} in world space",
                self.path.display(),
                geometry.dims,
                geometry.spacing,
                surface.display()
            );
        }
        match (region.as_deref_mut(), &volume) {
            (Some(region), _) => sample_attribute(grid, region, &self.name, precision),
            (None, Some(volume)) => {
                sample_attribute_in_memory(grid, &volume.view(), &self.name, precision)
            }
            (None, None) => unreachable!("one of the two is read"),
        }
        .map_err(name_both)
    }
}

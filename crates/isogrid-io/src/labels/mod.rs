//! Label volumes as files hold them, with the names and colours the files give: 3D Slicer
//! segmentations (`.seg.nrrd`, layered or not), OME-Zarr label images (`image.zarr/labels/NAME`),
//! folders of NIfTI masks (TotalSegmentator's, `masks`) and colour tables given beside
//! the volume ([`read_label_table`]). Any other volume file is a label volume without names.
//!
//! A file's labels are numbered by their values in the volume, with one exception: a layered
//! `.seg.nrrd` (segments that overlap are kept in separate layers, a 4-D file whose first axis is
//! the layer) has a value per segment *within its layer*, and the same value may mean different
//! segments in different layers. Its labels are (layer, value) pairs, numbered layer after layer:
//! label `value + offset(layer)`, where `offset(0) = 0` and each next layer's offset is the
//! previous offset plus the largest value in the previous layer. Value 0 is every layer's
//! background. Each layer is extracted on its own (so overlapping segments each keep their whole
//! surface) and the grids are joined into one ([`isogrid::merge_label_grids`]).

mod masks;
mod ome;
mod segmentation;
mod table;

pub use ome::{label_image_path, ome_label_names};
pub use table::{parse_label_table, read_label_table};

use crate::read_options::ReadOptions;
use isogrid::extract::stream::RegionSource;
use isogrid::labels::LabelSample;
use isogrid::{
    CellGrid, Label, LabelOptions, LabelSelection, Progress, Result, ResultExt, Samples, Volume,
};
use std::path::Path;

/// A label volume read from a file, with the names and colours the file gives.
pub struct LabelVolume {
    /// One volume, or a layered segmentation's layers; each layer's label `v` (but 0) is the
    /// file's label `v + offset`.
    pub layers: Vec<LabelLayer>,
    /// The names and colours the file gives, by the file's label value (empty when it gives none).
    pub names: Vec<Label>,
}

/// One layer of a [`LabelVolume`].
pub struct LabelLayer {
    pub volume: Volume,
    /// Added to the layer's values (but 0) to give the file's label values.
    pub offset: u64,
}

impl LabelVolume {
    /// A volume without names.
    pub fn plain(volume: Volume) -> Self {
        LabelVolume {
            layers: vec![LabelLayer { volume, offset: 0 }],
            names: Vec::new(),
        }
    }
}

/// Reads a label volume and the names and colours its file gives: a `.seg.nrrd` (any NRRD with
/// `SegmentN_` keys), an OME-Zarr label image (`image.zarr/labels/NAME`), a folder of NIfTI
/// masks (one label per file, named after it), or any volume file
/// [`crate::read_volume`] reads. Returns notices for the user, as [`crate::read_volume_noted`].
pub fn read_label_volume(path: &Path, opts: &ReadOptions) -> Result<(LabelVolume, Vec<String>)> {
    if opts.raw.is_none() && masks::is_mask_folder(path) {
        return masks::read(path, opts);
    }
    if is_nrrd(path) && opts.raw.is_none() {
        return segmentation::read(path).map(|v| (v, Vec::new()));
    }
    let (volume, notices) = crate::read_volume_noted(path, opts)?;
    let mut source = LabelVolume::plain(volume);
    if path.is_dir() {
        source.names = ome_label_names(path)?;
    }
    Ok((source, notices))
}

/// A label volume read by region, and the names and colours its file gives (by label value).
pub type LabelRegion = (Box<dyn RegionSource + Send>, Vec<Label>);

/// Opens a label volume for reading by region (see [`crate::open_region`]), with the names and
/// colours its file gives: `path`, or its OME-Zarr label image `labels_of`. A one-layer NRRD (a
/// 3D Slicer segmentation whose segments do not overlap, or a plain label volume) reads by region
/// where its encoding allows, named by its header's `SegmentN_` keys. `None` where it must be
/// read whole with [`read_labels_of`]: a format or encoding without region reads, and a layered
/// segmentation (its layers are numbered after each other's largest value, which takes every
/// sample).
pub fn open_label_region(
    path: &Path,
    labels_of: Option<&str>,
    opts: &ReadOptions,
) -> Result<Option<LabelRegion>> {
    let path = match labels_of {
        None => path.to_path_buf(),
        Some(name) => label_image_path(path, name)?,
    };
    // Its masks are read whole, one after another, into layers.
    if masks::is_mask_folder(&path) {
        return Ok(None);
    }
    // A NRRD's header: its layers decide how it is read, its keys name its labels.
    let nrrd_keys = match is_nrrd(&path) && opts.raw.is_none() {
        true => match crate::nrrd::header_layers_and_keys(&path)? {
            (layers, _) if layers > 1 => return Ok(None),
            (_, key_values) => Some(key_values),
        },
        false => None,
    };
    let Some(source) = crate::open_region(&path, opts)? else {
        return Ok(None);
    };
    let names = if let Some(key_values) = nrrd_keys {
        segmentation::one_layer_names(&path, &key_values)?
    } else if path.is_dir() {
        ome_label_names(&path)?
    } else {
        Vec::new()
    };
    Ok(Some((source, names)))
}

fn is_nrrd(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    name.ends_with(".nrrd") || name.ends_with(".nhdr")
}

/// Extracts the labels `options` selects from `source` (one pass per layer, see the module
/// documentation) and gives them the file's names and colours; the other labels keep the default
/// ones ([`Label::default_for`]).
pub fn extract_label_volume(source: &LabelVolume, options: &LabelOptions) -> Result<CellGrid> {
    extract_label_volume_with_progress(source, options, &Progress::new())
}

/// [`extract_label_volume`], counting in `progress` as [`isogrid::extract_labels_with_progress`]
/// does (a layered segmentation's layers one after another, each from 0) and honouring its
/// cancel.
pub fn extract_label_volume_with_progress(
    source: &LabelVolume,
    options: &LabelOptions,
    progress: &Progress,
) -> Result<CellGrid> {
    let mut grid = if let [layer] = source.layers.as_slice() {
        if layer.offset != 0 {
            return Err(isogrid::Error::invalid(
                "a single layer's values are the file's labels",
            ));
        }
        isogrid::extract_labels_with_progress(&layer.volume.view(), options, progress)?
    } else {
        let mut grids = Vec::with_capacity(source.layers.len());
        for (l, layer) in source.layers.iter().enumerate() {
            let layer_options = LabelOptions {
                selection: layer_selection(&options.selection, layer, l == 0),
                ..options.clone()
            };
            grids.push(isogrid::extract_labels_with_progress(
                &layer.volume.view(),
                &layer_options,
                progress,
            )?);
        }
        let signed = isogrid::labels::signed_labels(source.layers[0].volume.scalar_type());
        let parts: Vec<(&CellGrid, Vec<Label>)> = grids
            .iter()
            .zip(&source.layers)
            .map(|(g, layer)| {
                let table = g.labels().expect("a label grid has labels").table();
                let renamed = table
                    .iter()
                    .map(|l| Label::default_for(layer_value(l.value, layer.offset), signed))
                    .collect();
                (g, renamed)
            })
            .collect();
        isogrid::merge_label_grids(&parts)?
    };
    apply_label_names(&mut grid, &source.names);
    Ok(grid)
}

/// The file's label of a layer's value `v` (0 stays the background).
fn layer_value(v: u64, offset: u64) -> u64 {
    if v == 0 {
        0
    } else {
        v + offset
    }
}

/// The values of `layer` that `selection` selects as file labels: those above 0 whose value plus
/// the offset is selected (a layer holds no value above the next layer's offset, so these never
/// reach the next layer's labels), and the background 0 in the first layer only.
fn layer_selection(selection: &LabelSelection, layer: &LabelLayer, first: bool) -> LabelSelection {
    let mut ranges = Vec::new();
    if first && selection.selects(0) {
        ranges.push(0..=0);
    }
    match selection {
        LabelSelection::All => ranges.push(1..=u64::MAX),
        // Front doors resolve names to values before extraction (`resolve_label_names`).
        LabelSelection::Values(wanted) | LabelSelection::Named { ranges: wanted, .. } => ranges
            .extend(
                wanted
                    .iter()
                    .flat_map(LabelSelection::key_ranges)
                    .filter_map(|r| {
                        let from = (*r.start()).max(layer.offset.saturating_add(1));
                        (from <= *r.end()).then(|| from - layer.offset..=*r.end() - layer.offset)
                    }),
            ),
    }
    LabelSelection::Values(ranges)
}

/// The largest label key among `samples` (0 for none).
pub(crate) fn max_key(samples: Samples<'_>) -> u64 {
    fn max<T: LabelSample>(s: &[T]) -> u64 {
        use rayon::prelude::*;
        s.par_chunks(1 << 16)
            .map(|c| c.iter().map(|v| v.key()).max().unwrap_or(0))
            .max()
            .unwrap_or(0)
    }
    isogrid::volume::with_samples!(samples, s => max(s))
}

/// `selection` with its names (`--labels liver,spleen`) resolved to values before extraction:
/// against the names the label file gives (`file_names`: a folder of masks, a `.seg.nrrd`, an
/// OME-Zarr label image), with those of a colour table (`table`) winning where both name a value,
/// as they do in the grid made ([`apply_label_names`]).
pub fn resolve_label_names(
    selection: &LabelSelection,
    file_names: &[Label],
    table: Option<&[Label]>,
) -> Result<LabelSelection> {
    if !matches!(selection, LabelSelection::Named { .. }) {
        return Ok(selection.clone());
    }
    let mut named = std::collections::BTreeMap::new();
    for label in file_names.iter().chain(table.unwrap_or_default()) {
        named.insert(label.value, label.clone());
    }
    selection.resolved(&named.into_values().collect::<Vec<_>>())
}

/// Gives the grid's labels the names and colours `names` has for their values; returns the
/// values `names` lists (but 0, the background) that the grid does not hold, for a notice.
pub fn apply_label_names(grid: &mut CellGrid, names: &[Label]) -> Vec<u64> {
    let Some(labels) = grid.labels_mut() else {
        return Vec::new();
    };
    let mut table = labels.table().to_vec();
    let absent = name_labels(&mut table, names);
    labels
        .set_table(table)
        .expect("names and colours keep the values");
    absent
}

/// Gives the labels of `table` (in increasing value) the names and colours `names` has for
/// their values; returns the values `names` lists (but 0) that the table lacks. The rule of
/// [`apply_label_names`], for a table not yet in a grid (a streamed extraction's).
pub fn name_labels(table: &mut [Label], names: &[Label]) -> Vec<u64> {
    let mut absent = Vec::new();
    for named in names {
        match table.binary_search_by_key(&named.value, |l| l.value) {
            Ok(i) => {
                table[i].name = named.name.clone();
                table[i].rgba = named.rgba;
            }
            Err(_) if named.value != 0 => absent.push(named.value),
            Err(_) => {}
        }
    }
    absent
}

/// The notice for a colour table's labels that `selection` asks for and the grid does not hold
/// (`absent`, as [`name_labels`] gives them; none when all are there): a table of every label of an
/// atlas given with a few of them selected lists the others, and they are not news.
pub fn absent_labels_notice(
    table: &Path,
    absent: &[u64],
    selection: &LabelSelection,
    signed: bool,
) -> Option<String> {
    const SHOWN: usize = 10;
    let absent: Vec<u64> = absent
        .iter()
        .copied()
        .filter(|&v| selection.selects(v))
        .collect();
    if absent.is_empty() {
        return None;
    }
    let shown: Vec<String> = absent
        .iter()
        .take(SHOWN)
        .map(|&v| isogrid::labels::display_value(v, signed))
        .collect();
    let more = if absent.len() > SHOWN { ", …" } else { "" };
    Some(format!(
        "{}: {} label{} of the table {} not among the labels extracted ({}{more})",
        table.display(),
        absent.len(),
        if absent.len() == 1 { "" } else { "s" },
        if absent.len() == 1 { "is" } else { "are" },
        shown.join(", ")
    ))
}

/// Reads `path` (an image, with `labels_of` the name of one of its OME-Zarr label images) as a
/// label volume: [`read_label_volume`] of `path`, or of `path/labels/NAME`.
pub fn read_labels_of(
    path: &Path,
    labels_of: Option<&str>,
    opts: &ReadOptions,
) -> Result<(LabelVolume, Vec<String>)> {
    match labels_of {
        None => read_label_volume(path, opts),
        Some(name) => {
            let label_path = label_image_path(path, name)?;
            read_label_volume(&label_path, opts).at_path(&label_path)
        }
    }
}

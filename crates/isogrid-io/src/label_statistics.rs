//! Segment statistics of a label volume before any surface is extracted: each selected label's
//! voxels, volume, box, name and colour, as `isogrid info VOLUME --labels` and Python's
//! `isogrid.label_statistics` list them.
//!
//! Boxes are in index space: the sample indices `[lo, hi)` per axis of the label's voxels. A
//! label's volume is its voxels × the voxel's volume (the product of the spacing: the spacing's
//! units cubed, mm³ for medical images). Names and colours are those `extract --labels` gives:
//! the default palette ([`Label::default_for`]), then the file's names, then a colour table's.

use crate::labels::{absent_labels_notice, name_labels, open_label_region, read_labels_of};
use crate::labels::{resolve_label_names, LabelVolume};
use crate::read_options::ReadOptions;
use isogrid::label_census::{label_census, LabelCount};
use isogrid::labels::signed_labels;
use isogrid::{Geometry, Label, LabelSelection, Progress, Result, ResultExt, ScalarType};
use std::path::Path;

/// One label of a label volume.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelStatistics {
    /// Its key (a signed volume's value as its two's complement), name and colour.
    pub label: Label,
    /// Samples holding it.
    pub voxels: u64,
    /// `voxels` × the voxel's volume, in the spacing's units cubed.
    pub volume: f64,
    /// Its voxels' box in sample indices, `[lo, hi)` per axis.
    pub lo: [u64; 3],
    pub hi: [u64; 3],
}

/// A label volume's grid and its selected labels.
#[derive(Debug, Clone)]
pub struct VolumeLabels {
    pub geometry: Geometry,
    pub scalar_type: ScalarType,
    /// Whether label keys are a signed type's values.
    pub signed: bool,
    /// The smallest and largest value the samples hold, background included; `None` for an
    /// empty volume.
    pub range: Option<(f64, f64)>,
    /// The selected labels but the background 0, by increasing key.
    pub labels: Vec<LabelStatistics>,
    /// Notes for the user: the reader's, and the colour table's labels the volume lacks.
    pub notices: Vec<String>,
}

/// A colour table given beside the volume: its file (named in notices) and its labels.
#[derive(Debug, Clone, Copy)]
pub struct GivenTable<'a> {
    pub path: &'a Path,
    pub labels: &'a [Label],
}

/// The statistics of the labels `selection` chooses (values, ranges, and names the file or
/// `table` give) of the label volume file `path`, or of its OME-Zarr label image `labels_of`.
/// Reads by region within `max_memory` bytes where the format allows ([`open_label_region`]),
/// so a volume larger than memory is counted slab by slab; else whole ([`read_labels_of`]: a
/// layered segmentation's layers each count their own values, numbered after each other), as
/// one step of `progress`. `spacing` replaces the file's. Errors name `path`; a cancelled
/// `progress` stops the count by region between slabs.
#[allow(clippy::too_many_arguments)]
pub fn file_label_statistics(
    path: &Path,
    labels_of: Option<&str>,
    options: &ReadOptions,
    selection: &LabelSelection,
    table: Option<GivenTable<'_>>,
    spacing: Option<[f64; 3]>,
    max_memory: u64,
    progress: &Progress,
) -> Result<VolumeLabels> {
    let resolve = |names: &[Label]| {
        resolve_label_names(selection, names, table.map(|t| t.labels)).at_path(path)
    };
    let (mut geometry, scalar_type, censuses, names, notices, selection) =
        match open_label_region(path, labels_of, options)? {
            Some((mut source, names)) => {
                // Names are resolved first: a name the file does not give fails before the count.
                let selection = resolve(&names)?;
                let census = isogrid::extract::stream::source_label_census(
                    source.as_mut(),
                    max_memory,
                    progress,
                )
                .at_path(path)?;
                let (geometry, scalar_type) = (source.geometry(), source.scalar_type());
                let census = vec![(census, 0)];
                (geometry, scalar_type, census, names, Vec::new(), selection)
            }
            None => {
                // Read whole and counted in memory: one step of `progress`.
                progress.start(1);
                let (volume, notices) = read_labels_of(path, labels_of, options)?;
                let selection = resolve(&volume.names)?;
                let (geometry, scalar_type, censuses) = layer_censuses(&volume).at_path(path)?;
                progress.advance(1);
                (
                    geometry,
                    scalar_type,
                    censuses,
                    volume.names,
                    notices,
                    selection,
                )
            }
        };
    if let Some(spacing) = spacing {
        geometry.spacing = spacing;
    }
    let mut labels = statistics(censuses, geometry, scalar_type, &names, &selection, table);
    labels.notices.splice(0..0, notices);
    Ok(labels)
}

/// [`file_label_statistics`] of a label volume in memory (one layer, no names of its own).
pub fn volume_label_statistics(
    volume: &isogrid::VolumeView<'_>,
    selection: &LabelSelection,
    table: Option<GivenTable<'_>>,
) -> Result<VolumeLabels> {
    let census = label_census(volume)?;
    let selection = resolve_label_names(selection, &[], table.map(|t| t.labels))?;
    Ok(statistics(
        vec![(census, 0)],
        *volume.geometry(),
        volume.scalar_type(),
        &[],
        &selection,
        table,
    ))
}

/// Each layer's census with the offset of its values (see the module documentation of
/// [`crate::labels`]), and the first layer's grid and type, which every layer shares.
#[allow(clippy::type_complexity)]
fn layer_censuses(
    volume: &LabelVolume,
) -> Result<(Geometry, ScalarType, Vec<(Vec<LabelCount>, u64)>)> {
    let first = &volume.layers[0].volume;
    let censuses = volume
        .layers
        .iter()
        .map(|layer| Ok((label_census(&layer.volume.view())?, layer.offset)))
        .collect::<Result<_>>()?;
    Ok((*first.geometry(), first.scalar_type(), censuses))
}

/// The selected labels of the layers' censuses (each layer's values but 0 are labels less the
/// layer's offset), named by the file's `names`, then by `table`.
fn statistics(
    censuses: Vec<(Vec<LabelCount>, u64)>,
    geometry: Geometry,
    scalar_type: ScalarType,
    names: &[Label],
    selection: &LabelSelection,
    table: Option<GivenTable<'_>>,
) -> VolumeLabels {
    let signed = signed_labels(scalar_type);
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
    name_labels(&mut labels, names);
    let mut notices = Vec::new();
    if let Some(table) = table {
        let absent = name_labels(&mut labels, table.labels);
        notices.extend(absent_labels_notice(table.path, &absent, selection, signed));
    }
    // The range of the values, the background's among them where a sample holds it.
    let as_value = |k: u64| if signed { k as i64 as f64 } else { k as f64 };
    let range = counts
        .iter()
        .map(|c| c.value)
        .chain(background.then_some(0))
        .map(as_value)
        .fold(None, |r: Option<(f64, f64)>, v| {
            Some(r.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))))
        });
    let voxel = geometry.spacing.iter().product::<f64>();
    let labels = counts
        .iter()
        .zip(labels)
        .filter(|(c, _)| selection.selects(c.value))
        .map(|(c, label)| LabelStatistics {
            label,
            voxels: c.voxels,
            volume: c.voxels as f64 * voxel,
            lo: c.lo,
            hi: c.hi,
        })
        .collect();
    VolumeLabels {
        geometry,
        scalar_type,
        signed,
        range,
        labels,
        notices,
    }
}

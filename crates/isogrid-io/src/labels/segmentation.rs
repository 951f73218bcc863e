//! 3D Slicer segmentations (`.seg.nrrd`): a NRRD label volume, or a 4-D one with a layer axis
//! first, whose `key:=value` pairs describe the segments: `SegmentN_Name`, `SegmentN_Color`
//! (three floats 0..1), `SegmentN_LabelValue` (its value in its layer) and `SegmentN_Layer`, as
//! Slicer's vtkMRMLSegmentationStorageNode writes them (N from 0). Files from before layers (one
//! binary volume per segment, no `LabelValue` or `Layer`) are read as Slicer reads them: segment
//! N in layer N with value 1.

use super::{max_key, LabelLayer, LabelVolume};
use isogrid::{Error, Label, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// One segment's fields, as written.
#[derive(Default)]
struct Segment {
    name: Option<String>,
    color: Option<String>,
    label_value: Option<String>,
    layer: Option<String>,
}

/// A segment as placed by the header: its layer, its value in the layer, its name and colour.
type Placed = (usize, u64, String, Option<[u8; 4]>);

pub(super) fn read(path: &Path) -> Result<LabelVolume> {
    let (volumes, key_values) = crate::nrrd::read_nrrd_layers(path, true)?;
    let placed = segments(path, &key_values, volumes.len())?;
    // Offsets: each layer's labels follow the largest value of the previous layer, in its
    // samples or among its segments (an empty segment keeps its own number).
    let mut layers = Vec::with_capacity(volumes.len());
    let mut offset = 0u64;
    for (l, volume) in volumes.into_iter().enumerate() {
        let declared = placed.iter().filter(|p| p.0 == l).map(|p| p.1).max();
        let max = max_key(volume.data().samples()).max(declared.unwrap_or(0));
        layers.push(LabelLayer { volume, offset });
        offset = offset.checked_add(max).ok_or_else(|| {
            Error::unsupported("the layers' label values are too large to number together")
                .with_path(path)
        })?;
    }
    let offsets: Vec<u64> = layers.iter().map(|l| l.offset).collect();
    let names = named(path, placed, &offsets)?;
    Ok(LabelVolume { layers, names })
}

/// The segments `key_values` (a NRRD header's `key:=value` pairs) describe, in a file of
/// `layer_count` layers, checked.
fn segments(
    path: &Path,
    key_values: &[(String, String)],
    layer_count: usize,
) -> Result<Vec<Placed>> {
    let mut segments: BTreeMap<usize, Segment> = BTreeMap::new();
    for (key, value) in key_values {
        let Some((n, field)) = key
            .strip_prefix("Segment")
            .and_then(|rest| rest.split_once('_'))
            .and_then(|(n, field)| Some((n.parse::<usize>().ok()?, field)))
        else {
            continue;
        };
        let s = segments.entry(n).or_default();
        let slot = match field {
            "Name" => &mut s.name,
            "Color" => &mut s.color,
            "LabelValue" => &mut s.label_value,
            "Layer" => &mut s.layer,
            _ => continue,
        };
        *slot = Some(value.trim().to_string());
    }

    // Each segment's layer and value, as written (defaults as Slicer reads old files).
    let layered = layer_count > 1;
    let mut placed = Vec::with_capacity(segments.len());
    for (n, s) in &segments {
        let bad = |what: String| Error::corrupt(format!("Segment{n}_{what}")).with_path(path);
        let number = |text: &Option<String>, field: &str, default: u64| -> Result<u64> {
            match text {
                None => Ok(default),
                Some(t) => t
                    .parse::<u64>()
                    .map_err(|_| bad(format!("{field} {t:?} is not a non-negative integer"))),
            }
        };
        // Before layers, segment N was layer N, value 1.
        let layer = number(&s.layer, "Layer", if layered { *n as u64 } else { 0 })?;
        let value = number(&s.label_value, "LabelValue", 1)?;
        if layer >= layer_count as u64 {
            return Err(bad(format!(
                "Layer {layer} is beyond the file's {} layer{}",
                layer_count,
                if layer_count == 1 { "" } else { "s" }
            )));
        }
        if value == 0 {
            return Err(bad("LabelValue 0 is the background, not a segment".into()));
        }
        let rgba = match &s.color {
            None => None,
            Some(text) => {
                let c: Vec<f64> = text
                    .split_whitespace()
                    .map(|v| v.parse::<f64>())
                    .collect::<std::result::Result<_, _>>()
                    .ok()
                    .filter(|c: &Vec<f64>| {
                        c.len() == 3 && c.iter().all(|v| (0.0..=1.0).contains(v))
                    })
                    .ok_or_else(|| bad(format!("Color {text:?} is not three numbers 0..1")))?;
                Some([
                    (c[0] * 255.0).round() as u8,
                    (c[1] * 255.0).round() as u8,
                    (c[2] * 255.0).round() as u8,
                    255,
                ])
            }
        };
        let name = s.name.clone().unwrap_or_else(|| format!("Segment_{n}"));
        placed.push((layer as usize, value, name, rgba));
    }

    Ok(placed)
}

/// The file's names and colours by label value: each segment's value in its layer moved by the
/// layer's offset, sorted; two segments on one value are an error.
fn named(path: &Path, placed: Vec<Placed>, offsets: &[u64]) -> Result<Vec<Label>> {
    let mut names: Vec<Label> = placed
        .into_iter()
        .map(|(layer, value, name, rgba)| {
            let value = value + offsets[layer];
            Label {
                value,
                name,
                rgba: rgba.unwrap_or_else(|| isogrid::labels::palette(value)),
            }
        })
        .collect();
    names.sort_by_key(|l| l.value);
    if let Some(w) = names.windows(2).find(|w| w[0].value == w[1].value) {
        return Err(Error::corrupt(format!(
            "two segments ({:?} and {:?}) have the same layer and LabelValue",
            w[0].name, w[1].name
        ))
        .with_path(path));
    }
    Ok(names)
}

/// The names and colours of a one-layer segmentation (or of any 3-D NRRD: none without
/// `SegmentN_` keys), from its header's `key_values` alone, for reading its samples by region.
pub(super) fn one_layer_names(path: &Path, key_values: &[(String, String)]) -> Result<Vec<Label>> {
    named(path, segments(path, key_values, 1)?, &[0])
}

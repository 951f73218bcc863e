//! OME-Zarr label images (OME-NGFF 0.4 and 0.5, "labels"): an image's `labels/` group lists its
//! label images by name (`"labels": [...]`), and each, `labels/NAME`, is a multiscale image whose
//! `image-label` metadata may give `colors` (`label-value`, `rgba` 0..255) and `properties`
//! (`label-value` and any other keys). A label's name is its `name` property, else the first
//! string property whose key holds "name". Metadata is read from `.zattrs` (Zarr v2) or the
//! `attributes` of `zarr.json` (Zarr v3), under `ome` in 0.5. Local folders only.

use isogrid::{Error, Label, Result};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A group's OME attributes: `.zattrs`, or `zarr.json`'s `attributes` (their `ome` member when
/// there is one). `None` when the folder has neither.
fn ome_attributes(dir: &Path) -> Result<Option<Value>> {
    let read = |name: &str| -> Result<Option<Value>> {
        let file = dir.join(name);
        if !file.is_file() {
            return Ok(None);
        }
        let text = std::fs::read(&file).map_err(|e| Error::io(e).with_path(&file))?;
        serde_json::from_slice(&text)
            .map(Some)
            .map_err(|e| Error::corrupt(format!("not JSON: {e}")).with_path(&file))
    };
    let attrs = match read("zarr.json")? {
        Some(meta) => meta.get("attributes").cloned(),
        None => read(".zattrs")?,
    };
    Ok(attrs.map(|a| a.get("ome").cloned().unwrap_or(a)))
}

/// The folder of label image `name` of the OME-Zarr image `image`, checked against the names its
/// `labels/` group lists; the error lists the names there are.
pub fn label_image_path(image: &Path, name: &str) -> Result<PathBuf> {
    let group = image.join("labels");
    let listed: Vec<String> = ome_attributes(&group)?
        .and_then(|a| a.get("labels").cloned())
        .and_then(|l| serde_json::from_value(l).ok())
        .unwrap_or_default();
    if listed.is_empty() {
        return Err(Error::invalid(format!(
            "the image has no OME-Zarr label images (no labels/ group listing any), so no {name:?}"
        ))
        .with_path(image));
    }
    if !listed.iter().any(|l| l == name) {
        return Err(Error::invalid(format!(
            "no label image {name:?}; the image has {}",
            listed
                .iter()
                .map(|l| format!("{l:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        ))
        .with_path(image));
    }
    Ok(group.join(name))
}

/// The names and colours of an OME-Zarr label image's `image-label` metadata, by label value
/// (empty when the folder is no label image). A label with a colour but no name is named
/// `label V`; one with a name but no colour gets the palette's.
pub fn ome_label_names(dir: &Path) -> Result<Vec<Label>> {
    let Some(attrs) = ome_attributes(dir)? else {
        return Ok(Vec::new());
    };
    let Some(image_label) = attrs.get("image-label") else {
        return Ok(Vec::new());
    };
    let bad = |what: String| Error::corrupt(format!("OME-Zarr image-label: {what}")).with_path(dir);
    let list = |key: &str| -> Result<Vec<Value>> {
        match image_label.get(key) {
            None => Ok(Vec::new()),
            Some(Value::Array(a)) => Ok(a.clone()),
            Some(_) => Err(bad(format!("{key} is not a list"))),
        }
    };
    let value_of = |entry: &Value, key: &str| -> Result<u64> {
        let v = entry
            .get("label-value")
            .ok_or_else(|| bad(format!("an entry of {key} has no label-value")))?;
        v.as_u64()
            .or_else(|| v.as_i64().map(|v| v as u64))
            .ok_or_else(|| bad(format!("label-value {v} of {key} is not an integer")))
    };
    let mut labels: BTreeMap<u64, (Option<String>, Option<[u8; 4]>)> = BTreeMap::new();
    for entry in list("colors")? {
        let value = value_of(&entry, "colors")?;
        let rgba: Option<[u8; 4]> = entry
            .get("rgba")
            .and_then(|c| c.as_array())
            .filter(|c| c.len() == 4)
            .and_then(|c| {
                let v: Option<Vec<u8>> = c
                    .iter()
                    .map(|x| x.as_u64().and_then(|x| u8::try_from(x).ok()))
                    .collect();
                v.map(|v| [v[0], v[1], v[2], v[3]])
            });
        let rgba = rgba.ok_or_else(|| {
            bad(format!(
                "the rgba of label {value} is not four integers 0..255"
            ))
        })?;
        labels.entry(value).or_default().1 = Some(rgba);
    }
    for entry in list("properties")? {
        let value = value_of(&entry, "properties")?;
        let Some(props) = entry.as_object() else {
            continue;
        };
        let name = props.get("name").and_then(|n| n.as_str()).or_else(|| {
            props
                .iter()
                .filter(|(k, _)| k.to_ascii_lowercase().contains("name"))
                .find_map(|(_, v)| v.as_str())
        });
        if let Some(name) = name {
            labels.entry(value).or_default().0 = Some(name.to_string());
        }
    }
    Ok(labels
        .into_iter()
        .map(|(value, (name, rgba))| Label {
            value,
            name: name.unwrap_or_else(|| format!("label {value}")),
            rgba: rgba.unwrap_or_else(|| isogrid::labels::palette(value)),
        })
        .collect())
}

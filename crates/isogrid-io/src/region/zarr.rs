//! Zarr v2 and v3 arrays and OME-Zarr 0.4/0.5 multiscale images, read plane range by plane range
//! through the `zarrs` crate (sharding; blosc, gzip and zstd codecs; missing chunks read as the
//! array's fill value, as the Zarr specs say), from a folder or a URL. A slab asks the store for
//! only the chunks that hold its planes.
//!
//! - A store whose root is an array is read as it is. Its axes are named by `dimension_names`
//!   (v3) or `_ARRAY_DIMENSIONS` (v2, as xarray writes it); unnamed, the last three are z, y, x
//!   (numpy's C order) and any others `dim0`, `dim1`, …
//! - A root group with OME-Zarr `multiscales` (0.4: in `.zattrs`; 0.5: under `ome` in
//!   `zarr.json`) is an image: `level` picks the dataset (0 is full resolution), axes come from
//!   `axes`, spacing and origin from the dataset's `coordinateTransformations` (scale, then
//!   translation) followed by the multiscale's own.
//! - Axes are mapped by name to x, y and z; every other axis needs an index (`t=0`), unless it has
//!   a single entry.
//! - Sample types: u8, u16, i16 and f32 are kept; i8 and bool widen, the other integers and f64
//!   become f32, as for every other format of this crate.

mod file_store;
mod rows;

use super::ZarrOptions;
use crate::samples::ElemType;
use isogrid::extract::stream::{BlockMask, RegionSource, SlabMut};
use isogrid::{Error, Geometry, Result, ScalarType};
use serde_json::Value;
use std::ops::Range;
use std::sync::Arc;
use zarrs::array::{Array, ArraySubset};
use zarrs::storage::{ReadableStorage, ReadableStorageTraits, StoreKey};

/// The stored element types this reader accepts: the element types of the other readers, and
/// bool, kept as u8 (0 or 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stored {
    Bool,
    Elem(ElemType),
}

impl Stored {
    fn parse(name: &str) -> Option<Self> {
        Some(Stored::Elem(match name {
            "bool" => return Some(Stored::Bool),
            "uint8" => ElemType::U8,
            "int8" => ElemType::I8,
            "uint16" => ElemType::U16,
            "int16" => ElemType::I16,
            "uint32" => ElemType::U32,
            "int32" => ElemType::I32,
            "uint64" => ElemType::U64,
            "int64" => ElemType::I64,
            "float32" => ElemType::F32,
            "float64" => ElemType::F64,
            _ => return None,
        }))
    }
    fn size(self) -> usize {
        match self {
            Stored::Bool => 1,
            Stored::Elem(e) => e.size(),
        }
    }
    fn kept(self) -> ScalarType {
        match self {
            Stored::Bool => ScalarType::U8,
            Stored::Elem(e) => e.kept(),
        }
    }
}

/// A Zarr array (or one level of an OME-Zarr image) as a region-readable volume.
pub struct ZarrSource {
    array: Array<dyn ReadableStorageTraits>,
    /// Path or URL, for messages.
    location: String,
    stored: Stored,
    geometry: Geometry,
    /// Array axis of x, y and z.
    spatial: [usize; 3],
    /// Index along every other axis.
    fixed: Vec<(usize, u64)>,
    /// Bytes of one decoded chunk (of the outer chunk grid).
    chunk_bytes: u64,
    /// The chunk-by-chunk reader, for arrays whose last axes are z, y, x; `None` for others,
    /// which zarrs assembles by subset.
    rows: Option<rows::ChunkRows>,
}

fn zarr_error(location: &str, what: &str, e: impl std::fmt::Display) -> Error {
    Error::corrupt(format!("{what}: {e}")).with_path(location)
}

/// The JSON document at `key`, `None` when the store has no such key.
fn json_at(store: &ReadableStorage, key: &str, location: &str) -> Result<Option<Value>> {
    let key = StoreKey::new(key).map_err(|e| zarr_error(location, "bad store key", e))?;
    let Some(bytes) = store
        .get(&key)
        .map_err(|e| zarr_error(location, &format!("cannot read {key}"), e))?
    else {
        return Ok(None);
    };
    serde_json::from_slice(&bytes)
        .map(Some)
        .map_err(|e| zarr_error(location, &format!("{key} is not valid JSON"), e))
}

/// What the store's root is.
enum Root {
    Array,
    /// A group, with its attributes.
    Group(Value),
}

fn root_kind(store: &ReadableStorage, location: &str) -> Result<Root> {
    if let Some(meta) = json_at(store, "zarr.json", location)? {
        return match meta.get("node_type").and_then(Value::as_str) {
            Some("array") => Ok(Root::Array),
            Some("group") => Ok(Root::Group(
                meta.get("attributes").cloned().unwrap_or(Value::Null),
            )),
            other => Err(Error::corrupt(format!(
                "zarr.json has node_type {other:?}, expected \"array\" or \"group\""
            ))
            .with_path(location)),
        };
    }
    if json_at(store, ".zarray", location)?.is_some() {
        return Ok(Root::Array);
    }
    if json_at(store, ".zgroup", location)?.is_some() {
        let attrs = json_at(store, ".zattrs", location)?.unwrap_or(Value::Null);
        return Ok(Root::Group(attrs));
    }
    Err(
        Error::invalid("not a Zarr store: no zarr.json, .zarray or .zgroup at its root")
            .with_path(location),
    )
}

/// Axis names, spacing, origin of the picked level of an OME-Zarr image, and its array path.
struct Image {
    path: String,
    axes: Vec<String>,
    scale: Vec<f64>,
    translation: Vec<f64>,
}

fn numbers(v: &Value) -> Option<Vec<f64>> {
    v.as_array()?.iter().map(Value::as_f64).collect()
}

/// Applies a list of OME `coordinateTransformations` to (scale, translation).
fn apply_transforms(
    list: Option<&Value>,
    scale: &mut [f64],
    translation: &mut [f64],
    location: &str,
) -> Result<()> {
    let Some(list) = list.and_then(Value::as_array) else {
        return Ok(());
    };
    let bad = |what: &str| {
        Error::corrupt(format!("OME-Zarr coordinateTransformations: {what}")).with_path(location)
    };
    for t in list {
        match t.get("type").and_then(Value::as_str) {
            Some("identity") => {}
            Some("scale") => {
                let s = t
                    .get("scale")
                    .and_then(numbers)
                    .filter(|s| s.len() == scale.len())
                    .ok_or_else(|| {
                        bad("a scale needs one number per axis (paths are not supported)")
                    })?;
                for a in 0..scale.len() {
                    scale[a] *= s[a];
                    translation[a] *= s[a];
                }
            }
            Some("translation") => {
                let s = t
                    .get("translation")
                    .and_then(numbers)
                    .filter(|s| s.len() == scale.len())
                    .ok_or_else(|| bad("a translation needs one number per axis"))?;
                for a in 0..scale.len() {
                    translation[a] += s[a];
                }
            }
            other => return Err(bad(&format!("unsupported transformation type {other:?}"))),
        }
    }
    Ok(())
}

fn ome_image(attrs: &Value, level: usize, location: &str) -> Result<Image> {
    let multiscales = attrs
        .get("ome")
        .and_then(|o| o.get("multiscales"))
        .or_else(|| attrs.get("multiscales"))
        .and_then(Value::as_array)
        .and_then(|m| m.first())
        .ok_or_else(|| {
            Error::invalid("a Zarr group without OME-Zarr multiscales: open one of its arrays")
                .with_path(location)
        })?;
    let bad =
        |what: &str| Error::corrupt(format!("OME-Zarr multiscales: {what}")).with_path(location);
    let axes: Vec<String> = multiscales
        .get("axes")
        .and_then(Value::as_array)
        .ok_or_else(|| bad("no axes"))?
        .iter()
        .map(|a| {
            a.get("name")
                .and_then(Value::as_str)
                .or_else(|| a.as_str())
                .map(str::to_string)
        })
        .collect::<Option<_>>()
        .ok_or_else(|| bad("an axis has no name"))?;
    let datasets = multiscales
        .get("datasets")
        .and_then(Value::as_array)
        .filter(|d| !d.is_empty())
        .ok_or_else(|| bad("no datasets"))?;
    let dataset = datasets.get(level).ok_or_else(|| {
        Error::invalid(format!(
            "level {level} asked for, but the image has {} levels (0..={})",
            datasets.len(),
            datasets.len() - 1
        ))
        .with_path(location)
    })?;
    let path = dataset
        .get("path")
        .and_then(Value::as_str)
        .ok_or_else(|| bad("a dataset has no path"))?
        .to_string();
    let mut scale = vec![1.0; axes.len()];
    let mut translation = vec![0.0; axes.len()];
    apply_transforms(
        dataset.get("coordinateTransformations"),
        &mut scale,
        &mut translation,
        location,
    )?;
    apply_transforms(
        multiscales.get("coordinateTransformations"),
        &mut scale,
        &mut translation,
        location,
    )?;
    Ok(Image {
        path,
        axes,
        scale,
        translation,
    })
}

/// Axis names of a plain array (see the module doc).
fn array_axes(array: &Array<dyn ReadableStorageTraits>) -> Vec<String> {
    let n = array.dimensionality();
    let named: Option<Vec<String>> = array
        .dimension_names()
        .as_ref()
        .and_then(|names| names.iter().cloned().collect::<Option<Vec<String>>>())
        .or_else(|| {
            array
                .attributes()
                .get("_ARRAY_DIMENSIONS")
                .and_then(Value::as_array)
                .and_then(|a| a.iter().map(|v| v.as_str().map(str::to_string)).collect())
        })
        .filter(|names: &Vec<String>| names.len() == n);
    named.unwrap_or_else(|| default_axes(n))
}

/// Names of `n` unnamed axes: the last three z, y, x (numpy's C order), the others `dim0`, ….
fn default_axes(n: usize) -> Vec<String> {
    (0..n)
        .map(|i| match n - i {
            1 => "x".to_string(),
            2 => "y".to_string(),
            3 => "z".to_string(),
            _ => format!("dim{i}"),
        })
        .collect()
}

/// What a volume reader decides from a store's metadata before it reads any chunk (see the
/// module doc): the array axes of x, y and z, the entry picked on every other axis, and the
/// volume's geometry. Public so that other readers of the same store (the Python
/// package's Dask extraction, through zarr-python) decide exactly as [`ZarrSource`] does.
#[derive(Debug, Clone, PartialEq)]
pub struct ZarrSelection {
    /// Array axis of x, y and z.
    pub spatial: [usize; 3],
    /// Index along every other axis: (array axis, entry).
    pub fixed: Vec<(usize, u64)>,
    pub geometry: Geometry,
}

/// The array path (inside the store, without a leading `/`) that `options.level` of the OME-Zarr
/// image with root group attributes `attrs_json` names; errors as [`ZarrSource::open`] does.
pub fn ome_level_path(attrs_json: &str, level: usize, location: &str) -> Result<String> {
    let attrs = parse_attrs(attrs_json, location)?;
    Ok(ome_image(&attrs, level, location)?
        .path
        .trim_matches('/')
        .to_string())
}

fn parse_attrs(attrs_json: &str, location: &str) -> Result<Value> {
    serde_json::from_str(attrs_json)
        .map_err(|e| zarr_error(location, "group attributes are not valid JSON", e))
}

/// The selection for an array of `shape` whose axes are named `axes` (`None`: unnamed, see the
/// module doc), inside an OME-Zarr image whose root group attributes are `group_attrs_json`
/// (`None`: the store's root is the array itself).
pub fn select(
    group_attrs_json: Option<&str>,
    axes: Option<Vec<String>>,
    shape: &[u64],
    options: &ZarrOptions,
    location: &str,
) -> Result<ZarrSelection> {
    let image = match group_attrs_json {
        Some(json) => Some(ome_image(
            &parse_attrs(json, location)?,
            options.level,
            location,
        )?),
        None => None,
    };
    let axes = axes.filter(|a| a.len() == shape.len());
    select_axes(image.as_ref(), axes, shape, options, location)
}

/// A single array has level 0 only.
fn check_single_array_level(options: &ZarrOptions, location: &str) -> Result<()> {
    if options.level != 0 {
        return Err(Error::invalid(format!(
            "--level {} asked for, but this is a single Zarr array, not a multiscale image",
            options.level
        ))
        .with_path(location));
    }
    Ok(())
}

fn select_axes(
    image: Option<&Image>,
    array_axes: Option<Vec<String>>,
    shape: &[u64],
    options: &ZarrOptions,
    location: &str,
) -> Result<ZarrSelection> {
    if image.is_none() {
        check_single_array_level(options, location)?;
    }
    let axes = match image {
        Some(image) => image.axes.clone(),
        None => array_axes.unwrap_or_else(|| default_axes(shape.len())),
    };
    if axes.len() != shape.len() {
        return Err(Error::corrupt(format!(
            "{} axes named but the array has {} dimensions",
            axes.len(),
            shape.len()
        ))
        .with_path(location));
    }
    let find = |name: &str| axes.iter().position(|a| a.eq_ignore_ascii_case(name));
    let spatial = match (find("x"), find("y"), find("z")) {
        (Some(x), Some(y), Some(z)) => [x, y, z],
        _ => {
            return Err(Error::unsupported(format!(
                "axes [{}]: a volume needs axes named x, y and z",
                axes.join(", ")
            ))
            .with_path(location))
        }
    };
    crate::read_options::refuse_repeated_axes(options.pick()).map_err(|e| e.with_path(location))?;
    for (name, _) in &options.indices {
        if find(name).is_none() || spatial.contains(&find(name).unwrap()) {
            return Err(Error::invalid(format!(
                "{} names {name}, which is not a non-spatial axis of [{}]",
                options.index_flag,
                axes.join(", ")
            ))
            .with_path(location));
        }
    }
    let mut fixed = Vec::new();
    let mut unindexed = Vec::new();
    for (axis, name) in axes.iter().enumerate() {
        if spatial.contains(&axis) {
            continue;
        }
        let given = options
            .indices
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|&(_, i)| i);
        match given {
            Some(i) if i < shape[axis] => fixed.push((axis, i)),
            Some(i) => {
                return Err(Error::invalid(format!(
                    "{} is out of range: axis {name} has {} entries",
                    options.index_flag.with(&[(name, &i.to_string())]),
                    shape[axis]
                ))
                .with_path(location))
            }
            None if shape[axis] == 1 => fixed.push((axis, 0)),
            None => unindexed.push(format!("{name} ({} entries)", shape[axis])),
        }
    }
    if !unindexed.is_empty() {
        let flag = options.index_flag;
        return Err(Error::invalid(format!(
            "{}-D data with axes [{}]: pick one entry of {} with {flag}, e.g. {}",
            shape.len(),
            axes.join(", "),
            unindexed.join(" and "),
            flag.with(
                &axes
                    .iter()
                    .enumerate()
                    .filter(|(a, _)| !spatial.contains(a) && shape[*a] > 1)
                    .map(|(_, n)| (n.as_str(), "0"))
                    .collect::<Vec<_>>()
            )
        ))
        .with_path(location));
    }
    let dims = spatial.map(|a| usize::try_from(shape[a]).unwrap_or(usize::MAX));
    // An empty axis or one beyond MAX_DIM is refused here, before any plan or read.
    crate::samples::sample_count(dims).map_err(|e| e.with_path(location))?;
    let mut geometry = Geometry::new(dims);
    if let Some(image) = image {
        geometry.spacing = spatial.map(|a| image.scale[a].abs());
        geometry.origin = spatial.map(|a| image.translation[a]);
        for (row, &a) in spatial.iter().enumerate() {
            if image.scale[a] < 0.0 {
                geometry.direction[row] = geometry.direction[row].map(|v| -v);
            }
        }
        // Scales multiply and translations add up: a zero scale, or products and sums that
        // overflow, would give a volume without a size or a place.
        let bad = geometry
            .spacing
            .iter()
            .any(|s| !(s.is_finite() && *s > 0.0))
            || geometry.origin.iter().any(|o| !o.is_finite());
        if bad {
            return Err(Error::corrupt(format!(
                "OME-Zarr coordinateTransformations give spacing {:?} and origin {:?}; \
                 spacing must be positive and finite, the origin finite",
                geometry.spacing, geometry.origin
            ))
            .with_path(location));
        }
    }
    Ok(ZarrSelection {
        spatial,
        fixed,
        geometry,
    })
}

impl ZarrSource {
    /// Opens the Zarr array or OME-Zarr image at the root of `store`.
    pub fn open(store: ReadableStorage, location: &str, options: &ZarrOptions) -> Result<Self> {
        let (array_path, image) = match root_kind(&store, location)? {
            Root::Array => ("/".to_string(), None),
            Root::Group(attrs) => {
                let image = ome_image(&attrs, options.level, location)?;
                (format!("/{}", image.path.trim_matches('/')), Some(image))
            }
        };
        if image.is_none() {
            check_single_array_level(options, location)?;
        }
        let array = Array::open(store.clone(), &array_path).map_err(|e| {
            Error::unsupported(format!("cannot open the Zarr array {array_path}: {e}"))
                .with_path(location)
        })?;
        let shape = array.shape().to_vec();
        let named = match &image {
            Some(_) => None,
            None => Some(array_axes(&array)),
        };
        let ZarrSelection {
            spatial,
            fixed,
            geometry,
        } = select_axes(image.as_ref(), named, &shape, options, location)?;
        // Shown as "uint16 / <u2" (the v3 name, then the v2 one where they differ).
        let type_name = array.data_type().to_string();
        let v3_name = type_name.split(" / ").next().unwrap_or_default();
        let stored = Stored::parse(v3_name).ok_or_else(|| {
            Error::unsupported(format!("Zarr data type {type_name} is not supported"))
                .with_path(location)
        })?;
        // Saturating: a declared chunk shape may multiply past u64, and then no budget fits it.
        let chunk_elements: u64 = array
            .chunk_shape(&vec![0; shape.len()])
            .map(|c| c.iter().fold(1u64, |acc, n| acc.saturating_mul(n.get())))
            .unwrap_or(0);
        let rows = rows::ChunkRows::new(&array, spatial, &fixed, geometry.dims);
        Ok(ZarrSource {
            array,
            location: location.to_string(),
            stored,
            geometry,
            spatial,
            fixed,
            chunk_bytes: chunk_elements.saturating_mul(stored.size() as u64),
            rows,
        })
    }

    fn subset(&self, z: &Range<usize>) -> ArraySubset {
        let [nx, ny, _] = self.geometry.dims;
        let mut ranges = vec![0..1; self.array.dimensionality()];
        for &(axis, i) in &self.fixed {
            ranges[axis] = i..i + 1;
        }
        ranges[self.spatial[0]] = 0..nx as u64;
        ranges[self.spatial[1]] = 0..ny as u64;
        ranges[self.spatial[2]] = z.start as u64..z.end as u64;
        ArraySubset::new_with_ranges(&ranges)
    }

    /// Element strides of x, y and z in the C-ordered subset buffer.
    fn strides(&self, subset: &ArraySubset) -> [usize; 3] {
        let shape = subset.shape();
        let mut stride = vec![1usize; shape.len()];
        for a in (0..shape.len().saturating_sub(1)).rev() {
            stride[a] = stride[a + 1] * shape[a + 1] as usize;
        }
        self.spatial.map(|a| stride[a])
    }

    /// Reads `subset` as stored elements; on a decoding error, finds the chunk at fault.
    fn retrieve<S: zarrs::array::ElementOwned>(&self, subset: &ArraySubset) -> Result<Vec<S>> {
        self.array
            .retrieve_array_subset::<Vec<S>>(subset)
            .map_err(|e| self.chunk_error::<S>(subset, e))
    }

    /// Names the first chunk of `subset` that fails to decode alone; the whole error otherwise.
    fn chunk_error<S: zarrs::array::ElementOwned>(
        &self,
        subset: &ArraySubset,
        error: impl std::fmt::Display,
    ) -> Error {
        if let Ok(Some(chunks)) = self.array.chunks_in_array_subset(subset) {
            for indices in &chunks.indices() {
                if let Err(e) = self.array.retrieve_chunk::<Vec<S>>(&indices) {
                    let key = self.array.chunk_key(&indices);
                    return Error::corrupt(format!("chunk {key} (indices {indices:?}): {e}"))
                        .with_path(&self.location);
                }
            }
        }
        Error::corrupt(format!("cannot read the Zarr array: {error}")).with_path(&self.location)
    }

    /// Reads planes `z` (with `wanted`, at least the samples of those blocks) into `out`.
    fn read_into<S, K>(
        &mut self,
        z: &Range<usize>,
        out: &mut [K],
        wanted: Option<&BlockMask>,
        convert: impl Fn(S) -> K + Sync,
    ) -> Result<()>
    where
        S: rows::ChunkElement,
        K: Copy + Default + Send + Sync + 'static,
    {
        if let Some(rows) = &mut self.rows {
            return rows.read(&self.array, &self.location, z.clone(), out, wanted, convert);
        }
        let subset = self.subset(z);
        let values = self.retrieve::<S>(&subset)?;
        let [nx, ny, _] = self.geometry.dims;
        let [sx, sy, sz] = self.strides(&subset);
        if sx == 1 && sy == nx && sz == nx * ny {
            for (o, &v) in out.iter_mut().zip(&values) {
                *o = convert(v);
            }
        } else {
            for (plane, out_plane) in out.chunks_mut(nx * ny).enumerate() {
                for (y, row) in out_plane.chunks_mut(nx).enumerate() {
                    let base = plane * sz + y * sy;
                    for (x, o) in row.iter_mut().enumerate() {
                        *o = convert(values[base + x * sx]);
                    }
                }
            }
        }
        Ok(())
    }

    /// Reads planes `z` into `out`, as the kept type (`Stored::kept`, as
    /// `crate::samples::read_samples` keeps them: bool as u8, i8 widened to i16).
    fn read_converted(
        &mut self,
        z: Range<usize>,
        out: SlabMut<'_>,
        wanted: Option<&BlockMask>,
    ) -> Result<()> {
        match (self.stored, out) {
            (Stored::Elem(ElemType::U8), SlabMut::U8(o)) => {
                self.read_into::<u8, u8>(&z, o, wanted, |v| v)
            }
            (Stored::Bool, SlabMut::U8(o)) => {
                self.read_into::<bool, u8>(&z, o, wanted, |v| v as u8)
            }
            (Stored::Elem(ElemType::U16), SlabMut::U16(o)) => {
                self.read_into::<u16, u16>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::I16), SlabMut::I16(o)) => {
                self.read_into::<i16, i16>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::I8), SlabMut::I16(o)) => {
                self.read_into::<i8, i16>(&z, o, wanted, |v| v as i16)
            }
            (Stored::Elem(ElemType::F32), SlabMut::F32(o)) => {
                self.read_into::<f32, f32>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::U32), SlabMut::U32(o)) => {
                self.read_into::<u32, u32>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::I32), SlabMut::I32(o)) => {
                self.read_into::<i32, i32>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::U64), SlabMut::U64(o)) => {
                self.read_into::<u64, u64>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::I64), SlabMut::I64(o)) => {
                self.read_into::<i64, i64>(&z, o, wanted, |v| v)
            }
            (Stored::Elem(ElemType::F64), SlabMut::F64(o)) => {
                self.read_into::<f64, f64>(&z, o, wanted, |v| v)
            }
            _ => Err(Error::invalid("slab buffer type differs from the array's")),
        }
    }
}

impl RegionSource for ZarrSource {
    fn geometry(&self) -> Geometry {
        self.geometry
    }
    fn scalar_type(&self) -> ScalarType {
        self.stored.kept()
    }
    fn read_planes(&mut self, z: Range<usize>, out: SlabMut<'_>) -> Result<()> {
        self.read_converted(z, out, None)
    }
    fn read_planes_within(
        &mut self,
        z: Range<usize>,
        out: SlabMut<'_>,
        wanted: &BlockMask,
    ) -> Result<()> {
        self.read_converted(z, out, Some(wanted))
    }
    fn plane_granularity(&self) -> usize {
        self.rows.as_ref().map_or(1, |rows| rows.row_depth())
    }
    fn read_overhead(&self, planes: usize) -> u64 {
        let [nx, ny, _] = self.geometry.dims;
        let plane = (nx * ny) as u64;
        // Read by chunk: the planes of the row kept for the next slab. Read by subset: the subset
        // as stored, twice (zarrs decodes it into its own bytes and converts those into the typed
        // Vec it returns, both alive at the conversion). Either way, the chunks being decoded at
        // once (encoded and decoded).
        let buffers = match &self.rows {
            Some(rows) => {
                rows.kept_planes(planes) as u64 * plane * self.stored.kept().size() as u64
            }
            None => 2 * plane * planes as u64 * self.stored.size() as u64,
        };
        let threads = rayon::current_num_threads() as u64;
        buffers.saturating_add((2 * threads).saturating_mul(self.chunk_bytes))
    }
}

/// Opens a local Zarr store (a folder).
pub fn open_path(path: &std::path::Path, options: &ZarrOptions) -> Result<ZarrSource> {
    let store = zarrs::filesystem::FilesystemStore::new(path)
        .map_err(|e| Error::invalid(format!("cannot open as a Zarr store: {e}")).with_path(path))?;
    let store: ReadableStorage = Arc::new(file_store::RegularFileStore(store));
    ZarrSource::open(store, &path.display().to_string(), options)
}

/// Opens a Zarr store served over HTTP at `url` (see [`super::http_store`]).
pub fn open_url(url: &str, options: &ZarrOptions) -> Result<ZarrSource> {
    if cfg!(not(feature = "https")) && url.to_ascii_lowercase().starts_with("https://") {
        return Err(Error::unsupported(
            "https:// needs isogrid-io built with its `https` feature (plain http:// works without it)",
        )
        .with_path(url));
    }
    let trusted = options.trusted_certificates.as_deref();
    let store = super::http_store::HttpStore::new(url, trusted).map_err(|e| e.with_path(url))?;
    let store: ReadableStorage = Arc::new(store);
    ZarrSource::open(store, url, options)
}

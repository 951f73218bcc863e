//! What the subcommands print: one JSON object with stable names (`--json`), or a short table.
//!
//! JSON names (documented in docs/cli.md): `dims`, `iso`, `precision`, `active_cells`, `metacells`
//! (occupied), `metacell_slots`, `clusters`, `blocks`, `nonempty_blocks`, `bytes` {`blocks`,
//! `metacells`, `cells`, `paper_total`}, `bytes_per_cell`, `seconds` {`read`, `extract`, `write`};
//! Marching Cubes: `vertices`, `triangles`, `bytes`, `seconds`.

use isogrid::{CellGrid, GridStats, Volume};
use serde::Serialize;
use std::path::Path;

/// One line on stderr when `grid` (from `source`) has no active cell, saying why
/// ([`isogrid::GridInfo::empty_surface_note`]). `volume`: the samples it was extracted from, when
/// at hand (not for a .cgc file).
pub fn note_if_empty(source: &Path, grid: &CellGrid, volume: Option<&Volume>) {
    let labels = grid.labels().map(|l| l.table());
    note_if_no_cells(
        source,
        grid.info(),
        grid.active_cells() as u64,
        labels,
        || volume.is_some_and(|v| v.view().value_range().is_none()),
    );
}

/// [`note_if_empty`] from a grid's header, cell count and label table (a streamed grid is never
/// in memory). `all_nan` says whether the volume has no finite sample; asked only for an empty
/// isosurface.
pub fn note_if_no_cells(
    source: &Path,
    info: &isogrid::GridInfo,
    active_cells: u64,
    labels: Option<&[isogrid::Label]>,
    all_nan: impl FnOnce() -> bool,
) {
    if active_cells == 0 {
        eprintln!(
            "isogrid: note: {}: {}",
            source.display(),
            info.empty_surface_note(labels, all_nan)
        );
    }
}

#[derive(Serialize, Default, Clone, Copy)]
pub struct Seconds {
    pub read: f64,
    pub extract: f64,
    pub write: f64,
}

#[derive(Serialize)]
pub struct Bytes {
    pub blocks: u64,
    pub metacells: u64,
    pub cells: u64,
    pub paper_total: u64,
}

#[derive(Serialize)]
pub struct GridReport {
    pub dims: [u32; 3],
    pub iso: f64,
    pub precision: u32,
    pub active_cells: u64,
    pub metacells: u64,
    pub metacell_slots: u64,
    pub clusters: u64,
    pub blocks: u64,
    pub nonempty_blocks: u64,
    pub bytes: Bytes,
    pub bytes_per_cell: f64,
    /// The per-cell attribute (`--color-by`), or null.
    pub attribute: Option<AttributeReport>,
    /// The labels of a label volume's grid (`--labels`); absent for an isosurface.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub labels: Option<Vec<LabelReport>>,
    /// The volume the grid was extracted from (`info`); absent where the report does not say.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<SourceReport>,
    pub seconds: Seconds,
    /// The grid of a `.cgc` file (`info`), timed opening and validating it: nothing was
    /// extracted or written, so the table shows that time alone.
    #[serde(skip)]
    pub opened_file: bool,
}

/// A label value: signed for a signed volume.
#[derive(Serialize)]
#[serde(untagged)]
pub enum LabelValue {
    Signed(i64),
    Unsigned(u64),
}

impl LabelValue {
    /// Label key `key` (a signed volume's value as its two's complement) as reports show it.
    pub fn of(key: u64, signed: bool) -> Self {
        if signed {
            LabelValue::Signed(key as i64)
        } else {
            LabelValue::Unsigned(key)
        }
    }
}

impl std::fmt::Display for LabelValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LabelValue::Signed(v) => v.fmt(f),
            LabelValue::Unsigned(v) => v.fmt(f),
        }
    }
}

/// One label of a label volume in `info VOLUME --labels`.
#[derive(Serialize)]
pub struct VolumeLabelReport {
    pub value: LabelValue,
    pub name: String,
    /// sRGB and alpha as `#rrggbbaa`.
    pub color: String,
    /// Samples holding it.
    pub voxels: u64,
    /// `voxels` × the volume of one voxel (the product of the spacing), in the file's units
    /// cubed (mm³ for medical images).
    pub volume: f64,
    /// Its voxels' box in sample indices, `[lo, hi)` per axis (index space).
    pub lo: [u64; 3],
    pub hi: [u64; 3],
}

/// One label of a grid in a report.
#[derive(Serialize)]
pub struct LabelReport {
    pub value: LabelValue,
    pub name: String,
    /// sRGB and alpha as `#rrggbbaa`.
    pub color: String,
    /// Active cells of its surface.
    pub cells: u64,
    /// Its active cells' box in cell indices, `[lo, hi)` per axis (index space).
    pub lo: [u32; 3],
    pub hi: [u32; 3],
}

/// The volume a grid was extracted from, as its header keeps it.
#[derive(Serialize)]
pub struct SourceReport {
    /// Its sample type (`u8`, `i16`, `f32`, ...).
    pub scalar_type: &'static str,
    /// Its smallest and largest finite sample, in data units.
    pub value_range: [f64; 2],
    /// Sample spacing along i, j, k, in the file's units.
    pub spacing: [f64; 3],
    /// The world position of sample (0, 0, 0).
    pub origin: [f64; 3],
    /// The world directions of the i, j and k axes, one row each.
    pub direction: [[f64; 3]; 3],
    /// The convention of the world coordinates: `"LPS"`, `"RAS"`, or null where the source file
    /// named none.
    pub frame: Option<&'static str>,
    /// The anatomical direction of the i, j and k axes (`"LIA"` for FreeSurfer's conformed
    /// volumes), or null without a convention.
    pub axes: Option<String>,
}

impl SourceReport {
    pub fn new(info: &isogrid::GridInfo) -> Self {
        let geometry = isogrid::extract::attribute::grid_geometry(info);
        SourceReport::of(&geometry, info.scalar_type, info.value_range)
    }

    /// A volume of `geometry` and `scalar_type` whose finite samples span `value_range` (NaN
    /// where it has none: null in JSON).
    pub fn of(
        geometry: &isogrid::Geometry,
        scalar_type: isogrid::ScalarType,
        value_range: [f64; 2],
    ) -> Self {
        SourceReport {
            scalar_type: scalar_type.name(),
            value_range,
            spacing: geometry.spacing,
            origin: geometry.origin,
            direction: geometry.direction,
            frame: match geometry.frame {
                isogrid::WorldFrame::Unknown => None,
                frame => Some(frame.name()),
            },
            axes: geometry.frame.axis_codes(&geometry.direction),
        }
    }
}

/// `info` of a volume: its grid, and what [`SourceReport`] says of a grid's source.
#[derive(Serialize)]
pub struct VolumeReport {
    /// Samples along i, j, k.
    pub dims: [usize; 3],
    #[serde(flatten)]
    pub volume: SourceReport,
    /// With `--labels`: the selected labels of a label volume (but the background, 0), in
    /// increasing value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub labels: Option<Vec<VolumeLabelReport>>,
    /// Reading the volume (its header, and every sample for the value range or the labels).
    pub seconds: f64,
}

impl VolumeReport {
    pub fn new(
        geometry: &isogrid::Geometry,
        scalar_type: isogrid::ScalarType,
        range: Option<(f64, f64)>,
        seconds: f64,
    ) -> Self {
        let range = range.map_or([f64::NAN; 2], |(lo, hi)| [lo, hi]);
        VolumeReport {
            dims: geometry.dims,
            volume: SourceReport::of(geometry, scalar_type, range),
            labels: None,
            seconds,
        }
    }

    /// The human table.
    pub fn print_human(&self) -> Result<(), crate::stdout::StdoutError> {
        let [x, y, z] = self.dims;
        let v = &self.volume;
        let scalar = isogrid::ScalarType::named(v.scalar_type).expect("a type's own name");
        let values = if v.value_range[0].is_nan() {
            "no finite sample".to_string()
        } else {
            format!(
                "[{}, {}]",
                scalar.display_value(v.value_range[0]),
                scalar.display_value(v.value_range[1])
            )
        };
        outln!("volume        {x} x {y} x {z} samples, {}", v.scalar_type);
        outln!("values        {values}");
        outln!("spacing       {:?}", v.spacing);
        outln!("origin        {:?} (sample 0, 0, 0)", v.origin);
        match (&v.axes, v.frame) {
            (Some(axes), Some(frame)) => {
                outln!("axes          {axes}, world coordinates {frame}")
            }
            _ => outln!(
                "axes          directions {:?}, no world convention named",
                v.direction
            ),
        }
        if let Some(labels) = &self.labels {
            outln!(
                "labels        {} (value, voxels, volume in the spacing's units cubed, sample box [lo, hi), colour, name)",
                group(labels.len() as u64)
            );
            let width = |column: &dyn Fn(&VolumeLabelReport) -> String, least: usize| {
                labels
                    .iter()
                    .map(|l| column(l).len())
                    .max()
                    .unwrap_or(0)
                    .max(least)
            };
            let volume = |l: &VolumeLabelReport| format!("{:.3}", l.volume);
            let value_width = width(&|l| l.value.to_string(), 8);
            let voxels_width = width(&|l| group(l.voxels), 10);
            let volume_width = width(&volume, 12);
            for l in labels {
                outln!(
                    "  {:>value_width$} {:>voxels_width$} {:>volume_width$}  {:?}..{:?}  {}  {}",
                    l.value.to_string(),
                    group(l.voxels),
                    volume(l),
                    l.lo,
                    l.hi,
                    l.color,
                    l.name
                );
            }
        }
        outln!("seconds       read {:.3}", self.seconds);
        Ok(())
    }
}

/// A grid's per-cell attribute in a report.
#[derive(Serialize)]
pub struct AttributeReport {
    pub name: String,
    /// Bits per stored value: 8 or 16 (codes over `range`) or 32 (f32).
    pub bits: u32,
    /// Smallest and largest finite value on the surface.
    pub range: [f64; 2],
    /// Bytes of the file's attribute section (head and values).
    pub bytes: u64,
    /// Attribute bytes per active cell.
    pub bytes_per_cell: f64,
}

impl AttributeReport {
    pub fn new(attribute: &isogrid::CellAttribute) -> Self {
        let info = attribute.info();
        let bytes = (attribute.head_bytes().len() + attribute.value_bytes().len()) as u64;
        AttributeReport {
            name: info.name.clone(),
            bits: info.precision.bits(),
            range: info.range,
            bytes,
            bytes_per_cell: info.precision.bytes() as f64,
        }
    }
}

impl GridReport {
    pub fn new(stats: &GridStats, seconds: Seconds) -> Self {
        GridReport {
            dims: stats.dims,
            iso: stats.iso,
            precision: stats.precision_bits,
            active_cells: stats.active_cells,
            metacells: stats.metacells,
            metacell_slots: stats.metacell_slots,
            clusters: stats.clusters,
            blocks: stats.blocks,
            nonempty_blocks: stats.nonempty_blocks,
            bytes: Bytes {
                blocks: stats.bytes.blocks,
                metacells: stats.bytes.metacells,
                cells: stats.bytes.cells,
                paper_total: stats.bytes.paper_total,
            },
            bytes_per_cell: stats.bytes_per_cell(),
            attribute: None,
            labels: None,
            source: None,
            seconds,
            opened_file: false,
        }
    }

    /// The report with the grid's attribute, when it has one.
    pub fn with_attribute(mut self, attribute: Option<&isogrid::CellAttribute>) -> Self {
        self.attribute = attribute.map(AttributeReport::new);
        self
    }

    /// The report with the grid's labels, when it has them.
    pub fn with_labels(self, grid: &CellGrid) -> Self {
        let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
        match grid.labels() {
            Some(labels) => self.with_label_table(labels.table(), labels.index(), signed),
            None => self,
        }
    }

    /// The labels of a label grid from its table and index (`signed`: how values are shown).
    pub fn with_label_table(
        mut self,
        table: &[isogrid::labels::Label],
        index: &[isogrid::labels::LabelEntry],
        signed: bool,
    ) -> Self {
        self.labels = Some(
            table
                .iter()
                .zip(index)
                .map(|(label, entry)| LabelReport {
                    value: LabelValue::of(label.value, signed),
                    name: label.name.clone(),
                    color: label.color_hex(),
                    cells: entry.cell_count,
                    lo: entry.lo,
                    hi: entry.hi,
                })
                .collect(),
        );
        self
    }

    /// The human table; of the labels, the first `label_rows` (all with `None`), then a line
    /// saying how many more there are and `more`, where to find them.
    pub fn print_human(
        &self,
        label_rows: Option<usize>,
        more: &str,
    ) -> Result<(), crate::stdout::StdoutError> {
        let [x, y, z] = self.dims;
        outln!(
            "grid          {x} x {y} x {z} samples, iso {}, {}-bit corners",
            self.iso,
            self.precision
        );
        outln!("active cells  {}", group(self.active_cells));
        outln!(
            "metacells     {} occupied in {} slots ({} clusters)",
            group(self.metacells),
            group(self.metacell_slots),
            group(self.clusters)
        );
        outln!(
            "blocks        {} ({} with cells)",
            group(self.blocks),
            group(self.nonempty_blocks)
        );
        outln!(
            "memory        {} (metacells {} + cells {}; paper's Table 3 figure), block volume {}",
            mb(self.bytes.paper_total),
            mb(self.bytes.metacells),
            mb(self.bytes.cells),
            mb(self.bytes.blocks)
        );
        outln!(
            "bytes/cell    {:.2} (blocks + metacells + cells)",
            self.bytes_per_cell
        );
        if let Some(a) = &self.attribute {
            outln!(
                "attribute     {:?}: {}-bit values in [{}, {}] on the surface, {} ({} B/cell)",
                a.name,
                a.bits,
                // The range of f32 values, in their precision.
                isogrid::ScalarType::F32.display_value(a.range[0]),
                isogrid::ScalarType::F32.display_value(a.range[1]),
                mb(a.bytes),
                a.bytes_per_cell
            );
        }
        if let Some(labels) = &self.labels {
            outln!(
                "labels        {} (value, cells, cell box [lo, hi), colour, name)",
                group(labels.len() as u64)
            );
            let shown = &labels[..label_rows.unwrap_or(labels.len()).min(labels.len())];
            let value = |l: &LabelReport| l.value.to_string();
            // Columns as wide as their widest entry (a 64-bit connectomics ID has 20 digits).
            let value_width = shown
                .iter()
                .map(|l| value(l).len())
                .max()
                .unwrap_or(0)
                .max(8);
            let cells_width = shown
                .iter()
                .map(|l| group(l.cells).len())
                .max()
                .unwrap_or(0)
                .max(12);
            for l in shown {
                outln!(
                    "  {:>value_width$} {:>cells_width$}  {:?}..{:?}  {}  {}",
                    value(l),
                    group(l.cells),
                    l.lo,
                    l.hi,
                    l.color,
                    l.name
                );
            }
            if shown.len() < labels.len() {
                outln!(
                    "  ... and {} more{more}",
                    group((labels.len() - shown.len()) as u64)
                );
            }
        }
        if self.opened_file {
            outln!("seconds       open and check {:.3}", self.seconds.read);
        } else {
            outln!(
                "seconds       read {:.3}, extract {:.3}, write {:.3}",
                self.seconds.read,
                self.seconds.extract,
                self.seconds.write
            );
        }
        Ok(())
    }
}

#[derive(Serialize)]
pub struct MeshReport {
    pub dims: [u32; 3],
    pub iso: f64,
    pub vertices: u64,
    pub triangles: u64,
    /// 6 B per vertex (snorm16 xyz) + 12 B per triangle (u32 indices), as the paper's Table 3.
    pub bytes: u64,
    /// With `--labels`: the labels with a surface, one mesh each (vertices and triangles are
    /// their sums).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub labels: Option<u64>,
    pub seconds: Seconds,
}

impl MeshReport {
    /// One JSON object with `json`, else the human table.
    pub fn print(&self, json: bool) -> anyhow::Result<()> {
        if json {
            print_json(self)
        } else {
            self.print_human()?;
            Ok(())
        }
    }

    pub fn print_human(&self) -> Result<(), crate::stdout::StdoutError> {
        match self.labels {
            Some(labels) => outln!(
                "meshes        {} labels, {} vertices, {} triangles",
                group(labels),
                group(self.vertices),
                group(self.triangles)
            ),
            None => outln!(
                "mesh          {} vertices, {} triangles, iso {}",
                group(self.vertices),
                group(self.triangles),
                self.iso
            ),
        }
        outln!(
            "memory        {} (6 B/vertex snorm16 + 12 B/triangle)",
            mb(self.bytes)
        );
        outln!(
            "seconds       read {:.3}, extract {:.3}, write {:.3}",
            self.seconds.read,
            self.seconds.extract,
            self.seconds.write
        );
        Ok(())
    }
}

pub fn print_json<T: Serialize>(value: &T) -> anyhow::Result<()> {
    outln!("{}", serde_json::to_string(value)?);
    Ok(())
}

/// Decimal megabytes, as the paper reports.
pub fn mb(bytes: u64) -> String {
    format!("{:.2} MB", bytes as f64 / 1e6)
}

/// 1234567 → "1,234,567".
pub fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

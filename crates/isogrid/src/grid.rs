//! [`CellGrid`]: an extracted clustered grid cell structure, owned or memory-mapped from a `.cgc` file.

use crate::attribute::CellAttribute;
use crate::labels::GridLabels;
use crate::layout::{
    Block, ClusterBound, Metacell, Precision, BLOCK_CELLS, BOUND_SLOT, CLUSTER_SLOTS,
};
use crate::quantize::ValueMapping;
use crate::volume::ScalarType;

/// Everything about a grid except its three buffers (the `.cgc` header).
#[derive(Debug, Clone, PartialEq)]
pub struct GridInfo {
    /// Samples per axis of the source volume; cells are one fewer.
    pub dims: [u32; 3],
    /// Physical sample spacing (file units). World position of sample (i,j,k) is (i·sx, j·sy, k·sz).
    pub spacing: [f64; 3],
    /// Physical position of sample (0,0,0) (metadata: rendering ignores it).
    pub origin: [f64; 3],
    /// Rows: world direction of the i, j, k axes (metadata only).
    pub direction: [[f64; 3]; 3],
    /// The convention of `origin` and `direction` (the `.cgc` world frame section; unknown when
    /// absent).
    pub frame: crate::volume::WorldFrame,
    /// Type of the source samples.
    pub scalar_type: ScalarType,
    /// Smallest and largest finite sample of the source volume.
    pub value_range: [f64; 2],
    /// The isovalue in data units (`inside ⇔ value >= iso`).
    pub iso: f64,
    pub precision: Precision,
    pub mapping: ValueMapping,
}

impl GridInfo {
    /// The header of a grid of `geometry`'s volume whose corners `quantizer` encodes.
    pub(crate) fn new(
        geometry: &crate::volume::Geometry,
        scalar_type: ScalarType,
        value_range: [f64; 2],
        iso: f64,
        quantizer: &crate::quantize::Quantizer,
    ) -> Self {
        GridInfo {
            dims: geometry.dims.map(|d| d as u32),
            spacing: geometry.spacing,
            origin: geometry.origin,
            direction: geometry.direction,
            frame: geometry.frame,
            scalar_type,
            value_range,
            iso,
            precision: quantizer.precision(),
            mapping: quantizer.mapping(),
        }
    }
    pub fn cell_dims(&self) -> [u32; 3] {
        self.dims.map(|n| n.saturating_sub(1))
    }
    /// Blocks per axis: `ceil(cells / 16)`.
    pub fn block_dims(&self) -> [u32; 3] {
        self.cell_dims().map(|c| c.div_ceil(BLOCK_CELLS as u32))
    }
    /// World-space box of the grid: sample (i,j,k) is at (i·sx, j·sy, k·sz), so `[0, (dims−1)·spacing]`.
    pub fn world_bounds(&self) -> ([f64; 3], [f64; 3]) {
        (
            [0.0; 3],
            [0, 1, 2].map(|a| self.dims[a].saturating_sub(1) as f64 * self.spacing[a]),
        )
    }
    pub fn block_count(&self) -> usize {
        self.block_dims().iter().map(|&n| n as usize).product()
    }

    /// Whether the grid's axes are a mirror image of its world's
    /// ([`crate::volume::directions_mirror`]): its images are then drawn by mirrored cameras
    /// ([`crate::Camera::mirrored`]), so that they show the world as it lies.
    pub fn mirrors_world(&self) -> bool {
        crate::volume::directions_mirror(&self.direction)
    }

    /// Why a surface of this header has no active cell, as the one line the front doors show for
    /// it (the CLI's note, Python's `EmptySurfaceWarning`): an empty surface is a valid result,
    /// but a blank image or zero hits alone look like a failure elsewhere. `labels`: the label
    /// table of a label grid, `None` for an isosurface. `all_nan` says whether the volume had no
    /// finite sample; asked only for an isosurface whose cells do not already say why.
    pub fn empty_surface_note(
        &self,
        labels: Option<&[crate::labels::Label]>,
        all_nan: impl FnOnce() -> bool,
    ) -> String {
        let Some(labels) = labels else {
            return isosurface_empty_note(
                self.dims,
                self.scalar_type,
                self.value_range,
                self.iso,
                all_nan,
            );
        };
        let thin = self.cell_dims().contains(&0);
        let signed = crate::labels::signed_labels(self.scalar_type);
        let why = match labels {
            _ if thin => THIN.to_string(),
            [] => "the volume holds no selected label".to_string(),
            // Unsmoothed corners are the indicator itself: a label present with no cell has no
            // sample outside it, in a volume whose samples all belong to cells.
            [one] if self.precision == crate::layout::Precision::Bits1 => format!(
                "label {} fills the whole volume",
                crate::labels::display_value(one.value, signed)
            ),
            _ if self.precision == crate::layout::Precision::Bits1 => {
                "each selected label in it fills the whole volume".to_string()
            }
            _ => "after smoothing, no selected label's indicator crosses ½ in any cell".to_string(),
        };
        format!("no selected label has a surface ({why}); the surface is empty")
    }
}

/// [`GridInfo::empty_surface_note`] of an isosurface at `iso` of a volume of `dims` samples of
/// `scalar_type` whose finite samples lie in `value_range` (`[0, 0]` when it has none), for a
/// front door that has the volume but no grid (a Marching Cubes mesh: it has triangles where a
/// grid has cells).
pub fn isosurface_empty_note(
    dims: [u32; 3],
    scalar_type: ScalarType,
    value_range: [f64; 2],
    iso: f64,
    all_nan: impl FnOnce() -> bool,
) -> String {
    let [lo, hi] = value_range.map(|v| scalar_type.display_value(v));
    let why = if dims.iter().any(|&d| d < 2) {
        THIN.to_string()
    } else if all_nan() {
        "every sample is NaN".to_string()
    } else if iso > value_range[1] {
        format!("every sample is below it: they lie in [{lo}, {hi}]")
    } else if iso <= value_range[0] {
        format!("every sample is at or above it: they lie in [{lo}, {hi}]")
    } else {
        format!("the samples lie in [{lo}, {hi}]")
    };
    format!("no cell crosses the isovalue {iso} ({why}); the surface is empty")
}

/// Why a volume one sample thick along an axis has no surface.
const THIN: &str = "the volume is one sample thick, so it has no cells";

/// Buffers of a grid: owned vectors or slices of a mapped file.
pub(crate) enum Storage {
    Owned {
        blocks: Vec<Block>,
        metacells: Vec<Metacell>,
        cells: Vec<u8>,
    },
    Mapped {
        map: memmap2::Mmap,
        blocks: std::ops::Range<usize>,
        metacells: std::ops::Range<usize>,
        cells: std::ops::Range<usize>,
    },
}

/// Clustered grid cells (paper §3.1): blocks, metacell slots and corner records. See [`crate::layout`].
///
/// ```
/// use isogrid::{extract, ExtractOptions, Iso, Volume, VolumeData};
/// // A 4×4×4 volume with one bright sample in the middle.
/// let mut data = vec![0u8; 64];
/// data[1 + 4 * (1 + 4 * 1)] = 200;
/// let volume = Volume::new([4, 4, 4], VolumeData::U8(data)).unwrap();
/// let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(100.0))).unwrap();
/// assert_eq!(grid.active_cells(), 8); // the 8 cells around the bright sample
/// assert_eq!(grid.clusters(), 1);
/// ```
pub struct CellGrid {
    info: GridInfo,
    storage: Storage,
    /// A second quantity per active cell, to colour the surface by.
    attribute: Option<CellAttribute>,
    /// The label of every cluster and the label table, for a grid of a label volume.
    labels: Option<GridLabels>,
}

impl std::fmt::Debug for CellGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CellGrid")
            .field("info", &self.info)
            .field("blocks", &self.blocks().len())
            .field("metacell_slots", &self.metacells().len())
            .field("active_cells", &self.active_cells())
            .field("attribute", &self.attribute.as_ref().map(|a| a.info()))
            .field("labels", &self.labels.as_ref().map(|l| l.table().len()))
            .finish()
    }
}

impl CellGrid {
    pub(crate) fn from_parts(
        info: GridInfo,
        blocks: Vec<Block>,
        metacells: Vec<Metacell>,
        cells: Vec<u8>,
    ) -> Self {
        CellGrid {
            info,
            storage: Storage::Owned {
                blocks,
                metacells,
                cells,
            },
            attribute: None,
            labels: None,
        }
    }
    pub(crate) fn from_storage(info: GridInfo, storage: Storage) -> Self {
        CellGrid {
            info,
            storage,
            attribute: None,
            labels: None,
        }
    }

    /// The grid with `attribute` as its per-cell attribute (replacing any it had). Fails unless the
    /// attribute has one value per active cell.
    pub fn with_attribute(mut self, attribute: CellAttribute) -> crate::Result<Self> {
        self.set_attribute(attribute)?;
        Ok(self)
    }
    /// Gives the grid `attribute` (see [`CellGrid::with_attribute`]).
    pub fn set_attribute(&mut self, attribute: CellAttribute) -> crate::Result<()> {
        if attribute.len() != self.active_cells() {
            return Err(crate::Error::invalid(format!(
                "the attribute has {} values for {} active cells",
                attribute.len(),
                self.active_cells()
            )));
        }
        self.attribute = Some(attribute);
        Ok(())
    }
    /// The grid with `labels` (replacing any it had). Fails unless they index exactly its clusters
    /// (see [`GridLabels`]).
    pub fn with_labels(mut self, labels: GridLabels) -> crate::Result<Self> {
        labels.check(self.metacells())?;
        self.labels = Some(labels);
        Ok(self)
    }
    /// [`CellGrid::with_labels`] for labels the extraction built, which hold by construction
    /// (checked in debug builds).
    pub(crate) fn with_built_labels(mut self, labels: GridLabels) -> Self {
        debug_assert!(labels.check(self.metacells()).is_ok());
        self.labels = Some(labels);
        self
    }
    /// The grid of the labels `shown` alone (one flag per label-table entry), to draw a label
    /// grid with some labels hidden: the clusters of the shown labels' runs, found through the
    /// label index (no scan of the others), with their metacell slots, corner records and
    /// attribute values (the attribute keeps the whole grid's range); the hidden labels stay in
    /// the table with no cells. Every renderer draws it as any label grid, so a hidden label's
    /// neighbours show their own surfaces where they touched it. Fails on a grid without labels
    /// or a flag count other than the table's.
    pub fn showing_labels(&self, shown: &[bool]) -> crate::Result<CellGrid> {
        use crate::labels::{ClusterRun, LabelEntry};
        let labels = self
            .labels()
            .ok_or_else(|| crate::Error::invalid("the grid has no labels to show or hide"))?;
        if shown.len() != labels.table().len() {
            return Err(crate::Error::invalid(format!(
                "{} show flags for {} labels",
                shown.len(),
                labels.table().len()
            )));
        }
        // Old cluster → new cluster, for the kept ones.
        let mut new_cluster = vec![u32::MAX; self.clusters()];
        for (l, _) in shown.iter().enumerate().filter(|(_, &s)| s) {
            for run in labels.runs_of(l) {
                new_cluster[run.clusters()].fill(0);
            }
        }
        let n = self.info.precision.bytes_per_cell();
        let (old_metacells, old_cells) = (self.metacells(), self.cells());
        let mut blocks = Vec::with_capacity(self.blocks().len());
        let (mut metacells, mut cells) = (Vec::new(), Vec::new());
        // The attribute's values of the kept cells, in their new order.
        let old_values = self.attribute.as_ref().map(|a| a.value_bytes());
        let value_bytes = self
            .attribute
            .as_ref()
            .map_or(0, |a| a.info().precision.bytes());
        let mut values = Vec::new();
        let mut cluster_labels = Vec::new();
        for block in self.blocks() {
            let pointer = metacells.len() as u32;
            for c in block.slots().start / CLUSTER_SLOTS..block.slots().end / CLUSTER_SLOTS {
                if new_cluster[c] == u32::MAX {
                    continue;
                }
                new_cluster[c] = (metacells.len() / CLUSTER_SLOTS) as u32;
                cluster_labels.push(labels.cluster_labels()[c]);
                for (k, m) in old_metacells[c * CLUSTER_SLOTS..(c + 1) * CLUSTER_SLOTS]
                    .iter()
                    .enumerate()
                {
                    let mut m = *m;
                    if k != BOUND_SLOT && !m.is_empty() {
                        let start = m.cell_pointer as usize * n;
                        let end = start + m.active_cells() as usize * n;
                        if let Some(old) = old_values {
                            let first = m.cell_pointer as usize * value_bytes;
                            let count = m.active_cells() as usize * value_bytes;
                            values.extend_from_slice(&old[first..first + count]);
                        }
                        m.cell_pointer = (cells.len() / n) as u32;
                        cells.extend_from_slice(&old_cells[start..end]);
                    }
                    metacells.push(m);
                }
            }
            blocks.push(Block {
                metacell_count: metacells.len() as u32 - pointer,
                metacell_pointer: pointer,
                ..*block
            });
        }
        let (mut index, mut runs) = (Vec::new(), Vec::new());
        for (l, e) in labels.index().iter().enumerate() {
            let first_run = runs.len() as u64;
            if shown[l] {
                runs.extend(labels.runs_of(l).iter().map(|r| ClusterRun {
                    first_cluster: new_cluster[r.first_cluster as usize],
                    cluster_count: r.cluster_count,
                }));
            }
            index.push(match shown[l] {
                true => LabelEntry { first_run, ..*e },
                false => LabelEntry {
                    first_run,
                    ..Default::default()
                },
            });
        }
        let labels = GridLabels::from_parts(labels.table().to_vec(), cluster_labels, index, runs);
        let mut grid = CellGrid::from_parts(self.info.clone(), blocks, metacells, cells)
            .with_built_labels(labels);
        // Its range stays the whole grid's, so that the colours do not change as labels hide.
        if let Some(attribute) = &self.attribute {
            grid.set_attribute(CellAttribute::from_encoded(
                attribute.info().clone(),
                values,
            ))?;
        }
        Ok(grid)
    }

    /// The labels of a grid extracted from a label volume.
    pub fn labels(&self) -> Option<&GridLabels> {
        self.labels.as_ref()
    }
    /// Mutable labels, to rename or recolour them ([`GridLabels::set_table`]).
    pub fn labels_mut(&mut self) -> Option<&mut GridLabels> {
        self.labels.as_mut()
    }

    /// The per-cell attribute, when the grid carries one.
    pub fn attribute(&self) -> Option<&CellAttribute> {
        self.attribute.as_ref()
    }

    pub fn info(&self) -> &GridInfo {
        &self.info
    }
    pub fn blocks(&self) -> &[Block] {
        match &self.storage {
            Storage::Owned { blocks, .. } => blocks,
            Storage::Mapped { map, blocks, .. } => bytemuck::cast_slice(&map[blocks.clone()]),
        }
    }
    /// All metacell slots, bound slots and padding included.
    pub fn metacells(&self) -> &[Metacell] {
        match &self.storage {
            Storage::Owned { metacells, .. } => metacells,
            Storage::Mapped { map, metacells, .. } => bytemuck::cast_slice(&map[metacells.clone()]),
        }
    }
    /// Corner records, `precision.bytes_per_cell()` bytes each.
    pub fn cells(&self) -> &[u8] {
        match &self.storage {
            Storage::Owned { cells, .. } => cells,
            Storage::Mapped { map, cells, .. } => &map[cells.clone()],
        }
    }
    /// Whether the buffers live in a memory-mapped file.
    pub fn is_mapped(&self) -> bool {
        matches!(self.storage, Storage::Mapped { .. })
    }

    pub fn active_cells(&self) -> usize {
        self.cells().len() / self.info.precision.bytes_per_cell()
    }
    pub fn metacell_slots(&self) -> usize {
        self.metacells().len()
    }
    pub fn clusters(&self) -> usize {
        self.metacells().len() / CLUSTER_SLOTS
    }
    /// The box of the surface in the renderers' frame (index × spacing, as
    /// [`GridInfo::world_bounds`]): the union of the clusters' bounds (metacells, two cells a
    /// side), within the grid; `None` without active cells. A grid showing some labels
    /// ([`CellGrid::showing_labels`]) holds only theirs, so this is the shown labels' box.
    pub fn surface_bounds(&self) -> Option<([f64; 3], [f64; 3])> {
        let cells = self.info.cell_dims();
        let (lo, hi) = self
            .metacells()
            .chunks_exact(CLUSTER_SLOTS)
            .map(|c| c[BOUND_SLOT].as_bound().cell_box())
            .reduce(|(lo, hi), (l, h)| {
                (
                    [0, 1, 2].map(|a| lo[a].min(l[a])),
                    [0, 1, 2].map(|a| hi[a].max(h[a])),
                )
            })?;
        let spacing = self.info.spacing;
        Some((
            [0, 1, 2].map(|a| lo[a].min(cells[a]) as f64 * spacing[a]),
            [0, 1, 2].map(|a| hi[a].min(cells[a]) as f64 * spacing[a]),
        ))
    }
    /// Metacells with at least one active cell (bound and padding slots excluded).
    pub fn occupied_metacells(&self) -> usize {
        self.metacells()
            .chunks_exact(CLUSTER_SLOTS)
            .map(|c| c[..BOUND_SLOT].iter().filter(|m| !m.is_empty()).count())
            .sum()
    }
    pub fn nonempty_blocks(&self) -> usize {
        self.blocks()
            .iter()
            .filter(|b| b.metacell_count > 0)
            .count()
    }
    /// The bound of cluster `index`.
    pub fn cluster_bound(&self, index: usize) -> ClusterBound {
        self.metacells()[index * CLUSTER_SLOTS + BOUND_SLOT].as_bound()
    }
    /// Corner record of active cell `index`.
    pub fn cell_record(&self, index: usize) -> &[u8] {
        let n = self.info.precision.bytes_per_cell();
        &self.cells()[index * n..(index + 1) * n]
    }
}

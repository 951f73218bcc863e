//! Scene data on the GPU, uploaded once and drawn by any number of views: clustered grid cells
//! split into pages of whole clusters (paper §3.1, byte for byte `isogrid::layout`), with a grid's
//! cell attribute as 16-bit codes (2 bytes per active cell) in the page of their records, the
//! Marching Cubes mesh (Table 3 layout) with optional per-vertex values, and the original volume
//! as a 3D texture for the CR baseline; with the bind-group layouts through which passes read them.

use crate::error::GpuError;
use crate::gpu_types::{MeshUniforms, PageDispatchArgs, PageDrawArgs, PageUniforms};
use crate::wgpu_util::{buffer_entry as entry, layout, storage, uniform, Gpu};
use isogrid::layout::{BOUND_SLOT, CLUSTER_SLOTS};
use isogrid::skip::occupancy::MetacellOccupancy;
use isogrid::skip::octant_space::OctantSpaceMap;
use isogrid::{CellGrid, GridInfo, Metacell};
use std::sync::atomic::{AtomicU64, Ordering};
use wgpu::ShaderStages;

/// How passes bind uploaded data: a page of a grid (group 1 of the cell passes) and a mesh.
pub(crate) struct GridLayouts {
    /// A page for the compute passes: uniforms, metacells, records, the three instance lists
    /// and the draw arguments (written by the expansion).
    pub page_compute: wgpu::BindGroupLayout,
    /// A page for the raster passes: uniforms, metacells, records and one instance list.
    pub page_render: wgpu::BindGroupLayout,
    /// The compute raster's dispatch arguments of a page (written by `size_dispatches`).
    pub dispatch_args: wgpu::BindGroupLayout,
    /// An MC mesh: decoding uniforms and snorm16 positions.
    pub mesh: wgpu::BindGroupLayout,
}

impl GridLayouts {
    pub fn new(device: &wgpu::Device) -> Self {
        let (c, v) = (ShaderStages::COMPUTE, ShaderStages::VERTEX);
        GridLayouts {
            page_compute: layout(
                device,
                "page (compute)",
                &[
                    uniform(0, c),
                    storage(1, c, true),
                    storage(2, c, true),
                    storage(3, c, false),
                    storage(4, c, false),
                    storage(5, c, false),
                    storage(6, c, false),
                ],
            ),
            page_render: layout(
                device,
                "page (render)",
                &[
                    uniform(0, v),
                    storage(1, v, true),
                    storage(2, v, true),
                    storage(3, v, true),
                ],
            ),
            dispatch_args: layout(device, "dispatch arguments", &[storage(0, c, false)]),
            mesh: layout(
                device,
                "mc mesh",
                &[uniform(0, v), storage(1, v, true), storage(2, v, true)],
            ),
        }
    }
}

/// The uploaded data a mode draws: [`crate::Mode::Cgc`] and [`crate::Mode::CgcNoEwa`] need a
/// grid, [`crate::Mode::Cr`] a grid and its volume, [`crate::Mode::Mc`] a mesh.
#[derive(Clone, Copy)]
pub enum Scene<'a> {
    Grid(&'a GpuGrid),
    Volume {
        grid: &'a GpuGrid,
        volume: &'a GpuVolume,
    },
    Mesh(&'a GpuMesh),
}

/// One binding's worth of a grid: a contiguous range of whole clusters.
pub(crate) struct Page {
    /// Global index of the page's first metacell slot and first corner record.
    pub first_slot: u32,
    pub first_cell: u32,
    pub slot_count: u32,
    /// [`PageUniforms::codes_word`]: where the page's attribute codes start in `cells`.
    pub codes_word: u32,
    /// Page uniforms, metacell slots and corner records (then their attribute codes, see
    /// [`RecordLayout`]), bound again by the ray tracer.
    pub uniforms: wgpu::Buffer,
    pub metacells: wgpu::Buffer,
    pub cells: wgpu::Buffer,
    pub args: wgpu::Buffer,
    pub compute_group: wgpu::BindGroup,
    /// Workgroup counts of the compute raster over the three lists ([`PageDispatchArgs`]), and
    /// the bind group through which `size_dispatches` writes them.
    pub dispatch_args: wgpu::Buffer,
    pub dispatch_group: wgpu::BindGroup,
    /// Render bind groups reading the full, probe and new instance list.
    pub render_groups: [wgpu::BindGroup; 3],
}

/// A [`CellGrid`] resident on the GPU: only what was uploaded, never changed by drawing it. What
/// one view of it keeps between frames (visibility bits, accumulated samples) lives in a
/// [`crate::ViewState`].
pub struct GpuGrid {
    /// Tells grids apart in a view's state: another grid starts that state afresh.
    pub(crate) id: u64,
    pub(crate) info: GridInfo,
    pub(crate) pages: Vec<Page>,
    /// Dense block records (the raster passes address cells through metacells only; blocks
    /// serve ray traversal).
    pub(crate) blocks: Option<wgpu::Buffer>,
    /// No sample of the grid's border is inside, so a ray from an eye outside the grid box first
    /// meets the surface from outside and back-face culling is safe.
    pub(crate) border_outside: bool,
    /// The decoding of the cell attribute's 16-bit codes, which each page holds after its
    /// corner records ([`RecordLayout`]); `None` without an attribute.
    pub(crate) attribute: Option<isogrid::CodeMapping>,
    /// A label grid's colours: the linear albedo of each cluster's label (`Label::albedo`), four
    /// f32 per cluster, for `COLOR_LABELS`.
    pub(crate) label_albedo: Option<wgpu::Buffer>,
    active_cells: u64,
    clusters: u64,
}

impl GpuGrid {
    pub fn info(&self) -> &GridInfo {
        &self.info
    }
    /// Number of pages (storage-binding-sized pieces) the grid was split into.
    pub fn page_count(&self) -> usize {
        self.pages.len()
    }
    /// Global index of each page's first corner record (and first attribute code).
    pub fn page_first_records(&self) -> Vec<u64> {
        self.pages.iter().map(|p| p.first_cell as u64).collect()
    }
    pub fn active_cells(&self) -> u64 {
        self.active_cells
    }
    pub fn clusters(&self) -> u64 {
        self.clusters
    }
    /// Whether the grid's cell attribute was uploaded (renders can colour by it).
    pub fn has_attribute(&self) -> bool {
        self.attribute.is_some()
    }
}

static NEXT_GRID_ID: AtomicU64 = AtomicU64::new(1);

/// An MC mesh on the GPU: snorm16 positions (6 bytes per vertex) and u32 indices.
/// What a mesh's one word per vertex holds.
#[derive(Clone, Copy)]
pub enum MeshColor<'a> {
    /// Nothing: the mesh is drawn in the one fixed albedo.
    None,
    /// An attribute value per vertex, interpolated across triangles and drawn through the colour
    /// map of [`crate::RenderOptions::coloring`].
    Values(&'a [f32]),
    /// The index in `table` of each vertex's label (every vertex of a triangle the same), drawn in
    /// its label's colour, or with `values` (one attribute value per vertex) through the colour
    /// map as [`MeshColor::Values`] are; `spacing`, the grid's (the mesh's positions are index ×
    /// spacing), sets how far a back face loses to the touching label's front face (half the
    /// smallest).
    Labels {
        vertex_labels: &'a [u32],
        table: &'a [isogrid::labels::Label],
        spacing: [f64; 3],
        values: Option<&'a [f32]>,
    },
}

pub struct GpuMesh {
    pub(crate) positions: wgpu::Buffer,
    pub(crate) indices: wgpu::Buffer,
    pub(crate) index_count: u32,
    /// Whether the mesh carries one attribute value per vertex (renders can colour by them).
    pub(crate) has_values: bool,
    /// A label mesh's colour words ([`label_mesh_color_words`]); its fragments carry their
    /// label's index where a grid's carry their cluster.
    pub(crate) label_albedo: Option<wgpu::Buffer>,
    pub(crate) bind_group: wgpu::BindGroup,
    /// World-space box of the vertices.
    pub(crate) bounds: ([f64; 3], [f64; 3]),
}

impl GpuMesh {
    pub fn triangle_count(&self) -> u32 {
        self.index_count / 3
    }
    pub fn has_values(&self) -> bool {
        self.has_values
    }
    /// Bytes as the paper counts them (Table 3): positions + indices.
    pub fn memory_bytes(&self) -> u64 {
        self.positions.size() + self.indices.size()
    }
}

/// The original samples of a volume as an `R32Float` 3D texture (data units), for [`crate::Mode::Cr`].
pub struct GpuVolume {
    pub(crate) view: wgpu::TextureView,
    pub(crate) dims: [u32; 3],
}

impl GpuVolume {
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }
}

/// Cell count of each cluster, from its metacells' masks.
fn cluster_cells(metacells: &[Metacell]) -> Vec<u64> {
    metacells
        .chunks_exact(CLUSTER_SLOTS)
        .map(|c| {
            c[..BOUND_SLOT]
                .iter()
                .map(|m| m.active_cells() as u64)
                .sum()
        })
        .collect()
}

/// What a page's record buffer holds for `cells` cells: their corner records (`bytes_per_cell`
/// each, `isogrid::layout`), then, where the grid has an attribute, their attribute codes
/// (`isogrid::CellAttribute::codes16`) from the next word on, two per word, the first in the low
/// half. A code so lives in the page of its record, at the record's page-local index: paging
/// the records pages the codes by the same rule (`record_code_in` in cell_decode.wgsl reads
/// them; web/src/renderer.ts `addPage` lays them out alike).
#[derive(Debug, Clone, Copy)]
pub(crate) struct RecordLayout {
    pub bytes_per_cell: u64,
    pub codes: bool,
}

impl RecordLayout {
    /// Word index of the first code ([`PageUniforms::codes_word`]): 0 without codes.
    pub fn codes_word(&self, cells: u64) -> u64 {
        if self.codes {
            (cells * self.bytes_per_cell).div_ceil(4)
        } else {
            0
        }
    }

    /// Bytes of the buffer (without codes, the records padded to a word).
    pub fn bytes(&self, cells: u64) -> u64 {
        let records = (cells * self.bytes_per_cell).div_ceil(4);
        let codes = if self.codes { cells.div_ceil(2) } else { 0 };
        4 * (records + codes)
    }
}

/// Splits clusters into contiguous ranges whose metacells, record buffers ([`RecordLayout`])
/// and instance lists (4 bytes per cell) each fit in `limit` bytes. Returns (first cluster,
/// cluster count, first record, record count).
pub(crate) fn plan_pages(
    per_cluster: &[u64],
    records: RecordLayout,
    limit: u64,
) -> Result<Vec<(u64, u64, u64, u64)>, GpuError> {
    let slot_bytes = (CLUSTER_SLOTS * std::mem::size_of::<Metacell>()) as u64;
    let cell_bytes = |n: u64| records.bytes(n).max(4 * n);
    let mut pages = Vec::new();
    let (mut first, mut count, mut first_cell, mut cells) = (0u64, 0u64, 0u64, 0u64);
    for (i, &n) in per_cluster.iter().enumerate() {
        if slot_bytes > limit || cell_bytes(n) > limit {
            return Err(GpuError::too_large(format!(
                "one cluster needs {} bytes, more than a storage binding holds ({limit} bytes)",
                cell_bytes(n).max(slot_bytes)
            )));
        }
        if count > 0 && ((count + 1) * slot_bytes > limit || cell_bytes(cells + n) > limit) {
            pages.push((first, count, first_cell, cells));
            first = i as u64;
            first_cell += cells;
            count = 0;
            cells = 0;
        }
        count += 1;
        cells += n;
    }
    if count > 0 {
        pages.push((first, count, first_cell, cells));
    }
    Ok(pages)
}

/// Where grids are uploaded to: the device, the layouts their pages are bound with, and the
/// bytes one page may take.
pub(crate) struct Uploader<'a> {
    pub gpu: &'a Gpu,
    pub layouts: &'a GridLayouts,
    pub page_bytes: u64,
}

impl Uploader<'_> {
    /// Uploads blocks, metacell slots and corner records with the attribute's codes, split into
    /// pages when they exceed one storage binding.
    pub fn upload_grid(&self, grid: &CellGrid) -> Result<GpuGrid, GpuError> {
        self.gpu
            .scoped("uploading the grid", || self.upload_grid_unscoped(grid))
    }

    fn upload_grid_unscoped(&self, grid: &CellGrid) -> Result<GpuGrid, GpuError> {
        // Checked before any page goes up.
        if let Some(labels) = grid.labels() {
            self.check_label_colors("clusters", grid.clusters(), labels.table().len())?;
        }
        let info = grid.info().clone();
        let metacells = grid.metacells();
        let cells = grid.cells();
        let bpc = info.precision.bytes_per_cell() as u64;
        let per_cluster = cluster_cells(metacells);
        let codes = grid.attribute().map(|a| a.codes16());
        let layout = RecordLayout {
            bytes_per_cell: bpc,
            codes: codes.is_some(),
        };
        let plan = plan_pages(&per_cluster, layout, self.page_bytes)?;
        let storage = wgpu::BufferUsages::STORAGE;
        let mut pages = Vec::with_capacity(plan.len());
        for (p, &(first_cluster, clusters, first_cell, cell_count)) in plan.iter().enumerate() {
            let slots = first_cluster as usize * CLUSTER_SLOTS
                ..(first_cluster + clusters) as usize * CLUSTER_SLOTS;
            let records = (first_cell * bpc) as usize..((first_cell + cell_count) * bpc) as usize;
            let codes_word = layout.codes_word(cell_count) as u32;
            let uniforms = PageUniforms {
                first_slot: slots.start as u32,
                first_cell: first_cell as u32,
                slot_count: slots.len() as u32,
                codes_word,
            };
            let uniforms = self.gpu.buffer_init(
                &format!("page {p} uniforms"),
                bytemuck::bytes_of(&uniforms),
                wgpu::BufferUsages::UNIFORM,
            )?;
            let metacell_buffer = self.gpu.buffer_init(
                &format!("page {p} metacells"),
                bytemuck::cast_slice(&metacells[slots.clone()]),
                storage,
            )?;
            let page_codes = codes.as_ref().map_or(&[][..], |(c, _)| {
                bytemuck::cast_slice(&c[first_cell as usize..(first_cell + cell_count) as usize])
            });
            let cell_buffer = self.gpu.buffer_init_parts(
                &format!("page {p} corner records and attribute codes"),
                &[&cells[records], page_codes],
                storage,
            )?;
            debug_assert_eq!(cell_buffer.size(), layout.bytes(cell_count).max(4));
            let list_bytes = [cell_count, slots.len() as u64, cell_count].map(|n| 4 * n);
            let lists = [
                self.gpu.buffer(
                    &format!("page {p} full instance list"),
                    list_bytes[0],
                    storage,
                )?,
                self.gpu.buffer(
                    &format!("page {p} probe instance list"),
                    list_bytes[1],
                    storage,
                )?,
                self.gpu.buffer(
                    &format!("page {p} new instance list"),
                    list_bytes[2],
                    storage,
                )?,
            ];
            let args = self.gpu.buffer_init(
                &format!("page {p} draw arguments"),
                bytemuck::bytes_of(&PageDrawArgs::empty()),
                storage
                    | wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            )?;
            let compute_group = self
                .gpu
                .device
                .create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&format!("page {p} (compute)")),
                    layout: &self.layouts.page_compute,
                    entries: &[
                        entry(0, &uniforms),
                        entry(1, &metacell_buffer),
                        entry(2, &cell_buffer),
                        entry(3, &lists[0]),
                        entry(4, &lists[1]),
                        entry(5, &lists[2]),
                        entry(6, &args),
                    ],
                });
            let dispatch_args = self.gpu.buffer_init(
                &format!("page {p} compute raster dispatch arguments"),
                bytemuck::bytes_of(&PageDispatchArgs::default()),
                storage | wgpu::BufferUsages::INDIRECT,
            )?;
            let dispatch_group = self
                .gpu
                .device
                .create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&format!("page {p} dispatch arguments (compute)")),
                    layout: &self.layouts.dispatch_args,
                    entries: &[entry(0, &dispatch_args)],
                });
            let render_groups = std::array::from_fn(|l| {
                self.gpu
                    .device
                    .create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some(&format!("page {p} list {l} (render)")),
                        layout: &self.layouts.page_render,
                        entries: &[
                            entry(0, &uniforms),
                            entry(1, &metacell_buffer),
                            entry(2, &cell_buffer),
                            entry(3, &lists[l]),
                        ],
                    })
            });
            pages.push(Page {
                first_slot: slots.start as u32,
                first_cell: first_cell as u32,
                slot_count: slots.len() as u32,
                codes_word,
                uniforms,
                metacells: metacell_buffer,
                cells: cell_buffer,
                args,
                compute_group,
                dispatch_args,
                dispatch_group,
                render_groups,
            });
        }
        let blocks = if grid.blocks().is_empty() {
            None
        } else {
            let words = tracer_block_words(grid);
            Some(self.gpu.buffer_init(
                "blocks, empty-space map and metacell occupancy",
                bytemuck::cast_slice(&words),
                storage,
            )?)
        };
        let label_albedo = match grid.labels() {
            Some(labels) => Some(self.gpu.buffer_init(
                "label colours",
                bytemuck::cast_slice(&label_color_words(labels)),
                wgpu::BufferUsages::STORAGE,
            )?),
            None => None,
        };
        Ok(GpuGrid {
            id: NEXT_GRID_ID.fetch_add(1, Ordering::Relaxed),
            border_outside: border_is_outside(grid),
            attribute: codes.map(|(_, mapping)| mapping),
            label_albedo,
            info,
            pages,
            blocks,
            active_cells: grid.active_cells() as u64,
            clusters: grid.clusters() as u64,
        })
    }

    /// Refuses label colour words ([`color_words_of`]: 4 B per item, 16 B per label) that one
    /// storage binding cannot hold, in words that say what to do, before anything is uploaded;
    /// `items` counts what carries a label (`what`: clusters, or a label mesh's labels).
    fn check_label_colors(&self, what: &str, items: usize, labels: usize) -> Result<(), GpuError> {
        let bytes = 4 * (2 + items as u64) + 16 * (labels as u64 + 1);
        if bytes > self.page_bytes {
            return Err(GpuError::too_large(format!(
                "the label colours of {items} {what} and {labels} labels need {bytes} bytes, more \
                 than one storage binding of this device holds ({} bytes); the CPU tracer draws \
                 them (--backend cpu)",
                self.page_bytes
            )));
        }
        Ok(())
    }

    /// Uploads an MC mesh as snorm16 positions scaled by its bounds and u32 indices (paper Table 3),
    /// with `color`'s words, one per vertex: an attribute value, or the index of its label.
    pub fn upload_mesh(
        &self,
        mesh: &isogrid::mc::McMesh,
        color: MeshColor<'_>,
    ) -> Result<GpuMesh, GpuError> {
        let count = match color {
            MeshColor::None => None,
            MeshColor::Values(v) => Some(v.len()),
            MeshColor::Labels { vertex_labels, .. } => Some(vertex_labels.len()),
        };
        let label_values = match color {
            MeshColor::Labels { values, .. } => values,
            _ => None,
        };
        let wrong_count = count.filter(|&n| n != mesh.positions.len());
        if let Some(n) = wrong_count.or(label_values
            .map(<[f32]>::len)
            .filter(|&n| n != mesh.positions.len()))
        {
            return Err(GpuError::invalid(format!(
                "{n} vertex values for a mesh of {} vertices",
                mesh.positions.len()
            )));
        }
        if let MeshColor::Labels {
            vertex_labels,
            table,
            ..
        } = color
        {
            if vertex_labels.iter().any(|&l| l as usize >= table.len()) {
                return Err(GpuError::invalid("a vertex names a label beyond the table"));
            }
            self.check_label_colors("labels", table.len(), table.len())?;
        }
        self.gpu.scoped("uploading the mesh", || {
            let snorm = mesh.to_snorm16();
            let index_count = u32::try_from(mesh.triangles.len() * 3)
                .map_err(|_| GpuError::too_large("the mesh has more than 2^32 indices"))?;
            let positions = self.gpu.buffer_init(
                "mc snorm16 positions",
                bytemuck::cast_slice(&snorm.positions),
                wgpu::BufferUsages::STORAGE,
            )?;
            let indices = self.gpu.buffer_init(
                "mc indices",
                bytemuck::cast_slice(&snorm.triangles),
                wgpu::BufferUsages::INDEX,
            )?;
            let uniforms = MeshUniforms {
                center: [
                    snorm.center[0],
                    snorm.center[1],
                    snorm.center[2],
                    match color {
                        MeshColor::Labels { spacing, .. } => {
                            (0.5 * spacing.iter().copied().fold(f64::INFINITY, f64::min)) as f32
                        }
                        _ => 0.0,
                    },
                ],
                half_extent: [
                    snorm.half_extent[0],
                    snorm.half_extent[1],
                    snorm.half_extent[2],
                    if label_values.is_some() { 1.0 } else { 0.0 },
                ],
            };
            let uniforms = self.gpu.buffer_init(
                "mc mesh uniforms",
                bytemuck::bytes_of(&uniforms),
                wgpu::BufferUsages::UNIFORM,
            )?;
            // A label mesh with values: each vertex's label, then its value's bits.
            let pairs: Vec<u32>;
            let words: &[u32] = match color {
                MeshColor::Values(v) if !v.is_empty() => bytemuck::cast_slice(v),
                MeshColor::Labels {
                    vertex_labels,
                    values: Some(values),
                    ..
                } if !vertex_labels.is_empty() => {
                    pairs = vertex_labels
                        .iter()
                        .zip(values)
                        .flat_map(|(&l, v)| [l, v.to_bits()])
                        .collect();
                    &pairs
                }
                MeshColor::Labels { vertex_labels, .. } if !vertex_labels.is_empty() => {
                    vertex_labels
                }
                _ => &[f32::NAN.to_bits()],
            };
            let vertex_values = self.gpu.buffer_init(
                "mc vertex words",
                bytemuck::cast_slice(words),
                wgpu::BufferUsages::STORAGE,
            )?;
            let label_albedo = match color {
                MeshColor::Labels { table, .. } => Some(self.gpu.buffer_init(
                    "label mesh colours",
                    bytemuck::cast_slice(&label_mesh_color_words(table)),
                    wgpu::BufferUsages::STORAGE,
                )?),
                _ => None,
            };
            let bind_group = self
                .gpu
                .device
                .create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("mc mesh"),
                    layout: &self.layouts.mesh,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: uniforms.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: positions.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: vertex_values.as_entire_binding(),
                        },
                    ],
                });
            let lo = std::array::from_fn(|a| (snorm.center[a] - snorm.half_extent[a]) as f64);
            let hi = std::array::from_fn(|a| (snorm.center[a] + snorm.half_extent[a]) as f64);
            Ok(GpuMesh {
                positions,
                indices,
                index_count,
                has_values: matches!(color, MeshColor::Values(_)) || label_values.is_some(),
                label_albedo,
                bind_group,
                bounds: (lo, hi),
            })
        })
    }

    /// Uploads the original samples (as f32 data values) for the CR baseline; `grid` must have
    /// been extracted from this volume.
    pub fn upload_volume(
        &self,
        volume: &isogrid::VolumeView,
        grid: &GpuGrid,
    ) -> Result<GpuVolume, GpuError> {
        let dims = volume.dims();
        if dims.map(|d| d as u32) != grid.info.dims {
            return Err(GpuError::invalid(format!(
                "volume is {}x{}x{} but the grid was extracted from {}x{}x{}",
                dims[0], dims[1], dims[2], grid.info.dims[0], grid.info.dims[1], grid.info.dims[2]
            )));
        }
        let max = self.gpu.limits.max_texture_dimension_3d as usize;
        if dims.iter().any(|&d| d > max) {
            return Err(GpuError::too_large(format!(
                "volume {}x{}x{} exceeds the largest 3D texture ({max} per axis)",
                dims[0], dims[1], dims[2]
            )));
        }
        self.gpu.scoped("uploading the volume", || {
            let size = wgpu::Extent3d {
                width: dims[0] as u32,
                height: dims[1] as u32,
                depth_or_array_layers: dims[2] as u32,
            };
            let texture = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("original volume (CR)"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let samples = volume.samples();
            let slice = dims[0] * dims[1];
            // One z slice at a time keeps the f32 staging copy small.
            let mut plane = vec![0f32; slice];
            for z in 0..dims[2] {
                for (i, v) in plane.iter_mut().enumerate() {
                    *v = samples.get_f64(z * slice + i) as f32;
                }
                self.gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d {
                            x: 0,
                            y: 0,
                            z: z as u32,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(&plane),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(4 * dims[0] as u32),
                        rows_per_image: Some(dims[1] as u32),
                    },
                    wgpu::Extent3d {
                        depth_or_array_layers: 1,
                        ..size
                    },
                );
            }
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("original volume view"),
                ..Default::default()
            });
            Ok(GpuVolume {
                view,
                dims: dims.map(|d| d as u32),
            })
        })
    }
}

/// Words of occupancy record per non-empty block: see [`tracer_block_words`].
const OCCUPANCY_RECORD_WORDS: usize = 25;

/// What the tracer reads per block, as one array of words (keep in sync with `block_side`
/// and `occupancy_index` in trace.wgsl):
/// - the block records byte for byte (4 words each, `isogrid::layout::Block`);
/// - the octant empty-space map (`isogrid::skip::octant_space`, as the CPU tracer leaps): for
///   each of the 8 ray octants in turn, one byte per block, the whole padded to a whole word;
/// - per block, the word offset of its occupancy record in this array (`u32::MAX` when empty);
/// - per non-empty block, a record of [`OCCUPANCY_RECORD_WORDS`]: the 512-bit Morton-order mask
///   of its occupied metacells (16 words), the count of occupied metacells before each mask word
///   (8 words of two 16-bit counts) and the box of the occupied metacells (1 word: lowest x, y,
///   z at bits 0, 3, 6, highest at 9, 12, 15, and bit 18 set when the block is listed); a
///   listed block (a label grid's block of several labels) follows it with its list, the slots
///   at each occupied position (`isogrid::skip::occupancy`): `occupied + 1` word offsets from
///   the record's start (rank `k`'s slots begin at the `k`-th, the last ends them), then the
///   slots.
fn tracer_block_words(grid: &CellGrid) -> Vec<u32> {
    let blocks = grid.blocks();
    let block_dims = grid.info().block_dims().map(|b| b as usize);
    let map = OctantSpaceMap::new(blocks, block_dims);
    let occupancy = MetacellOccupancy::new(blocks, grid.metacells(), block_dims);
    let mut words: Vec<u32> = bytemuck::cast_slice(blocks).to_vec();
    let sides: Vec<u8> = (0..8).flat_map(|o| map.octant(o).iter().copied()).collect();
    words.extend(
        sides
            .chunks(4)
            .map(|c| c.iter().rev().fold(0u32, |w, &d| w << 8 | d as u32)),
    );
    let index_start = words.len();
    words.resize(index_start + blocks.len(), u32::MAX);
    for index in 0..blocks.len() {
        let Some(record) = occupancy.of_block(index) else {
            continue;
        };
        let start = words.len();
        words[index_start + index] = start as u32;
        let mask: Vec<u32> = record
            .mask()
            .iter()
            .flat_map(|&w| [w as u32, (w >> 32) as u32])
            .collect();
        let mut before = 0u32;
        let mut counts = [0u32; 8];
        for (w, &m) in mask.iter().enumerate() {
            counts[w / 2] |= before << (16 * (w % 2));
            before += m.count_ones();
        }
        words.extend(mask);
        words.extend(counts);
        words.push(record.packed_bounds());
        debug_assert_eq!(words.len() - start, OCCUPANCY_RECORD_WORDS);
        if let Some(list) = occupancy.list(record) {
            let offsets = record.occupied() + 1;
            words.extend(
                list[..offsets]
                    .iter()
                    .map(|&o| o + OCCUPANCY_RECORD_WORDS as u32),
            );
            words.extend(&list[offsets..]);
        }
    }
    words
}

/// Whether no sample on the grid's border is inside. Border samples of active cells are checked
/// from their corner records; the remaining border samples lie in inactive cells only, and since
/// the border is connected, a border sample inside next to one outside would make an active cell
/// with an inside border corner. So with no such corner all border samples share one side, which
/// is "outside" once one border sample is known to be outside: a border corner of an active cell,
/// or a border block whose largest sample is below the isovalue.
fn border_is_outside(grid: &CellGrid) -> bool {
    let info = grid.info();
    let iso_code = info.mapping.iso_code;
    let last = info.dims.map(|d| d.saturating_sub(1));
    let mut known_outside = false;
    let on_border = |p: [u32; 3]| (0..3).any(|a| p[a] == 0 || p[a] >= last[a]);
    for m in grid
        .metacells()
        .chunks_exact(CLUSTER_SLOTS)
        .flat_map(|c| &c[..BOUND_SLOT])
    {
        let mut record = m.cell_pointer as usize;
        for bit in 0..8 {
            if m.cell_mask & (1 << bit) == 0 {
                continue;
            }
            let cell = m.cell_position(bit);
            if (0..3).any(|a| cell[a] == 0 || cell[a] + 1 >= last[a]) {
                let corners =
                    isogrid::layout::read_corners(grid.cell_record(record), info.precision);
                for (c, code) in corners.iter().enumerate() {
                    let p = [
                        cell[0] + (c as u32 & 1),
                        cell[1] + (c as u32 >> 1 & 1),
                        cell[2] + (c as u32 >> 2 & 1),
                    ];
                    if on_border(p) {
                        if *code >= iso_code {
                            return false;
                        }
                        known_outside = true;
                    }
                }
            }
            record += 1;
        }
    }
    if known_outside {
        return true;
    }
    let n = info.block_dims();
    let blocks = grid.blocks();
    (0..blocks.len()).any(|i| {
        let b = [
            i as u32 % n[0],
            i as u32 / n[0] % n[1],
            i as u32 / (n[0] * n[1]),
        ];
        let border = (0..3).any(|a| b[a] == 0 || b[a] + 1 == n[a]);
        border && (blocks[i].max as f64) < info.iso
    })
}

/// The colour words of a label grid that `cluster_albedo` (color.wgsl) reads, 4 B per cluster and
/// 16 B per label rather than 16 B per cluster, so that a binding holds four times the clusters:
/// word 0 the first word of the table; from word 1 each cluster's label index, then one for a miss
/// naming the table's last entry; then the table, each label's linear albedo (`Label::albedo`,
/// f32 bits, four words), and a zero entry. Twin: `labelColorWords` in web/src/colors.ts.
pub(crate) fn label_color_words(labels: &isogrid::labels::GridLabels) -> Vec<u32> {
    color_words_of(labels.cluster_labels(), labels.table())
}

/// [`label_color_words`] for items (clusters, or a label mesh's labels) whose label indices are
/// `item_labels`, of the labels `table`.
fn color_words_of(item_labels: &[u32], table: &[isogrid::labels::Label]) -> Vec<u32> {
    let label_count = table.len() as u32;
    let table_word = 2 + item_labels.len() as u32;
    let mut words = Vec::with_capacity(table_word as usize + 4 * (table.len() + 1));
    words.push(table_word);
    words.extend_from_slice(item_labels);
    words.push(label_count);
    for label in table {
        let [r, g, b] = label.albedo();
        words.extend([r.to_bits(), g.to_bits(), b.to_bits(), 0]);
    }
    words.extend([0; 4]);
    words
}

/// The colour words of a label mesh, whose fragments carry their label's index where a grid's
/// carry their cluster: the items are the labels themselves.
pub(crate) fn label_mesh_color_words(table: &[isogrid::labels::Label]) -> Vec<u32> {
    let identity: Vec<u32> = (0..table.len() as u32).collect();
    color_words_of(&identity, table)
}

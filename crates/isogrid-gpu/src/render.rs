//! One rendered image: per-frame pass sequence (see the crate docs), timestamp queries around each
//! pass, and read-back of colour, depth, normal and cluster AOVs.

use crate::compute_raster::{CellRaster, ComputeRaster, RasterStep};
use crate::error::GpuError;
use crate::gpu_types::*;
use crate::pathtrace::{PathTraceOptions, PrimaryRays};
use crate::pipelines::*;
use crate::upload::{GpuGrid, GpuMesh, GpuVolume};
use crate::Renderer;
use isogrid::Camera;
use std::sync::atomic::Ordering;

/// What to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Cell rasterisation of the clustered grid cells with EWA normal splatting (§3.2–3.4).
    Cgc,
    /// Cell rasterisation with per-pixel trilinear-gradient normals, no EWA pass.
    CgcNoEwa,
    /// The Marching Cubes mesh baseline.
    Mc,
    /// Cell rasterisation sampling the original volume (the paper's CR [13] baseline), with the
    /// same clusters and visibility buffer.
    Cr,
    /// Hybrid path tracing (§3.6): the [`Mode::Cgc`] G-buffer gives primary hits, secondary rays
    /// are traced through the blocks, clusters, metacells and cells in a compute pass, and the
    /// samples accumulate while the view rests. See [`Renderer::path_trace`] for the options,
    /// among them tracing the primary rays too ([`crate::PrimaryRays::Traced`]).
    PathTrace,
}

/// The uploaded data a mode draws: [`Mode::Cgc`] and [`Mode::CgcNoEwa`] need a grid,
/// [`Mode::Cr`] a grid and its volume, [`Mode::Mc`] a mesh.
#[derive(Clone, Copy)]
pub enum Scene<'a> {
    Grid(&'a GpuGrid),
    Volume {
        grid: &'a GpuGrid,
        volume: &'a GpuVolume,
    },
    Mesh(&'a GpuMesh),
}

/// How to render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderOptions {
    /// Renders the same view this many times (at least 1); the visibility buffer converges over
    /// frames and timings are the median over frames after the first.
    pub frames: u32,
    /// Draws only clusters visible last frame (or found visible by probes this frame).
    pub occlusion_culling: bool,
    /// Skips cells whose surface faces away from the eye, where that cannot change the image (the
    /// grid's border is outside the surface and the eye is outside the grid box).
    pub backface_culling: bool,
    /// Which raster draws the cells; see [`CellRaster`].
    pub cell_raster: CellRaster,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            frames: 1,
            occlusion_culling: true,
            backface_culling: true,
            cell_raster: CellRaster::Auto,
        }
    }
}

/// GPU time of the last frames' passes in milliseconds (median over frames after the first);
/// `None` without timestamp queries or where the pass did not run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassTimings {
    /// Depth and G-buffer passes: cell raster (both visibility passes) plus EWA splatting, or the
    /// MC mesh pass (the quantity of the paper's Table 4).
    pub raster_ms: Option<f64>,
    /// The EWA splatting pass alone; `raster_ms - ewa_ms` is the raster time without EWA.
    pub ewa_ms: Option<f64>,
    /// Deferred shading.
    pub shade_ms: Option<f64>,
    /// Culling work: cluster expansion (both), probes and the visibility update.
    pub cull_ms: Option<f64>,
    /// First to last timestamp of the frame.
    pub frame_ms: Option<f64>,
    /// The path tracing pass ([`Mode::PathTrace`]): secondary rays (and primary ones with
    /// [`crate::PrimaryRays::Traced`]), accumulation, tone mapping.
    pub trace_ms: Option<f64>,
}

/// A rendered image with per-pixel AOVs, row-major from the top-left.
#[derive(Debug, Clone)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// sRGB colour, 4 bytes per pixel (alpha 255).
    pub rgba8: Vec<u8>,
    /// World distance from the eye to the hit along the pixel's ray; `+inf` on a miss.
    pub depth: Vec<f32>,
    /// Unit world normal −∇f (pointing out of the solid, to values below the isovalue) as shaded;
    /// NaN on a miss.
    pub normal: Vec<[f32; 3]>,
    /// Cluster index of the hit (global, slot / 16); `u32::MAX` on a miss, 0 for MC hits.
    pub cluster: Vec<u32>,
    pub timings: PassTimings,
    /// Cells fully rasterised in the last frame (both visibility passes; 0 for MC).
    pub drawn_cells: u64,
    /// Probe splats drawn in the last frame.
    pub probed_cells: u64,
    /// [`Mode::PathTrace`]: mean linear RGB radiance per pixel over all accumulated samples (what
    /// `rgba8` encodes as sRGB); empty in other modes.
    pub linear: Vec<[f32; 3]>,
    /// [`Mode::PathTrace`]: samples per pixel accumulated so far for this view; 0 in other modes.
    pub samples: u32,
    /// The raster that drew the cells ([`CellRaster::Auto`] resolved); `None` for the MC mesh.
    pub cell_raster: Option<CellRaster>,
}

impl Frame {
    pub fn is_hit(&self, pixel: usize) -> bool {
        self.cluster[pixel] != u32::MAX
    }
}

// Timestamp slots of one frame: begin/end of each pass.
const TS_EXPAND: u32 = 0;
const TS_RASTER: u32 = 2;
const TS_PROBE: u32 = 4;
const TS_EXPAND_NEW: u32 = 6;
const TS_RASTER_NEW: u32 = 8;
const TS_EWA: u32 = 10;
const TS_VISIBILITY: u32 = 12;
const TS_SHADE: u32 = 14;
const TS_TRACE: u32 = 16;
const TS_PER_FRAME: u32 = 18;
/// Passes with timestamp slots.
const TIMED_PASSES: usize = (TS_PER_FRAME / 2) as usize;
/// Frames whose timestamps are kept.
const TIMED_FRAMES: u32 = 64;

/// Render targets of one image size.
struct Targets {
    depth: wgpu::Texture,
    /// The compute raster's depth: reversed-Z bits per pixel, row-major.
    raster_depth: wgpu::Buffer,
    surface: wgpu::Texture,
    ids: wgpu::Texture,
    ewa: wgpu::Texture,
    color: wgpu::Texture,
    final_normal: wgpu::Texture,
}

fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor::default())
}

fn color_attachment(
    view: &wgpu::TextureView,
    clear: Option<wgpu::Color>,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: match clear {
                Some(c) => wgpu::LoadOp::Clear(c),
                None => wgpu::LoadOp::Load,
            },
            store: wgpu::StoreOp::Store,
        },
    })
}

/// Bytes per row of a read-back copy, padded to wgpu's 256-byte alignment.
fn padded_row(width: u32, texel_bytes: u32) -> u32 {
    (width * texel_bytes).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    Some(v[v.len() / 2])
}

impl Renderer {
    /// Renders `frames` frames of one view with default culling; see [`Renderer::render_with`].
    pub fn render(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        frames: u32,
    ) -> Result<Frame, GpuError> {
        self.render_with(
            scene,
            camera,
            mode,
            &RenderOptions {
                frames,
                ..Default::default()
            },
        )
    }

    /// Renders `options.frames` frames of one view and reads back the last one.
    ///
    /// Visibility persists in the [`GpuGrid`] between calls with the same camera, mode and
    /// options; any other view starts from "every cluster visible", so the first frame is complete.
    ///
    /// [`Mode::PathTrace`] uses [`PathTraceOptions::default`] with these frames and culling
    /// options; [`Renderer::path_trace`] takes the others.
    pub fn render_with(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
    ) -> Result<Frame, GpuError> {
        let path_trace = (mode == Mode::PathTrace).then(|| PathTraceOptions {
            frames: options.frames,
            occlusion_culling: options.occlusion_culling,
            backface_culling: options.backface_culling,
            ..Default::default()
        });
        self.render_checked(scene, camera, mode, options, path_trace.as_ref())
    }

    pub(crate) fn render_checked(
        &self,
        scene: Scene<'_>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
        path_trace: Option<&PathTraceOptions>,
    ) -> Result<Frame, GpuError> {
        camera
            .validate()
            .map_err(|e| GpuError::invalid(e.to_string()))?;
        let max = self.limits.max_texture_dimension_2d;
        if camera.width > max || camera.height > max {
            return Err(GpuError::too_large(format!(
                "image {}x{} exceeds the device's largest texture ({max} per side)",
                camera.width, camera.height
            )));
        }
        let (grid, volume, mesh) = match (mode, scene) {
            (
                Mode::Cgc | Mode::CgcNoEwa | Mode::PathTrace,
                Scene::Grid(g) | Scene::Volume { grid: g, .. },
            ) => (Some(g), None, None),
            (Mode::Cr, Scene::Volume { grid, volume }) => (Some(grid), Some(volume), None),
            (Mode::Mc, Scene::Mesh(m)) => (None, None, Some(m)),
            _ => {
                return Err(GpuError::invalid(format!(
                    "mode {mode:?} needs {}",
                    match mode {
                        Mode::Mc => "an uploaded mesh (Scene::Mesh)",
                        Mode::Cr => "a grid and its volume (Scene::Volume)",
                        _ => "an uploaded grid (Scene::Grid)",
                    }
                )))
            }
        };
        self.scoped("rendering", || {
            self.render_unscoped(grid, volume, mesh, camera, mode, options, path_trace)
        })
    }

    fn texture(
        &self,
        label: &str,
        camera: &Camera,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: camera.width,
                height: camera.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }

    /// `final_in_compute`: the final normal is written as a storage texture (by the compute
    /// shading pass or the path tracer's traced primaries), a usage the fragment shading pass does
    /// not need (it can cost render targets their compression). The raster G-buffer (surface, ids,
    /// EWA) is always storage: the compute raster writes it.
    fn targets(&self, camera: &Camera, final_in_compute: bool) -> Targets {
        use wgpu::TextureUsages as U;
        let rt = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING;
        let written = if final_in_compute {
            U::STORAGE_BINDING
        } else {
            U::empty()
        };
        Targets {
            depth: self.texture("raster depth (reversed-Z)", camera, DEPTH_FORMAT, rt),
            raster_depth: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("compute raster depth (reversed-Z bits)"),
                size: 4 * camera.width as u64 * camera.height as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            // Storage: the compute raster writes these two.
            surface: self.texture(
                "raster normal + distance",
                camera,
                SURFACE_FORMAT,
                rt | U::STORAGE_BINDING,
            ),
            ids: self.texture(
                "cluster ids",
                camera,
                IDS_FORMAT,
                rt | U::COPY_SRC | U::STORAGE_BINDING,
            ),
            // Storage: the compute splats' resolve writes it.
            ewa: self.texture(
                "ewa normal accumulation",
                camera,
                EWA_FORMAT,
                rt | U::STORAGE_BINDING,
            ),
            color: self.texture(
                "shaded colour",
                camera,
                COLOR_FORMAT,
                // Storage: the path tracer writes its tone-mapped mean here.
                U::RENDER_ATTACHMENT | U::COPY_SRC | U::STORAGE_BINDING,
            ),
            final_normal: self.texture(
                "final normal + distance",
                camera,
                FINAL_FORMAT,
                // Texture binding: the path tracer's primary hits.
                U::RENDER_ATTACHMENT | U::COPY_SRC | U::TEXTURE_BINDING | written,
            ),
        }
    }

    fn frame_uniforms(
        &self,
        camera: &Camera,
        grid: Option<&GpuGrid>,
        volume: bool,
        bounds: ([f64; 3], [f64; 3]),
        flags: u32,
        frame: u32,
    ) -> FrameUniforms {
        let (right, up, forward) = camera.basis();
        let tan = (camera.fovy_degrees.to_radians() * 0.5).tan();
        let aspect = camera.width as f64 / camera.height as f64;
        let center: [f64; 3] = std::array::from_fn(|a| 0.5 * (bounds.0[a] + bounds.1[a]));
        let radius = (0..3)
            .map(|a| (bounds.1[a] - bounds.0[a]).powi(2))
            .sum::<f64>()
            .sqrt()
            * 0.5;
        let distance = (0..3)
            .map(|a| (camera.eye[a] - center[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        // Reversed-Z keeps precision far away, so a near plane well in front of anything costs nothing.
        let near = 1e-5 * (distance + radius).max(1e-6);
        let v4 = |v: [f64; 3], w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
        let (spacing, iso, precision) = match grid {
            Some(g) => {
                let iso = if volume {
                    g.info.iso as f32
                } else {
                    g.info.mapping.iso_code
                };
                (g.info.spacing, iso, g.info.precision.bits())
            }
            None => ([1.0; 3], 0.0, 0),
        };
        // For the volume, the smallest f32 at or above the isovalue keeps `value >= iso` exact.
        let iso = match grid {
            Some(g) if volume && (iso as f64) < g.info.iso => iso.next_up(),
            _ => iso,
        };
        FrameUniforms {
            eye: v4(camera.eye, near),
            right: v4(right, tan * aspect),
            up: v4(up, tan),
            forward: v4(forward, EWA_SIGMA_CELLS),
            viewport: [
                camera.width as f32,
                camera.height as f32,
                1.0 / camera.width as f32,
                1.0 / camera.height as f32,
            ],
            cell_to_world: [spacing[0] as f32, spacing[1] as f32, spacing[2] as f32, iso],
            params: [
                precision,
                if volume {
                    SOURCE_VOLUME
                } else {
                    SOURCE_RECORDS
                },
                flags,
                frame,
            ],
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn render_unscoped(
        &self,
        grid: Option<&GpuGrid>,
        volume: Option<&GpuVolume>,
        mesh: Option<&GpuMesh>,
        camera: &Camera,
        mode: Mode,
        options: &RenderOptions,
        path_trace: Option<&PathTraceOptions>,
    ) -> Result<Frame, GpuError> {
        let frames = options.frames.max(1);
        let ewa = matches!(mode, Mode::Cgc | Mode::PathTrace);
        // Traced primaries: the path-trace pass alone fills the image and the G-buffer.
        let traced = path_trace.is_some_and(|o| o.primary == PrimaryRays::Traced);
        let raster_grid = grid.filter(|_| !traced);
        let bounds = match (grid, mesh) {
            (Some(g), _) => g.info.world_bounds(),
            (None, Some(m)) => m.bounds,
            _ => ([0.0; 3], [1.0; 3]),
        };
        let eye_outside =
            (0..3).any(|a| camera.eye[a] < bounds.0[a] || camera.eye[a] > bounds.1[a]);
        let occlusion = options.occlusion_culling && grid.is_some();
        let cell_raster = raster_grid.map(|g| options.cell_raster.resolve(camera, &g.info));
        let compute_raster = cell_raster == Some(CellRaster::Compute);
        let targets = self.targets(camera, traced || compute_raster);
        let backface =
            options.backface_culling && grid.is_some_and(|g| g.border_outside) && eye_outside;
        let mut flags = 0;
        if occlusion {
            flags |= FLAG_OCCLUSION;
        }
        if backface {
            flags |= FLAG_BACKFACE;
        }
        if ewa {
            flags |= FLAG_EWA;
        }

        // Visibility state belongs to one view; a new view starts with every cluster visible.
        if let Some(g) = grid {
            let key = format!("{camera:?} {mode:?} {flags}");
            let mut last = g
                .last_view
                .lock()
                .map_err(|_| GpuError::device("visibility state poisoned"))?;
            if last.as_deref() != Some(key.as_str()) {
                let all = vec![0xffu8; g.visibility_bytes as usize];
                self.queue.write_buffer(&g.visible_last_frame, 0, &all);
                let none = vec![0u8; g.visibility_bytes as usize];
                self.queue.write_buffer(&g.visible_new, 0, &none);
                *last = Some(key);
            }
        }

        let uniform_buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let dummy_storage = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("unused visibility bits"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let dummy_volume = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("unused volume"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let dummy_volume_view = view(&dummy_volume);
        let volume_view = volume.map(|v| &v.view).unwrap_or(&dummy_volume_view);
        let (vis_last, vis_new) = match grid {
            Some(g) => (&g.visible_last_frame, &g.visible_new),
            None => (&dummy_storage, &dummy_storage),
        };
        let p = &self.pipelines;
        let scene_compute = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene (compute)"),
            layout: &p.scene_compute,
            entries: &[
                buffer_entry(0, &uniform_buffer),
                buffer_entry(1, vis_last),
                texture_entry(2, volume_view),
                buffer_entry(3, vis_new),
            ],
        });
        let scene_render = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene (render)"),
            layout: &p.scene_render,
            entries: &[
                buffer_entry(0, &uniform_buffer),
                texture_entry(2, volume_view),
                buffer_entry(3, vis_new),
            ],
        });
        let depth_view = view(&targets.depth);
        let surface_view = view(&targets.surface);
        let ids_view = view(&targets.ids);
        let ewa_view = view(&targets.ewa);
        let color_view = view(&targets.color);
        let final_view = view(&targets.final_normal);
        let depth_input = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raster depth input"),
            layout: &p.depth_input,
            entries: &[texture_entry(0, &depth_view)],
        });
        let surface_input = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raster surface input"),
            layout: &p.surface_input,
            entries: &[texture_entry(0, &surface_view)],
        });
        let raster_targets = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("compute raster targets"),
            layout: &p.raster_targets,
            entries: &[
                buffer_entry(0, &targets.raster_depth),
                texture_entry(1, &surface_view),
                texture_entry(2, &ids_view),
            ],
        });
        // The compute splats' integer sums: 4 words per pixel, only when they run.
        let ewa_sum = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("compute ewa sums"),
            size: if ewa && compute_raster {
                16 * camera.width as u64 * camera.height as u64
            } else {
                16
            },
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let ewa_targets = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("compute ewa targets"),
            layout: &p.ewa_targets,
            entries: &[
                buffer_entry(0, &ewa_sum),
                texture_entry(1, &surface_view),
                texture_entry(2, &ewa_view),
            ],
        });
        let ids_input = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cluster id input"),
            layout: &p.ids_input,
            entries: &[texture_entry(0, &ids_view)],
        });
        let shade_inputs = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shading inputs"),
            layout: &p.shade_inputs,
            entries: &[
                texture_entry(0, &surface_view),
                texture_entry(1, &ewa_view),
                texture_entry(2, &ids_view),
            ],
        });

        // Only the compute shading pass binds its outputs as storage (see `targets`).
        let shade_outputs = compute_raster.then(|| {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("compute shading outputs"),
                layout: &p.shade_outputs,
                entries: &[texture_entry(0, &color_view), texture_entry(1, &final_view)],
            })
        });

        let timed_frames = frames.min(TIMED_FRAMES);
        let queries = self.timestamps.then(|| {
            let count = TS_PER_FRAME * timed_frames;
            let set = self.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            });
            let resolve = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: 8 * count as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp readback"),
                size: 8 * count as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            (set, resolve, readback)
        });
        let args_template = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("empty draw arguments"),
            size: std::mem::size_of::<PageDrawArgs>() as u64,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.queue.write_buffer(
            &args_template,
            0,
            bytemuck::bytes_of(&PageDrawArgs::empty()),
        );

        let readbacks = [
            (&targets.color, 4u32, "colour readback"),
            (&targets.final_normal, 16, "normal readback"),
            (&targets.ids, 8, "cluster id readback"),
        ]
        .map(|(texture, texel, label)| {
            let row = padded_row(camera.width, texel);
            let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: row as u64 * camera.height as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            (texture, row, buffer)
        });

        let page_count = grid.map_or(0, |g| g.pages.len()) as u64;
        let args_size = std::mem::size_of::<PageDrawArgs>() as u64;
        let args_readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("draw arguments readback"),
            size: (args_size * page_count).max(args_size),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let path_pass = match (path_trace, grid) {
            (Some(o), Some(g)) => Some(self.prepare_path_trace(
                g,
                camera,
                o,
                [&targets.final_normal, &targets.color, &targets.ids],
                &uniform_buffer,
            )?),
            _ => None,
        };
        let mut ran = [false; TIMED_PASSES];
        for f in 0..frames {
            let frame_index = grid.map_or(0, |g| g.frame_index.fetch_add(1, Ordering::Relaxed));
            let uniforms =
                self.frame_uniforms(camera, grid, volume.is_some(), bounds, flags, frame_index);
            self.queue
                .write_buffer(&uniform_buffer, 0, bytemuck::bytes_of(&uniforms));
            let mut encoder = self
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("frame"),
                });
            let ts_base = (f < timed_frames).then_some(f * TS_PER_FRAME);
            let render_ts = |slot: u32| {
                queries.as_ref().zip(ts_base).map(|((set, _, _), base)| {
                    wgpu::RenderPassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(base + slot),
                        end_of_pass_write_index: Some(base + slot + 1),
                    }
                })
            };
            let compute_ts = |slot: u32| {
                queries.as_ref().zip(ts_base).map(|((set, _, _), base)| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(base + slot),
                        end_of_pass_write_index: Some(base + slot + 1),
                    }
                })
            };
            fn clear_targets<'e>(
                encoder: &'e mut wgpu::CommandEncoder,
                label: &str,
                ts: Option<wgpu::RenderPassTimestampWrites<'e>>,
                views: [&'e wgpu::TextureView; 3],
            ) -> wgpu::RenderPass<'e> {
                let [surface_view, ids_view, depth_view] = views;
                encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(label),
                    color_attachments: &[
                        color_attachment(surface_view, Some(wgpu::Color::TRANSPARENT)),
                        color_attachment(
                            ids_view,
                            Some(wgpu::Color {
                                r: u32::MAX as f64,
                                g: u32::MAX as f64,
                                b: 0.0,
                                a: 0.0,
                            }),
                        ),
                    ],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: depth_view,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(0.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: ts,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
            }
            let views = [&surface_view, &ids_view, &depth_view];
            if let Some(m) = mesh {
                let mut pass =
                    clear_targets(&mut encoder, "mc mesh raster", render_ts(TS_RASTER), views);
                ran[(TS_RASTER / 2) as usize] = true;
                if m.index_count > 0 {
                    pass.set_pipeline(&p.mesh_pipeline);
                    pass.set_bind_group(0, &scene_render, &[]);
                    pass.set_bind_group(1, &m.bind_group, &[]);
                    pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..m.index_count, 0, 0..1);
                }
            }
            if let Some(g) = raster_grid {
                for page in &g.pages {
                    encoder.copy_buffer_to_buffer(
                        &args_template,
                        0,
                        &page.args,
                        0,
                        args_template.size(),
                    );
                }
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("expand visible clusters"),
                        timestamp_writes: compute_ts(TS_EXPAND),
                    });
                    ran[(TS_EXPAND / 2) as usize] = true;
                    pass.set_pipeline(&p.expand_visible);
                    pass.set_bind_group(0, &scene_compute, &[]);
                    for page in &g.pages {
                        pass.set_bind_group(1, &page.compute_group, &[]);
                        let (x, y) = dispatch_size(page.slot_count);
                        pass.dispatch_workgroups(x, y, 1);
                    }
                }
                let compute = ComputeRaster {
                    pipelines: p,
                    scene: &scene_compute,
                    targets: &raster_targets,
                    ewa_targets: &ewa_targets,
                    pages: &g.pages,
                    size: (camera.width, camera.height),
                };
                ran[(TS_RASTER / 2) as usize] = true;
                if compute_raster {
                    compute.size_dispatches(&mut encoder);
                    drop(clear_targets(
                        &mut encoder,
                        "clear cell raster targets",
                        None,
                        views,
                    ));
                    encoder.clear_buffer(&targets.raster_depth, 0, None);
                    let steps: &[RasterStep] = if occlusion {
                        &[RasterStep::DepthFull]
                    } else {
                        &[RasterStep::DepthFull, RasterStep::ResolveFull]
                    };
                    compute.pass(
                        &mut encoder,
                        "compute cell raster",
                        compute_ts(TS_RASTER),
                        steps,
                    );
                } else {
                    let mut pass =
                        clear_targets(&mut encoder, "cell raster", render_ts(TS_RASTER), views);
                    pass.set_pipeline(&p.cells);
                    pass.set_bind_group(0, &scene_render, &[]);
                    for page in &g.pages {
                        pass.set_bind_group(1, &page.render_groups[LIST_FULL as usize], &[]);
                        pass.draw_indirect(&page.args, PageDrawArgs::offset(LIST_FULL));
                    }
                }
                if occlusion {
                    ran[(TS_PROBE / 2) as usize] = true;
                    if compute_raster {
                        let probes = [RasterStep::Probe];
                        compute.pass(
                            &mut encoder,
                            "compute probes",
                            compute_ts(TS_PROBE),
                            &probes,
                        );
                    } else {
                        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                            label: Some("visibility probes"),
                            color_attachments: &[color_attachment(&ids_view, None)],
                            depth_stencil_attachment: None,
                            timestamp_writes: render_ts(TS_PROBE),
                            occlusion_query_set: None,
                            multiview_mask: None,
                        });
                        pass.set_pipeline(&p.probe);
                        pass.set_bind_group(0, &scene_render, &[]);
                        pass.set_bind_group(2, &depth_input, &[]);
                        for page in &g.pages {
                            pass.set_bind_group(1, &page.render_groups[LIST_PROBE as usize], &[]);
                            pass.draw_indirect(&page.args, PageDrawArgs::offset(LIST_PROBE));
                        }
                    }
                    {
                        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                            label: Some("expand newly visible clusters"),
                            timestamp_writes: compute_ts(TS_EXPAND_NEW),
                        });
                        ran[(TS_EXPAND_NEW / 2) as usize] = true;
                        pass.set_pipeline(&p.expand_new);
                        pass.set_bind_group(0, &scene_compute, &[]);
                        for page in &g.pages {
                            pass.set_bind_group(1, &page.compute_group, &[]);
                            let (x, y) = dispatch_size(page.slot_count);
                            pass.dispatch_workgroups(x, y, 1);
                        }
                    }
                    ran[(TS_RASTER_NEW / 2) as usize] = true;
                    if compute_raster {
                        compute.size_dispatches(&mut encoder);
                        let steps = [
                            RasterStep::DepthNew,
                            RasterStep::ResolveFull,
                            RasterStep::ResolveNew,
                        ];
                        let label = "compute cell raster (newly visible) and resolve";
                        compute.pass(&mut encoder, label, compute_ts(TS_RASTER_NEW), &steps);
                    } else {
                        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                            label: Some("cell raster (newly visible)"),
                            color_attachments: &[
                                color_attachment(&surface_view, None),
                                color_attachment(&ids_view, None),
                            ],
                            depth_stencil_attachment: Some(
                                wgpu::RenderPassDepthStencilAttachment {
                                    view: &depth_view,
                                    depth_ops: Some(wgpu::Operations {
                                        load: wgpu::LoadOp::Load,
                                        store: wgpu::StoreOp::Store,
                                    }),
                                    stencil_ops: None,
                                },
                            ),
                            timestamp_writes: render_ts(TS_RASTER_NEW),
                            occlusion_query_set: None,
                            multiview_mask: None,
                        });
                        pass.set_pipeline(&p.cells);
                        pass.set_bind_group(0, &scene_render, &[]);
                        for page in &g.pages {
                            pass.set_bind_group(1, &page.render_groups[LIST_NEW as usize], &[]);
                            pass.draw_indirect(&page.args, PageDrawArgs::offset(LIST_NEW));
                        }
                    }
                }
                if ewa && compute_raster && !g.pages.is_empty() {
                    ran[(TS_EWA / 2) as usize] = true;
                    encoder.clear_buffer(&ewa_sum, 0, None);
                    let steps: &[RasterStep] = if occlusion {
                        &[
                            RasterStep::SplatFull,
                            RasterStep::SplatNew,
                            RasterStep::ResolveSplats,
                        ]
                    } else {
                        &[RasterStep::SplatFull, RasterStep::ResolveSplats]
                    };
                    compute.pass(
                        &mut encoder,
                        "compute ewa splats",
                        compute_ts(TS_EWA),
                        steps,
                    );
                } else {
                    // Cleared in every mode so that the shading pass can always read it.
                    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("ewa normal splats"),
                        color_attachments: &[color_attachment(
                            &ewa_view,
                            Some(wgpu::Color::TRANSPARENT),
                        )],
                        depth_stencil_attachment: None,
                        timestamp_writes: if ewa { render_ts(TS_EWA) } else { None },
                        occlusion_query_set: None,
                        multiview_mask: None,
                    });
                    if ewa {
                        ran[(TS_EWA / 2) as usize] = true;
                        pass.set_pipeline(&p.ewa);
                        pass.set_bind_group(0, &scene_render, &[]);
                        pass.set_bind_group(2, &surface_input, &[]);
                        let lists: &[u64] = if occlusion {
                            &[LIST_FULL, LIST_NEW]
                        } else {
                            &[LIST_FULL]
                        };
                        for page in &g.pages {
                            for &list in lists {
                                pass.set_bind_group(1, &page.render_groups[list as usize], &[]);
                                pass.draw_indirect(&page.args, PageDrawArgs::offset(list));
                            }
                        }
                    }
                }
                if occlusion {
                    encoder.clear_buffer(&g.visible_last_frame, 0, None);
                    encoder.clear_buffer(&g.visible_new, 0, None);
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("visibility update"),
                        timestamp_writes: compute_ts(TS_VISIBILITY),
                    });
                    ran[(TS_VISIBILITY / 2) as usize] = true;
                    pass.set_pipeline(&p.visibility);
                    pass.set_bind_group(0, &scene_compute, &[]);
                    pass.set_bind_group(1, &ids_input, &[]);
                    pass.dispatch_workgroups(
                        camera.width.div_ceil(8),
                        camera.height.div_ceil(8),
                        1,
                    );
                }
            }
            if grid.is_none() {
                // The mesh path never touches the EWA target; clear it for the shading pass.
                encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("clear ewa target"),
                    color_attachments: &[color_attachment(
                        &ewa_view,
                        Some(wgpu::Color::TRANSPARENT),
                    )],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
            }
            if let Some(outputs) = &shade_outputs {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("deferred shading (compute)"),
                    timestamp_writes: compute_ts(TS_SHADE),
                });
                ran[(TS_SHADE / 2) as usize] = true;
                pass.set_pipeline(&p.shade_compute);
                pass.set_bind_group(0, &scene_compute, &[]);
                pass.set_bind_group(1, &shade_inputs, &[]);
                pass.set_bind_group(2, outputs, &[]);
                pass.dispatch_workgroups(camera.width.div_ceil(8), camera.height.div_ceil(8), 1);
            } else if !traced {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("deferred shading"),
                    color_attachments: &[
                        color_attachment(&color_view, Some(wgpu::Color::BLACK)),
                        color_attachment(&final_view, Some(wgpu::Color::TRANSPARENT)),
                    ],
                    depth_stencil_attachment: None,
                    timestamp_writes: render_ts(TS_SHADE),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                ran[(TS_SHADE / 2) as usize] = true;
                pass.set_pipeline(&p.shade);
                pass.set_bind_group(0, &scene_render, &[]);
                pass.set_bind_group(1, &shade_inputs, &[]);
                pass.draw(0..3, 0..1);
            }
            if let Some(pt) = &path_pass {
                ran[(TS_TRACE / 2) as usize] = true;
                pt.encode(self, &mut encoder, f, compute_ts(TS_TRACE), f + 1 == frames);
            }
            if f + 1 == frames {
                if let Some((set, resolve, readback)) = &queries {
                    encoder.resolve_query_set(set, 0..TS_PER_FRAME * timed_frames, resolve, 0);
                    encoder.copy_buffer_to_buffer(resolve, 0, readback, 0, resolve.size());
                }
                for (i, page) in raster_grid.iter().flat_map(|g| &g.pages).enumerate() {
                    encoder.copy_buffer_to_buffer(
                        &page.args,
                        0,
                        &args_readback,
                        i as u64 * args_size,
                        args_size,
                    );
                }
                for (texture, row, buffer) in &readbacks {
                    encoder.copy_texture_to_buffer(
                        texture.as_image_copy(),
                        wgpu::TexelCopyBufferInfo {
                            buffer,
                            layout: wgpu::TexelCopyBufferLayout {
                                offset: 0,
                                bytes_per_row: Some(*row),
                                rows_per_image: Some(camera.height),
                            },
                        },
                        texture.size(),
                    );
                }
            }
            self.queue.submit([encoder.finish()]);
        }

        let mut mapped = Vec::new();
        for (_, _, buffer) in &readbacks {
            mapped.push(self.read_buffer(buffer)?);
        }
        let timings = match &queries {
            Some((_, _, readback)) => {
                let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&self.read_buffer(readback)?);
                self.pass_timings(&ticks, timed_frames, &ran)
            }
            None => PassTimings::default(),
        };
        let args: Vec<PageDrawArgs> =
            bytemuck::pod_collect_to_vec(&self.read_buffer(&args_readback)?);
        let count = |list: u64| -> u64 {
            args.iter()
                .take(page_count as usize)
                .map(|a| a.lists[list as usize][1] as u64)
                .sum()
        };
        let (w, h) = (camera.width as usize, camera.height as usize);
        let mut frame = Frame {
            width: camera.width,
            height: camera.height,
            rgba8: Vec::with_capacity(4 * w * h),
            depth: Vec::with_capacity(w * h),
            normal: Vec::with_capacity(w * h),
            cluster: Vec::with_capacity(w * h),
            timings,
            drawn_cells: count(LIST_FULL) + if occlusion { count(LIST_NEW) } else { 0 },
            probed_cells: if occlusion { count(LIST_PROBE) } else { 0 },
            linear: Vec::new(),
            samples: 0,
            cell_raster,
        };
        let rows = |i: usize| mapped[i].chunks(readbacks[i].1 as usize);
        for ((color, normal), ids) in rows(0).zip(rows(1)).zip(rows(2)) {
            frame.rgba8.extend_from_slice(&color[..4 * w]);
            let normal: &[[f32; 4]] = bytemuck::cast_slice(&normal[..16 * w]);
            let ids: &[[u32; 2]] = bytemuck::cast_slice(&ids[..8 * w]);
            for (n, id) in normal.iter().zip(ids) {
                let hit = id[0] != u32::MAX;
                frame.cluster.push(id[0]);
                frame.depth.push(if hit { n[3] } else { f32::INFINITY });
                frame.normal.push(if hit {
                    [n[0], n[1], n[2]]
                } else {
                    [f32::NAN; 3]
                });
            }
        }
        if let (Some(pt), Some(g)) = (path_pass, grid) {
            pt.finish(self, &mut frame, g, frames)?;
        }
        Ok(frame)
    }

    /// Maps a MAP_READ buffer and copies its bytes out.
    pub(crate) fn read_buffer(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::device(format!("waiting for the GPU: {e}")))?;
        rx.recv()
            .map_err(|_| GpuError::device("read-back was cancelled"))?
            .map_err(|e| GpuError::device(format!("read-back failed: {e}")))?;
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| GpuError::device(format!("read-back failed: {e}")))?
            .to_vec();
        buffer.unmap();
        Ok(bytes)
    }

    fn pass_timings(&self, ticks: &[u64], frames: u32, ran: &[bool; TIMED_PASSES]) -> PassTimings {
        let period_ms = self.queue.get_timestamp_period() as f64 * 1e-6;
        // Frames after the first (the first one draws every cluster), unless there is only one.
        let frames: Vec<u32> = if frames > 1 {
            (1..frames).collect()
        } else {
            vec![0]
        };
        let pass = |slot: u32, f: u32| -> Option<f64> {
            if !ran[(slot / 2) as usize] {
                return None;
            }
            let base = (f * TS_PER_FRAME + slot) as usize;
            let (a, b) = (*ticks.get(base)?, *ticks.get(base + 1)?);
            Some(b.saturating_sub(a) as f64 * period_ms)
        };
        let sum = |slots: &[u32]| -> Option<f64> {
            let per_frame: Vec<f64> = frames
                .iter()
                .filter_map(|&f| {
                    let times: Vec<f64> = slots.iter().filter_map(|&s| pass(s, f)).collect();
                    (!times.is_empty()).then(|| times.iter().sum())
                })
                .collect();
            median(per_frame)
        };
        let span = median(
            frames
                .iter()
                .filter_map(|&f| {
                    let ran_slots: Vec<u32> = (0..TIMED_PASSES as u32)
                        .filter(|&i| ran[i as usize])
                        .map(|i| 2 * i)
                        .collect();
                    let first = ticks.get((f * TS_PER_FRAME + *ran_slots.first()?) as usize)?;
                    let last = ticks.get((f * TS_PER_FRAME + *ran_slots.last()? + 1) as usize)?;
                    Some(last.saturating_sub(*first) as f64 * period_ms)
                })
                .collect(),
        );
        PassTimings {
            raster_ms: sum(&[TS_RASTER, TS_RASTER_NEW, TS_EWA]),
            ewa_ms: sum(&[TS_EWA]),
            shade_ms: sum(&[TS_SHADE]),
            cull_ms: sum(&[TS_EXPAND, TS_PROBE, TS_EXPAND_NEW, TS_VISIBILITY]),
            frame_ms: span,
            trace_ms: sum(&[TS_TRACE]),
        }
    }
}

pub(crate) fn buffer_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

pub(crate) fn texture_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    }
}

/// EWA Gaussian standard deviation in cells: neighbours one cell apart weigh exp(−1/(2·0.7²)) ≈ 0.36.
const EWA_SIGMA_CELLS: f64 = 0.7;

/// Workgroups (x, y) of 64 threads covering `slots` threads; y spills over the 65535 x limit.
pub(crate) fn dispatch_size(slots: u32) -> (u32, u32) {
    let groups = slots.div_ceil(64).max(1);
    let x = groups.min(65535);
    (x, groups.div_ceil(x))
}

//! [`UploadedScene`] and [`SceneView`]: requests on the GPU renderer (isogrid-gpu) against data
//! uploaded once. A scene holds what was uploaded for one input — the clustered grid cells (paper
//! §3.1), the Marching Cubes mesh and the volume samples of the MC and CR baselines (Table 4), the
//! path tracer's environment map — and any number of views draw it; a view holds what one camera
//! keeps between frames: the visibility buffer (§3.3) and the path-traced samples accumulated
//! while the view is unchanged (§3.6). Uploaded data apart from per-view state follows rerun's
//! re_renderer, and `isogrid_gpu::ViewState` already keys what carries over.
//!
//! The one-shot [`crate::render`] builds a scene with only what its mode draws and one fresh view;
//! the viewer keeps a scene per opened input and one view for its window.

use crate::context::RenderContext;
use crate::environment::EnvSource;
use crate::mode::Mode;
use crate::output::{GpuStats, Rendered};
use crate::policy::Placement;
use crate::request::RenderRequest;
use isogrid::mc::McMesh;
use isogrid::{CellGrid, Error, GridInfo, Progress, Result, Volume};
use isogrid_gpu::{Frame, GpuEnvMap, GpuGrid, GpuMesh, GpuVolume, Renderer, ViewState};
use std::time::Instant;

/// What is uploaded to the GPU renderer for one input (a volume and its extractions, or a `.cgc`
/// file), drawn by any number of [`SceneView`]s. Each part is replaced on its own: a new grid
/// (another isovalue or precision) keeps the mesh and the volume samples of CR (a texture of the
/// input's samples, whatever the isovalue).
pub struct UploadedScene<'r> {
    renderer: &'r Renderer,
    /// The input's world box: standard views ([`crate::CameraSpec::View`]) frame it.
    world_bounds: ([f64; 3], [f64; 3]),
    /// The input's axes mirror its world: its cameras are mirrored ([`GridInfo::mirrors_world`]).
    mirrored: bool,
    /// The shown grid's surface box ([`CellGrid::surface_bounds`]): surface views frame it.
    surface_bounds: Option<([f64; 3], [f64; 3])>,
    grid: Option<GpuGrid>,
    /// The attribute of the shown grid or mesh (its range is the default colour range).
    attribute: Option<isogrid::AttributeInfo>,
    volume: Option<GpuVolume>,
    mesh: Option<GpuMesh>,
    /// Whether `mesh` is a label grid's meshes, drawn in the labels' colours.
    label_mesh: bool,
    /// The environment map of the last path-traced request, kept while requests name the same
    /// one (its upload identifies it in the accumulation key, so a new upload would restart it).
    environment: Option<(EnvSource, Option<GpuEnvMap>)>,
}

/// What one view of an [`UploadedScene`] keeps between frames: visibility persists while the grid,
/// camera, mode and culling stay the same, and path-traced samples accumulate while the grid,
/// camera, bounces, environment and primary rays do; anything else starts that part afresh.
#[derive(Default)]
pub struct SceneView {
    state: ViewState,
}

impl SceneView {
    pub fn new() -> SceneView {
        SceneView::default()
    }
}

impl<'r> UploadedScene<'r> {
    /// An empty scene on `ctx`'s GPU renderer (opened now if it is not yet) for an input with
    /// `info`'s world box.
    pub fn new(ctx: &'r RenderContext, info: &GridInfo) -> Result<UploadedScene<'r>> {
        Ok(UploadedScene::on(ctx.renderer()?, info))
    }

    pub(crate) fn on(renderer: &'r Renderer, info: &GridInfo) -> UploadedScene<'r> {
        UploadedScene {
            renderer,
            world_bounds: info.world_bounds(),
            mirrored: info.mirrors_world(),
            surface_bounds: None,
            grid: None,
            attribute: None,
            volume: None,
            mesh: None,
            label_mesh: false,
            environment: None,
        }
    }

    /// Uploads `grid`, replacing the grid shown so far (freed first: two large grids may not fit
    /// at once). The volume samples stay where the new grid has the old one's dimensions.
    pub fn show_grid(&mut self, grid: &CellGrid) -> Result<()> {
        let same_dims = self.grid.as_ref().map(|g| g.info().dims) == Some(grid.info().dims);
        if !same_dims {
            self.volume = None;
        }
        self.grid = None;
        self.grid = Some(self.renderer.upload_grid(grid)?);
        self.surface_bounds = grid.surface_bounds();
        self.attribute = grid.attribute().map(|a| a.info().clone());
        Ok(())
    }

    /// Uploads the samples of `volume`, the source of the grid shown, for [`Mode::Cr`].
    pub fn show_volume(&mut self, volume: &Volume) -> Result<()> {
        let Some(grid) = &self.grid else {
            return Err(Error::invalid(
                "the volume for CR is checked against the grid's dimensions: upload the grid first",
            ));
        };
        self.volume = None;
        self.volume = Some(self.renderer.upload_volume(&volume.view(), grid)?);
        Ok(())
    }

    /// Uploads `mesh` for [`Mode::Mc`], replacing the one shown so far; with `values` (one per
    /// vertex, of the attribute `info` describes) coloured requests colour it.
    pub fn show_mesh(
        &mut self,
        mesh: &McMesh,
        values: Option<(&[f32], &isogrid::AttributeInfo)>,
    ) -> Result<()> {
        self.mesh = None;
        self.label_mesh = false;
        self.mesh = Some(match values {
            Some((v, info)) => {
                self.attribute = Some(info.clone());
                self.renderer.upload_colored_mesh(mesh, v)?
            }
            None => self.renderer.upload_mesh(mesh)?,
        });
        Ok(())
    }

    /// Uploads a label mesh for [`Mode::Mc`] ([`isogrid::mc::labelled_mesh`] of a grid of
    /// `spacing`: each vertex's label as an index in `table`), replacing the one shown so far; it
    /// is drawn in the labels' colours, or with `values` (one per vertex, of the attribute `info`
    /// describes: [`isogrid::mc::labelled_mesh_with_values`]) coloured requests colour it.
    pub fn show_label_mesh(
        &mut self,
        mesh: &McMesh,
        vertex_labels: &[u32],
        table: &[isogrid::labels::Label],
        spacing: [f64; 3],
        values: Option<(&[f32], &isogrid::AttributeInfo)>,
    ) -> Result<()> {
        self.mesh = None;
        self.mesh = Some(self.renderer.upload_label_mesh(
            mesh,
            vertex_labels,
            table,
            spacing,
            values.map(|(v, _)| v),
        )?);
        if let Some((_, info)) = values {
            self.attribute = Some(info.clone());
        }
        self.label_mesh = true;
        Ok(())
    }

    pub fn has_volume(&self) -> bool {
        self.volume.is_some()
    }

    /// Whether everything `mode` draws is uploaded.
    pub fn can_draw(&self, mode: Mode) -> bool {
        self.drawable(mode).is_some()
    }

    /// The adapter's name and API.
    pub fn adapter(&self) -> String {
        self.renderer.adapter_info()
    }

    fn drawable(&self, mode: Mode) -> Option<isogrid_gpu::Scene<'_>> {
        match (mode, &self.grid, &self.volume, &self.mesh) {
            (Mode::Mc, _, _, Some(mesh)) => Some(isogrid_gpu::Scene::Mesh(mesh)),
            (Mode::Cr, Some(grid), Some(volume), _) => {
                Some(isogrid_gpu::Scene::Volume { grid, volume })
            }
            (Mode::Cgc | Mode::CgcNoEwa | Mode::PathTrace, Some(grid), _, _) => {
                Some(isogrid_gpu::Scene::Grid(grid))
            }
            _ => None,
        }
    }

    /// Renders `request` with `view`'s state: raster modes draw `frames` frames, path tracing adds
    /// `samples` samples per pixel to those `view` holds for the same view (one frame each). The
    /// camera is the request's, standard views framing the scene's world box. `progress` counts
    /// frames of path tracing (one step for raster modes) and stops path tracing within a frame
    /// of [`Progress::cancel`]. Errors: a mode whose data is not uploaded ([`Self::can_draw`]),
    /// the renderer's.
    pub fn render(
        &mut self,
        view: &mut SceneView,
        request: &RenderRequest,
        progress: &Progress,
    ) -> Result<Rendered> {
        let parts = request.parts();
        let mode = parts.mode;
        let camera = request.camera(self.world_bounds, self.surface_bounds, self.mirrored)?;
        if !self.can_draw(mode) {
            return Err(Error::invalid(format!(
                "mode {mode} has nothing uploaded to draw{}",
                match mode {
                    Mode::Mc => ": no Marching Cubes mesh",
                    Mode::Cr => ": no grid with its volume",
                    _ => ": no grid",
                }
            )));
        }
        progress.check()?;
        let uncoloured_labels =
            self.label_mesh && !self.mesh.as_ref().is_some_and(|m| m.has_values());
        if mode == Mode::Mc && uncoloured_labels && parts.color.is_some() {
            return Err(Error::invalid(
                "mode mc draws these labels' meshes in the labels' colours: they were uploaded \
                 without the attribute's values",
            ));
        }
        let coloring = match (&parts.color, &self.attribute) {
            (None, _) => None,
            (Some(spec), Some(info)) => Some(spec.coloring(info)?),
            (Some(_), None) => {
                return Err(Error::invalid(
                    "colouring asks for the grid's attribute, and the grid has none",
                ))
            }
        };
        let start = Instant::now();
        let (frame, frames) = if mode == Mode::PathTrace {
            self.load_environment(request)?;
            let env = self.environment.as_ref().and_then(|(_, env)| env.as_ref());
            let options = isogrid_gpu::PathTraceOptions {
                frames: parts.samples,
                bounces: parts.bounces,
                env,
                primary: parts.primary.unwrap_or_default().gpu(),
                occlusion_culling: parts.occlusion_culling,
                progress: Some(progress),
                coloring: coloring.as_ref(),
                ..Default::default()
            };
            let grid = self.grid.as_ref().expect("can_draw checked the grid");
            let frame = self
                .renderer
                .path_trace_view(&mut view.state, grid, &camera, &options)?;
            (frame, parts.samples)
        } else {
            // One step: raster frames are too quick to count one by one.
            progress.start(1);
            let options = isogrid_gpu::RenderOptions {
                frames: parts.frames,
                occlusion_culling: parts.occlusion_culling,
                cell_raster: parts.cell_raster,
                coloring,
                ..Default::default()
            };
            let scene = self.drawable(mode).expect("can_draw checked the data");
            let frame =
                self.renderer
                    .render_view(&mut view.state, scene, &camera, mode, &options)?;
            progress.advance(1);
            (frame, parts.frames)
        };
        let seconds = start.elapsed().as_secs_f64();
        Ok(rendered(self.renderer, frame, frames, seconds, mode))
    }

    /// Uploads the environment map `request` names (none for the built-in sky) unless the last
    /// request named the same.
    fn load_environment(&mut self, request: &RenderRequest) -> Result<()> {
        let source = &request.parts().environment;
        if self.environment.as_ref().is_none_or(|(s, _)| s != source) {
            self.environment = None;
            let uploaded = request.env.upload(self.renderer)?;
            self.environment = Some((source.clone(), uploaded));
        }
        Ok(())
    }
}

fn rendered(renderer: &Renderer, f: Frame, frames: u32, seconds: f64, mode: Mode) -> Rendered {
    let rgb8 = f
        .rgba8
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    Rendered {
        width: f.width,
        height: f.height,
        rgb8,
        placement: Placement::Gpu,
        adapter: renderer.adapter_info(),
        seconds,
        samples: (mode == Mode::PathTrace).then_some(f.samples),
        cpu: None,
        gpu: Some(GpuStats {
            frames,
            timings: f.timings,
            drawn_cells: f.drawn_cells,
            probed_cells: f.probed_cells,
            cell_raster: f.cell_raster,
        }),
        depth: f.depth,
        normal: f.normal,
        cluster: f.cluster,
        value: (!f.value.is_empty()).then_some(f.value),
        label: None,
    }
}

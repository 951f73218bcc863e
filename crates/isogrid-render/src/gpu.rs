//! A one-shot request on the GPU renderer (isogrid-gpu): cell rasterisation (paper §3.2–3.4),
//! the MC and CR baselines of Table 4, or path tracing (§3.6) with one sample per pixel per
//! frame; a label grid's MC mode draws the Marching Cubes meshes of its labels' stored cells, each
//! in its label's colour. Uploads what the mode draws into a fresh [`UploadedScene`] and renders one fresh view
//! of it, the interactive path with nothing kept.

use crate::mode::Mode;
use crate::output::Rendered;
use crate::request::RenderRequest;
use crate::scene::{SceneView, UploadedScene};
use isogrid::extract::attribute::values_at_surface_points;
use isogrid::mc::{labelled_mesh, labelled_mesh_with_values, marching_cubes};
use isogrid::{CellGrid, Error, Progress, Result, Volume};
use isogrid_gpu::Renderer;

pub(crate) fn render(
    renderer: &Renderer,
    request: &RenderRequest,
    grid: &CellGrid,
    volume: Option<&Volume>,
    progress: &Progress,
) -> Result<Rendered> {
    let mode = request.mode();
    // A label grid's meshes come from its own cells.
    let labels = grid.labels().filter(|_| mode == Mode::Mc);
    let volume = match (mode.needs_volume() && labels.is_none(), volume) {
        (true, None) => {
            return Err(Error::invalid(format!(
                "mode {mode} needs the original volume, which a grid alone (a .cgc file) lacks; a label grid draws mc from its own cells"
            )))
        }
        (_, v) => v,
    };
    progress.check()?;
    let mut scene = UploadedScene::on(renderer, grid.info());
    match (mode, volume) {
        (Mode::Mc, _) if labels.is_some() => {
            let table = labels.map(|l| l.table()).unwrap_or_default();
            let spacing = grid.info().spacing;
            // Coloured, each vertex takes the attribute of its label's cells around it (the
            // values the cell modes show there).
            match (request.parts().color.as_ref(), grid.attribute()) {
                (Some(_), Some(attribute)) => {
                    let (mesh, vertex_labels, values) = labelled_mesh_with_values(grid)?;
                    let values = Some((&values[..], attribute.info()));
                    scene.show_label_mesh(&mesh, &vertex_labels, table, spacing, values)?
                }
                _ => {
                    let (mesh, vertex_labels) = labelled_mesh(grid)?;
                    scene.show_label_mesh(&mesh, &vertex_labels, table, spacing, None)?
                }
            }
        }
        (Mode::Mc, Some(volume)) => {
            let mesh = marching_cubes(&volume.view(), grid.info().iso);
            // Coloured, each vertex takes the attribute of the cells it lies on (the values the
            // cell modes show there).
            let values = match (request.parts().color.as_ref(), grid.attribute()) {
                (Some(_), Some(attribute)) => {
                    let points = mesh.index_positions(grid.info().spacing);
                    Some((values_at_surface_points(grid, &points)?, attribute.info()))
                }
                _ => None,
            };
            scene.show_mesh(&mesh, values.as_ref().map(|(v, info)| (&v[..], *info)))?
        }
        (Mode::Cr, Some(volume)) => {
            scene.show_grid(grid)?;
            scene.show_volume(volume)?;
        }
        _ => scene.show_grid(grid)?,
    }
    scene.render(&mut SceneView::new(), request, progress)
}

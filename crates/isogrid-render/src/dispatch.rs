//! [`render`]: runs a placed request on its renderer, reporting progress and stopping on cancel.

use crate::context::RenderContext;
use crate::output::Rendered;
use crate::policy::Placement;
use crate::request::RenderRequest;
use isogrid::labels::GridLabels;
use isogrid::{CellGrid, Error, Progress, Result, Volume};

/// Renders `grid` (with its `volume` for the modes that need it) as `request` asks, on
/// `placement` (from [`RenderContext::decide`]). `progress` counts finished work (image rows on
/// the CPU, frames of GPU path tracing) and stops the render within a tile or a frame of
/// [`Progress::cancel`], with an error of kind [`isogrid::ErrorKind::Cancelled`].
pub fn render(
    ctx: &RenderContext,
    request: &RenderRequest,
    placement: Placement,
    grid: &CellGrid,
    volume: Option<&Volume>,
    progress: &Progress,
) -> Result<Rendered> {
    // Checked before anything is uploaded or traced.
    let shown = shown_labels(request, grid)?;
    let grid = shown.as_ref().unwrap_or(grid);
    let info = grid.info();
    let camera = request.camera(
        info.world_bounds(),
        grid.surface_bounds(),
        info.mirrors_world(),
    )?;
    let mut rendered = match placement {
        Placement::Cpu => crate::cpu::render(request, grid, &camera, progress),
        Placement::Gpu => {
            let renderer = ctx.renderer()?;
            crate::gpu::render(renderer, request, grid, volume, progress)
        }
    }?;
    rendered.label = grid
        .labels()
        .map(|l| label_aov(l, request.mode(), &rendered.cluster));
    Ok(rendered)
}

/// Which labels of `grid` the request's `show` / `hide` leave drawn, one flag per label, `None`
/// when they choose none. Refuses them, and the label AOV, on a grid without labels, and a value
/// naming no label of the grid; [`render`] checks this first, and a front end may call it to
/// fail before choosing a backend.
pub fn label_choice(request: &RenderRequest, grid: &CellGrid) -> Result<Option<Vec<bool>>> {
    let parts = request.parts();
    let choose = parts.show.is_some() || parts.hide.is_some();
    let Some(labels) = grid.labels() else {
        if choose || parts.aovs.contains(&crate::mode::Aov::Label) {
            return Err(Error::invalid(
                "showing, hiding and the label AOV need a label grid (extract --labels), and this grid has no labels",
            ));
        }
        return Ok(None);
    };
    let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
    let shown = match choose {
        true => Some(labels.shown(parts.show.as_ref(), parts.hide.as_ref(), signed)?),
        false => None,
    };
    // The label AOV marks a miss with all ones, the value a label of u64::MAX (or -1 in a
    // signed volume) also has: such a label, drawn, would read as background.
    if parts.aovs.contains(&crate::mode::Aov::Label) {
        let table = labels.table();
        let all_ones = table
            .iter()
            .position(|l| l.value == u64::MAX)
            .filter(|&l| shown.as_ref().is_none_or(|s| s[l]));
        if let Some(l) = all_ones {
            let value = isogrid::labels::display_value(table[l].value, signed);
            return Err(Error::invalid(format!(
                "label {value} cannot be told from a miss in the label AOV, which marks a miss \
                 with all ones (u64 {}): hide it (--hide={value}) to write the AOV",
                u64::MAX
            )));
        }
    }
    Ok(shown)
}

/// The grid of the labels `show` / `hide` leave (through the label index, see
/// [`CellGrid::showing_labels`]), `None` when they choose none.
fn shown_labels(request: &RenderRequest, grid: &CellGrid) -> Result<Option<CellGrid>> {
    label_choice(request, grid)?
        .map(|shown| grid.showing_labels(&shown))
        .transpose()
}

/// The label value under each pixel of a render in `mode` of the label grid with `labels`, from its
/// cluster AOV (`cluster`: the drawn grid's cluster indices, or in [`crate::mode::Mode::Mc`] the
/// label indices a label mesh's fragments carry in their place); `u64::MAX` on a miss. The viewer
/// reads the label under its pointer with it from the grid it uploaded.
pub fn label_aov(labels: &GridLabels, mode: crate::mode::Mode, cluster: &[u32]) -> Vec<u64> {
    let (table, of_cluster) = (labels.table(), labels.cluster_labels());
    let label_of = |c: u32| match mode {
        crate::mode::Mode::Mc => Some(c),
        _ => of_cluster.get(c as usize).copied(),
    };
    cluster
        .iter()
        .map(|&c| {
            label_of(c)
                .and_then(|l| table.get(l as usize))
                .map_or(u64::MAX, |l| l.value)
        })
        .collect()
}

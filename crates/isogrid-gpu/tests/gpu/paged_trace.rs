//! Ray tracing of grids split into several pages (larger than one storage binding, paper §3.6):
//! the same grid forced into 3–6 pages must trace exactly like one page, and like the CPU tracer
//! (`isogrid_trace::Tracer`, the same three-sample crossing search); more pages than the tracer
//! binds at once is a clear error.

use crate::pathtrace::random_rays;
use crate::{new_renderer, renderer, scene, HitAgreement};
use isogrid::generate::Field;
use isogrid::layout::CLUSTER_SLOTS;
use isogrid::{CellGrid, Precision};
use isogrid_gpu::{GpuErrorKind, PathTraceOptions};
use isogrid_trace::{Crossing, Tracer};

/// A binding size that splits `grid` into about four pages: pages are cut where the metacell
/// slots or the corner records (or the instance lists, 4 bytes per cell) outgrow it.
pub fn quarter_binding(grid: &CellGrid) -> u64 {
    let slots = std::mem::size_of_val(grid.metacells()) as u64;
    let per_cell = grid.info().precision.bytes_per_cell().max(4) as u64;
    let cells = grid.active_cells() as u64 * per_cell;
    slots.max(cells).div_ceil(4)
}

/// Whether some 16³ block's clusters lie in two pages (pages of `page_bytes` are cut between
/// whole clusters, as `plan_pages` does): the case that forces the tracer to look pages up per
/// cluster rather than per block. Recomputed here from the grid, so the test knows it covers it.
fn a_block_straddles_pages(grid: &CellGrid, page_bytes: u64) -> bool {
    let slot_bytes = (CLUSTER_SLOTS * std::mem::size_of::<isogrid::Metacell>()) as u64;
    let per_cell = grid.info().precision.bytes_per_cell().max(4) as u64;
    let mut first_slot_of_page = vec![0u64];
    let (mut clusters, mut cells) = (0u64, 0u64);
    for (i, cluster) in grid.metacells().chunks_exact(CLUSTER_SLOTS).enumerate() {
        let n: u64 = cluster[..CLUSTER_SLOTS - 1]
            .iter()
            .map(|m| m.active_cells() as u64)
            .sum();
        if clusters > 0
            && ((clusters + 1) * slot_bytes > page_bytes || (cells + n) * per_cell > page_bytes)
        {
            first_slot_of_page.push((i * CLUSTER_SLOTS) as u64);
            clusters = 0;
            cells = 0;
        }
        clusters += 1;
        cells += n;
    }
    grid.blocks().iter().any(|b| {
        let lo = b.metacell_pointer as u64;
        let hi = lo + b.metacell_count as u64;
        first_slot_of_page.iter().any(|&s| s > lo && s < hi)
    })
}

/// One grid, one set of random rays (about half start inside the solid, some miss the box):
/// the paged trace equals the one-page trace ray for ray (same shader arithmetic, only the page
/// lookup differs), and both agree with the CPU tracer like the one-page traversal test does.
#[test]
fn trace_rays_finds_the_same_hits_in_one_page_and_in_several() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    // Gyroid 17: a single 16³ block, so every page boundary cuts a block; gyroid 40: 27 blocks;
    // 4-bit sphere: another record size.
    for (field, size, precision) in [
        (Field::Gyroid, 17, None),
        (Field::Gyroid, 40, None),
        (Field::Sphere, 40, Some(Precision::Bits4)),
    ] {
        let label = format!("{field} {size}");
        let (_, grid) = scene(field, size, precision);
        let page_bytes = quarter_binding(&grid);
        paged.set_page_bytes(page_bytes);
        let a = one_page.upload_grid(&grid).unwrap();
        let b = paged.upload_grid(&grid).unwrap();
        assert_eq!(a.page_count(), 1);
        assert!(
            (3..=6).contains(&b.page_count()),
            "{label}: {} pages",
            b.page_count()
        );
        assert!(a_block_straddles_pages(&grid, page_bytes), "{label}");

        let (_, hi) = grid.info().world_bounds();
        let rays = random_rays(hi, 2000, 91);
        let one = one_page.trace_rays(&a, &rays).unwrap();
        let many = paged.trace_rays(&b, &rays).unwrap();
        let mut identical = 0;
        for (i, (x, y)) in one.iter().zip(&many).enumerate() {
            match (x, y) {
                (None, None) => identical += 1,
                (Some(x), Some(y)) => {
                    let dn = (0..3).map(|c| (x.normal[c] - y.normal[c]).abs());
                    assert!(
                        (x.t - y.t).abs() <= 1e-5 * (1.0 + x.t) && dn.fold(0.0, f32::max) <= 1e-5,
                        "{label} ray {i}: one page {x:?}, {} pages {y:?}",
                        b.page_count()
                    );
                    identical += 1;
                }
                (x, y) => panic!(
                    "{label} ray {i}: one page {x:?}, {} pages {y:?}",
                    b.page_count()
                ),
            }
        }
        eprintln!(
            "{label}: {} pages, {identical} of {} rays as one page",
            b.page_count(),
            rays.len()
        );
        let cpu = Tracer::new(&grid, Crossing::Samples3);
        HitAgreement::of(&cpu, &rays, &many).assert_close(&label, 300);
    }
}

/// The gyroid's labyrinth sends most secondary rays into other clusters, many in other pages. The
/// primary raster is the same in both (pages are drawn one after another) and the random numbers
/// depend only on pixel and sample, so the images agree except where EWA blending order changes
/// the last bits of a primary normal and a path takes another turn.
#[test]
fn a_grid_in_several_pages_path_traces_like_one_page() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    let (_, grid) = scene(Field::Gyroid, 32, None);
    paged.set_page_bytes(quarter_binding(&grid));
    let a = one_page.upload_grid(&grid).unwrap();
    let b = paged.upload_grid(&grid).unwrap();
    assert!(
        (3..=6).contains(&b.page_count()),
        "{} pages",
        b.page_count()
    );
    let cam = isogrid::Camera::preset(2, [0.0; 3], [31.0; 3], 64, 48).unwrap();
    let options = PathTraceOptions {
        frames: 2,
        bounces: 3,
        ..Default::default()
    };
    let fa = one_page.path_trace(&a, &cam, &options).unwrap();
    let fb = paged.path_trace(&b, &cam, &options).unwrap();
    assert_eq!(fb.samples, 2);
    let hits = (0..fa.linear.len()).filter(|&i| fa.is_hit(i)).count();
    assert!(hits > 600, "only {hits} surface pixels");
    assert!(
        (0..fa.linear.len()).all(|i| fa.is_hit(i) == fb.is_hit(i)),
        "hit masks differ"
    );
    let diffs: Vec<f32> = fa
        .linear
        .iter()
        .zip(&fb.linear)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .collect();
    let mean_diff = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let close = diffs.iter().filter(|&&d| d <= 1e-3).count();
    eprintln!(
        "{} pages: mean |Δ| {mean_diff:.2e}, {close} of {} values within 1e-3",
        b.page_count(),
        diffs.len()
    );
    assert!(mean_diff < 1e-3, "mean |Δ| {mean_diff}");
    assert!(close as f64 >= 0.99 * diffs.len() as f64, "{close} close");
}

/// More pages than the tracer binds at once: both trace entry points refuse with the numbers,
/// and the renderer keeps working.
#[test]
fn more_pages_than_the_tracer_binds_is_a_clear_error() {
    let Some(mut paged) = new_renderer() else {
        return;
    };
    let (_, grid) = scene(Field::Gyroid, 32, None);
    paged.set_page_bytes(quarter_binding(&grid) / 4);
    let gpu = paged.upload_grid(&grid).unwrap();
    assert!(gpu.page_count() > 6, "{} pages", gpu.page_count());
    let cam = isogrid::Camera::preset(2, [0.0; 3], [31.0; 3], 16, 16).unwrap();
    let e = paged
        .path_trace(&gpu, &cam, &Default::default())
        .unwrap_err();
    assert_eq!(e.kind(), GpuErrorKind::TooLarge, "{e}");
    assert!(
        e.to_string()
            .contains(&format!("{} pages", gpu.page_count())),
        "{e}"
    );
    let rays = random_rays([31.0; 3], 4, 1);
    let e = paged.trace_rays(&gpu, &rays).unwrap_err();
    assert_eq!(e.kind(), GpuErrorKind::TooLarge, "{e}");
    paged
        .render(
            isogrid_gpu::Scene::Grid(&gpu),
            &cam,
            isogrid_gpu::Mode::Cgc,
            1,
        )
        .unwrap();
}

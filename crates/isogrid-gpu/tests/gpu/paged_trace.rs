//! Ray tracing of grids split into several pages (larger than one storage binding, paper §3.6):
//! the same grid forced into 3–6 pages (one pass binds them all) or into 7, 13 and 20 pages
//! (traced in passes over groups of six) must trace exactly like one page, and like the CPU
//! tracer (`isogrid_trace::Tracer`, the same three-sample crossing search).

use crate::pathtrace::random_rays;
use crate::{new_renderer, renderer, scene, HitAgreement};
use isogrid::generate::Field;
use isogrid::layout::CLUSTER_SLOTS;
use isogrid::{CellGrid, Precision};
use isogrid_gpu::{Frame, PathTraceOptions, PrimaryRays, RayHit};
use isogrid_trace::{Crossing, Tracer};

/// A binding size that splits `grid` into about four pages: pages are cut where the metacell
/// slots or the corner records (or the instance lists, 4 bytes per cell) outgrow it.
pub fn quarter_binding(grid: &CellGrid) -> u64 {
    let slots = std::mem::size_of_val(grid.metacells()) as u64;
    let per_cell = grid.info().precision.bytes_per_cell().max(4) as u64;
    let cells = grid.active_cells() as u64 * per_cell;
    slots.max(cells).div_ceil(4)
}

/// The first global metacell slot of each page when `grid` is uploaded with pages of
/// `page_bytes` (cut between whole clusters where the metacell slots, the corner records or the
/// instance lists outgrow them, as `plan_pages` does). Recomputed here from the grid, so that
/// the tests know which cases they cover.
fn page_first_slots(grid: &CellGrid, page_bytes: u64) -> Vec<u64> {
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
    first_slot_of_page
}

/// Whether some 16³ block's clusters lie in two pages: the case that forces the tracer to look
/// pages up per cluster rather than per block, and to skip part of a block in a pass.
fn a_block_straddles_pages(grid: &CellGrid, page_bytes: u64) -> bool {
    let first_slot_of_page = page_first_slots(grid, page_bytes);
    grid.blocks().iter().any(|b| {
        let lo = b.metacell_pointer as u64;
        let hi = lo + b.metacell_count as u64;
        first_slot_of_page.iter().any(|&s| s > lo && s < hi)
    })
}

/// The largest page size that splits `grid` into exactly `pages` pages, by bisection (fewer
/// bytes never make fewer pages).
fn page_bytes_for(grid: &CellGrid, pages: usize) -> u64 {
    let count = |bytes| page_first_slots(grid, bytes).len();
    // The renderer takes no less than 256 bytes per page.
    let (mut fits, mut too_small) = (quarter_binding(grid) * 8, 255u64);
    assert!(count(fits) < pages && count(too_small + 1) > pages);
    while fits - too_small > 1 {
        let mid = (fits + too_small) / 2;
        if count(mid) <= pages {
            fits = mid;
        } else {
            too_small = mid;
        }
    }
    assert_eq!(count(fits), pages, "no page size makes {pages} pages");
    fits
}

/// Ray for ray, `paged` finds `one`'s hits: the same misses, and the same t (relative to 1 + t)
/// and normal up to `tolerance`.
fn assert_same_hits(label: &str, one: &[Option<RayHit>], paged: &[Option<RayHit>], tolerance: f32) {
    assert_eq!(one.len(), paged.len());
    for (i, (x, y)) in one.iter().zip(paged).enumerate() {
        match (x, y) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                let dn = (0..3).map(|c| (x.normal[c] - y.normal[c]).abs());
                assert!(
                    (x.t - y.t).abs() <= tolerance * (1.0 + x.t)
                        && dn.fold(0.0, f32::max) <= tolerance,
                    "{label} ray {i}: one page {x:?}, paged {y:?}"
                );
            }
            (x, y) => panic!("{label} ray {i}: one page {x:?}, paged {y:?}"),
        }
    }
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
    // 4- and 1-bit spheres: other record sizes, the 1-bit one four records to a word, so pages
    // start inside a word of the grid's records.
    for (field, size, precision) in [
        (Field::Gyroid, 17, None),
        (Field::Gyroid, 40, None),
        (Field::Sphere, 40, Some(Precision::Bits4)),
        (Field::Sphere, 40, Some(Precision::Bits1)),
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
        assert_same_hits(&label, &one, &many, 1e-5);
        let cpu = Tracer::new(&grid, Crossing::Samples3);
        HitAgreement::of(&cpu, &rays, &many).assert_close(&label, 300);
    }
}

/// More pages than one pass binds (six): 7 pages (two groups, the second of one page), 13 and 20
/// (three and four groups). Each group's pass sees only its own clusters, visits no block beyond
/// the nearest crossing of the groups before it and keeps the nearer of the two; the nearest
/// over the groups is the nearest in the grid, found in the same cell by the same arithmetic as
/// with one page, so the hits are bit-identical. They also agree with the CPU tracer.
#[test]
fn trace_rays_through_any_number_of_pages_finds_the_one_page_hits() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    for (field, size, precision) in [
        (Field::Gyroid, 40, None),
        (Field::Sphere, 40, Some(Precision::Bits4)),
        (Field::Sphere, 40, Some(Precision::Bits1)),
    ] {
        let (_, grid) = scene(field, size, precision);
        let a = one_page.upload_grid(&grid).unwrap();
        let (_, hi) = grid.info().world_bounds();
        let rays = random_rays(hi, 2000, 17);
        let one = one_page.trace_rays(&a, &rays).unwrap();
        let cpu = Tracer::new(&grid, Crossing::Samples3);
        for pages in [7, 13, 20] {
            let label = format!("{field} {size} in {pages} pages");
            let page_bytes = page_bytes_for(&grid, pages);
            paged.set_page_bytes(page_bytes);
            let b = paged.upload_grid(&grid).unwrap();
            assert_eq!(b.page_count(), pages, "{label}");
            assert!(a_block_straddles_pages(&grid, page_bytes), "{label}");
            let many = paged.trace_rays(&b, &rays).unwrap();
            assert_same_hits(&label, &one, &many, 0.0);
            HitAgreement::of(&cpu, &rays, &many).assert_close(&label, 300);
        }
    }
}

/// The same hit mask, and linear colours within 1e-3 on 99 % of values with a mean |Δ| under
/// 1e-3.
fn assert_images_close(fa: &Frame, fb: &Frame, label: &str) {
    assert!(
        (0..fa.linear.len()).all(|i| fa.is_hit(i) == fb.is_hit(i)),
        "{label}: hit masks differ"
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
        "{label}: mean |Δ| {mean_diff:.2e}, {close} of {} values within 1e-3",
        diffs.len()
    );
    assert!(mean_diff < 1e-3, "{label}: mean |Δ| {mean_diff}");
    assert!(
        close as f64 >= 0.99 * diffs.len() as f64,
        "{label}: {close} close"
    );
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
    assert_images_close(&fa, &fb, &format!("{} pages", b.page_count()));
}

/// Path tracing in passes over page groups (7, 13 and 20 pages) with traced primaries: every
/// primary and bounce ray finds the one-page crossing bit for bit (as `trace_rays` does above),
/// and the wavefront passes take `follow_path`'s steps with its arithmetic, so colours, depths
/// and clusters equal the one-page ones exactly. With raster primaries (13 pages) the image
/// equals the one-page one within the EWA blending-order tolerance of the 3–6 pages test, and
/// the cell raster alone draws all 13 pages.
#[test]
fn a_grid_in_any_number_of_pages_path_traces_like_one_page() {
    let Some(one_page) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    let (_, grid) = scene(Field::Gyroid, 32, None);
    let a = one_page.upload_grid(&grid).unwrap();
    let cam = isogrid::Camera::preset(2, [0.0; 3], [31.0; 3], 64, 48).unwrap();
    let traced = PathTraceOptions {
        frames: 2,
        bounces: 3,
        primary: PrimaryRays::Traced,
        ..Default::default()
    };
    let fa = one_page.path_trace(&a, &cam, &traced).unwrap();
    let hits = (0..fa.linear.len()).filter(|&i| fa.is_hit(i)).count();
    assert!(hits > 600, "only {hits} surface pixels");
    for pages in [7, 13, 20] {
        paged.set_page_bytes(page_bytes_for(&grid, pages));
        let b = paged.upload_grid(&grid).unwrap();
        assert_eq!(b.page_count(), pages);
        let fb = paged.path_trace(&b, &cam, &traced).unwrap();
        assert_eq!(fb.samples, 2);
        assert_eq!(fa.cluster, fb.cluster, "{pages} pages: primary clusters");
        assert_eq!(fa.depth, fb.depth, "{pages} pages: primary depths");
        for (i, (p, q)) in fa.linear.iter().zip(&fb.linear).enumerate() {
            assert_eq!(p, q, "{pages} pages: pixel {i}");
        }
        assert_eq!(fa.rgba8, fb.rgba8, "{pages} pages");
    }

    paged.set_page_bytes(page_bytes_for(&grid, 13));
    let b = paged.upload_grid(&grid).unwrap();
    let hybrid = PathTraceOptions {
        frames: 2,
        bounces: 3,
        ..Default::default()
    };
    let fa = one_page.path_trace(&a, &cam, &hybrid).unwrap();
    let fb = paged.path_trace(&b, &cam, &hybrid).unwrap();
    assert_images_close(&fa, &fb, "13 pages, raster primaries");
    let raster = paged
        .render(
            isogrid_gpu::Scene::Grid(&b),
            &cam,
            isogrid_gpu::Mode::Cgc,
            1,
        )
        .unwrap();
    assert!(
        (0..raster.cluster.len()).all(|i| raster.is_hit(i) == fa.is_hit(i)),
        "cell raster hit mask of 13 pages"
    );
}

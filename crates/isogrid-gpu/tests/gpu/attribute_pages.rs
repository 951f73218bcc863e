//! A coloured grid split into pages: each page holds its records' attribute codes after its
//! corner records, so the codes are paged with the cells. Forced into 3–6 pages (one trace pass
//! binds them all) and into more than six (traced in passes over groups), with pages starting at
//! odd records (in the middle of a word of two codes), every mode that colours must give the
//! one-page picture pixel for pixel (colour and value AOV), and the one-page value AOV must be the
//! CPU tracer's (the attribute of the hit cell, independently of the GPU's code layout).

use crate::colour::coloured_by;
use crate::{new_renderer, renderer};
use isogrid::colormap::Coloring;
use isogrid::generate::{generate, Field};
use isogrid::{extract, Camera, CellGrid, ExtractOptions, Iso, Volume};
use isogrid_gpu::{
    CellRaster, Frame, Mode, PathTraceOptions, PrimaryRays, RenderOptions, Renderer, Scene,
};

const SIZE: u32 = 64;

/// A 37³ gyroid (odd sizes: odd record counts per cluster) coloured by `x + 2y` (sample index
/// units, on the same grid), its volume (for CR) and a turbo colouring over the attribute's range.
fn coloured_gyroid() -> (Volume, CellGrid, Coloring) {
    let n = 37usize;
    let volume = generate(Field::Gyroid, n, 7);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
    let (grid, coloring) = coloured_by(grid, n, |x, y, _| x as f32 + 2.0 * y as f32);
    (volume, grid, coloring)
}

/// The viewer's view 2 of the grid box (world = index units).
fn camera() -> Camera {
    Camera::preset(2, [0.0; 3], [36.0; 3], SIZE, SIZE).unwrap()
}

/// The largest page size (bytes) that uploads `grid` into at least `pages` pages.
fn page_bytes_for(r: &mut Renderer, grid: &CellGrid, pages: usize) -> u64 {
    let (mut lo, mut hi) = (256u64, 1u64 << 30);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        r.set_page_bytes(mid);
        if r.upload_grid(grid).unwrap().page_count() >= pages {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Pixel for pixel the same value AOV (NaN where either misses) and the same colours, each
/// channel within `tolerance` levels.
fn assert_same_picture(label: &str, one: &Frame, paged: &Frame, tolerance: u8) {
    assert_eq!(one.value.len(), paged.value.len(), "{label}");
    for (i, (a, b)) in one.value.iter().zip(&paged.value).enumerate() {
        assert!(
            a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
            "{label} pixel {i}: value {a} in one page, {b} paged"
        );
    }
    let (mut differing, mut worst) = (0, 0);
    for (x, y) in one.rgba8.iter().zip(&paged.rgba8) {
        differing += (x != y) as usize;
        worst = worst.max(x.abs_diff(*y));
    }
    eprintln!("{label}: {differing} colour channels differ, by at most {worst}");
    assert!(worst <= tolerance, "{label}: colours differ by {worst}");
}

/// Every mode that colours a grid, on one page and on `pages` pages or more.
fn compare_paged(pages: usize) {
    let Some(one) = renderer() else { return };
    let Some(mut paged) = new_renderer() else {
        return;
    };
    let (volume, grid, coloring) = coloured_gyroid();
    let bytes = page_bytes_for(&mut paged, &grid, pages);
    paged.set_page_bytes(bytes);
    let one_grid = one.upload_grid(&grid).unwrap();
    let paged_grid = paged.upload_grid(&grid).unwrap();
    assert_eq!(one_grid.page_count(), 1);
    let firsts = paged_grid.page_first_records();
    eprintln!(
        "{} pages of at most {bytes} bytes, first records {firsts:?}",
        firsts.len()
    );
    assert!(firsts.len() >= pages, "{firsts:?}");
    // A page starting at an odd record starts its codes in the middle of a word of the whole
    // grid's codes: the page-local layout must not shift them.
    assert!(firsts.iter().any(|f| f % 2 == 1), "{firsts:?}");
    let one_volume = one.upload_volume(&volume.view(), &one_grid).unwrap();
    let paged_volume = paged.upload_volume(&volume.view(), &paged_grid).unwrap();
    let cam = camera();

    // The one-page value AOV is the attribute of the hit cell: the CPU tracer's.
    let cpu = isogrid_trace::render(
        &grid,
        &cam,
        &isogrid_trace::RenderOptions {
            coloring: Some(coloring.clone()),
            ..Default::default()
        },
    )
    .unwrap();
    let cpu_value = cpu.value.unwrap();

    let raster_modes = [
        ("cgc", Mode::Cgc),
        ("cgc-noewa", Mode::CgcNoEwa),
        ("cr", Mode::Cr),
    ];
    for (name, mode) in raster_modes {
        for raster in [CellRaster::Hardware, CellRaster::Compute] {
            let label = format!("{name}, {raster:?} raster, {} pages", firsts.len());
            let options = RenderOptions {
                cell_raster: raster,
                coloring: Some(coloring.clone()),
                ..Default::default()
            };
            let scene = |g, v| match mode {
                Mode::Cr => Scene::Volume { grid: g, volume: v },
                _ => Scene::Grid(g),
            };
            let a = one
                .render_with(scene(&one_grid, &one_volume), &cam, mode, &options)
                .unwrap();
            let b = paged
                .render_with(scene(&paged_grid, &paged_volume), &cam, mode, &options)
                .unwrap();
            // Against the CPU: the values of pixels both hit, within 1 % of the range (the
            // crossing may fall in a neighbouring cell at cell edges on 1 % of pixels).
            let width = coloring.clim[1] - coloring.clim[0];
            let both: Vec<usize> = (0..a.value.len())
                .filter(|&i| a.is_hit(i) && cpu.cluster[i] != u32::MAX)
                .collect();
            let close = both
                .iter()
                .filter(|&&i| (a.value[i] as f64 - cpu_value[i] as f64).abs() <= 0.01 * width)
                .count();
            let distinct: std::collections::BTreeSet<u32> =
                both.iter().map(|&i| a.value[i].to_bits()).collect();
            eprintln!(
                "{label}: {} of {} common hits within 1 % of the CPU value, {} distinct values",
                close,
                both.len(),
                distinct.len()
            );
            assert!(both.len() > 1000, "{label}: {} hits", both.len());
            assert!(distinct.len() > 50, "{label}: {} values", distinct.len());
            assert!(close as f64 >= 0.99 * both.len() as f64, "{label}");
            // EWA normals are sums in blending order, which follows the order the expansion
            // lists cells in (atomics, per page): the shading may move by a level or two.
            let tolerance = if mode == Mode::Cgc { 2 } else { 0 };
            assert_same_picture(&label, &a, &b, tolerance);
        }
    }

    for primary in [PrimaryRays::Raster, PrimaryRays::Traced] {
        let label = format!("path trace, {primary:?} primaries, {} pages", firsts.len());
        let options = PathTraceOptions {
            frames: 2,
            bounces: 2,
            primary,
            coloring: Some(&coloring),
            ..Default::default()
        };
        let a = one.path_trace(&one_grid, &cam, &options).unwrap();
        let b = paged.path_trace(&paged_grid, &cam, &options).unwrap();
        let hits = (0..a.depth.len()).filter(|&i| a.is_hit(i)).count();
        assert!(hits > 1000, "{label}: {hits} hits");
        // Coloured: far more distinct colours than shading one albedo gives.
        let colours: std::collections::BTreeSet<&[u8]> = a.rgba8.chunks(4).collect();
        eprintln!("{label}: {hits} hits, {} colours", colours.len());
        assert_same_picture(&label, &a, &b, 0);
        let linear_differs = a
            .linear
            .iter()
            .zip(&b.linear)
            .filter(|(x, y)| x != y)
            .count();
        assert_eq!(linear_differs, 0, "{label}: linear radiance differs");
    }
}

/// 3–6 pages: one trace pass binds them all.
#[test]
fn a_coloured_grid_in_a_few_pages_draws_like_one_page_in_every_mode() {
    compare_paged(3);
}

/// More than six pages: traced in passes over groups of pages (the wavefront path tracer).
#[test]
fn a_coloured_grid_in_many_pages_draws_like_one_page_in_every_mode() {
    compare_paged(8);
}

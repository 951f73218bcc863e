//! Extraction against an independent brute-force reference (paper §3.1): active cells, their
//! Morton order, metacells, clusters, padding, bounds, pointers, block ranges and corner values.

use crate::common::{blobs_u8, field, random_u8, Rng};
use isogrid::layout::read_corners;
use isogrid::{extract, CellGrid, ExtractOptions, Iso, Precision, Volume, VolumeData};

/// Morton code by a plain bit loop (independent of the library's table-free version).
fn morton_slow(p: [usize; 3]) -> usize {
    let mut code = 0;
    for bit in 0..4 {
        for (axis, v) in p.iter().enumerate() {
            code |= ((v >> bit) & 1) << (3 * bit + axis);
        }
    }
    code
}

struct Expected {
    /// (block index, slots as (position, mask) or bound, cells as grid positions)
    blocks: Vec<ExpectedBlock>,
}

struct ExpectedBlock {
    slots: Vec<Slot>,
    cells: Vec<[usize; 3]>,
    min: f64,
    max: f64,
}

#[derive(Debug, PartialEq)]
enum Slot {
    Metacell { position: [usize; 3], mask: u8 },
    Padding,
    Bound { lo: [usize; 3], hi: [usize; 3] },
}

fn brute_force(volume: &Volume, iso: f64) -> Expected {
    let d = volume.dims();
    let cells = d.map(|n| n - 1);
    let nb = cells.map(|c| c.div_ceil(16));
    let mut blocks = Vec::new();
    for bz in 0..nb[2] {
        for by in 0..nb[1] {
            for bx in 0..nb[0] {
                let b = [bx, by, bz];
                let mut active = Vec::new();
                let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
                for z in 16 * bz..(16 * bz + 16).min(cells[2]) {
                    for y in 16 * by..(16 * by + 16).min(cells[1]) {
                        for x in 16 * bx..(16 * bx + 16).min(cells[0]) {
                            let mut inside = 0;
                            for c in 0..8 {
                                let v = volume.get(x + (c & 1), y + (c >> 1 & 1), z + (c >> 2 & 1));
                                if !v.is_nan() {
                                    min = min.min(v);
                                    max = max.max(v);
                                }
                                inside += (v >= iso) as u32;
                            }
                            if inside != 0 && inside != 8 {
                                active.push([x, y, z]);
                            }
                        }
                    }
                }
                active.sort_by_key(|p| morton_slow([0, 1, 2].map(|a| p[a] - 16 * b[a])));
                // Group consecutive cells into metacells (consecutive in Morton order by construction).
                let mut metacells: Vec<([usize; 3], u8)> = Vec::new();
                for p in &active {
                    let m = p.map(|v| v / 2);
                    let bit = (p[0] & 1) | (p[1] & 1) << 1 | (p[2] & 1) << 2;
                    match metacells.last_mut() {
                        Some((pos, mask)) if *pos == m => *mask |= 1 << bit,
                        _ => metacells.push((m, 1 << bit)),
                    }
                }
                let mut slots = Vec::new();
                for chunk in metacells.chunks(15) {
                    for (pos, mask) in chunk {
                        slots.push(Slot::Metacell {
                            position: *pos,
                            mask: *mask,
                        });
                    }
                    for _ in chunk.len()..15 {
                        slots.push(Slot::Padding);
                    }
                    let lo = [0, 1, 2].map(|a| chunk.iter().map(|(p, _)| p[a]).min().unwrap());
                    let hi = [0, 1, 2].map(|a| chunk.iter().map(|(p, _)| p[a]).max().unwrap());
                    slots.push(Slot::Bound { lo, hi });
                }
                blocks.push(ExpectedBlock {
                    slots,
                    cells: active,
                    min,
                    max,
                });
            }
        }
    }
    Expected { blocks }
}

/// Compares a grid with the reference, field by field; `exact` when the corner codes must decode to the samples exactly.
fn check(volume: &Volume, grid: &CellGrid, iso: f64, exact: bool) {
    let expected = brute_force(volume, iso);
    let info = grid.info();
    assert_eq!(info.iso, iso);
    assert_eq!(grid.blocks().len(), expected.blocks.len());
    let precision = info.precision;
    let mapping = info.mapping;
    let mut slot_cursor = 0usize;
    let mut cell_cursor = 0usize;
    for (index, (block, exp)) in grid.blocks().iter().zip(&expected.blocks).enumerate() {
        assert_eq!(
            block.metacell_pointer as usize, slot_cursor,
            "block {index} pointer"
        );
        assert_eq!(
            block.metacell_count as usize,
            exp.slots.len(),
            "block {index} slot count"
        );
        if exp.min.is_finite() {
            assert_eq!(block.min as f64, exp.min as f32 as f64, "block {index} min");
            assert_eq!(block.max as f64, exp.max as f32 as f64, "block {index} max");
        }
        let slots = &grid.metacells()[block.slots()];
        let mut cells_of_block = Vec::new();
        for (s, (got, want)) in slots.iter().zip(&exp.slots).enumerate() {
            match want {
                Slot::Metacell { position, mask } => {
                    assert_eq!(
                        got.position.map(|v| v as usize),
                        *position,
                        "block {index} slot {s}"
                    );
                    assert_eq!(got.cell_mask, *mask as u16, "block {index} slot {s} mask");
                    assert_eq!(
                        got.cell_pointer as usize,
                        cell_cursor + cells_of_block.len(),
                        "cell pointer"
                    );
                    for bit in 0..8 {
                        if mask >> bit & 1 == 1 {
                            cells_of_block.push(got.cell_position(bit).map(|v| v as usize));
                        }
                    }
                }
                Slot::Padding => {
                    assert_eq!(bytemuck::bytes_of(got), &[0u8; 12], "padding must be zero")
                }
                Slot::Bound { lo, hi } => {
                    assert_eq!(s % 16, 15);
                    let b = got.as_bound();
                    assert_eq!(b.lo.map(|v| v as usize), *lo, "bound lo");
                    assert_eq!(b.hi.map(|v| v as usize), *hi, "bound hi");
                }
            }
        }
        assert_eq!(
            cells_of_block, exp.cells,
            "block {index}: active cells in Morton order"
        );
        for (k, p) in exp.cells.iter().enumerate() {
            let corners = read_corners(grid.cell_record(cell_cursor + k), precision);
            for (c, code) in corners.iter().enumerate() {
                let v = volume.get(p[0] + (c & 1), p[1] + (c >> 1 & 1), p[2] + (c >> 2 & 1));
                assert_eq!(
                    *code >= mapping.iso_code,
                    v >= iso,
                    "cell {p:?} corner {c}: side changed"
                );
                let decoded = mapping.value(*code);
                if exact {
                    assert!(
                        decoded == v || (v.is_nan() && code.is_nan()),
                        "cell {p:?} corner {c}: {decoded} != {v}"
                    );
                } else if !v.is_nan() {
                    // 32-bit corners of wider samples are f32s: off by up to one f32 step.
                    let f32_step = (v.abs() as f32).next_up() as f64 - v.abs() as f32 as f64;
                    let tolerance = match precision {
                        Precision::Float32 => f32_step,
                        _ => mapping.step,
                    };
                    assert!(
                        (decoded - v).abs() <= tolerance * 1.0000001,
                        "cell {p:?} corner {c}: {decoded} vs {v}"
                    );
                }
            }
        }
        slot_cursor += exp.slots.len();
        cell_cursor += exp.cells.len();
    }
    assert_eq!(grid.metacell_slots(), slot_cursor);
    assert_eq!(grid.active_cells(), cell_cursor);
}

fn run(volume: &Volume, iso: f64, precision: Option<Precision>) -> CellGrid {
    let mut options = ExtractOptions::new(Iso::Value(iso));
    options.precision = precision;
    extract(&volume.view(), &options).unwrap()
}

#[test]
fn random_u8_volumes_of_awkward_sizes_match_the_reference() {
    let sizes = [
        [13, 7, 5],
        [2, 9, 17],
        [9, 2, 3],
        [5, 6, 2],
        [2, 2, 2],
        [33, 17, 18],
        [17, 17, 17],
        [70, 3, 20],
        [66, 35, 4],
    ];
    for (seed, dims) in sizes.into_iter().enumerate() {
        let volume = random_u8(dims, seed as u64, 256);
        for iso in [127.5, 128.0, 0.5, 254.5] {
            check(&volume, &run(&volume, iso, None), iso, true);
        }
        // Isovalues exactly on sample values, where ties decide.
        let coarse = random_u8(dims, 100 + seed as u64, 3);
        for iso in [0.0, 127.0, 255.0] {
            check(&coarse, &run(&coarse, iso, None), iso, true);
        }
    }
}

#[test]
fn structured_volume_matches_the_reference_at_every_precision() {
    let volume = blobs_u8([45, 38, 41]);
    check(&volume, &run(&volume, 127.5, None), 127.5, true);
    check(
        &volume,
        &run(&volume, 127.5, Some(Precision::Bits4)),
        127.5,
        false,
    );
    check(
        &volume,
        &run(&volume, 127.5, Some(Precision::Bits16)),
        127.5,
        true,
    );
    check(
        &volume,
        &run(&volume, 127.5, Some(Precision::Float32)),
        127.5,
        true,
    );
}

#[test]
fn other_scalar_types_match_the_reference() {
    let dims = [23, 19, 35];
    let mut rng = Rng::new(7);
    let f = field(dims, |x, y, z| {
        ((x * 0.4).sin() + (y * 0.3).cos() + (z * 0.25).sin()) * 1000.0
    });
    let n: usize = dims.iter().product();

    let u16s = Volume::new(
        dims,
        VolumeData::U16(f.iter().map(|v| (v + 3000.0) as u16).collect()),
    )
    .unwrap();
    check(&u16s, &run(&u16s, 3000.5, None), 3000.5, true);
    check(
        &u16s,
        &run(&u16s, 3000.5, Some(Precision::Bits8)),
        3000.5,
        false,
    );

    let i16s = Volume::new(dims, VolumeData::I16(f.iter().map(|v| *v as i16).collect())).unwrap();
    for iso in [0.0, -250.0, 999.0] {
        check(&i16s, &run(&i16s, iso, None), iso, true);
    }

    let mut floats: Vec<f32> = f
        .iter()
        .map(|v| (*v / 1000.0) as f32 + (rng.unit() as f32 - 0.5) * 0.1)
        .collect();
    floats[n / 2] = f32::NAN; // NaN counts as outside and is ignored by ranges
    let f32s = Volume::new(dims, VolumeData::F32(floats)).unwrap();
    for iso in [0.1, 0.0, -0.7] {
        check(&f32s, &run(&f32s, iso, None), iso, false);
        check(&f32s, &run(&f32s, iso, Some(Precision::Float32)), iso, true);
        check(&f32s, &run(&f32s, iso, Some(Precision::Bits4)), iso, false);
    }
}

#[test]
fn all_inside_all_outside_and_single_sample_axes_are_empty() {
    let volume = random_u8([20, 20, 20], 3, 256);
    for iso in [0.0, 256.0, 1e9, -1e9] {
        let grid = run(&volume, iso, None);
        assert_eq!(grid.active_cells(), 0, "iso {iso}");
        assert_eq!(grid.metacell_slots(), 0);
        assert_eq!(grid.blocks().len(), 8);
        check(&volume, &grid, iso, true);
    }
    let flat = random_u8([30, 20, 1], 4, 256);
    let grid = run(&flat, 100.0, None);
    assert_eq!((grid.blocks().len(), grid.active_cells()), (0, 0));
    let (lo, hi) = flat.value_range().unwrap();
    assert_eq!(grid.info().value_range, [lo, hi]);
}

#[test]
fn normalized_isovalue_is_relative_to_the_value_range() {
    let volume = Volume::new(
        [3, 2, 2],
        VolumeData::I16(vec![-100, 0, 100, 20, 30, 40, 50, 60, 70, 80, 90, 95]),
    )
    .unwrap();
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.25))).unwrap();
    assert_eq!(grid.info().iso, -50.0);
    assert_eq!(grid.info().value_range, [-100.0, 100.0]);
    assert!(extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(1.5))).is_err());
    assert!(extract(&volume.view(), &ExtractOptions::new(Iso::Value(f64::NAN))).is_err());
}

#[test]
fn output_is_identical_for_any_thread_count() {
    let volume = blobs_u8([90, 70, 66]);
    let with_threads = |n: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap();
        pool.install(|| run(&volume, 127.5, None))
    };
    let one = with_threads(1);
    for n in [2, 3, 5] {
        let other = with_threads(n);
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(one.blocks()),
            bytemuck::cast_slice::<_, u8>(other.blocks())
        );
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(one.metacells()),
            bytemuck::cast_slice::<_, u8>(other.metacells())
        );
        assert_eq!(one.cells(), other.cells());
    }
    assert!(one.active_cells() > 10_000);
}

#[test]
fn the_largest_grid_coordinates_fit_the_16_bit_metacell_positions() {
    // 131,072 samples along x (the paper's 128K limit): the last cell is x = 131,070, metacell 65,535.
    let n = isogrid::MAX_DIM;
    let mut data = vec![0u8; n * 2 * 2];
    for k in 0..2 {
        for j in 0..2 {
            data[n - 1 + n * (j + 2 * k)] = 255; // the last sample of every row is inside
            data[n / 2 + n * (j + 2 * k)] = 255;
        }
    }
    let volume = Volume::new([n, 2, 2], VolumeData::U8(data)).unwrap();
    let grid = run(&volume, 127.5, None);
    assert_eq!(grid.active_cells(), 3);
    let positions: Vec<[u16; 3]> = grid
        .metacells()
        .iter()
        .enumerate()
        .filter(|(s, m)| s % 16 != 15 && !m.is_empty())
        .map(|(_, m)| m.position)
        .collect();
    assert!(positions.contains(&[65535, 0, 0]), "{positions:?}");
    check(&volume, &grid, 127.5, true);
    let back = isogrid::cgc::read_bytes(&isogrid::cgc::to_bytes(&grid)).unwrap();
    assert_eq!(back.metacells(), grid.metacells());
    assert!(Volume::new([n + 1, 1, 1], VolumeData::U8(vec![0; n + 1])).is_err());
}

#[test]
fn progress_counts_two_steps_per_block_and_cancel_stops_between_the_passes() {
    let volume = blobs_u8([45, 38, 41]);
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let progress = isogrid::Progress::new();
    let counted = isogrid::extract_with_progress(&volume.view(), &options, &progress).unwrap();
    let plain = extract(&volume.view(), &options).unwrap();
    assert_eq!(counted.cells(), plain.cells());
    assert_eq!(counted.metacells(), plain.metacells());
    // 3 × 3 × 3 blocks of 16³ cells.
    assert_eq!(plain.blocks().len(), 27);
    assert_eq!(progress.counts(), (54, 54));
    let cancelled = isogrid::Progress::new();
    cancelled.cancel();
    let err = isogrid::extract_with_progress(&volume.view(), &options, &cancelled).unwrap_err();
    assert_eq!(err.kind(), isogrid::ErrorKind::Cancelled, "{err}");
    // Cancelled before it began, it scanned and emitted nothing.
    assert_eq!(cancelled.counts(), (0, 54));
}

/// Active cells and crossed edges of `samples` counted by brute force, the side of each sample
/// decided by `inside` (which the callers write in the sample's own type).
fn count_straddling<T: Copy>(
    dims: [usize; 3],
    samples: &[T],
    inside: impl Fn(T) -> bool,
) -> (usize, usize) {
    let [nx, ny, nz] = dims;
    let at = |i: usize, j: usize, k: usize| inside(samples[i + nx * (j + ny * k)]);
    let mut cells = 0;
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let n = (0..8)
                    .filter(|c| at(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)))
                    .count();
                cells += (n != 0 && n != 8) as usize;
            }
        }
    }
    let mut edges = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let here = at(i, j, k);
                edges += (i + 1 < nx && at(i + 1, j, k) != here) as usize
                    + (j + 1 < ny && at(i, j + 1, k) != here) as usize
                    + (k + 1 < nz && at(i, j, k + 1) != here) as usize;
            }
        }
    }
    (cells, edges)
}

/// Every precision's active cells and corner sides, and Marching Cubes' vertices (one per crossed
/// edge), against `count_straddling`; the header's value range is the samples' true one.
fn check_wide(volume: &Volume, iso: f64, expected: (usize, usize), range: [f64; 2]) {
    let name = volume.scalar_type().name();
    assert!(
        expected.0 > 0,
        "{name}: the test volume must straddle {iso}"
    );
    for precision in Precision::ALL {
        let grid = run(volume, iso, Some(precision));
        assert_eq!(
            grid.active_cells(),
            expected.0,
            "{name} {precision:?} at {iso}"
        );
        assert_eq!(grid.info().value_range, range, "{name} {precision:?}");
        if volume.scalar_type().fits_f64() {
            // Samples are exact as f64 here, so the brute force of `check` applies, corners included.
            check(volume, &grid, iso, false);
        }
    }
    let mesh = isogrid::mc::marching_cubes(&volume.view(), iso);
    assert_eq!(
        mesh.positions.len(),
        expected.1,
        "{name}: Marching Cubes vertices"
    );
}

#[test]
fn wide_samples_are_classified_in_their_own_type() {
    let mut rng = Rng::new(42);
    let dims = [19, 17, 18];
    let n = dims.iter().product::<usize>();
    let mut pick = |lo, hi| -> Vec<usize> {
        (0..n)
            .map(|_| if rng.below(2) == 0 { lo } else { hi })
            .collect()
    };

    // 16777216 and 16777217 are one f32: converted, every sample fell on one side of 16777216.5.
    let v: Vec<u32> = pick(0, 1).iter().map(|&b| 16_777_216 + b as u32).collect();
    let expected = count_straddling(dims, &v, |x| x > 16_777_216);
    let volume = Volume::new(dims, VolumeData::U32(v)).unwrap();
    check_wide(
        &volume,
        16_777_216.5,
        expected,
        [16_777_216.0, 16_777_217.0],
    );

    // i32 near 1e8 (f32 steps are 8 there).
    let v: Vec<i32> = pick(0, 3)
        .iter()
        .map(|&b| -100_000_001 + b as i32)
        .collect();
    let expected = count_straddling(dims, &v, |x| x >= -99_999_999);
    let volume = Volume::new(dims, VolumeData::I32(v)).unwrap();
    check_wide(
        &volume,
        -99_999_999.0,
        expected,
        [-100_000_001.0, -99_999_998.0],
    );

    // f64 values 1e-12 apart.
    let (a, b) = (0.25, 0.25 + 1e-12);
    let v: Vec<f64> = pick(0, 1)
        .iter()
        .map(|&s| if s == 0 { a } else { b })
        .collect();
    let iso = 0.25 + 0.5e-12;
    let expected = count_straddling(dims, &v, |x| x >= iso);
    let volume = Volume::new(dims, VolumeData::F64(v)).unwrap();
    check_wide(&volume, iso, expected, [a, b]);

    // u64 IDs beyond 2^53, split at an isovalue that is an f64 integer: compared as u64.
    let base = (1u64 << 60) + 4096;
    let v: Vec<u64> = pick(0, 512).iter().map(|&s| base + s as u64).collect();
    let expected = count_straddling(dims, &v, |x| x >= base + 256);
    let volume = Volume::new(dims, VolumeData::U64(v)).unwrap();
    check_wide(
        &volume,
        (base + 256) as f64,
        expected,
        [base as f64, (base + 512) as f64],
    );

    // i64 on both sides of zero, far beyond f32.
    let v: Vec<i64> = pick(0, 1)
        .iter()
        .map(|&s| if s == 0 { -(1 << 40) } else { (1 << 40) + 1 })
        .collect();
    let expected = count_straddling(dims, &v, |x| x >= 1 << 40);
    let volume = Volume::new(dims, VolumeData::I64(v)).unwrap();
    check_wide(
        &volume,
        (1u64 << 40) as f64,
        expected,
        [-(2f64.powi(40)), 2f64.powi(40) + 1.0],
    );
}

#[test]
fn u64_isovalues_at_the_top_of_the_type_are_exact() {
    // 2^64 is above u64::MAX: nothing is inside (a saturating conversion made u64::MAX inside).
    let dims = [3, 3, 3];
    let v: Vec<u64> = (0..27)
        .map(|i| if i % 2 == 0 { u64::MAX } else { 0 })
        .collect();
    let volume = Volume::new(dims, VolumeData::U64(v.clone())).unwrap();
    assert_eq!(run(&volume, 2f64.powi(64), None).active_cells(), 0);
    let expected = count_straddling(dims, &v, |x| x >= 1 << 63);
    assert_eq!(run(&volume, 2f64.powi(63), None).active_cells(), expected.0);
    assert!(expected.0 > 0);
}

/// `CellGrid::surface_bounds` (what surface views frame) holds every active cell, found by
/// brute force from the samples, and reaches past them by at most one cell a side (clusters
/// bound whole metacells, two cells a side); an empty surface has none.
#[test]
fn the_surface_box_holds_every_active_cell_within_a_cell() {
    let spacing = [0.5, 1.0, 2.5];
    let blobs = blobs_u8([37, 30, 26]);
    let geometry = isogrid::Geometry {
        spacing,
        ..*blobs.geometry()
    };
    let volume = Volume::with_geometry(geometry, blobs.into_data()).unwrap();
    for iso in [60.0, 200.0] {
        let grid = run(&volume, iso, None);
        let d = volume.dims();
        let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
        for z in 0..d[2] - 1 {
            for y in 0..d[1] - 1 {
                for x in 0..d[0] - 1 {
                    let inside = (0..8)
                        .filter(|c| {
                            volume.get(x + (c & 1), y + (c >> 1 & 1), z + (c >> 2 & 1)) >= iso
                        })
                        .count();
                    if inside % 8 != 0 {
                        for (a, p) in [x, y, z].into_iter().enumerate() {
                            lo[a] = lo[a].min(p);
                            hi[a] = hi[a].max(p + 1);
                        }
                    }
                }
            }
        }
        assert!(
            grid.active_cells() > 0 && hi[0] - lo[0] < d[0] - 1,
            "a box inside the grid"
        );
        let (blo, bhi) = grid.surface_bounds().unwrap();
        for a in 0..3 {
            let (cells_lo, cells_hi) = (blo[a] / spacing[a], bhi[a] / spacing[a]);
            assert!(
                cells_lo <= lo[a] as f64 && cells_lo >= lo[a] as f64 - 1.0,
                "axis {a}"
            );
            assert!(
                cells_hi >= hi[a] as f64 && cells_hi <= hi[a] as f64 + 1.0,
                "axis {a}"
            );
        }
    }
    assert_eq!(run(&volume, 300.0, None).surface_bounds(), None);
}

//! The attribute pass: values at each active cell's surface point, against a brute-force
//! reference computed from the raw volume (not the stored codes) and an attribute that is a
//! linear function of world position, which trilinear sampling reproduces exactly.

use crate::common::{blobs_u8, field};
use isogrid::extract::attribute::{
    alignment, sample_attribute, sample_attribute_in_memory, surface_point, Alignment,
};
use isogrid::extract::stream;
use isogrid::{
    cgc, extract, AttributePrecision, CellGrid, ErrorKind, ExtractOptions, Geometry, Iso, Volume,
    VolumeData,
};
use std::collections::HashMap;

/// World position of index point `p` under `g`: `origin + Σₐ pₐ·spacingₐ·directionₐ`.
fn world(g: &Geometry, p: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| {
        g.origin[r]
            + (0..3)
                .map(|a| p[a] * g.spacing[a] * g.direction[a][r])
                .sum::<f64>()
    })
}

/// Every active cell of `volume` at `iso` (brute force over all cells), with its surface point in
/// index space: the centroid of the edge crossings of the raw samples.
fn reference_points(volume: &Volume, iso: f64) -> HashMap<[u32; 3], [f64; 3]> {
    let [nx, ny, nz] = volume.geometry().dims;
    let samples = volume.view();
    let at = |x: usize, y: usize, z: usize| samples.samples().get_f64(x + nx * (y + ny * z));
    let mut out = HashMap::new();
    for z in 0..nz - 1 {
        for y in 0..ny - 1 {
            for x in 0..nx - 1 {
                let c: [f64; 8] =
                    std::array::from_fn(|i| at(x + (i & 1), y + (i >> 1 & 1), z + (i >> 2 & 1)));
                let inside = c.iter().filter(|&&v| v >= iso).count();
                if inside == 0 || inside == 8 {
                    continue;
                }
                let (mut sum, mut n) = ([0.0; 3], 0.0);
                for axis in 0..3 {
                    for i in 0..8usize {
                        let j = i | 1 << axis;
                        if i >> axis & 1 == 1 || (c[i] >= iso) == (c[j] >= iso) {
                            continue;
                        }
                        let t = (iso - c[i]) / (c[j] - c[i]);
                        for k in 0..3 {
                            sum[k] += if k == axis { t } else { (i >> k & 1) as f64 };
                        }
                        n += 1.0;
                    }
                }
                let p = [
                    x as f64 + sum[0] / n,
                    y as f64 + sum[1] / n,
                    z as f64 + sum[2] / n,
                ];
                out.insert([x as u32, y as u32, z as u32], p);
            }
        }
    }
    out
}

/// (cell position, attribute value) for every active cell of `grid`, in cell order.
fn grid_values(grid: &CellGrid) -> Vec<([u32; 3], f32)> {
    let attribute = grid.attribute().expect("an attribute");
    let mut out = Vec::new();
    for (s, m) in grid.metacells().iter().enumerate() {
        if s % 16 == 15 || m.is_empty() {
            continue;
        }
        let mut cell = m.cell_pointer as usize;
        for bit in 0..8 {
            if m.cell_mask >> bit & 1 == 1 {
                out.push((m.cell_position(bit), attribute.value(cell)));
                cell += 1;
            }
        }
    }
    assert_eq!(out.len(), grid.active_cells());
    out
}

fn u8_sphere(n: usize) -> Volume {
    let c = (n as f64 - 1.0) / 2.0;
    let data: Vec<u8> = field([n, n, n], |x, y, z| {
        (255.0 - 10.0 * ((x - c).powi(2) + (y - c).powi(2) + (z - c).powi(2)).sqrt())
            .clamp(0.0, 255.0)
    })
    .into_iter()
    .map(|v| v as u8)
    .collect();
    Volume::new([n, n, n], VolumeData::U8(data)).unwrap()
}

/// An f32 attribute volume of `geometry` holding `f(world position)` at every sample.
fn linear_attribute(geometry: Geometry, f: impl Fn([f64; 3]) -> f64) -> Volume {
    let [nx, ny, nz] = geometry.dims;
    let data: Vec<f32> = (0..nx * ny * nz)
        .map(|i| {
            f(world(
                &geometry,
                [
                    (i % nx) as f64,
                    (i / nx % ny) as f64,
                    (i / (nx * ny)) as f64,
                ],
            )) as f32
        })
        .collect();
    Volume::with_geometry(geometry, VolumeData::F32(data)).unwrap()
}

fn check_against_reference(
    grid: &CellGrid,
    volume: &Volume,
    iso: f64,
    expected: impl Fn([f64; 3]) -> Option<f64>,
    tolerance: f64,
) {
    let reference = reference_points(volume, iso);
    let values = grid_values(grid);
    assert_eq!(values.len(), reference.len(), "active cells");
    let mut nan = 0;
    for (cell, value) in values {
        let p = reference[&cell];
        match expected(p) {
            Some(e) => assert!(
                (value as f64 - e).abs() <= tolerance,
                "cell {cell:?}: {value} vs {e} (tolerance {tolerance})"
            ),
            None => {
                assert!(value.is_nan(), "cell {cell:?}: {value}, expected NaN");
                nan += 1;
            }
        }
    }
    eprintln!("{nan} NaN values");
}

#[test]
fn same_grid_values_are_the_attribute_at_each_cells_surface_point() {
    let volume = u8_sphere(40).with_spacing([0.5, 0.75, 1.25]).unwrap();
    let iso = 127.5;
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(iso))).unwrap();
    let attribute = linear_attribute(*volume.geometry(), |w| w[0] + 2.0 * w[1] - 0.5 * w[2]);
    assert_eq!(
        alignment(volume.geometry(), attribute.geometry()).unwrap(),
        Alignment::SameGrid
    );
    for precision in AttributePrecision::ALL {
        let values = sample_attribute(&grid, &mut attribute.view(), "x+2y-z/2", precision).unwrap();
        // Read where it lies, the volume gives the same values as read slab by slab.
        let in_memory =
            sample_attribute_in_memory(&grid, &attribute.view(), "x+2y-z/2", precision).unwrap();
        assert_eq!(in_memory, values);
        let [lo, hi] = values.info().range;
        let tolerance = match precision {
            AttributePrecision::F32 => 1e-4,
            p => (hi - lo) / (2.0 * ((1u64 << p.bits()) - 2) as f64) + 1e-4,
        };
        let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(iso)))
            .unwrap()
            .with_attribute(values)
            .unwrap();
        let g = *volume.geometry();
        check_against_reference(
            &grid,
            &volume,
            iso,
            |p| {
                let w = world(&g, p);
                Some(w[0] + 2.0 * w[1] - 0.5 * w[2])
            },
            tolerance,
        );
    }
}

/// PET on CT: an attribute of another size, spacing, origin and direction (a flip and an oblique
/// rotation), sampled at the world positions of the surface points; a point outside it is NaN.
#[test]
fn resampled_values_follow_world_space_through_origin_spacing_and_direction() {
    let volume = u8_sphere(36)
        .with_spacing([1.0, 1.5, 2.0])
        .unwrap()
        .with_origin([-20.0, 5.0, 30.0])
        .unwrap();
    let iso = 127.5;
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(iso))).unwrap();
    let f = |w: [f64; 3]| 3.0 * w[0] - w[1] + 0.25 * w[2] + 7.0;
    let (c, s) = (0.6f64.cos(), 0.6f64.sin());
    let directions = [
        [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], // a flipped axis
        [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]],         // oblique
    ];
    for direction in directions {
        // Coarser, shifted, covering only part of the surface's volume along z.
        let mut geometry = Geometry::new([30, 34, 14]);
        geometry.spacing = [1.7, 1.9, 2.5];
        geometry.direction = direction;
        // Place the attribute's centre near the grid's centre.
        let centre = world(volume.geometry(), [17.5, 17.5, 17.5]);
        let half = world(&geometry, [14.5, 16.5, 6.5]);
        geometry.origin = [0, 1, 2].map(|a| centre[a] - half[a] + [0.0, 0.0, 8.0][a]);
        let attribute = linear_attribute(geometry, f);
        assert!(matches!(
            alignment(volume.geometry(), attribute.geometry()).unwrap(),
            Alignment::Resampled { .. }
        ));
        let values =
            sample_attribute(&grid, &mut attribute.view(), "pet", AttributePrecision::F32).unwrap();
        let in_memory =
            sample_attribute_in_memory(&grid, &attribute.view(), "pet", AttributePrecision::F32)
                .unwrap();
        assert_eq!(
            in_memory.value_bytes(),
            values.value_bytes(),
            "in memory and by slab"
        );
        let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(iso)))
            .unwrap()
            .with_attribute(values)
            .unwrap();
        // Inside the attribute's box (index space of the attribute, by inverting its geometry
        // numerically here: solve the 3×3 system), the linear function; outside, NaN.
        let g = *volume.geometry();
        let inverse = |w: [f64; 3]| -> [f64; 3] {
            let m: [[f64; 3]; 3] = std::array::from_fn(|r| {
                std::array::from_fn(|a| geometry.spacing[a] * geometry.direction[a][r])
            });
            let b = [0, 1, 2].map(|r| w[r] - geometry.origin[r]);
            // Cramer's rule.
            let det3 = |m: [[f64; 3]; 3]| {
                m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                    - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                    + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
            };
            let d = det3(m);
            [0, 1, 2].map(|a| {
                let mut ma = m;
                for r in 0..3 {
                    ma[r][a] = b[r];
                }
                det3(ma) / d
            })
        };
        let extent = geometry.dims.map(|n| (n - 1) as f64);
        let (mut inside, mut margin_skipped) = (0, 0);
        let reference = reference_points(&volume, iso);
        for (cell, value) in grid_values(&grid) {
            let w = world(&g, reference[&cell]);
            let q = inverse(w);
            let distance_to_edge = (0..3)
                .map(|a| q[a].min(extent[a] - q[a]))
                .fold(f64::INFINITY, f64::min);
            if distance_to_edge.abs() < 1e-6 {
                margin_skipped += 1; // on the boundary: either answer is right
            } else if distance_to_edge > 0.0 {
                assert!(
                    (value as f64 - f(w)).abs() <= 1e-3 * f(w).abs().max(1.0),
                    "cell {cell:?}: {value} vs {}",
                    f(w)
                );
                inside += 1;
            } else {
                assert!(
                    value.is_nan(),
                    "cell {cell:?} outside the attribute: {value}"
                );
            }
        }
        assert!(
            inside > 500 && inside < grid.active_cells(),
            "{inside} of {} inside ({margin_skipped} on the edge)",
            grid.active_cells()
        );
    }
}

#[test]
fn nan_samples_give_nan_values_and_disjoint_volumes_are_refused() {
    let volume = u8_sphere(24);
    let iso = 127.5;
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(iso))).unwrap();
    // NaN in the half x < 11.5.
    let mut attribute = linear_attribute(*volume.geometry(), |w| {
        if w[0] < 11.5 {
            f64::NAN
        } else {
            w[1]
        }
    });
    let values = sample_attribute(
        &grid,
        &mut attribute.view(),
        "half",
        AttributePrecision::Code8,
    )
    .unwrap();
    let grid = grid.with_attribute(values).unwrap();
    let mut nan = 0;
    for (cell, value) in grid_values(&grid) {
        if (cell[0] as f64) < 11.5 {
            assert!(value.is_nan(), "cell {cell:?}: {value}");
            nan += 1;
        } else if cell[0] >= 12 {
            assert!(value.is_finite(), "cell {cell:?}");
        }
    }
    assert!(nan > 100);
    // NaN survives the file.
    let read = cgc::read_bytes(&cgc::to_bytes(&grid)).unwrap();
    assert_eq!(read.attribute(), grid.attribute());
    // An attribute volume beside the surface's, not over it.
    let mut geometry = *volume.geometry();
    geometry.origin = [100.0, 0.0, 0.0];
    attribute = linear_attribute(geometry, |w| w[0]);
    let err = sample_attribute(
        &grid,
        &mut attribute.view(),
        "far",
        AttributePrecision::Code8,
    )
    .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::InvalidInput);
    assert!(err.to_string().contains("does not overlap"), "{err}");
}

#[test]
fn attributes_round_trip_through_files_and_every_damaged_bit_is_rejected() {
    let volume = blobs_u8([20, 18, 17]);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(127.5))).unwrap();
    let attribute = linear_attribute(*volume.geometry(), |w| w[2] - w[0]);
    for precision in AttributePrecision::ALL {
        let values = sample_attribute(&grid, &mut attribute.view(), "z-x", precision).unwrap();
        let with = extract(&volume.view(), &ExtractOptions::new(Iso::Value(127.5)))
            .unwrap()
            .with_attribute(values)
            .unwrap();
        let bytes = cgc::to_bytes(&with);
        let read = cgc::read_bytes(&bytes).unwrap();
        assert_eq!(read.attribute(), with.attribute());
        assert_eq!(read.attribute().unwrap().info().name, "z-x");
        let dir = crate::stream::TempDir::new(&format!("attr-{}", precision.bits()));
        let path = dir.0.join(format!("a{}.cgc", precision.bits()));
        cgc::write(&path, &with).unwrap();
        assert_eq!(cgc::read(&path).unwrap().attribute(), with.attribute());
        assert_eq!(cgc::open(&path).unwrap().attribute(), with.attribute());
        // The attribute section is the fourth, optional.
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        assert_eq!(
            (u32_at(168), u32_at(320 + 96), u32_at(320 + 100)),
            (4, 4, 0)
        );
        if precision == AttributePrecision::Code8 {
            for at in 0..bytes.len() {
                let mut damaged = bytes.clone();
                damaged[at] ^= 1 << (at % 8);
                assert!(cgc::read_bytes(&damaged).is_err(), "flip at {at} accepted");
            }
            for len in 0..bytes.len() {
                assert!(
                    cgc::read_bytes(&bytes[..len]).is_err(),
                    "truncation to {len} accepted"
                );
            }
        }
    }
}

/// The attribute pass reads only the grid's records, so a streamed grid (any budget) gets the
/// bytes of the in-memory one.
#[test]
fn streamed_and_in_memory_grids_get_the_same_attribute_bytes() {
    let volume = blobs_u8([45, 40, 70]);
    let options = ExtractOptions::new(Iso::Value(127.5));
    let attribute = linear_attribute(*volume.geometry(), |w| (w[0] * 0.3).sin() + w[2]);
    let in_memory = extract(&volume.view(), &options).unwrap();
    let values = sample_attribute(
        &in_memory,
        &mut attribute.view(),
        "a",
        AttributePrecision::Code16,
    )
    .unwrap();
    let expected = cgc::to_bytes(&in_memory.with_attribute(values).unwrap());
    let dir = crate::stream::TempDir::new("attr-stream");
    let path = dir.0.join("streamed.cgc");
    let mut view = volume.view();
    // One block layer per slab and a small output buffer (many groups), then everything at once.
    for (layers, output_buffer) in [(1, 4096u64), (8, 64 << 20)] {
        let plan = stream::MemoryPlan {
            max_memory: u64::MAX,
            slab_layers: layers,
            slab_bytes: 0,
            output_buffer,
            fixed: 0,
            minimum: 0,
        };
        stream::extract_planned(&mut view, &options, &plan, &path, &isogrid::Progress::new())
            .unwrap();
        let streamed = cgc::open(&path).unwrap();
        let values = sample_attribute(
            &streamed,
            &mut attribute.view(),
            "a",
            AttributePrecision::Code16,
        )
        .unwrap();
        assert_eq!(
            cgc::to_bytes(&streamed.with_attribute(values).unwrap()),
            expected,
            "{layers} layers per slab"
        );
    }
}

#[test]
fn the_surface_point_is_the_centroid_of_the_edge_crossings() {
    // One corner inside at threshold 1: the crossings are at t = 0.5 along its three edges.
    let mut corners = [0.0f32; 8];
    corners[0] = 2.0;
    let p = surface_point(&corners, 1.0);
    let e = 0.5 / 3.0;
    // f32 arithmetic: within a few ulps of a cell.
    assert!(p.iter().all(|&v| (v - e).abs() < 1e-6), "{p:?}");
    // A plane x = 0.25: crossings on the four x edges.
    let corners = [1.0f32, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0].map(|v| v * 4.0);
    assert_eq!(surface_point(&corners, 3.0), [0.25, 0.5, 0.5]);
}

/// An attribute in the other convention (LPS for a RAS grid) lines up once its x and y change
/// sign: the same place is the same grid; a geometry of no known convention is taken as it is.
#[test]
fn an_attribute_of_the_other_world_convention_is_taken_into_the_grids() {
    use isogrid::{Geometry, WorldFrame};
    let ras = Geometry {
        spacing: [1.5, 1.0, 0.75],
        origin: [30.0, -12.5, 5.0],
        direction: [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        frame: WorldFrame::Ras,
        ..Geometry::new([8, 7, 6])
    };
    let lps = Geometry {
        origin: [-30.0, 12.5, 5.0],
        direction: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        frame: WorldFrame::Lps,
        ..ras
    };
    assert_eq!(lps.in_frame(WorldFrame::Ras), ras);
    assert_eq!(ras.in_frame(WorldFrame::Lps), lps);
    assert_eq!(ras.in_frame(WorldFrame::Unknown), ras);
    assert!(matches!(alignment(&ras, &lps), Ok(Alignment::SameGrid)));
    assert!(matches!(alignment(&lps, &ras), Ok(Alignment::SameGrid)));
    // Without a convention on one side the numbers are taken as they are: here, no overlap.
    let unknown = Geometry {
        frame: WorldFrame::Unknown,
        ..lps
    };
    assert!(alignment(&ras, &unknown).is_err());
}

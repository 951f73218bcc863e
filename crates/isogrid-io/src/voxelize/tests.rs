//! Voxeliser tests against independent references: exact point-in-convex-polyhedron counts, the
//! divergence-theorem volume of the mesh, and analytic box coverage.

use super::*;
use std::collections::HashMap;

/// An icosahedron subdivided `levels` times, projected onto a sphere of `radius` around `centre`.
/// Faces are wound consistently (outward).
fn icosphere(levels: usize, centre: [f64; 3], radius: f64) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, verts: &mut Vec<[f64; 3]>| {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (verts[a as usize], verts[b as usize]);
                verts.push([0, 1, 2].map(|i| (p[i] + q[i]) / 2.0));
                verts.len() as u32 - 1
            })
        };
        let mut next = Vec::new();
        for [a, b, c] in faces {
            let (ab, bc, ca) = (
                mid(a, b, &mut verts),
                mid(b, c, &mut verts),
                mid(c, a, &mut verts),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let vertices = verts
        .iter()
        .map(|p| {
            let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            [0, 1, 2].map(|i| (centre[i] + radius * p[i] / len) as f32)
        })
        .collect();
    TriMesh {
        vertices,
        triangles: faces,
    }
}

/// Volume enclosed by a closed, consistently wound mesh (divergence theorem).
fn enclosed_volume(mesh: &TriMesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize].map(|x| x as f64));
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum::<f64>()
        .abs()
}

fn samples(v: &Volume) -> &[u8] {
    match v.data() {
        VolumeData::U8(d) => d,
        _ => panic!("voxeliser makes u8"),
    }
}

fn no_progress(_: u64, _: u64) {}

fn opts(resolution: usize, supersample: usize, padding: usize) -> VoxelizeOptions {
    VoxelizeOptions {
        resolution,
        supersample,
        padding,
        cube: false,
    }
}

#[test]
fn placement_dims_spacing_origin() {
    // A box from (1, 2, 3) to (3, 3, 3.5): longest side 2 spans 20 − 2·2 = 16 voxels of 0.125.
    let mut mesh = icosphere(0, [0.0; 3], 1.0);
    mesh.vertices = vec![[1.0, 2.0, 3.0], [3.0, 3.0, 3.5], [1.0, 3.0, 3.0]];
    mesh.triangles = vec![[0, 1, 2]];
    let v = voxelize(&mesh, &opts(20, 3, 2), &no_progress).unwrap();
    assert_eq!(v.dims(), [20, 12, 8]);
    assert_eq!(v.spacing(), [0.125; 3]);
    let o = v.origin();
    for (got, want) in o
        .iter()
        .zip([1.0 - 1.5 * 0.125, 2.0 - 1.5 * 0.125, 3.0 - 1.5 * 0.125])
    {
        assert!((got - want).abs() < 1e-12, "{o:?}");
    }
}

#[test]
fn cube_placement_centres_the_mesh_and_keeps_the_voxels() {
    let mesh = icosphere(2, [0.0, 0.0, 0.0], 1.0);
    let mut stretched = mesh.clone();
    stretched.vertices.iter_mut().for_each(|v| v[1] *= 0.5);
    let tight = voxelize(&stretched, &opts(24, 2, 2), &no_progress).unwrap();
    let cube = voxelize(
        &stretched,
        &VoxelizeOptions {
            cube: true,
            ..opts(24, 2, 2)
        },
        &no_progress,
    )
    .unwrap();
    assert_eq!(cube.dims(), [24, 24, 24]);
    assert_eq!(cube.spacing(), tight.spacing());
    // Same samples, shifted by whole voxels along y: the tight volume sits centred inside the cube.
    let [tx, ty, tz] = tight.dims();
    assert_eq!((tx, tz), (24, 24));
    let shift = (24 - ty) / 2;
    for k in 0..tz {
        for j in 0..ty {
            for i in 0..tx {
                assert_eq!(
                    tight.get(i, j, k),
                    cube.get(i, j + shift, k),
                    "({i}, {j}, {k})"
                );
            }
        }
    }
    let total = |v: &Volume| samples(v).iter().map(|&x| x as u64).sum::<u64>();
    assert_eq!(total(&tight), total(&cube));
    assert!(
        (cube.origin()[1] - (tight.origin()[1] - shift as f64 * tight.spacing()[1])).abs() < 1e-9
    );
}

/// The voxeliser against a brute-force count of fine-voxel centres inside a convex polyhedron,
/// with vertices on the fixed-point grid so both see exactly the same solid: every output sample
/// must match exactly.
#[test]
fn matches_brute_force_point_in_convex_polyhedron() {
    let (resolution, s, padding) = (20usize, 4usize, 2usize);
    // Bounding box [0, 1]³ from two unreferenced corner vertices: h = 1/16, fine = 1/64, and the
    // fixed-point step is 1/(64·256) = 2⁻¹⁴, on which we place every vertex.
    let mut mesh = icosphere(2, [0.517, 0.483, 0.502], 0.37);
    let q = 16384.0f32;
    for v in mesh.vertices.iter_mut() {
        *v = v.map(|c| (c * q).round() / q);
    }
    mesh.vertices.push([0.0; 3]);
    mesh.vertices.push([1.0; 3]);
    let v = voxelize(&mesh, &opts(resolution, s, padding), &no_progress).unwrap();
    assert_eq!(v.dims(), [resolution; 3]);

    // Integer geometry in units of 2⁻¹⁴ (plus the padding offset): exact plane tests in i64.
    let to_int = |p: [f32; 3]| p.map(|c| (c * q) as i64 + (padding as i64) * 1024);
    let planes: Vec<([i64; 3], i64)> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| to_int(mesh.vertices[i as usize]));
            let (u, w) = (
                [0, 1, 2].map(|i| b[i] - a[i]),
                [0, 1, 2].map(|i| c[i] - a[i]),
            );
            let n = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            (n, n[0] * a[0] + n[1] * a[1] + n[2] * a[2])
        })
        .collect();
    let centre = to_int([0.517, 0.483, 0.502]);
    let side = |p: [i64; 3], (n, d): &([i64; 3], i64)| {
        (n[0] * p[0] + n[1] * p[1] + n[2] * p[2] - d).signum()
    };
    let inner: Vec<i64> = planes.iter().map(|pl| side(centre, pl)).collect();
    let mut ambiguous = 0;
    let fine = resolution * s;
    for k in 0..resolution {
        for j in 0..resolution {
            for i in 0..resolution {
                let mut count = 0;
                let mut tie = false;
                for fz in k * s..(k + 1) * s {
                    for fy in j * s..(j + 1) * s {
                        for fx in i * s..(i + 1) * s {
                            // Fine centre (f + ½)/64 in units of 2⁻¹⁴ is 256·f + 128.
                            let p = [fx, fy, fz].map(|f| 256 * f as i64 + 128);
                            let sides = planes
                                .iter()
                                .zip(&inner)
                                .map(|(pl, &inside)| side(p, pl) * inside);
                            let min = sides.min().unwrap();
                            count += (min > 0) as u32;
                            tie |= min == 0;
                        }
                    }
                }
                assert!(fine > 0);
                if tie {
                    ambiguous += 1;
                    continue;
                }
                let expected = ((count * 255 + 32) / 64) as f64;
                assert_eq!(v.get(i, j, k), expected, "sample ({i},{j},{k})");
            }
        }
    }
    assert!(
        ambiguous < 10,
        "{ambiguous} samples with a centre exactly on a face"
    );
}

#[test]
fn sphere_volume_and_partial_values_near_the_surface() {
    let (centre, radius) = ([0.3, -1.2, 2.0], 1.7);
    let mesh = icosphere(3, centre, radius);
    let exact = enclosed_volume(&mesh);
    let v = voxelize(&mesh, &opts(48, 3, 2), &no_progress).unwrap();
    let h = v.spacing()[0];
    let data = samples(&v);
    let coverage: f64 = data.iter().map(|&x| x as f64 / 255.0).sum::<f64>() * h * h * h;
    assert!(
        (coverage - exact).abs() / exact < 0.01,
        "coverage {coverage} vs {exact}"
    );
    let inside = data.iter().filter(|&&x| x >= 128).count() as f64 * h * h * h;
    assert!(
        (inside - exact).abs() / exact < 0.03,
        "inside {inside} vs {exact}"
    );

    // Partial values only where the sample's cube can straddle the surface: within half a
    // diagonal (plus the polyhedron's deviation from the sphere) of radius.
    let [nx, ny, nz] = v.dims();
    let o = v.origin();
    let slack = 3f64.sqrt() / 2.0 * h + 0.01 * radius;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let value = data[i + nx * (j + ny * k)];
                let p = [
                    o[0] + i as f64 * h,
                    o[1] + j as f64 * h,
                    o[2] + k as f64 * h,
                ];
                let r = ((p[0] - centre[0]).powi(2)
                    + (p[1] - centre[1]).powi(2)
                    + (p[2] - centre[2]).powi(2))
                .sqrt();
                if value == 0 {
                    assert!(r > radius - slack, "empty sample at r = {r}");
                } else if value == 255 {
                    assert!(r < radius + slack, "full sample at r = {r}");
                } else {
                    assert!((r - radius).abs() < slack, "partial {value} at r = {r}");
                }
            }
        }
    }
}

/// Holes break ray parity only along rays through them; the vote keeps the solid.
#[test]
fn sphere_with_holes_stays_solid() {
    let closed = icosphere(3, [0.0; 3], 1.0);
    let reference = voxelize(&closed, &opts(40, 3, 2), &no_progress).unwrap();
    let reference_inside = samples(&reference).iter().filter(|&&x| x >= 128).count();
    // Remove the fan around one vertex (a small hole) and a band of triangles near the bottom
    // pole (a large hole, about 4 % of the surface).
    let mut open = closed.clone();
    open.triangles.retain(|t| {
        let touches_fan = t.contains(&0);
        let low = t.iter().all(|&i| closed.vertices[i as usize][2] < -0.92);
        !(touches_fan || low)
    });
    let removed = closed.triangles.len() - open.triangles.len();
    assert!(removed > 20, "removed {removed}");
    let v = voxelize(&open, &opts(40, 3, 2), &no_progress).unwrap();
    // Below the rim of the big hole no surface is left at all, so that thin cap is legitimately
    // empty; everywhere else the solid must be unchanged.
    let [nx, ny, _] = v.dims();
    let (o, h) = (v.origin()[2], v.spacing()[2]);
    let mut differing_in_cap = 0;
    let mut differing_elsewhere = 0;
    for (n, (a, b)) in samples(&v).iter().zip(samples(&reference)).enumerate() {
        if (*a >= 128) != (*b >= 128) {
            let z = o + (n / (nx * ny)) as f64 * h;
            if z < -0.92 + h {
                differing_in_cap += 1;
            } else {
                differing_elsewhere += 1;
            }
        }
    }
    // The cap below z = -0.92 holds about πh²(3 − h)/3 ≈ 0.0196 of the unit ball's 4.19.
    assert!(
        (differing_in_cap as f64) < 0.006 * reference_inside as f64,
        "{differing_in_cap} of {reference_inside} inside samples changed in the cap"
    );
    assert!(
        (differing_elsewhere as f64) < 0.0005 * reference_inside as f64,
        "{differing_elsewhere} of {reference_inside} inside samples changed away from the hole"
    );
}

/// A box whose faces fall between fine centres: coverage has a closed form per sample.
#[test]
fn box_coverage_is_exact() {
    let (lo, hi) = ([0.0f32, 0.0, 0.0], [1.0f32, 0.63, 0.41]);
    let c =
        |x: usize, y: usize, z: usize| [[lo[0], hi[0]][x], [lo[1], hi[1]][y], [lo[2], hi[2]][z]];
    let vertices = (0..8)
        .map(|i| c(i & 1, (i >> 1) & 1, (i >> 2) & 1))
        .collect();
    // Faces as quads split in two, both windings mixed on purpose: parity ignores orientation.
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let triangles = quads
        .iter()
        .enumerate()
        .flat_map(|(n, q)| {
            if n % 2 == 0 {
                [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
            } else {
                [[q[0], q[2], q[1]], [q[0], q[3], q[2]]]
            }
        })
        .collect();
    let mesh = TriMesh {
        vertices,
        triangles,
    };
    let (resolution, s, padding) = (24usize, 3usize, 2usize);
    let v = voxelize(&mesh, &opts(resolution, s, padding), &no_progress).unwrap();
    let h = 1.0 / (resolution - 2 * padding) as f64;
    let dims = v.dims();
    assert_eq!(
        dims,
        [
            24,
            (0.63f64 / h).ceil() as usize + 4,
            (0.41f64 / h).ceil() as usize + 4
        ]
    );
    // Fine centres inside [lo, hi] per axis for output index i.
    let inside_per_axis = |i: usize, a: usize| {
        (i * s..(i + 1) * s)
            .filter(|&f| {
                let x = ((f as f64 + 0.5) / s as f64 - padding as f64) * h;
                x > lo[a] as f64 && x < hi[a] as f64
            })
            .count()
    };
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let count = inside_per_axis(i, 0) * inside_per_axis(j, 1) * inside_per_axis(k, 2);
                let expected = ((count * 255 + 13) / 27) as f64;
                assert_eq!(v.get(i, j, k), expected, "({i},{j},{k})");
            }
        }
    }
}

#[test]
fn deterministic_across_thread_counts_and_reports_progress() {
    let mut mesh = icosphere(3, [0.0; 3], 1.0);
    // A second, overlapping and open shell makes the vote do real work.
    let other = icosphere(2, [0.6, 0.1, 0.2], 0.7);
    let base = mesh.vertices.len() as u32;
    mesh.vertices.extend(other.vertices);
    mesh.triangles
        .extend(other.triangles.iter().skip(7).map(|t| t.map(|i| i + base)));
    let run = |threads: usize| {
        let calls = std::sync::Mutex::new(Vec::new());
        let v = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                voxelize(&mesh, &opts(36, 2, 1), &|done, total| {
                    calls.lock().unwrap().push((done, total))
                })
            })
            .unwrap();
        (v, calls.into_inner().unwrap())
    };
    let (one, calls) = run(1);
    let (three, _) = run(3);
    assert_eq!(one, three);
    let nz = one.dims()[2] as u64;
    assert_eq!(calls.first(), Some(&(0, nz)));
    assert_eq!(calls.last(), Some(&(nz, nz)));
    assert!(calls.windows(2).all(|w| w[1].0 == w[0].0 + 1));
}

#[test]
fn supersample_one_is_binary() {
    let mesh = icosphere(2, [0.0; 3], 1.0);
    let v = voxelize(&mesh, &opts(30, 1, 2), &no_progress).unwrap();
    assert!(samples(&v).iter().all(|&x| x == 0 || x == 255));
    assert!(samples(&v).contains(&255));
}

#[test]
fn bad_input_is_rejected() {
    let mesh = icosphere(0, [0.0; 3], 1.0);
    let check = |mesh: &TriMesh, o: VoxelizeOptions, expected: &str| {
        let err = voxelize(mesh, &o, &no_progress).unwrap_err();
        assert!(err.to_string().contains(expected), "{expected}: got {err}");
    };
    check(&mesh, opts(4, 3, 2), "no room");
    check(&mesh, opts(16, 0, 2), "supersample 0");
    check(&mesh, opts(16, 17, 2), "supersample 17");
    check(&mesh, opts(MAX_DIM + 1, 1, 2), "exceeds");
    check(&mesh, opts(200_000, 16, 2), "exceeds");
    check(&TriMesh::default(), opts(16, 3, 2), "no triangles");
    let mut bad = mesh.clone();
    bad.triangles.push([0, 1, 99]);
    check(&bad, opts(16, 3, 2), "beyond the 12 vertices");
    let mut bad = mesh.clone();
    bad.vertices[3][1] = f32::NAN;
    check(&bad, opts(16, 3, 2), "non-finite");
    let point = TriMesh {
        vertices: vec![[1.0; 3]; 3],
        triangles: vec![[0, 1, 2]],
    };
    check(&point, opts(16, 3, 2), "zero extent");
}

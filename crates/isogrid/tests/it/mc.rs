//! Marching Cubes against independent references: brute-force edge enumeration over the grid,
//! mesh topology (watertightness, orientation, Euler characteristic), analytic volumes, and
//! files parsed back by hand.

use isogrid::mc::{
    marching_cubes, marching_cubes_with_slab_planes, try_marching_cubes_with,
    try_marching_cubes_with_progress, Inside, McMesh,
};
use isogrid::{Geometry, Volume, VolumeData, VolumeView};
use std::collections::HashMap;

// ---------------------------------------------------------------- volumes

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        // splitmix64
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

#[derive(Clone, Copy, Debug)]
enum Ty {
    U8,
    U16,
    I16,
    F32,
}
const TYPES: [Ty; 4] = [Ty::U8, Ty::U16, Ty::I16, Ty::F32];

/// A volume whose samples are `f` rounded into type `ty` (saturating).
fn volume(dims: [usize; 3], ty: Ty, mut f: impl FnMut([usize; 3]) -> f64) -> Volume {
    let mut values = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                values.push(f([i, j, k]));
            }
        }
    }
    let data = match ty {
        Ty::U8 => VolumeData::U8(values.iter().map(|&v| v.round() as u8).collect()),
        Ty::U16 => VolumeData::U16(values.iter().map(|&v| v.round() as u16).collect()),
        Ty::I16 => VolumeData::I16(values.iter().map(|&v| v.round() as i16).collect()),
        Ty::F32 => VolumeData::F32(values.iter().map(|&v| v as f32).collect()),
    };
    Volume::new(dims, data).unwrap()
}

fn random_volume(dims: [usize; 3], ty: Ty, levels: u64, seed: u64) -> Volume {
    let mut rng = Rng(seed);
    let offset = if matches!(ty, Ty::I16) { -2.0 } else { 0.0 };
    volume(dims, ty, |_| rng.below(levels) as f64 + offset)
}

fn distance(p: [usize; 3], c: [f64; 3]) -> f64 {
    let d = [p[0] as f64 - c[0], p[1] as f64 - c[1], p[2] as f64 - c[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Higher inside: 100 + 10·(r − |p − c|), so the 100 isosurface is the sphere of radius r.
fn sphere(n: usize, ty: Ty, r: f64) -> Volume {
    let c = (n as f64 - 1.0) / 2.0 + 0.13;
    volume([n, n, n], ty, |p| {
        100.0 + 10.0 * (r - distance(p, [c, c - 0.21, c + 0.07]))
    })
}

fn torus(n: usize, ty: Ty, major: f64, minor: f64) -> Volume {
    let c = (n as f64 - 1.0) / 2.0 + 0.11;
    volume([n, n, n], ty, |p| {
        let (x, y, z) = (p[0] as f64 - c, p[1] as f64 - c, p[2] as f64 - c + 0.23);
        let ring = ((x * x + y * y).sqrt() - major).hypot(z);
        100.0 + 10.0 * (minor - ring)
    })
}

fn two_spheres(ty: Ty) -> Volume {
    volume([40, 24, 22], ty, |p| {
        let a = 8.0 - distance(p, [11.3, 11.6, 10.9]);
        let b = 7.0 - distance(p, [28.6, 11.2, 10.4]);
        100.0 + 10.0 * a.max(b)
    })
}

/// Gyroid clipped to a ball: closed, but with many handles.
fn gyroid_ball(n: usize, ty: Ty) -> Volume {
    let c = (n as f64 - 1.0) / 2.0;
    volume([n, n, n], ty, |p| {
        let s = 0.45;
        let (x, y, z) = (p[0] as f64 * s, p[1] as f64 * s, p[2] as f64 * s);
        let g = x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos();
        let ball = (c - 2.0) - distance(p, [c, c, c]);
        100.0 + 20.0 * g.min(ball * 0.5)
    })
}

/// Random values with every border sample set below the isovalue, so the surface is closed.
fn random_blobs(dims: [usize; 3], ty: Ty, seed: u64) -> Volume {
    let mut rng = Rng(seed);
    volume(dims, ty, |p| {
        let border = (0..3).any(|a| p[a] == 0 || p[a] + 1 == dims[a]);
        let v = rng.below(6) as f64;
        if border {
            0.0
        } else {
            v
        }
    })
}

// ---------------------------------------------------------------- references

/// A crossed edge: lower sample and axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Edge {
    at: [usize; 3],
    axis: usize,
}

fn inside(v: f64, iso: f64, rule: Inside) -> bool {
    match rule {
        Inside::AtOrAbove => v >= iso,
        Inside::Above => v > iso,
    }
}

/// All crossed edges, in the documented vertex order: (k, axis, j, i).
fn crossed_edges(view: &VolumeView, iso: f64, rule: Inside) -> Vec<Edge> {
    let [nx, ny, nz] = view.dims();
    let mut edges = Vec::new();
    for k in 0..nz {
        for axis in 0..3 {
            for j in 0..ny {
                for i in 0..nx {
                    let mut b = [i, j, k];
                    b[axis] += 1;
                    if b[0] >= nx || b[1] >= ny || b[2] >= nz {
                        continue;
                    }
                    let va = view.get(i, j, k);
                    let vb = view.get(b[0], b[1], b[2]);
                    if inside(va, iso, rule) != inside(vb, iso, rule) {
                        edges.push(Edge {
                            at: [i, j, k],
                            axis,
                        });
                    }
                }
            }
        }
    }
    edges
}

/// The documented crossing fraction along an edge from value `va` to `vb`.
fn fraction(va: f64, vb: f64, iso: f64) -> f64 {
    let t = (iso - va) / (vb - va);
    if t.is_nan() {
        0.5
    } else {
        t.clamp(0.0, 1.0)
    }
}

/// The expected vertices: one per crossed edge, except that crossings exactly on a sample are one
/// vertex for every edge meeting there, placed at the first such edge. Each vertex lists its edges.
fn expected_vertices(view: &VolumeView, iso: f64, rule: Inside) -> Vec<Vec<Edge>> {
    let mut vertices: Vec<Vec<Edge>> = Vec::new();
    let mut at_sample: HashMap<[usize; 3], usize> = HashMap::new();
    for e in crossed_edges(view, iso, rule) {
        let mut b = e.at;
        b[e.axis] += 1;
        let t = fraction(
            view.get(e.at[0], e.at[1], e.at[2]),
            view.get(b[0], b[1], b[2]),
            iso,
        );
        let sample = if t == 0.0 {
            Some(e.at)
        } else if t == 1.0 {
            Some(b)
        } else {
            None
        };
        match sample {
            Some(s) => match at_sample.get(&s) {
                Some(&v) => vertices[v].push(e),
                None => {
                    at_sample.insert(s, vertices.len());
                    vertices.push(vec![e]);
                }
            },
            None => vertices.push(vec![e]),
        }
    }
    vertices
}

/// Checks the vertices against [`expected_vertices`]: count, order, each on its (first) edge
/// where the field interpolates to iso; no two vertices at the same position.
fn check_vertices(mesh: &McMesh, view: &VolumeView, iso: f64) -> Vec<Vec<Edge>> {
    check_vertices_with(mesh, view, iso, Inside::AtOrAbove)
}

fn check_vertices_with(mesh: &McMesh, view: &VolumeView, iso: f64, rule: Inside) -> Vec<Vec<Edge>> {
    let vertices = expected_vertices(view, iso, rule);
    assert_eq!(
        mesh.vertex_count(),
        vertices.len(),
        "vertex count != crossed edges (crossings on one sample counted once)"
    );
    let mut seen = HashMap::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        if let Some(w) = seen.insert(p.map(f32::to_bits), v) {
            panic!("vertices {w} and {v} share the position {p:?}");
        }
    }
    let s = view.geometry().spacing;
    for (v, (p, edges)) in mesh.positions.iter().zip(&vertices).enumerate() {
        let e = &edges[0];
        for a in 0..3 {
            let lower = e.at[a] as f64 * s[a];
            if a != e.axis {
                assert_eq!(p[a], lower as f32, "vertex {v} off its edge {e:?}: {p:?}");
            } else {
                let upper = lower + s[a];
                assert!(
                    (p[a] as f64) >= (lower as f32) as f64
                        && (p[a] as f64) <= (upper as f32) as f64,
                    "vertex {v} outside edge {e:?}: {p:?}"
                );
            }
        }
        let mut b = e.at;
        b[e.axis] += 1;
        let va = view.get(e.at[0], e.at[1], e.at[2]);
        let vb = view.get(b[0], b[1], b[2]);
        let t = (p[e.axis] as f64 / s[e.axis]) - e.at[e.axis] as f64;
        if va.is_finite() && vb.is_finite() {
            let f = va + t * (vb - va);
            let tol = 1e-5 * (vb - va).abs() * (1.0 + e.at[e.axis] as f64);
            assert!(
                (f - iso).abs() <= tol,
                "vertex {v} on {e:?}: field {f} != iso {iso}"
            );
        } else {
            // The documented rule for NaN or infinite endpoints.
            let fraction = (iso - va) / (vb - va);
            let expected = if fraction.is_nan() {
                0.5
            } else {
                fraction.clamp(0.0, 1.0)
            };
            assert!(
                (t - expected).abs() < 1e-5,
                "vertex {v} on {e:?} ({va}, {vb}): t {t}"
            );
        }
    }
    vertices
}

/// Checks each triangle uses three distinct vertices of the edges of one cell.
fn check_triangles_are_local(mesh: &McMesh, vertices: &[Vec<Edge>]) {
    let cells = |e: &Edge| -> Vec<[usize; 3]> {
        let mut out = Vec::new();
        let others: Vec<usize> = (0..3).filter(|&a| a != e.axis).collect();
        for d0 in 0..2 {
            for d1 in 0..2 {
                let mut c = e.at;
                let (a0, a1) = (others[0], others[1]);
                if d0 > c[a0] || d1 > c[a1] {
                    continue;
                }
                c[a0] -= d0;
                c[a1] -= d1;
                out.push(c);
            }
        }
        out
    };
    for (n, t) in mesh.triangles.iter().enumerate() {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "triangle {n} repeats an index: {t:?}"
        );
        let sets: Vec<Vec<[usize; 3]>> = t
            .iter()
            .map(|&v| vertices[v as usize].iter().flat_map(cells).collect())
            .collect();
        assert!(
            sets[0]
                .iter()
                .any(|c| sets[1].contains(c) && sets[2].contains(c)),
            "triangle {n} spans several cells"
        );
    }
}

/// How a mesh may be joined at its edges.
#[derive(Clone, Copy, PartialEq)]
enum Joins {
    /// Every directed edge at most once: a manifold, consistently oriented.
    Manifold,
    /// Vertices on samples were merged: where the surface touches itself at such a sample an edge
    /// may be in four triangles, so only the balance of the two directions is required.
    Touching,
}

/// `Touching` when some vertex stands for several crossed edges (a merged crossing on a sample).
fn joins(vertices: &[Vec<Edge>]) -> Joins {
    if vertices.iter().any(|edges| edges.len() > 1) {
        Joins::Touching
    } else {
        Joins::Manifold
    }
}

/// Directed edge counts; for a `Manifold` asserts no directed edge appears twice (consistent
/// orientation).
fn directed_edges(mesh: &McMesh, joins: Joins) -> HashMap<(u32, u32), u32> {
    let mut map = HashMap::new();
    for t in &mesh.triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *map.entry((a, b)).or_insert(0) += 1;
        }
    }
    if joins == Joins::Manifold {
        for (&(a, b), &n) in &map {
            assert_eq!(
                n, 1,
                "directed edge {a}->{b} used {n} times: inconsistent orientation or non-manifold"
            );
        }
    }
    map
}

/// Whether edge a->b is used as often as b->a (closed there, oriented consistently).
fn balanced(map: &HashMap<(u32, u32), u32>, a: u32, b: u32) -> bool {
    map.get(&(a, b)) == map.get(&(b, a))
}

/// A closed, consistently oriented mesh: each directed edge once (with merged vertices: as often
/// as its reverse), with its reverse present, and every vertex of a single edge in a triangle (a
/// merged vertex may be left alone when all its triangles collapsed, e.g. a lone sample at iso).
fn assert_watertight(mesh: &McMesh, vertices: &[Vec<Edge>]) {
    assert!(mesh.triangle_count() > 0);
    let map = directed_edges(mesh, joins(vertices));
    for &(a, b) in map.keys() {
        assert!(
            balanced(&map, a, b),
            "edge {a}-{b} is on a hole or has one orientation"
        );
    }
    let mut used = vec![false; mesh.vertex_count()];
    for t in &mesh.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    assert!(
        used.iter()
            .zip(vertices)
            .all(|(&u, edges)| u || edges.len() > 1),
        "unreferenced vertex in a closed mesh"
    );
}

/// An open mesh from a volume cut by its border: edges in one triangle must lie on the border.
fn assert_manifold_with_border(mesh: &McMesh, view: &VolumeView, joins: Joins) {
    let map = directed_edges(mesh, joins);
    let s = view.geometry().spacing;
    let dims = view.dims();
    let on_border_plane = |p: [f32; 3], a: usize, side: usize| {
        let coord = if side == 0 {
            0.0
        } else {
            ((dims[a] - 1) as f64 * s[a]) as f32
        };
        p[a] == coord
    };
    for &(a, b) in map.keys() {
        if balanced(&map, a, b) {
            continue;
        }
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        let shared = (0..3).any(|ax| {
            (0..2).any(|side| on_border_plane(pa, ax, side) && on_border_plane(pb, ax, side))
        });
        assert!(
            shared,
            "hole away from the volume border at edge {a}-{b}: {pa:?} {pb:?}"
        );
    }
}

fn euler_characteristic(mesh: &McMesh) -> i64 {
    let map = directed_edges(mesh, Joins::Manifold);
    let undirected = map
        .keys()
        .filter(|(a, b)| a < b || !map.contains_key(&(*b, *a)))
        .count();
    mesh.vertex_count() as i64 - undirected as i64 + mesh.triangle_count() as i64
}

/// Volume enclosed (divergence theorem); positive when normals point outward.
fn signed_volume(mesh: &McMesh) -> f64 {
    let p = |v: u32| mesh.positions[v as usize].map(|c| c as f64);
    mesh.triangles
        .iter()
        .map(|t| {
            let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
            let cross = [
                b[1] * c[2] - b[2] * c[1],
                b[2] * c[0] - b[0] * c[2],
                b[0] * c[1] - b[1] * c[0],
            ];
            (a[0] * cross[0] + a[1] * cross[1] + a[2] * cross[2]) / 6.0
        })
        .sum()
}

// ---------------------------------------------------------------- tests

#[test]
fn vertices_are_the_crossed_edges_of_random_volumes() {
    let shapes = [
        [13, 7, 5],
        [2, 9, 11],
        [9, 2, 6],
        [7, 8, 2],
        [64, 3, 3],
        [65, 4, 3],
        [127, 2, 3],
        [129, 3, 2],
        [1, 6, 7],
        [5, 1, 4],
        [1, 1, 9],
        [1, 1, 1],
    ];
    let mut seed = 1;
    for dims in shapes {
        for ty in TYPES {
            for (levels, iso) in [(4, 1.5), (256, 100.25), (3, 1.0)] {
                seed += 1;
                let vol = random_volume(dims, ty, levels, seed);
                let iso = if matches!(ty, Ty::I16) {
                    iso - 2.0
                } else {
                    iso
                };
                let mesh = marching_cubes(&vol.view(), iso);
                let edges = check_vertices(&mesh, &vol.view(), iso);
                check_triangles_are_local(&mesh, &edges);
                assert_manifold_with_border(&mesh, &vol.view(), joins(&edges));
                if dims.contains(&1) {
                    assert_eq!(mesh.triangle_count(), 0, "{dims:?} has no cells");
                }
            }
        }
    }
}

#[test]
fn isovalues_on_sample_values_count_as_inside() {
    for ty in TYPES {
        let vol = random_volume([11, 10, 9], ty, 3, 77);
        let values: &[f64] = if matches!(ty, Ty::I16) {
            &[-2.0, -1.0, 0.0]
        } else {
            &[0.0, 1.0, 2.0]
        };
        for &iso in values {
            let mesh = marching_cubes(&vol.view(), iso);
            let edges = check_vertices(&mesh, &vol.view(), iso);
            check_triangles_are_local(&mesh, &edges);
            assert_manifold_with_border(&mesh, &vol.view(), joins(&edges));
        }
        // The lowest value: everything inside, nothing crossed.
        let lowest = values[0];
        assert_eq!(marching_cubes(&vol.view(), lowest), McMesh::default());
    }
}

fn triangle_area(mesh: &McMesh, t: &[u32; 3]) -> f64 {
    let p = |v: u32| mesh.positions[v as usize].map(|c| c as f64);
    let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
    let (u, w) = (
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    );
    let cross = [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ];
    0.5 * (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt()
}

/// Integer data at an integer isovalue puts crossings exactly on samples, where several crossed
/// edges meet: they must give one vertex there, and no triangle of zero area.
#[test]
fn crossings_on_samples_are_one_vertex_without_degenerate_triangles() {
    // Integer steps of 1 per voxel from 19 at the centre; the border is below 12.
    let ball = |ty| {
        volume([21, 20, 19], ty, |p| {
            (19.0 - distance(p, [10.2, 9.6, 9.1])).round()
        })
    };
    for ty in TYPES {
        let vol = ball(ty);
        for (rule, iso) in [
            (Inside::AtOrAbove, 12.0),
            (Inside::AtOrAbove, 15.0),
            (Inside::Above, 12.0),
            (Inside::Above, 14.0),
        ] {
            let mesh = try_marching_cubes_with(&vol.view(), iso, rule).unwrap();
            let vertices = check_vertices_with(&mesh, &vol.view(), iso, rule);
            assert!(
                vertices.iter().any(|edges| edges.len() > 1),
                "{ty:?} {rule:?} {iso}: no crossing on a sample, the test tests nothing"
            );
            check_triangles_are_local(&mesh, &vertices);
            for t in &mesh.triangles {
                assert!(
                    triangle_area(&mesh, t) > 0.0,
                    "{ty:?} {rule:?} {iso}: zero-area {t:?}"
                );
            }
            // Still closed and consistently oriented.
            assert_watertight(&mesh, &vertices);
        }
    }
}

/// `Inside::Above` (scikit-image's rule) is `Inside::AtOrAbove` just above the isovalue on
/// integer data, and the same on float data away from sample values.
#[test]
fn inside_above_counts_samples_at_the_isovalue_as_outside() {
    for ty in TYPES {
        let vol = random_volume([12, 9, 10], ty, 4, 31);
        let lo = if matches!(ty, Ty::I16) { -2.0 } else { 0.0 };
        for iso in [lo, lo + 1.0, lo + 1.5] {
            let mesh = try_marching_cubes_with(&vol.view(), iso, Inside::Above).unwrap();
            let vertices = check_vertices_with(&mesh, &vol.view(), iso, Inside::Above);
            check_triangles_are_local(&mesh, &vertices);
        }
        let sphere = sphere(20, ty, 6.5);
        let above = try_marching_cubes_with(&sphere.view(), 100.5, Inside::Above).unwrap();
        let at = marching_cubes(&sphere.view(), 100.5);
        if !matches!(ty, Ty::F32) {
            assert_eq!(above, at, "{ty:?}: no sample equals 100.5");
        }
    }
}

#[test]
fn structured_volumes_match_brute_force() {
    for ty in TYPES {
        for (name, vol) in [
            ("sphere", sphere(24, ty, 8.3)),
            ("two spheres", two_spheres(ty)),
            ("gyroid", gyroid_ball(30, ty)),
            ("torus", torus(28, ty, 8.0, 3.2)),
        ] {
            for iso in [100.0, 100.5, 93.7] {
                let mesh = marching_cubes(&vol.view(), iso);
                let edges = check_vertices(&mesh, &vol.view(), iso);
                check_triangles_are_local(&mesh, &edges);
                assert!(mesh.triangle_count() > 0, "{name} {ty:?}");
                assert_watertight(&mesh, &edges);
            }
        }
    }
}

#[test]
fn uniform_volumes_give_empty_meshes() {
    for ty in TYPES {
        let vol = volume([9, 8, 7], ty, |_| 5.0);
        for iso in [4.0, 5.0, 5.5, 1e9, -1e9, f64::NAN, f64::INFINITY] {
            assert_eq!(
                marching_cubes(&vol.view(), iso),
                McMesh::default(),
                "{ty:?} {iso}"
            );
        }
    }
}

#[test]
fn nan_samples_are_outside() {
    let mut rng = Rng(5);
    let values: Vec<f32> = (0..12 * 9 * 7)
        .map(|_| match rng.below(5) {
            0 => f32::NAN,
            1 => f32::INFINITY,
            v => v as f32,
        })
        .collect();
    let vol = Volume::new([12, 9, 7], VolumeData::F32(values)).unwrap();
    for iso in [2.5, 3.0, f64::INFINITY] {
        let mesh = marching_cubes(&vol.view(), iso);
        let edges = check_vertices(&mesh, &vol.view(), iso);
        check_triangles_are_local(&mesh, &edges);
        assert_manifold_with_border(&mesh, &vol.view(), joins(&edges));
    }
}

#[test]
fn random_blobs_are_watertight() {
    let mut seed = 100;
    for dims in [[9, 8, 7], [16, 5, 12], [66, 4, 5], [20, 20, 20]] {
        for ty in TYPES {
            for iso in [1.0, 2.5, 3.0, 5.0] {
                seed += 1;
                let vol = random_blobs(dims, ty, seed);
                let mesh = marching_cubes(&vol.view(), iso);
                let edges = check_vertices(&mesh, &vol.view(), iso);
                check_triangles_are_local(&mesh, &edges);
                assert_watertight(&mesh, &edges);
            }
        }
    }
}

#[test]
fn euler_characteristic_matches_the_topology() {
    for ty in TYPES {
        assert_eq!(
            euler_characteristic(&marching_cubes(&sphere(26, ty, 9.0).view(), 100.0)),
            2
        );
        assert_eq!(
            euler_characteristic(&marching_cubes(&two_spheres(ty).view(), 100.0)),
            4
        );
        assert_eq!(
            euler_characteristic(&marching_cubes(&torus(30, ty, 8.5, 3.5).view(), 100.0)),
            0
        );
    }
}

#[test]
fn normals_point_outward_and_enclose_the_right_volume() {
    let r = 11.0;
    let vol = sphere(32, Ty::F32, r);
    let exact = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    let mesh = marching_cubes(&vol.view(), 100.0);
    let enclosed = signed_volume(&mesh);
    assert!(
        (enclosed - exact).abs() < 0.02 * exact,
        "{enclosed} vs {exact}"
    );

    // Anisotropic spacing scales world positions, and the volume with them.
    let spacing = [0.5, 2.0, 1.25];
    let scaled = vol.clone().with_spacing(spacing).unwrap();
    let mesh_s = marching_cubes(&scaled.view(), 100.0);
    assert_eq!(mesh_s.triangles, mesh.triangles);
    for (p, q) in mesh.positions.iter().zip(&mesh_s.positions) {
        for a in 0..3 {
            assert!((p[a] as f64 * spacing[a] - q[a] as f64).abs() < 1e-4);
        }
    }
    let factor = spacing.iter().product::<f64>();
    assert!((signed_volume(&mesh_s) - enclosed * factor).abs() < 1e-3 * exact);

    // Inverting the field (inside = low values in the original) flips every triangle.
    let inverted = volume([32, 32, 32], Ty::F32, |p| -vol.get(p[0], p[1], p[2]));
    let mesh_i = marching_cubes(&inverted.view(), -100.0 + 1e-3);
    assert!(signed_volume(&mesh_i) < -0.9 * exact);
}

#[test]
fn output_does_not_depend_on_threads_or_slabs() {
    let vols = [
        gyroid_ball(37, Ty::U16),
        random_volume([21, 13, 19], Ty::F32, 7, 9),
    ];
    for vol in &vols {
        let iso = 100.5;
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| marching_cubes(&vol.view(), iso));
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(|| marching_cubes(&vol.view(), iso));
        assert!(one.vertex_count() > 0 || iso > 7.0);
        assert_eq!(bytes(&one), bytes(&three));
        for planes in [1, 2, 3, 5, 64] {
            let split = marching_cubes_with_slab_planes(&vol.view(), iso, planes).unwrap();
            assert_eq!(bytes(&split), bytes(&one), "{planes} planes per slab");
        }
    }
    // Random volumes at a low isovalue exercise every slab border with triangles.
    let vol = &vols[1];
    let base = marching_cubes(&vol.view(), 3.5);
    assert!(base.triangle_count() > 100);
    for planes in [1, 2, 4] {
        let split = marching_cubes_with_slab_planes(&vol.view(), 3.5, planes).unwrap();
        assert_eq!(bytes(&split), bytes(&base));
    }
}

fn bytes(mesh: &McMesh) -> Vec<u8> {
    let mut out = Vec::new();
    for p in &mesh.positions {
        for c in p {
            out.extend_from_slice(&c.to_bits().to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

#[test]
fn view_from_borrowed_samples_matches_owned_volume() {
    let vol = sphere(20, Ty::I16, 6.0);
    let VolumeData::I16(values) = vol.data() else {
        unreachable!()
    };
    let mut geometry = Geometry::new([20, 20, 20]);
    geometry.spacing = [1.0, 1.0, 3.0];
    geometry.origin = [7.0, -3.0, 1.0];
    let view = VolumeView::new(geometry, isogrid::Samples::I16(values)).unwrap();
    let mesh = marching_cubes(&view, 100.0);
    let edges = check_vertices(&mesh, &view, 100.0);
    assert_watertight(&mesh, &edges);
}

/// A path in the system's temporary folder for the file `name` of this process (no folder of
/// its own, so that nothing is left behind once the test removes its files).
fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("isogrid-mc-test-{}-{name}", std::process::id()))
}

/// A hand parser for the binary PLY layout we promise.
fn parse_ply(bytes: &[u8]) -> McMesh {
    let end = b"end_header\n";
    let header_len = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let header = std::str::from_utf8(&bytes[..header_len]).unwrap();
    let lines: Vec<&str> = header.lines().collect();
    assert_eq!(lines[0], "ply");
    assert_eq!(lines[1], "format binary_little_endian 1.0");
    let count = |element: &str| -> usize {
        lines
            .iter()
            .find_map(|l| l.strip_prefix(&format!("element {element} ")))
            .unwrap()
            .parse()
            .unwrap()
    };
    let (nv, nf) = (count("vertex"), count("face"));
    let props: Vec<&str> = lines
        .iter()
        .filter(|l| l.starts_with("property"))
        .copied()
        .collect();
    assert_eq!(
        props,
        [
            "property float x",
            "property float y",
            "property float z",
            "property list uchar uint vertex_indices"
        ]
    );
    let mut body = &bytes[header_len..];
    let mut take = |n: usize| {
        let (a, b) = body.split_at(n);
        body = b;
        a
    };
    let mut mesh = McMesh::default();
    for _ in 0..nv {
        let b = take(12);
        mesh.positions.push(std::array::from_fn(|c| {
            f32::from_le_bytes(b[4 * c..4 * c + 4].try_into().unwrap())
        }));
    }
    for _ in 0..nf {
        assert_eq!(take(1)[0], 3);
        let b = take(12);
        mesh.triangles.push(std::array::from_fn(|c| {
            u32::from_le_bytes(b[4 * c..4 * c + 4].try_into().unwrap())
        }));
    }
    assert!(take(0).is_empty() && body.is_empty(), "trailing bytes");
    mesh
}

fn parse_obj(text: &str) -> McMesh {
    let mut mesh = McMesh::default();
    for line in text.lines() {
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => {
                let p: Vec<f32> = parts.map(|x| x.parse().unwrap()).collect();
                mesh.positions.push([p[0], p[1], p[2]]);
            }
            Some("f") => {
                let f: Vec<u32> = parts.map(|x| x.parse::<u32>().unwrap() - 1).collect();
                mesh.triangles.push([f[0], f[1], f[2]]);
            }
            Some("#") | None => {}
            Some(other) => panic!("unexpected OBJ line {other}"),
        }
    }
    mesh
}

#[test]
fn ply_and_obj_round_trip() {
    let vol = torus(24, Ty::F32, 7.0, 2.5)
        .with_spacing([0.37, 1.1, 0.9])
        .unwrap();
    let mesh = marching_cubes(&vol.view(), 100.3);
    assert!(mesh.triangle_count() > 100);
    let ply = temp_path("torus.ply");
    mesh.write_ply(&ply).unwrap();
    assert_eq!(parse_ply(&std::fs::read(&ply).unwrap()), mesh);
    let obj = temp_path("torus.obj");
    mesh.write_obj(&obj).unwrap();
    let back = parse_obj(&std::fs::read_to_string(&obj).unwrap());
    assert_eq!(bytes(&back), bytes(&mesh));

    let empty = McMesh::default();
    empty.write_ply(&ply).unwrap();
    assert_eq!(parse_ply(&std::fs::read(&ply).unwrap()), empty);
    empty.write_obj(&obj).unwrap();
    assert_eq!(parse_obj(&std::fs::read_to_string(&obj).unwrap()), empty);

    let missing = temp_path("no-such-dir").join("x.ply");
    let err = mesh.write_ply(&missing).unwrap_err();
    assert!(err.to_string().contains("x.ply"), "{err}");
    std::fs::remove_file(&ply).unwrap();
    std::fs::remove_file(&obj).unwrap();
}

#[test]
fn memory_and_snorm16_follow_table_3() {
    let vol = two_spheres(Ty::U8).with_spacing([0.8, 0.8, 1.6]).unwrap();
    let mesh = marching_cubes(&vol.view(), 101.0);
    let (v, t) = (mesh.vertex_count() as u64, mesh.triangle_count() as u64);
    assert!(v > 0 && t > 0);
    assert_eq!(mesh.memory_bytes(), 6 * v + 12 * t);
    let q = mesh.to_snorm16();
    assert_eq!(q.memory_bytes(), mesh.memory_bytes());
    assert_eq!(q.triangles, mesh.triangles);
    assert_eq!(q.positions.len(), mesh.positions.len());
    // Bounds from the positions themselves.
    for a in 0..3 {
        let lo = mesh
            .positions
            .iter()
            .map(|p| p[a])
            .fold(f32::INFINITY, f32::min);
        let hi = mesh
            .positions
            .iter()
            .map(|p| p[a])
            .fold(f32::NEG_INFINITY, f32::max);
        assert!((q.center[a] - 0.5 * (lo + hi)).abs() <= 1e-5 * hi.abs().max(1.0));
        assert!((q.half_extent[a] - 0.5 * (hi - lo)).abs() <= 1e-5 * hi.abs().max(1.0));
        assert!(
            q.positions.iter().any(|p| p[a].abs() == 32767),
            "range not used on axis {a}"
        );
    }
    for (v, p) in mesh.positions.iter().enumerate() {
        let d = q.position(v);
        for a in 0..3 {
            let step = q.half_extent[a] as f64 / 32767.0;
            let err = (d[a] as f64 - p[a] as f64).abs();
            assert!(
                err <= 0.5 * step + 1e-6 * (p[a].abs() as f64 + 1.0),
                "vertex {v} axis {a}: {err} > {step}/2"
            );
            // The documented decode formula.
            let formula = q.center[a] + q.half_extent[a] * (q.positions[v][a] as f32 / 32767.0);
            assert_eq!(d[a], formula);
        }
    }
    assert_eq!(q.decode().len(), mesh.vertex_count());

    // Flat along z: that axis decodes to its single value.
    let flat = McMesh {
        positions: vec![[0.0, 1.0, 5.0], [2.0, -1.0, 5.0]],
        triangles: vec![],
    };
    let qf = flat.to_snorm16();
    assert_eq!(qf.half_extent[2], 0.0);
    assert_eq!(qf.position(0), [0.0, 1.0, 5.0]);
    assert_eq!(qf.position(1), [2.0, -1.0, 5.0]);
    assert_eq!(McMesh::default().to_snorm16().positions.len(), 0);
}

#[test]
fn progress_counts_every_sample_plane_once() {
    let vol = sphere(21, Ty::F32, 7.0);
    let progress = isogrid::Progress::new();
    let mesh =
        try_marching_cubes_with_progress(&vol.view(), 100.0, Inside::AtOrAbove, &progress).unwrap();
    assert_eq!(mesh, marching_cubes(&vol.view(), 100.0));
    assert!(mesh.triangle_count() > 100);
    assert_eq!(progress.counts(), (21, 21));
    // No sample can be inside: the planes count as done all the same.
    let empty = isogrid::Progress::new();
    let mesh =
        try_marching_cubes_with_progress(&vol.view(), f64::NAN, Inside::AtOrAbove, &empty).unwrap();
    assert_eq!((mesh, empty.counts()), (McMesh::default(), (21, 21)));
    // Cancelled, it stops at the next slab (here before the first) with a Cancelled error.
    let cancelled = isogrid::Progress::new();
    cancelled.cancel();
    let err = try_marching_cubes_with_progress(&vol.view(), 100.0, Inside::AtOrAbove, &cancelled)
        .unwrap_err();
    assert_eq!(err.kind(), isogrid::ErrorKind::Cancelled, "{err}");
    assert_eq!(cancelled.counts(), (0, 21));
}

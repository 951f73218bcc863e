"""isogrid.skimage.marching_cubes against scikit-image's own marching_cubes on the same volumes.

What is compared, and why:

* Vertices: both make one vertex per crossed edge (inside is ``value > level`` in both), at the
  same positions within float32 rounding, so every scikit-image vertex is matched to the isogrid
  vertex at its position. Unmatched ones must be the vertices Lewiner's method adds at the centre
  of an ambiguous cell. scikit-image also repeats some edges' vertices (same position, a miss in
  its per-layer cache), and crossings that round onto a sample in float32 share a position in
  both meshes: vertices are therefore compared per distinct position.
* Faces: a cell's surface may be cut into triangles differently (both are valid), so faces are
  compared per cell through their summed area vectors, which do not depend on the triangulation
  of the same boundary loop: equal in every cell that Lewiner's case table does not mark as
  ambiguous (cases 3, 4, 6, 7, 10, 12, 13), where both draw the same loops. Ambiguous cells may
  legitimately differ (Lewiner's asymptotic decider against isogrid's fixed rule) and are counted.
* Normals: both sum, per face, differences along the cell's edges at the ends of the vertex's
  edge; where a cell's polygon is cut into triangles differently the sums differ. On the spheres
  every normal must agree (dot > 0.9); on the random fields, where the field bends within a cell,
  at least 99.5 % (97 % with cells of two samples).
* Values: the largest corner spread of the cells of the faces at a vertex: equal per position.
"""

import base64

import numpy as np
import pytest

import isogrid
from isogrid.skimage import marching_cubes

measure = pytest.importorskip("skimage.measure")
from scipy.spatial import cKDTree  # noqa: E402  (scikit-image depends on SciPy)
from skimage.measure import _marching_cubes_lewiner_luts as luts  # noqa: E402

AMBIGUOUS_CASES = {3, 4, 6, 7, 10, 12, 13}


def lewiner_case_of_cells(volume, level):
    """Lewiner's case number of every cell (scikit-image's corner numbering)."""
    shape, text = luts.CASES
    cases = np.frombuffer(base64.decodebytes(text.encode()), dtype=np.int8).reshape(shape)[:, 0]
    v = np.asarray(volume, dtype=np.float32).astype(np.float64) - level
    a = v > 0
    corners = [
        a[:-1, :-1, :-1], a[:-1, :-1, 1:], a[:-1, 1:, 1:], a[:-1, 1:, :-1],
        a[1:, :-1, :-1], a[1:, :-1, 1:], a[1:, 1:, 1:], a[1:, 1:, :-1],
    ]
    index = sum(c.astype(np.int32) << i for i, c in enumerate(corners))
    return cases[index]


def cell_area_vectors(verts, faces, cell_shape):
    """Sum of the faces' area vectors per cell (the cell holding each face's centroid)."""
    p = verts[faces].astype(np.float64)
    area = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    cell = np.clip(np.floor(p.mean(axis=1)).astype(np.int64), 0, np.array(cell_shape) - 1)
    flat = np.ravel_multi_index(cell.T, cell_shape)
    out = np.zeros((int(np.prod(cell_shape)), 3))
    np.add.at(out, flat, area)
    return out.reshape(tuple(cell_shape) + (3,))


def compare(volume, level=None, normals_agree=0.995, **kw):
    ours = marching_cubes(volume, level, **kw)
    theirs = measure.marching_cubes(volume, level, **kw)
    for name, a, b in zip(("verts", "faces", "normals", "values"), ours, theirs):
        assert a.dtype == b.dtype, f"{name}: {a.dtype} != {b.dtype}"
        assert a.shape[1:] == b.shape[1:], name
    v_ours, f_ours, n_ours, val_ours = ours
    v_sk, f_sk, n_sk, val_sk = theirs
    scale = np.asarray(kw.get("spacing", (1.0, 1.0, 1.0)), dtype=np.float64) * kw.get("step_size", 1)
    idx_ours = v_ours / scale
    idx_sk = v_sk / scale

    # Vertices whose crossing rounds onto a sample in float32 may share a position (in both
    # meshes); group equal positions, then map every scikit-image vertex to the group at its
    # position. scikit-image also repeats some edges' vertices (a miss in its per-layer cache);
    # those land in the same group.
    groups, group_of = np.unique(idx_ours, axis=0, return_inverse=True)
    group_of = group_of.ravel()
    distance, nearest = cKDTree(groups).query(idx_sk)
    on_edge = distance < 1e-4
    centre = idx_sk[~on_edge]
    fractional = np.sum(np.abs(centre - np.round(centre)) > 1e-6, axis=1)
    assert (fractional >= 2).all(), "a scikit-image vertex on an edge has no isogrid vertex"
    mapped = np.bincount(nearest[on_edge], minlength=len(groups))
    assert (mapped >= 1).all(), "an isogrid vertex has no scikit-image vertex"
    sk_idx = np.flatnonzero(on_edge)
    sk_group = nearest[on_edge]
    # Positions: each scikit-image vertex against its group's position.
    np.testing.assert_allclose(idx_sk[sk_idx], groups[sk_group], rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(v_ours, groups[group_of] * scale, rtol=1e-6)
    # Normals: the sum of the group's scikit-image normals against each of ours in the group.
    n_group = np.zeros((len(groups), 3))
    np.add.at(n_group, sk_group, n_sk[sk_idx])
    n_group /= np.linalg.norm(n_group, axis=1, keepdims=True)
    dots = np.einsum("ij,ij->i", n_ours, n_group[group_of])
    # Values: the largest of the group, on both sides.
    v_group_sk = np.zeros(len(groups))
    np.maximum.at(v_group_sk, sk_group, val_sk[sk_idx])
    v_group_ours = np.zeros(len(groups))
    np.maximum.at(v_group_ours, group_of, val_ours)
    np.testing.assert_allclose(v_group_ours, v_group_sk, rtol=1e-5, atol=1e-6)
    distinct_sk = len(np.unique(idx_sk[sk_idx], axis=0)) + int((~on_edge).sum())

    sub = volume[:: kw.get("step_size", 1), :: kw.get("step_size", 1), :: kw.get("step_size", 1)]
    cells = np.array(sub.shape) - 1
    lev = 0.5 * (np.float32(volume.min()) + np.float32(volume.max())) if level is None else level
    ambiguous = np.isin(lewiner_case_of_cells(sub, float(lev)), list(AMBIGUOUS_CASES))
    mask = kw.get("mask")
    if mask is not None:
        step = kw.get("step_size", 1)
        ambiguous &= mask[::step, ::step, ::step][1:, 1:, 1:]
    # Normals: the face sums depend on how each cell's polygon is cut into triangles, which may
    # differ (a vertex on two triangles of a cell in one mesh, on one in the other); where the
    # field bends sharply within a cell that turns a normal. All but a few must agree.
    agree = (dots > 0.9).mean()
    assert agree > normals_agree, f"{(dots <= 0.9).sum()} of {len(dots)} normals disagree"
    a_ours = cell_area_vectors(idx_ours, f_ours, cells)
    a_sk = cell_area_vectors(idx_sk, f_sk, cells)
    plain = ~ambiguous
    np.testing.assert_allclose(a_ours[plain], a_sk[plain], atol=1e-4)
    differing = np.any(np.abs(a_ours - a_sk) > 1e-4, axis=-1)
    return {
        "vertices": (len(groups), distinct_sk),
        "skimage_vertices": len(v_sk),
        "faces": (len(f_ours), len(f_sk)),
        "ambiguous_cells": int(ambiguous.sum()),
        "differing_cells": int(differing.sum()),
        "min_normal_dot": float(dots.min()),
    }


def ball(n=40, centre=(19.3, 20.6, 18.2), radius=13.73):
    """radius − distance; no sample is exactly 0 (then crossings never land on samples)."""
    z, y, x = np.mgrid[:n, :n, :n]
    return radius - np.sqrt((z - centre[0]) ** 2 + (y - centre[1]) ** 2 + (x - centre[2]) ** 2)


def smooth_random_field(shape=(36, 30, 33), seed=7):
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal(shape)
    spectrum = np.fft.fftn(noise)
    k = np.meshgrid(*[np.fft.fftfreq(n) for n in shape], indexing="ij")
    spectrum *= np.exp(-(k[0] ** 2 + k[1] ** 2 + k[2] ** 2) / (2 * 0.06**2))
    return np.real(np.fft.ifftn(spectrum)).astype(np.float32)


def test_sphere_matches_skimage_exactly():
    vol = ball().astype(np.float32)
    assert not (vol == 0).any()
    report = compare(vol, 0.0)
    assert report["min_normal_dot"] > 0.9
    assert report["vertices"][0] == report["vertices"][1]
    assert report["faces"][0] == report["faces"][1]
    assert report["differing_cells"] == 0


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_sphere_float64_with_default_level_and_direction(direction):
    vol = ball() + 3.0  # float64, converted to float32 as scikit-image does
    report = compare(vol, None, gradient_direction=direction)
    assert report["faces"][0] == report["faces"][1]
    assert report["min_normal_dot"] > 0.9


def test_random_smooth_field_differs_only_in_ambiguous_cells():
    vol = smooth_random_field()
    level = float(np.median(vol))
    report = compare(vol, level)
    assert report["vertices"][0] > 1000
    # Every cell that differs is ambiguous (checked in compare); they are few.
    assert report["differing_cells"] <= report["ambiguous_cells"]
    assert report["differing_cells"] < 0.02 * report["faces"][0]


def test_non_cubic_fortran_array_with_spacing_and_step():
    vol = np.asfortranarray(smooth_random_field((41, 23, 30), seed=3))
    level = float(np.percentile(vol, 60))
    compare(vol, level, spacing=(0.5, 2.0, 1.25))
    # Cells twice as large: the field bends more within one, so triangulations matter more.
    compare(vol, level, step_size=2, normals_agree=0.97)


def test_mask():
    vol = ball().astype(np.float32)
    mask = np.zeros(vol.shape, dtype=bool)
    mask[:, :, :21] = True
    mask[5:9] = False
    report = compare(vol, 0.0, mask=mask)
    assert report["faces"][0] == report["faces"][1]


def test_a_small_mask_marches_only_its_bounding_box(monkeypatch):
    """A mask of 6 x 8 x 7 samples in the ball: the marched array is the box of the cells the mask
    allows (cell c where the mask holds at c + 1), not the whole volume, and the mesh is the one
    scikit-image makes."""
    import isogrid.skimage as isk

    vol = ball().astype(np.float32)
    mask = np.zeros(vol.shape, dtype=bool)
    mask[10:16, 4:12, 9:16] = True
    shapes = []
    native = isk._isogrid.marching_cubes

    def recording(array, *args, **kwargs):
        shapes.append(array.shape)
        return native(array, *args, **kwargs)

    monkeypatch.setattr(isk._isogrid, "marching_cubes", recording)
    report = compare(vol, 0.0, mask=mask)
    assert report["faces"][0] == report["faces"][1]
    # Cells 9..14 x 3..10 x 8..14: samples 9..15 x 3..11 x 8..15.
    assert shapes == [(7, 9, 8)]


def test_integer_data_at_an_integer_level():
    """Crossings on samples: scikit-image makes coincident vertices and zero-area faces unless
    allow_degenerate=False; isogrid's mesh is that merged one with either setting."""
    solid = (ball() > 0).astype(np.uint8)
    level = 0
    ours = marching_cubes(solid, level)
    v, f = ours[0], ours[1]
    assert len(np.unique(v, axis=0)) == len(v)
    p = v[f].astype(np.float64)
    assert (np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) > 0).all()
    sk_v, sk_f, _, sk_val = measure.marching_cubes(solid, level, allow_degenerate=False)
    assert len(v) == len(sk_v) and len(f) == len(sk_f)
    order = lambda a: a[np.lexsort(a.T[::-1])]  # noqa: E731
    np.testing.assert_array_equal(order(v), order(sk_v))
    strict = marching_cubes(solid, level, allow_degenerate=False)
    assert strict[1].dtype == sk_f.dtype
    np.testing.assert_array_equal(strict[0], v)
    # scikit-image's default keeps the duplicates: the same distinct positions, more vertices.
    dup_v = measure.marching_cubes(solid, level)[0]
    assert len(dup_v) > len(v) and len(np.unique(dup_v, axis=0)) == len(v)


def test_errors_match_skimage():
    vol = ball(12)
    cases = [
        ((vol[0],), {}),
        ((vol[:1],), {}),
        ((vol, 1e6), {}),
        ((vol, -1e6), {}),
        ((vol, 0.0), {"spacing": (1.0, 2.0)}),
        ((vol, 0.0), {"step_size": 0}),
        ((vol, 0.0), {"method": "other"}),
        ((vol, 0.0), {"gradient_direction": "up"}),
        ((vol, 0.0), {"mask": np.ones((3, 3, 3), bool)}),
        ((vol.tolist(), 0.0), {}),
    ]
    for args, kw in cases:
        with pytest.raises(ValueError) as sk_err:
            measure.marching_cubes(*args, **kw)
        with pytest.raises(ValueError) as our_err:
            marching_cubes(*args, **kw)
        assert str(our_err.value) == str(sk_err.value), (kw, str(our_err.value))
    # A level that no cell crosses (the maximum, with inside = value > level).
    with pytest.raises(RuntimeError, match="No surface found"):
        measure.marching_cubes(vol, float(vol.max()))
    with pytest.raises(RuntimeError, match="No surface found"):
        marching_cubes(vol, float(vol.max()))


def test_reachable_from_the_package():
    assert isogrid.skimage.marching_cubes is marching_cubes

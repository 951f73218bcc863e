"""marching_cubes and voxelize: the (x, y, z) convention, spacing, and argument checks."""

import warnings

import numpy as np
import pytest

import isogrid
from conftest import same_grid, sphere

# A closed unit cube, outward counter-clockwise faces.
CUBE_V = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
    dtype=np.float64,
)
CUBE_F = np.array(
    [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
     [2, 3, 7], [2, 7, 6], [1, 2, 6], [1, 6, 5], [0, 4, 7], [0, 7, 3]],
    dtype=np.int64,
)


def test_marching_cubes_vertices_are_xyz_world_coordinates():
    a = sphere(centre_xyz=(13.0, 11.0, 9.0), radius=6.0)
    v, f = isogrid.marching_cubes(a, iso=0.0, spacing=(1.0, 2.0, 0.5))
    assert v.dtype == np.float32 and v.shape[1] == 3 and f.dtype == np.uint32 and f.shape[1] == 3
    assert f.max() < len(v)
    # Vertices lie on the sphere, centred at (13·1, 11·2, 9·0.5) in world units.
    centre = np.array([13.0, 22.0, 4.5])
    scaled = (v - centre) / np.array([1.0, 2.0, 0.5])
    r = np.linalg.norm(scaled, axis=1)
    assert np.abs(r - 6.0).max() < 0.1
    np.testing.assert_allclose((v.min(0) + v.max(0)) / 2, centre, atol=0.05)


def test_marching_cubes_orders_and_normalised_iso():
    a = sphere(dtype=np.uint8)  # values 0..8: 8 - distance clipped by the cast
    f = np.asfortranarray(a.transpose())
    va, fa = isogrid.marching_cubes(a, iso_normalized=0.5)
    vf, ff = isogrid.marching_cubes(f, iso_normalized=0.5)
    np.testing.assert_array_equal(va, vf)
    np.testing.assert_array_equal(fa, ff)
    with pytest.raises(ValueError, match="exactly one"):
        isogrid.marching_cubes(a)
    with pytest.raises(ValueError, match="3-D"):
        isogrid.marching_cubes(a[0], iso=1)


def test_marching_cubes_faces_point_outward():
    a = sphere(radius=6.6)  # no sample exactly on the surface, so no degenerate triangle
    v, f = isogrid.marching_cubes(a, iso=0.0)
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(p1 - p0, p2 - p0)
    out = (p0 + p1 + p2) / 3 - np.array([13.0, 11.0, 9.0])
    assert (np.einsum("ij,ij->i", n, out) > 0).all()


@pytest.mark.parametrize("name", ["flipped", "oblique"])
def test_marching_cubes_of_a_nifti_is_in_nibabels_world_space(tmp_path, name):
    """Vertices of a NIfTI with a flipped axis (direction -I) and with oblique axes are nibabel's
    affine applied to the index-space vertices, and the faces still point outward."""
    nib = pytest.importorskip("nibabel")
    zooms = np.array([0.8, 1.1, 1.5])
    if name == "flipped":
        rotation = -np.eye(3)
    else:
        a, b = np.radians(25.0), np.radians(-40.0)
        rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
        rotation = rz @ rx
    affine = np.eye(4)
    affine[:3, :3] = rotation * zooms  # column a: the world step of index axis a
    affine[:3, 3] = (90.5, -30.0, 12.25)
    # A ball of radius 6 mm at sample (13, 11, 9), distances measured in mm.
    x, y, z = np.meshgrid(np.arange(28), np.arange(24), np.arange(20), indexing="ij")
    mm = np.stack([(x - 13.0) * zooms[0], (y - 11.0) * zooms[1], (z - 9.0) * zooms[2]])
    data = (6.0 - np.sqrt((mm**2).sum(0))).astype(np.float32)  # > 0 inside, Fortran (x, y, z)
    img = nib.Nifti1Image(data, affine)
    img.set_qform(affine, code=1)
    img.set_sform(affine, code=2)
    nib.save(img, tmp_path / f"{name}.nii.gz")
    vol = isogrid.load_volume(tmp_path / f"{name}.nii.gz")
    world, faces = isogrid.marching_cubes(vol, iso=0.0)
    index, faces_index = isogrid.marching_cubes(vol, iso=0.0, space="index")
    assert len(world) > 100
    np.testing.assert_array_equal(faces_index[:, 0], faces[:, 0])
    expected = nib.affines.apply_affine(nib.load(tmp_path / f"{name}.nii.gz").affine, index.astype(np.float64))
    np.testing.assert_allclose(world, expected, atol=1e-3)
    # Outward: from the ball's centre in world space, every face normal points away.
    centre = nib.affines.apply_affine(affine, (13.0, 11.0, 9.0))
    p0, p1, p2 = (world[faces[:, k]].astype(np.float64) for k in range(3))
    n = np.cross(p1 - p0, p2 - p0)
    assert (np.einsum("ij,ij->i", n, (p0 + p1 + p2) / 3 - centre) > 0).all()
    with pytest.raises(ValueError, match="space must be"):
        isogrid.marching_cubes(vol, iso=0.0, space="voxel")


def test_marching_cubes_vertices_beyond_float32_are_an_error():
    # A finite but huge origin put the vertices at inf.
    vol = isogrid.Volume(sphere(), (1.0, 1.0, 1.0), (1e200, 0.0, 0.0))
    with pytest.raises(ValueError, match="beyond the range of 32-bit floats"):
        isogrid.marching_cubes(vol, iso=0.0)
    # In index space the origin plays no part.
    v, _ = isogrid.marching_cubes(vol, iso=0.0, space="index")
    assert np.isfinite(v).all()


def test_voxelize_cube():
    vol = isogrid.voxelize(CUBE_V * 10, CUBE_F, resolution=24, supersample=1, padding=2)
    assert isinstance(vol, isogrid.Volume)
    assert vol.array.dtype == np.uint8 and vol.array.shape == (24, 24, 24)
    assert vol.spacing == pytest.approx((0.5, 0.5, 0.5))
    solid = vol.array == 255
    # 20 voxels across, padding 2 on each side, fully solid inside.
    assert solid[2:22, 2:22, 2:22].all() and solid.sum() == 20**3
    grid = isogrid.extract(vol, iso_normalized=0.5)
    assert grid.info["spacing"] == pytest.approx((0.5, 0.5, 0.5))


def test_voxelize_axes_follow_xyz():
    box = CUBE_V * np.array([4.0, 2.0, 1.0])  # long in x, short in z
    vol = isogrid.voxelize(box, CUBE_F, resolution=20, supersample=2, padding=0)
    nz, ny, nx = vol.array.shape
    assert (nx, ny, nz) == (20, 10, 5) == vol.dims


def test_voxelize_argument_errors():
    with pytest.raises(ValueError, match="vertices must have shape"):
        isogrid.voxelize(CUBE_V[:, :2], CUBE_F, 16)
    with pytest.raises(ValueError, match="faces must have shape"):
        isogrid.voxelize(CUBE_V, CUBE_F.ravel(), 16)
    with pytest.raises(ValueError, match="faces must be integers"):
        isogrid.voxelize(CUBE_V, CUBE_F.astype(float), 16)
    with pytest.raises(ValueError, match="face indices"):
        isogrid.voxelize(CUBE_V, CUBE_F + 1, 16)
    with pytest.raises(ValueError, match="leaves no room"):
        isogrid.voxelize(CUBE_V, CUBE_F, 4, padding=2)
    with pytest.raises(ValueError, match="supersample 99"):
        isogrid.voxelize(CUBE_V, CUBE_F, 16, supersample=99)
    with pytest.raises(ValueError, match="no triangles"):
        isogrid.voxelize(CUBE_V, np.zeros((0, 3), dtype=np.uint32), 16)


def test_voxelize_cube_gives_every_axis_the_resolution():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 0.5, 0], [0, 0, 0.25]], dtype=np.float32)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.uint32)
    tight = isogrid.voxelize(v, f, resolution=20)
    cube = isogrid.voxelize(v, f, resolution=20, cube=True)
    assert cube.array.shape == (20, 20, 20)
    assert tight.array.shape[2] == 20 and tight.array.shape[0] < 20
    assert int(cube.array.sum(dtype=np.int64)) == int(tight.array.sum(dtype=np.int64))


def test_marching_cubes_merges_crossings_on_samples():
    """Integer data at an integer iso: crossings land exactly on samples, where several crossed
    edges meet. One vertex per such sample, and no zero-area triangle (issue: 48 of them on a
    ball, with duplicate positions). Checked against scikit-image on the complement volume: the
    same crossed edges and the same crossing points, which scikit-image merges only with
    allow_degenerate=False."""
    measure = pytest.importorskip("skimage.measure")
    z, y, x = np.mgrid[:24, :24, :24]
    ball = np.round(9.0 - np.sqrt((x - 11.4) ** 2 + (y - 12.1) ** 2 + (z - 11.7) ** 2)).astype(np.int16)
    iso = 2
    v, f = isogrid.marching_cubes(ball, iso=iso)
    assert len(np.unique(v, axis=0)) == len(v), "duplicate vertex positions"
    p = v[f].astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    assert (area > 0).all(), f"{(area == 0).sum()} zero-area triangles"
    assert np.isin(v, np.arange(24)).all(axis=1).any(), "no vertex on a sample: the test tests nothing"
    # inside = value >= iso here; scikit-image's inside is value > level, so -ball > -iso is
    # exactly our outside: the same crossed edges and crossing points.
    sk_v, sk_f, _, _ = measure.marching_cubes(-ball, -iso, allow_degenerate=False)
    sk_xyz = sk_v[:, ::-1]
    order = lambda a: a[np.lexsort(a.T[::-1])]  # noqa: E731
    assert len(v) == len(sk_v)
    np.testing.assert_allclose(order(v), order(sk_xyz), atol=1e-5)
    assert abs(len(f) - len(sk_f)) <= 0.01 * len(f)


def test_an_empty_mesh_warns_with_the_reason_extract_gives():
    a = sphere()
    lo, hi = float(a.min()), float(a.max())
    for kwargs, why in [(dict(iso=hi + 1), "every sample is below it"), (dict(iso=lo), "at or above it")]:
        with pytest.warns(isogrid.EmptySurfaceWarning, match=why) as by_mesh:
            vertices, faces = isogrid.marching_cubes(a, **kwargs)
        assert len(vertices) == len(faces) == 0
        # Reported at the caller's line, in the words of extract's warning.
        assert by_mesh[0].filename == __file__
        with pytest.warns(isogrid.EmptySurfaceWarning) as by_extract:
            isogrid.extract(a, **kwargs)
        assert str(by_mesh[0].message) == str(by_extract[0].message)
    with pytest.warns(isogrid.EmptySurfaceWarning, match="one sample thick"):
        isogrid.marching_cubes(np.full((1, 5, 6), 9, np.uint8), iso=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(isogrid.marching_cubes(a, iso_normalized=0.5)[1]) > 0

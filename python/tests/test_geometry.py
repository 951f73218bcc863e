"""The volume's origin survives into grids and meshes (files written by nibabel)."""

import numpy as np
import pytest

import isogrid
from conftest import sphere

nib = pytest.importorskip("nibabel")

ORIGIN = (-10.0, 20.0, 30.0)
SPACING = (0.5, 0.75, 2.0)


def nifti_at_origin(tmp_path):
    f = np.asfortranarray(sphere(dtype=np.float32).transpose())  # nibabel's [x, y, z]
    affine = np.diag([*SPACING, 1.0])
    affine[:3, 3] = ORIGIN
    path = tmp_path / "placed.nii.gz"
    nib.save(nib.Nifti1Image(f, affine), path)
    return path


def test_extract_keeps_the_origin_like_the_cli(tmp_path):
    vol = isogrid.load_volume(nifti_at_origin(tmp_path))
    assert vol.origin == ORIGIN
    grid = isogrid.extract(vol, iso=0.0)
    assert grid.info["origin"] == ORIGIN
    assert grid.info["spacing"] == SPACING
    assert grid.info["direction"] == vol.direction
    # Saved and loaded, the .cgc keeps it too.
    grid.save(tmp_path / "g.cgc")
    assert isogrid.load(tmp_path / "g.cgc").info["origin"] == ORIGIN


def test_extract_of_a_bare_array_takes_origin_and_direction(tmp_path):
    vol = isogrid.load_volume(nifti_at_origin(tmp_path))
    flipped = ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    grid = isogrid.extract(vol.array, iso=0.0, spacing=SPACING, origin=ORIGIN, direction=flipped)
    assert grid.info["origin"] == ORIGIN and grid.info["direction"] == flipped
    # The same grid as from the Volume with that geometry; an explicit origin overrides a Volume's.
    placed = isogrid.Volume(vol.array, SPACING, ORIGIN, flipped)
    assert isogrid.extract(placed, iso=0.0).info == grid.info
    assert isogrid.extract(vol, iso=0.0, origin=(1.0, 2.0, 3.0)).info["origin"] == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="origin"):
        isogrid.extract(vol.array, iso=0.0, origin=(1.0, 2.0))


def test_cli_cgc_and_python_grid_agree_on_geometry(cli, tmp_path):
    import subprocess

    path = nifti_at_origin(tmp_path)
    out = tmp_path / "cli.cgc"
    subprocess.run([cli, "extract", str(path), "--iso", "0", "-o", str(out)], check=True, capture_output=True)
    assert isogrid.load(out).info == isogrid.extract(isogrid.load_volume(path), iso=0.0).info


def test_marching_cubes_vertices_are_placed_at_the_origin(tmp_path):
    vol = isogrid.load_volume(nifti_at_origin(tmp_path))
    v, f = isogrid.marching_cubes(vol, iso=0.0)
    bare, bare_f = isogrid.marching_cubes(vol.array, iso=0.0, spacing=vol.spacing)
    np.testing.assert_array_equal(f, bare_f)
    np.testing.assert_allclose(v, bare + np.array(ORIGIN, dtype=np.float32), atol=1e-5)
    # The sphere's centre, sample (13, 11, 9), in world coordinates.
    centre = np.array(ORIGIN) + np.array([13.0, 11.0, 9.0]) * np.array(SPACING)
    np.testing.assert_allclose((v.min(0) + v.max(0)) / 2, centre, atol=0.05)


def test_voxelize_then_marching_cubes_lands_on_the_mesh():
    a = sphere(radius=7.0)
    v, f = isogrid.marching_cubes(isogrid.Volume(a, spacing=(0.5, 0.5, 0.5), origin=(100.0, -50.0, 7.0)), iso=0.0)
    vol = isogrid.voxelize(v, f, resolution=48)
    v2, _ = isogrid.marching_cubes(vol, iso_normalized=0.5)
    # Same box, to within a voxel of the voxelisation.
    tolerance = max(vol.spacing)
    np.testing.assert_allclose(v2.min(0), v.min(0), atol=tolerance)
    np.testing.assert_allclose(v2.max(0), v.max(0), atol=tolerance)

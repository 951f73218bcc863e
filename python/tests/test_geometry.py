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


def _letter_axes(codes):
    """A 3×3 matrix whose columns point along the RAS letters `codes` (e.g. "LIA"), turned 10°
    about z so that the axes are oblique."""
    unit = {"R": (1, 0, 0), "L": (-1, 0, 0), "A": (0, 1, 0), "P": (0, -1, 0), "S": (0, 0, 1), "I": (0, 0, -1)}
    columns = np.array([unit[c] for c in codes], dtype=float).T
    t = np.radians(10)
    turn = np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])
    return turn @ columns


@pytest.mark.parametrize("codes", ["RAS", "LAS", "LIA", "PSR", "ASL"])
def test_info_names_the_axes(cli, tmp_path, codes):
    """The axes' anatomical directions against nibabel's aff2axcodes (NIfTI, MGH) and SimpleITK's
    DICOMOrientImageFilter (MetaImage, LPS), in `info` of the .cgc and of the volume; render, whose
    images show the world as it lies whatever the axes, says nothing about them."""
    import json
    import subprocess

    sitk = pytest.importorskip("SimpleITK")
    affine = np.eye(4)
    affine[:3, :3] = _letter_axes(codes) * [0.9, 1.1, 1.3]
    affine[:3, 3] = (-20.0, 15.0, 5.0)
    f = np.asfortranarray(sphere(shape_zyx=(14, 16, 18), centre_xyz=(8.0, 7.0, 6.0), radius=5.0).transpose())
    nib.save(nib.Nifti1Image(f, affine), tmp_path / "v.nii.gz")
    nib.save(nib.MGHImage(f, affine), tmp_path / "v.mgz")
    sitk.WriteImage(sitk.ReadImage(str(tmp_path / "v.nii.gz")), str(tmp_path / "v.mha"))
    expected = {
        "v.nii.gz": "".join(nib.aff2axcodes(affine)),
        "v.mgz": "".join(nib.aff2axcodes(affine)),
        "v.mha": sitk.DICOMOrientImageFilter.GetOrientationFromDirectionCosines(
            sitk.ReadImage(str(tmp_path / "v.mha")).GetDirection()),
    }
    assert expected["v.nii.gz"] == codes
    for name, axes in expected.items():
        out = tmp_path / f"{name}.cgc"
        subprocess.run([cli, "extract", tmp_path / name, "--iso", "0", "-o", out], check=True, capture_output=True)
        source = json.loads(subprocess.run([cli, "info", out, "--json"], check=True, capture_output=True,
                                           text=True).stdout)["source"]
        assert source["axes"] == axes, name
        assert source["frame"] == ("LPS" if name.endswith("mha") else "RAS")
        assert isogrid.load_volume(tmp_path / name).axes == axes
        assert isogrid.load(out).info["axes"] == axes
        # `info` of the volume file: the same place in the world, and the samples' range.
        volume = json.loads(subprocess.run([cli, "info", tmp_path / name, "--json"], check=True,
                                           capture_output=True, text=True).stdout)
        for key in ("axes", "frame", "spacing", "origin", "direction", "scalar_type"):
            assert volume[key] == source[key], (name, key)
        assert volume["dims"] == [18, 16, 14]
        assert volume["value_range"] == pytest.approx([float(f.min()), float(f.max())])
        for shown in (out, tmp_path / name):
            iso = [] if shown == out else ["--iso", "0"]
            run = subprocess.run([cli, "render", shown, *iso, "--size", "32x24", "--backend", "cpu",
                                  "-o", tmp_path / "x.png"], capture_output=True, text=True)
            assert run.returncode == 0, run.stderr
            assert "mirror" not in run.stderr, (name, run.stderr)


def _lopsided(shape=(18, 16, 14)):
    """An (x, y, z) field > 0 inside a ball with a bump towards +x, +y: no mirror maps it onto
    itself, so a picture of it mirrored shows."""
    x, y, z = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in shape), indexing="ij")
    ball = 5.0 - np.sqrt((x - 8) ** 2 + (y - 7) ** 2 + (z - 6) ** 2)
    bump = 2.5 - np.sqrt((x - 13) ** 2 + (y - 11) ** 2 + (z - 6) ** 2)
    return np.asfortranarray(np.maximum(ball, bump))


@pytest.mark.parametrize("codes", ["LAS", "LIA", "RAS"])
def test_a_volume_is_drawn_as_its_world_lies_whatever_its_axes(tmp_path, codes):
    """The same world stored along mirrored axes (LAS as FSL writes, LIA as FreeSurfer does) and
    as nibabel's as_closest_canonical turns it (RAS: the samples flipped and permuted) draws the
    same picture, on the CPU and on the GPU where there is one: a camera in the first file's
    index × spacing space sees what the same camera, carried into the second's, sees. Drawn
    along its stored axes, the mirrored file would show the world mirrored."""
    affine = np.eye(4)
    affine[:3, :3] = _letter_axes(codes) * [0.9, 1.1, 1.3]
    affine[:3, 3] = (-20.0, 15.0, 5.0)
    stored = nib.Nifti1Image(_lopsided(), affine)
    canonical = nib.as_closest_canonical(stored)
    assert "".join(nib.aff2axcodes(canonical.affine)) == "RAS"
    nib.save(stored, tmp_path / "stored.nii.gz")
    nib.save(canonical, tmp_path / "canonical.nii.gz")
    grids = [isogrid.extract(tmp_path / f"{n}.nii.gz", iso=0) for n in ("stored", "canonical")]
    # Index × spacing of the stored file → of the canonical one: x' = A x + c, A a signed
    # permutation (orthogonal), the mirror when the stored axes are mirrored.
    to_index = np.linalg.inv(canonical.affine) @ stored.affine
    s0, s1 = np.array(stored.header.get_zooms()[:3]), np.array(canonical.header.get_zooms()[:3])
    a = np.diag(s1) @ to_index[:3, :3] @ np.diag(1 / s0)
    c = s1 * to_index[:3, 3]
    np.testing.assert_allclose(a @ a.T, np.eye(3), atol=1e-9)
    assert (np.linalg.det(a) < 0) == (codes != "RAS")
    box = np.array([17 * 0.9, 15 * 1.1, 13 * 1.3])
    target = box / 2
    eye = target + 40 * np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    up = np.array([0.0, 1.0, 0.0])
    cameras = [
        (tuple(eye), tuple(target), tuple(up), 35.0),
        (tuple(a @ eye + c), tuple(a @ target + c), tuple(a @ up), 35.0),
    ]
    backends = ["cpu"]
    try:
        isogrid.render(grids[0], size=(8, 8), backend="gpu")
        backends.append("gpu")
    except ValueError:
        pass
    for backend in backends:
        stored_image, canonical_image = (
            isogrid.render(g, camera=cam, size=(96, 72), backend=backend).astype(int)
            for g, cam in zip(grids, cameras)
        )
        background = (stored_image == stored_image[0, 0]).all(axis=2)
        assert 0.1 < 1 - background.mean() < 0.7, backend
        close = (np.abs(stored_image - canonical_image).max(axis=2) <= 8).mean()
        assert close >= 0.995, (backend, close)
        if codes != "RAS":
            # Its mirror image is another picture.
            mirrored = (np.abs(stored_image[:, ::-1] - canonical_image).max(axis=2) <= 8).mean()
            assert mirrored < 0.97, (backend, mirrored)

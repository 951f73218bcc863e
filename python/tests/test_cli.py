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

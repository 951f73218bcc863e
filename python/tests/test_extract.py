"""isogrid.extract: dtypes, memory orders, shapes, arguments and the axis convention."""

import re
import warnings

import numpy as np
import pytest

import isogrid
from conftest import active_cells_xyz, same_grid, sort_rows, sphere


def test_cell_positions_match_brute_force_in_xyz():
    a = sphere()
    grid = isogrid.extract(a, iso=0.0)
    assert grid.stats["dims"] == (28, 24, 20)  # (nx, ny, nz) = reversed C shape
    np.testing.assert_array_equal(sort_rows(grid.cell_positions()), active_cells_xyz(a, 0.0))
    assert grid.active_cells == len(grid.cell_positions()) == grid.stats["active_cells"]


def test_u8_corner_values_are_the_samples_in_corner_order():
    rng = np.random.default_rng(1)
    a = rng.integers(0, 256, size=(9, 10, 11), dtype=np.uint8)
    grid = isogrid.extract(a, iso=128)
    info = grid.info
    assert info["precision"] == 8 and info["scalar_type"] == "uint8"
    values = info["mapping"]["offset"] + grid.corners().astype(np.float64) * info["mapping"]["step"]
    for (x, y, z), corners in zip(grid.cell_positions(), values):
        expected = [a[z + (c >> 2 & 1), y + (c >> 1 & 1), x + (c & 1)] for c in range(8)]
        np.testing.assert_array_equal(corners, expected)
    inside = grid.corners() >= info["iso_code"]
    assert inside.any(axis=1).all() and not inside.all(axis=1).any()


@pytest.mark.parametrize(
    "dtype",
    [np.uint8, np.uint16, np.int16, np.float32, np.uint32, np.int32, np.uint64, np.int64, np.float64],
)
def test_supported_dtypes_are_kept(dtype):
    a = (sphere() * 10 + 100).astype(dtype)
    grid = isogrid.extract(a, iso=100)
    assert grid.info["scalar_type"] == np.dtype(dtype).name
    np.testing.assert_array_equal(sort_rows(grid.cell_positions()), active_cells_xyz(a, 100))


@pytest.mark.parametrize(
    "dtype, kept",
    [
        (np.int8, "int16"),
        (np.bool_, "uint8"),
        (np.float16, "float32"),
        (">u4", "uint32"),
        (">u2", "uint16"),  # non-native byte order: same type, swapped
        (">f4", "float32"),
    ],
)
def test_other_dtypes_are_converted(dtype, kept):
    # Values 5..110 fit every type; the bool volume is the sphere itself.
    a = sphere() > 0 if dtype is np.bool_ else np.round(sphere() * 5 + 70).astype(dtype)
    iso = 1 if dtype is np.bool_ else 70
    grid = isogrid.extract(a, iso=iso)
    assert grid.info["scalar_type"] == kept
    assert grid.active_cells > 100
    np.testing.assert_array_equal(sort_rows(grid.cell_positions()), active_cells_xyz(a, iso))


@pytest.mark.parametrize("dtype", [np.complex64, object, "U3", "datetime64[s]"])
def test_non_numeric_dtypes_are_refused(dtype):
    a = np.zeros((4, 4, 4), dtype=dtype)
    with pytest.raises(ValueError, match="unsupported sample dtype"):
        isogrid.extract(a, iso=0)


def test_c_array_and_its_fortran_transpose_give_the_same_grid():
    a = sphere(dtype=np.uint8)
    f = np.asfortranarray(a.transpose())
    assert f.flags.f_contiguous and not f.flags.c_contiguous and f.shape == (28, 24, 20)
    ga, gf = isogrid.extract(a, iso=3), isogrid.extract(f, iso=3)
    assert same_grid(ga, gf)
    # A transpose that is not re-laid-out is a Fortran view of the same memory: also the same.
    assert same_grid(ga, isogrid.extract(a.T, iso=3))


def test_fortran_array_is_read_with_x_first():
    """f[x, y, z] in Fortran order: dims are its shape and cells land at (x, y, z)."""
    c = sphere(shape_zyx=(12, 14, 30), centre_xyz=(20.0, 7.0, 5.0), radius=4.0)
    f = np.asfortranarray(c.transpose())
    grid = isogrid.extract(f, iso=0)
    assert grid.stats["dims"] == f.shape == (30, 14, 12)
    np.testing.assert_array_equal(sort_rows(grid.cell_positions()), active_cells_xyz(c, 0))


def test_non_contiguous_arrays_are_copied_in_their_own_order():
    big = sphere(shape_zyx=(20, 48, 28), centre_xyz=(13.0, 22.0, 9.0), radius=9.0)
    view = big[:, ::2, :]  # C-like strides, not contiguous
    assert not view.flags.c_contiguous and not view.flags.f_contiguous
    assert same_grid(isogrid.extract(view, iso=0), isogrid.extract(np.ascontiguousarray(view), iso=0))
    fview = np.asfortranarray(big.transpose())[:, ::2, :]  # Fortran-like strides
    assert not fview.flags.c_contiguous and not fview.flags.f_contiguous
    assert same_grid(isogrid.extract(fview, iso=0), isogrid.extract(np.asfortranarray(fview), iso=0))
    assert same_grid(isogrid.extract(fview, iso=0), isogrid.extract(view, iso=0))


def test_unaligned_array_is_copied():
    a = sphere()
    raw = np.zeros(a.nbytes + 1, dtype=np.uint8)
    unaligned = raw[1:].view(np.float32).reshape(a.shape)
    unaligned[...] = a
    assert not unaligned.flags.aligned
    assert same_grid(isogrid.extract(unaligned, iso=0), isogrid.extract(a, iso=0))


def test_input_is_not_modified_and_lists_work():
    a = sphere(shape_zyx=(6, 7, 8), radius=3.0, centre_xyz=(4, 3, 3))
    before = a.copy()
    grid = isogrid.extract(a, iso=0)
    np.testing.assert_array_equal(a, before)
    # Lists of floats are float64 to numpy, and kept as such.
    assert same_grid(isogrid.extract(a.astype(np.float64), iso=0), isogrid.extract(a.tolist(), iso=0))


@pytest.mark.parametrize("shape", [(10,), (4, 5), (2, 3, 4, 5), ()])
def test_arrays_that_are_not_3d_are_refused(shape):
    with pytest.raises(ValueError, match=f"expected a 3-D array, got {len(shape)} dimension"):
        isogrid.extract(np.zeros(shape, dtype=np.uint8), iso=1)


def test_empty_and_too_small_volumes():
    with pytest.raises(ValueError, match="outside 1..=131072"):
        isogrid.extract(np.zeros((0, 4, 4), dtype=np.uint8), iso=1)
    with pytest.warns(isogrid.EmptySurfaceWarning, match="one sample thick"):
        grid = isogrid.extract(np.zeros((1, 1, 1), dtype=np.uint8), iso=1)
    assert grid.active_cells == 0 and grid.stats["blocks"] == 0 and len(grid.blocks) == 0


def test_an_empty_surface_warns_with_the_reason_and_the_range():
    a = sphere()
    lo, hi = float(a.min()), float(a.max())
    with pytest.warns(isogrid.EmptySurfaceWarning, match="every sample is below it") as caught:
        grid = isogrid.extract(a, iso=hi + 1)
    assert grid.active_cells == 0
    # The range as the samples hold it: f32 values, each printed as the shortest text that is it.
    shown = re.search(r"they lie in \[(\S+), (\S+)\]", str(caught[0].message))
    assert shown and [np.float32(shown[1]), np.float32(shown[2])] == [np.float32(lo), np.float32(hi)]
    assert len(shown[1]) <= 10, shown[1]
    # Reported at the caller's line, not inside the package.
    assert caught[0].filename == __file__
    with pytest.warns(isogrid.EmptySurfaceWarning, match="at or above it"):
        isogrid.extract(a, iso=lo)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert isogrid.extract(a, iso_normalized=0.5).active_cells > 0


def test_iso_arguments():
    a = sphere()
    with pytest.raises(ValueError, match="exactly one of iso and iso_normalized"):
        isogrid.extract(a)
    with pytest.raises(ValueError, match="exactly one of iso and iso_normalized"):
        isogrid.extract(a, iso=0, iso_normalized=0.5)
    with pytest.raises(ValueError, match="outside \\[0, 1\\]"):
        isogrid.extract(a, iso_normalized=1.5)
    with pytest.raises(ValueError, match="not a finite number"):
        isogrid.extract(a, iso=float("nan"))
    lo, hi = float(a.min()), float(a.max())
    g = isogrid.extract(a, iso_normalized=0.25)
    assert g.info["iso"] == pytest.approx(lo + 0.25 * (hi - lo))
    assert g.info["value_range"] == (lo, hi)
    assert isogrid.extract(a, iso=np.float32(0.0)).stats == isogrid.extract(a, 0.0).stats
    with pytest.raises(ValueError, match="no finite sample"):
        isogrid.extract(np.full((3, 3, 3), np.nan, dtype=np.float32), iso_normalized=0.5)


@pytest.mark.parametrize("bits", [4, 8, 16, 32])
def test_precision(bits):
    grid = isogrid.extract(sphere(), iso=0, precision=bits)
    assert grid.info["precision"] == bits == grid.stats["precision"]
    assert grid.cells.shape == (grid.active_cells, bits)  # 8 corners × bits / 8 bytes


@pytest.mark.parametrize("bad", [3, 0, 64, 8.0, "8"])
def test_bad_precision(bad):
    with pytest.raises(ValueError, match="precision must be"):
        isogrid.extract(sphere(), iso=0, precision=bad)


def test_spacing():
    a = sphere()
    grid = isogrid.extract(a, iso=0, spacing=(0.5, 2, 3.25))
    assert grid.info["spacing"] == (0.5, 2.0, 3.25)
    assert grid.info["world_bounds"] == ((0, 0, 0), (27 * 0.5, 23 * 2.0, 19 * 3.25))
    with pytest.raises(ValueError, match="spacing must have 3 values"):
        isogrid.extract(a, iso=0, spacing=(1, 1))
    with pytest.raises(ValueError, match="spacing -1 is not a positive finite number"):
        isogrid.extract(a, iso=0, spacing=(1, -1, 1))


def test_threads_give_identical_grids():
    a = sphere(shape_zyx=(40, 50, 60), centre_xyz=(30, 25, 20), radius=15)
    one = isogrid.extract(a, iso=0, threads=1)
    assert same_grid(one, isogrid.extract(a, iso=0, threads=3))
    assert same_grid(one, isogrid.extract(a, iso=0))
    for bad in (0, -2, 1.5):
        with pytest.raises(ValueError, match="threads must be"):
            isogrid.extract(a, iso=0, threads=bad)


def test_volume_object_supplies_spacing():
    a = sphere()
    vol = isogrid.Volume(a, spacing=(1, 2, 3))
    assert vol.dims == (28, 24, 20)
    assert isogrid.extract(vol, iso=0).info["spacing"] == (1.0, 2.0, 3.0)
    assert isogrid.extract(vol, iso=0, spacing=(4, 4, 4)).info["spacing"] == (4.0, 4.0, 4.0)
    np.testing.assert_array_equal(np.asarray(vol), a)

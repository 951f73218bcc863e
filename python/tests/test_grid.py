"""CellGrid: read-only buffer views that keep the grid alive, stats, save/load and file errors."""

import gc
import json
import weakref

import numpy as np
import pytest

import isogrid
from conftest import same_grid, sphere


@pytest.fixture
def grid():
    return isogrid.extract(sphere(shape_zyx=(40, 36, 34), centre_xyz=(17, 18, 20), radius=14), iso=0)


def test_view_dtypes_and_shapes(grid):
    s = grid.stats
    blocks, metacells, cells = grid.blocks, grid.metacells, grid.cells
    assert blocks.dtype.names == ("metacell_count", "metacell_pointer", "min", "max")
    assert blocks.dtype.itemsize == 16 and len(blocks) == s["blocks"] == 3 * 3 * 3
    assert metacells.dtype.names == ("position", "cell_mask", "cell_pointer")
    assert metacells.dtype.itemsize == 12 and metacells["position"].shape == (s["metacell_slots"], 3)
    assert cells.dtype == np.uint8 and cells.shape == (s["active_cells"], 16)
    assert s["bytes"] == {
        "blocks": blocks.nbytes,
        "metacells": metacells.nbytes,
        "cells": cells.nbytes,
        "paper_total": metacells.nbytes + cells.nbytes,
    }


def test_views_agree_with_each_other(grid):
    """Block slot ranges tile the metacells, and metacell masks count the active cells."""
    blocks, metacells = grid.blocks, grid.metacells
    assert blocks["metacell_count"].sum() == len(metacells)
    assert (blocks["metacell_count"] % 16 == 0).all()
    starts = np.cumsum(np.concatenate([[0], blocks["metacell_count"][:-1]]))
    np.testing.assert_array_equal(blocks["metacell_pointer"], starts)
    real = metacells.reshape(-1, 16)[:, :15].ravel()
    masks = real["cell_mask"].astype(np.int64)
    bits = sum((masks >> b) & 1 for b in range(8))
    assert bits.sum() == grid.active_cells
    occupied = real[masks != 0]
    assert len(occupied) == grid.stats["metacells"]
    # Cell pointers of occupied metacells are the running count of their cells.
    np.testing.assert_array_equal(occupied["cell_pointer"], np.cumsum(np.concatenate([[0], bits[masks != 0][:-1]])))
    # Every active cell lies inside the metacell it was found in.
    pos = grid.cell_positions() // 2
    expanded = np.repeat(occupied["position"], bits[masks != 0], axis=0)
    np.testing.assert_array_equal(pos, expanded)


@pytest.mark.parametrize("name", ["blocks", "metacells", "cells"])
def test_views_are_read_only(grid, name):
    view = getattr(grid, name)
    assert not view.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        view[0] = view[1]
    with pytest.raises(ValueError, match="cannot set WRITEABLE flag"):
        view.flags.writeable = True


@pytest.mark.parametrize("name", ["blocks", "metacells", "cells"])
def test_views_keep_the_grid_alive(name):
    grid = isogrid.extract(sphere(), iso=0)
    expected = getattr(grid, name).copy()
    ref = weakref.ref(grid)
    view = getattr(grid, name)
    del grid
    gc.collect()
    assert ref() is not None  # the view's base chain holds the grid
    np.testing.assert_array_equal(view, expected)
    del view
    gc.collect()
    assert ref() is None  # and lets it go with the view


def test_stats_names_match_the_cli_json(grid):
    s = grid.stats
    assert set(s) == {
        "dims", "iso", "precision", "active_cells", "metacells", "metacell_slots", "clusters",
        "blocks", "nonempty_blocks", "bytes", "bytes_per_cell", "attribute",
    }
    assert s["attribute"] is None
    assert s["clusters"] * 16 == s["metacell_slots"]
    total = s["bytes"]["blocks"] + s["bytes"]["paper_total"]
    assert s["bytes_per_cell"] == pytest.approx(total / s["active_cells"])
    json.dumps(s)  # plain Python values only


def test_save_and_load_round_trip(grid, tmp_path):
    path = tmp_path / "sphere.cgc"
    grid.save(path)
    loaded = isogrid.load(path)
    assert loaded.is_mapped and not grid.is_mapped
    assert same_grid(grid, loaded)
    assert isogrid.load(str(path)).stats == grid.stats
    assert "mapped=True" in repr(loaded)
    # Views of the mapping outlive the CellGrid object.
    cells = loaded.cells
    del loaded
    gc.collect()
    assert cells.tobytes() == grid.cells.tobytes()


def test_save_packed_form(grid, tmp_path):
    """A name ending in .cgcz gets the packed transfer form: the .cgc's header and section table
    as they are after a 56-byte head (version 2), in far fewer bytes; load names it for what it is."""
    path = tmp_path / "sphere.cgcz"
    grid.save(path)
    packed = path.read_bytes()
    whole = grid.to_bytes()
    head = 320 + 32 * int.from_bytes(whole[168:172], "little")
    assert packed[:8] == b"\x89CGZ\r\n\x1a\n"
    assert int.from_bytes(packed[16:24], "little") == len(whole)
    assert int.from_bytes(packed[8:12], "little") == 2
    assert packed[56 : 56 + head] == whole[:head]
    assert len(packed) * 3 < len(whole)
    with pytest.raises(isogrid.IsogridError, match="packed .cgcz"):
        isogrid.load(path)


def test_save_into_missing_folder_raises_oserror(grid, tmp_path):
    with pytest.raises(OSError):
        grid.save(tmp_path / "no" / "such" / "dir" / "x.cgc")


def test_load_errors(tmp_path, grid):
    with pytest.raises(FileNotFoundError) as e:
        isogrid.load(tmp_path / "missing.cgc")
    assert e.value.filename == str(tmp_path / "missing.cgc")
    garbage = tmp_path / "garbage.cgc"
    garbage.write_bytes(b"not a cgc file at all" * 40)
    with pytest.raises(isogrid.IsogridError, match="garbage.cgc"):
        isogrid.load(garbage)
    # A flipped byte in the cells section breaks its checksum.
    good = tmp_path / "good.cgc"
    grid.save(good)
    data = bytearray(good.read_bytes())
    data[-1] ^= 0xFF
    bad = tmp_path / "bad.cgc"
    bad.write_bytes(bytes(data))
    with pytest.raises(isogrid.IsogridError) as e:
        isogrid.load(bad)
    assert isinstance(e.value, ValueError) and "bad.cgc" in str(e.value)
    truncated = tmp_path / "short.cgc"
    truncated.write_bytes(good.read_bytes()[:-100])
    with pytest.raises(isogrid.IsogridError):
        isogrid.load(truncated)


def test_repr_and_info(grid):
    info = grid.info
    assert repr(grid).startswith("CellGrid(dims=(34, 36, 40), iso=0, precision=16")
    assert info["iso_code"] == info["mapping"]["iso_code"]
    assert info["origin"] == (0.0, 0.0, 0.0)
    assert set(info) >= {"dims", "spacing", "iso", "precision", "iso_code", "mapping"}

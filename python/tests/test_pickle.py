"""CellGrid pickles through its .cgc bytes and crosses process boundaries."""

import multiprocessing
import pickle

import numpy as np
import pytest

import isogrid
from conftest import same_grid, sphere


def _grid():
    return isogrid.extract(sphere(dtype=np.float32) * 7, iso=1.5, precision=8)


def test_pickle_round_trip_is_byte_identical(tmp_path):
    grid = _grid()
    back = pickle.loads(pickle.dumps(grid))
    assert isinstance(back, isogrid.CellGrid)
    assert same_grid(back, grid)
    grid.save(tmp_path / "a.cgc")
    back.save(tmp_path / "b.cgc")
    assert (tmp_path / "a.cgc").read_bytes() == (tmp_path / "b.cgc").read_bytes()
    assert back.to_bytes() == (tmp_path / "a.cgc").read_bytes()
    # A memory-mapped grid pickles the same way.
    mapped = isogrid.load(tmp_path / "a.cgc")
    assert mapped.is_mapped
    assert pickle.loads(pickle.dumps(mapped)).to_bytes() == back.to_bytes()


def test_constructor_validates_the_bytes():
    data = _grid().to_bytes()
    assert same_grid(isogrid.CellGrid(data), _grid())
    with pytest.raises(isogrid.IsogridError):
        isogrid.CellGrid(data[: len(data) // 2])
    with pytest.raises(isogrid.IsogridError):
        isogrid.CellGrid(b"not a cgc file at all")


def _summary(grid):
    return grid.active_cells, grid.info["iso"], grid.to_bytes()


def test_grids_cross_a_process_pool():
    grids = [_grid(), isogrid.extract(sphere(dtype=np.uint8), iso=3)]
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(2) as pool:
        results = pool.map(_summary, grids)
    assert results == [_summary(g) for g in grids]

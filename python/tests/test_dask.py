"""isogrid.dask: extraction spread over Dask gives the bytes of the in-process extraction, for dask
arrays with chunks that do not divide 16 and tiles cut along x, y and z, zarr arrays written by zarr-python, Zarr paths, OME-Zarr
0.4 and 0.5 images (levels, indexed t/c axes, transforms; also the CLI's bytes), a LocalCluster of
two worker processes and a worker killed mid-run; its statistics are the CLI's."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

dask = pytest.importorskip("dask")
da = pytest.importorskip("dask.array")
distributed = pytest.importorskip("distributed")
zarr = pytest.importorskip("zarr")

import isogrid  # noqa: E402
import isogrid.dask  # noqa: E402
from conftest import sphere  # noqa: E402

# Shapes that are not multiples of 16, chunks that do not divide 16, and a task budget small
# enough for several tiles and several emit jobs.
SHAPE = (45, 38, 41)
CHUNKS = (7, 11, 13)
TILE_BYTES = 41 * 38 * 4 * 40  # tiles take half: 20 planes of float32
# Tilings: whole block layers (the budget above); boxes of one block for float32 and rows of
# blocks for uint8 (a budget below one layer); 1 x 2 x 1 blocks (z, y, x) given as a shape.
TILINGS = [{"tile_bytes": TILE_BYTES}, {"tile_bytes": 24_000}, {"tile_shape": (16, 32, 16)}]
TILING_IDS = ["layers", "blocks-or-rows", "shape"]


def volume(dtype=np.float32):
    """Two overlapping spheres plus a ripple, (z, y, x)."""
    a = sphere(SHAPE, (20.0, 17.0, 21.0), 12.0, np.float64)
    b = sphere(SHAPE, (30.0, 25.0, 30.0), 9.0, np.float64)
    z = np.arange(SHAPE[0])[:, None, None]
    v = np.maximum(a, b) + 0.5 * np.sin(z * 0.7)
    if np.dtype(dtype).kind == "f":
        return v.astype(dtype)
    return np.clip(v * 8 + 100, 0, 255).astype(dtype)


def in_process_bytes(array, tmp_path, **kwargs):
    path = tmp_path / "reference.cgc"
    isogrid.extract(array, **kwargs).save(path)
    return path.read_bytes()


@pytest.mark.parametrize(
    "dtype,kwargs",
    [
        (np.float32, {"iso": 0.0}),
        (np.uint8, {"iso_normalized": 0.5}),
        (np.float64, {"iso_normalized": 0.4, "precision": 8}),
        (np.int16, {"iso": 101, "precision": 4}),
    ],
    ids=["f32-iso", "u8-normalized", "f64-as-f32", "i16-4bit"],
)
@pytest.mark.parametrize("tiling", TILINGS, ids=TILING_IDS)
def test_dask_array_with_chunks_not_dividing_16_is_byte_identical(tmp_path, dtype, kwargs, tiling):
    a = volume(dtype)
    expected = in_process_bytes(a, tmp_path, spacing=(0.5, 0.75, 2.0), **kwargs)
    out = tmp_path / "dask.cgc"
    stats = isogrid.dask.extract(
        da.from_array(a, chunks=CHUNKS),
        output=out,
        spacing=(0.5, 0.75, 2.0),
        **tiling,
        **kwargs,
    )
    assert out.read_bytes() == expected
    assert stats["active_cells"] > 1000
    assert stats["dims"] == (41, 38, 45)
    assert sorted(os.listdir(tmp_path)) == ["dask.cgc", "reference.cgc"]


@pytest.mark.parametrize("chunks", [(16, 32, 16), (32, 16, 48)], ids=["blocks", "uneven"])
def test_chunks_of_whole_blocks_are_tiled_along_them(tmp_path, chunks):
    a = volume(np.uint8)
    expected = in_process_bytes(a, tmp_path, iso_normalized=0.5)
    # Room for two chunks' samples, not for a whole layer: tiles of whole chunks along y and x.
    isogrid.dask.extract(
        da.from_array(a, chunks=chunks), iso_normalized=0.5, output=tmp_path / "dask.cgc", tile_bytes=40_000
    )
    assert (tmp_path / "dask.cgc").read_bytes() == expected


@pytest.mark.parametrize(
    "dims,chunks,itemsize",
    [
        ((4096, 4096, 4096), ((4096,), (256,) * 16, (16,) * 256), 1),
        ((4096, 4096, 4096), ((128,) * 32,) * 3, 1),
        ((16384, 16384, 300), ((1000,) * 16 + (384,), (1000,) * 16 + (384,), (300,)), 4),
        ((100000, 3, 3), ((100000,), (3,), (3,)), 4),
    ],
    ids=["u8-rows", "u8-cubes", "f32-wide-planes", "long-x"],
)
def test_tiles_stay_within_the_budget_on_any_plane(dims, chunks, itemsize):
    budget = 64 << 20
    tile = isogrid.dask._tile_blocks(dims, chunks, itemsize, budget)
    samples = itemsize
    for n, k in zip(dims, tile):
        samples *= min(16 * k + 1, n)
    assert samples <= budget
    # Near the budget: along each axis the tile is whole, or one more chunk (where chunks are
    # whole blocks) or block would not fit.
    for axis in range(3):
        step = chunks[axis][0] // 16 if chunks[axis][0] % 16 == 0 else 1
        grown = itemsize
        for a, (n, k) in enumerate(zip(dims, tile)):
            grown *= min(16 * (k + step * (a == axis)) + 1, n)
        assert grown > budget or 16 * tile[axis] + 1 >= dims[axis], (axis, tile)
        # Along chunks of whole blocks, tiles are whole chunks.
        assert tile[axis] % step == 0 or 16 * tile[axis] + 1 >= dims[axis], (axis, tile)


def test_block_size_comes_from_the_extension():
    # One rule for the tile geometry: the library's block edge, not a copy in dask.py.
    from isogrid import _isogrid

    assert isogrid.dask.BLOCK_CELLS == _isogrid.BLOCK_CELLS == 16
    grid = isogrid.extract(volume(), iso=0.0)
    assert grid.info["dims"] and len(grid.blocks) == np.prod([-(-(n - 1) // _isogrid.BLOCK_CELLS) for n in SHAPE])


def test_tile_shape_must_be_whole_blocks(tmp_path):
    with pytest.raises(ValueError, match="multiples of 16"):
        isogrid.dask.extract(da.zeros((20, 20, 20)), iso=0.5, output=tmp_path / "out.cgc", tile_shape=(16, 20, 16))
    assert os.listdir(tmp_path) == []


def test_zarr_array_on_disk_and_zarr_path(tmp_path):
    a = volume(np.uint16)
    expected = in_process_bytes(a, tmp_path, iso_normalized=0.5)
    store = tmp_path / "volume.zarr"
    z = zarr.open(str(store), mode="w", shape=a.shape, chunks=CHUNKS, dtype=a.dtype)
    z[...] = a
    opened = zarr.open(str(store), mode="r")
    isogrid.dask.extract(opened, iso_normalized=0.5, output=tmp_path / "array.cgc", tile_bytes=TILE_BYTES)
    isogrid.dask.extract(str(store), iso_normalized=0.5, output=tmp_path / "path.cgc", tile_bytes=TILE_BYTES)
    assert (tmp_path / "array.cgc").read_bytes() == expected
    assert (tmp_path / "path.cgc").read_bytes() == expected


ZARR_FIXTURES = Path(__file__).resolve().parents[2] / "crates" / "isogrid-io" / "tests" / "fixtures" / "zarr"
OME_IMAGES = [("ome_v04.zarr", {"t": 1, "c": 0}), ("ome_v05.zarr", None)]


@pytest.mark.parametrize("level", [0, 1])
@pytest.mark.parametrize("name,index", OME_IMAGES, ids=["0.4-tczyx", "0.5-zyx"])
def test_ome_zarr_image_is_the_load_volume_extraction(tmp_path, name, index, level):
    store = ZARR_FIXTURES / name
    volume = isogrid.load_volume(store, level=level, index=index)
    grid = isogrid.extract(volume, iso_normalized=0.5)
    grid.save(tmp_path / "reference.cgc")
    out = tmp_path / "dask.cgc"
    # A tile budget of one block: many tiles and emit jobs even on these small images.
    isogrid.dask.extract(store, iso_normalized=0.5, level=level, index=index, output=out, tile_bytes=1)
    assert out.read_bytes() == (tmp_path / "reference.cgc").read_bytes()
    # Not the defaults: the transforms reached the file.
    info = isogrid.load(out).info
    assert tuple(info["spacing"]) == pytest.approx(volume.spacing) and tuple(info["spacing"]) != (1.0, 1.0, 1.0)
    assert tuple(info["origin"]) == pytest.approx(volume.origin)


def test_ome_zarr_level_is_the_cli_bytes(tmp_path, cli):
    store = str(ZARR_FIXTURES / "ome_v04.zarr")
    subprocess.run(
        [cli, "extract", store, "--level", "1", "--index", "t=1,c=0", "--iso-normalized", "0.5", "-o", str(tmp_path / "cli.cgc")],
        capture_output=True,
        check=True,
    )
    group = zarr.open_group(store, mode="r")
    isogrid.dask.extract(group, iso_normalized=0.5, level=1, index={"t": 1, "c": 0}, output=tmp_path / "dask.cgc")
    assert (tmp_path / "dask.cgc").read_bytes() == (tmp_path / "cli.cgc").read_bytes()


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"index": {"t": 2, "c": 0}}, {"index": {"z": 0}}, {"level": 2, "index": {"t": 0, "c": 0}}],
    ids=["unindexed", "out-of-range", "spatial", "no-level"],
)
def test_ome_zarr_errors_are_load_volume_errors(tmp_path, kwargs):
    store = ZARR_FIXTURES / "ome_v04.zarr"
    with pytest.raises(ValueError) as expected:
        isogrid.load_volume(store, **kwargs)
    with pytest.raises(ValueError) as got:
        isogrid.dask.extract(str(store), iso=0.5, output=tmp_path / "out.cgc", **kwargs)
    assert str(got.value) == str(expected.value)
    assert os.listdir(tmp_path) == []


def test_level_and_index_need_a_zarr_source(tmp_path):
    with pytest.raises(ValueError, match="level and index pick from a Zarr source"):
        isogrid.dask.extract(da.zeros((20, 20, 20)), iso=0.5, level=1, output=tmp_path / "out.cgc")
    assert os.listdir(tmp_path) == []


@pytest.fixture(scope="module")
def two_workers():
    """A LocalCluster of two single-threaded worker processes, and its client."""
    cluster = distributed.LocalCluster(
        n_workers=2,
        processes=True,
        threads_per_worker=1,
        memory_limit="1GiB",
        dashboard_address=None,
    )
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def test_local_cluster_of_two_processes_is_byte_identical(tmp_path, two_workers):
    a = volume(np.float32)
    expected = in_process_bytes(a, tmp_path, iso_normalized=0.5)
    source = da.from_array(a, chunks=CHUNKS)
    # Given explicitly, and found as the current client.
    with distributed.get_task_stream(two_workers) as tasks:
        isogrid.dask.extract(
            source, iso_normalized=0.5, output=tmp_path / "given.cgc", client=two_workers, tile_bytes=TILE_BYTES
        )
    isogrid.dask.extract(source, iso_normalized=0.5, output=tmp_path / "current.cgc", tile_bytes=TILE_BYTES)
    # Tiles of single blocks, split along x, y and z.
    isogrid.dask.extract(source, iso_normalized=0.5, output=tmp_path / "blocks.cgc", tile_bytes=24_000)
    assert (tmp_path / "given.cgc").read_bytes() == expected
    assert (tmp_path / "current.cgc").read_bytes() == expected
    assert (tmp_path / "blocks.cgc").read_bytes() == expected
    # Both worker processes ran tasks.
    assert len({task["worker"] for task in tasks.data}) == 2


@pytest.mark.parametrize("scheduler", ["client", "threads", "synchronous"])
@pytest.mark.parametrize("dtype, passes", [(np.uint8, 1), (np.int16, 2)], ids=["one-pass", "scan-then-emit"])
def test_each_chunk_is_computed_once_per_pass_with_tiles_along_y_and_x(tmp_path, dtype, passes, scheduler):
    # uint8 corner values are stored as they are, so tiles scan and emit in one pass; int16 ones
    # are quantised from the whole volume's range, so tiles are scanned, then emitted.
    a = volume(np.uint8).astype(dtype)
    expected = in_process_bytes(a, tmp_path, iso=100)
    log = str(tmp_path / "computed")

    def counted(block, block_info=None):
        # A line per computation, appended from whichever worker runs it (tasks are pickled).
        with open(log, "a") as f:
            f.write(f"{block_info[0]['chunk-location']}\n")
        return block

    # Chunks of whole blocks, cut into tiles of 1 x 2 x 1 chunks with halos from the neighbours.
    source = da.from_array(a, chunks=(16, 16, 16)).map_blocks(counted, dtype=a.dtype)
    if scheduler == "client":
        with distributed.Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as c:
            isogrid.dask.extract(source, iso=100, output=tmp_path / "dask.cgc", client=c, tile_shape=(16, 32, 16))
    else:
        # Dask's local scheduler: a pass is one graph there too, its results handed over one by one.
        with dask.config.set(scheduler=scheduler):
            isogrid.dask.extract(source, iso=100, output=tmp_path / "dask.cgc", tile_shape=(16, 32, 16))
    assert (tmp_path / "dask.cgc").read_bytes() == expected
    # Every chunk at least once (the first pass), none more than once per pass.
    computed = open(log).read().split("\n")[:-1]
    counts = {loc: computed.count(loc) for loc in set(computed)}
    assert len(counts) == source.npartitions
    assert max(counts.values()) == passes, counts


@pytest.mark.parametrize("dtype, iso", [(np.float32, 0.0), (np.uint8, 100)], ids=["scan-then-emit", "one-pass"])
def test_an_array_persisted_on_the_cluster_gives_the_same_bytes(tmp_path, dtype, iso):
    # A persisted array's chunks are futures, and the tile tasks got their names (tuples) in place
    # of the samples: AttributeError "'tuple' object has no attribute 'dtype'".
    a = volume(dtype)
    expected = in_process_bytes(a, tmp_path, iso=iso)
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as c:
        source = c.persist(da.from_array(a, chunks=CHUNKS))
        isogrid.dask.extract(source, iso=iso, output=tmp_path / "persisted.cgc", client=c, tile_bytes=TILE_BYTES)
        # And a view of it, whose chunks are tasks over the futures.
        isogrid.dask.extract(source[:, :, :], iso=iso, output=tmp_path / "view.cgc", client=c, tile_bytes=TILE_BYTES)
    assert (tmp_path / "persisted.cgc").read_bytes() == expected
    assert (tmp_path / "view.cgc").read_bytes() == expected


@pytest.mark.parametrize("dtype, iso", [(np.float32, 0.0), (np.uint8, 100)], ids=["scan-then-emit", "one-pass"])
def test_a_worker_killed_mid_run_changes_nothing(tmp_path, two_workers, dtype, iso):
    a = volume(np.float32) if dtype == np.float32 else volume(np.uint8)
    expected = in_process_bytes(a, tmp_path, iso=iso)
    marker = str(tmp_path / "killed")

    def kill_once(block, block_info=None):
        # The first time chunk (3, 1, 1) is computed, its worker process dies without a word.
        if block_info[0]["chunk-location"] == (3, 1, 1):
            try:
                os.close(os.open(marker, os.O_CREAT | os.O_EXCL))
            except FileExistsError:
                return block
            os.kill(os.getpid(), signal.SIGKILL)
        return block

    killing = da.from_array(a, chunks=CHUNKS).map_blocks(kill_once, dtype=a.dtype)
    out = tmp_path / "killed.cgc"
    isogrid.dask.extract(killing, iso=iso, output=out, client=two_workers, tile_bytes=TILE_BYTES)
    assert os.path.exists(marker), "no worker was killed"
    assert out.read_bytes() == expected


def test_stats_are_the_cli_json_figures(tmp_path, cli):
    a = volume(np.uint8)
    np.save(tmp_path / "v.npy", a)
    run = subprocess.run(
        [cli, "extract", str(tmp_path / "v.npy"), "--iso-normalized", "0.5", "--json", "-o", str(tmp_path / "cli.cgc")],
        capture_output=True,
        text=True,
        check=True,
    )
    expected = json.loads(run.stdout)
    stats = isogrid.dask.extract(
        da.from_array(a, chunks=CHUNKS), iso_normalized=0.5, output=tmp_path / "dask.cgc", tile_bytes=TILE_BYTES
    )
    assert set(stats["seconds"]) == {"read", "extract", "write"}
    del stats["seconds"], expected["seconds"]
    expected["dims"] = tuple(expected["dims"])
    assert stats == expected
    assert (tmp_path / "dask.cgc").read_bytes() == (tmp_path / "cli.cgc").read_bytes()


@pytest.mark.parametrize(
    "source,message",
    [
        (da.zeros((4, 20, 20, 20), chunks=10), "expected a 3-D array"),
        (da.from_array(np.full((20, 20, 20), "a")), "unsupported sample dtype"),
        (da.zeros((20, 20, 20), dtype=np.complex64), "unsupported sample dtype"),
    ],
    ids=["4-D", "strings", "complex"],
)
def test_bad_input_gets_a_clear_error_and_no_file(tmp_path, source, message):
    out = tmp_path / "out.cgc"
    if isinstance(source, str):
        source = str(tmp_path / source)
    with pytest.raises(ValueError, match=message):
        isogrid.dask.extract(source, iso=0.5, output=out)
    assert os.listdir(tmp_path) == []


def test_a_missing_path_and_an_empty_surface_are_reported_as_extract_reports_them(tmp_path):
    # A missing store: FileNotFoundError, as load_volume (and so extract) gives, not ValueError.
    missing = tmp_path / "no-such.zarr"
    with pytest.raises(FileNotFoundError):
        isogrid.load_volume(missing)
    with pytest.raises(FileNotFoundError, match="no-such.zarr"):
        isogrid.dask.extract(missing, iso=0.5, output=tmp_path / "out.cgc")
    assert os.listdir(tmp_path) == []
    # An isovalue above every sample: the same EmptySurfaceWarning as extract.
    a = volume()
    with pytest.warns(isogrid.EmptySurfaceWarning) as by_extract:
        isogrid.extract(a, iso=1000.0)
    with pytest.warns(isogrid.EmptySurfaceWarning) as by_dask:
        stats = isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), iso=1000.0, output=tmp_path / "e.cgc")
    assert stats["active_cells"] == 0
    assert str(by_dask[0].message) == str(by_extract[0].message)
    assert "every sample is below it" in str(by_dask[0].message)


def test_a_task_failing_while_the_file_is_written_leaves_no_file(tmp_path):
    a = volume(np.float32)
    marker = str(tmp_path.parent / f"{tmp_path.name}-scanned")

    def fail_second_time(block, block_info=None):
        # Chunk (0, 0, 0) lies in the first tile only: its first computation is the scan, its
        # second the emit job, by when the output file is being written.
        if block_info[0]["chunk-location"] == (0, 0, 0):
            if os.path.exists(marker):
                raise RuntimeError("the store went away")
            open(marker, "w").close()
        return block

    source = da.from_array(a, chunks=CHUNKS).map_blocks(fail_second_time, dtype=a.dtype)
    out = tmp_path / "out.cgc"
    with pytest.raises(RuntimeError, match="the store went away"):
        isogrid.dask.extract(source, iso=0.0, output=out, tile_bytes=TILE_BYTES)
    assert os.path.exists(marker)
    assert os.listdir(tmp_path) == []


def test_a_task_failing_after_one_pass_tiles_were_spooled_leaves_no_file(tmp_path):
    # uint8 at iso=100 is one pass: the tiles before the failing one have their output in the
    # scratch file beside the output when the run fails.
    a = volume(np.uint8)
    last = tuple(-(-n // c) - 1 for n, c in zip(a.shape, CHUNKS))

    def fail_last(block, block_info=None):
        if block_info[0]["chunk-location"] == last:
            raise RuntimeError("the store went away")
        return block

    source = da.from_array(a, chunks=CHUNKS).map_blocks(fail_last, dtype=a.dtype)
    out = tmp_path / "out.cgc"
    with pytest.raises(RuntimeError, match="the store went away"):
        isogrid.dask.extract(source, iso=100, output=out, tile_shape=(16, 16, 16))
    assert os.listdir(tmp_path) == []


def test_a_local_process_pool_runs_in_windows_and_gives_the_same_bytes(tmp_path):
    # The processes scheduler's tasks cannot hand results to the driver's queue: windows of tasks.
    a = volume(np.uint8)
    expected = in_process_bytes(a, tmp_path, iso=100)
    source = da.from_array(a, chunks=CHUNKS)
    with dask.config.set(scheduler="processes", num_workers=2):
        isogrid.dask.extract(source, iso=100, output=tmp_path / "dask.cgc", tile_shape=(16, 16, 16))
    assert (tmp_path / "dask.cgc").read_bytes() == expected


def test_the_driver_stopping_ends_a_local_pass(tmp_path):
    # A refused fragment stops the driver mid-pass: the tasks still running must stop at their
    # hand-over instead of waiting for room in the queue forever.
    runner = isogrid.dask._Runner(None)
    runner.window = 1
    tasks = [dask.delayed(bytes)(1000 + n) for n in range(20)]
    results = runner.as_completed(tasks)
    assert len(next(results)) >= 1000
    results.close()  # joins the pass's thread: returns only if the pass ended
    assert not any(t.name == "isogrid-dask-pass" for t in threading.enumerate())


def test_an_attribute_gives_the_bytes_of_extract_with_it(tmp_path):
    """``attribute=`` as a path (read by region in the driver) and as an array: the file is
    ``isogrid.extract(..., attribute=...)``'s, byte for byte, and a bad one leaves no file."""
    a = volume(np.uint16)
    field = (volume(np.float32) * 3.0 + np.arange(SHAPE[2], dtype=np.float32)).astype(np.float32)
    np.save(tmp_path / "field.npy", field)
    store = tmp_path / "volume.zarr"
    z = zarr.open(str(store), mode="w", shape=a.shape, chunks=CHUNKS, dtype=a.dtype)
    z[...] = a
    for attribute, name in [(tmp_path / "field.npy", "path"), (field, "array")]:
        expected = in_process_bytes(a, tmp_path, iso_normalized=0.5, attribute=attribute)
        out = tmp_path / f"{name}.cgc"
        stats = isogrid.dask.extract(str(store), iso_normalized=0.5, output=out, tile_bytes=TILE_BYTES,
                                     attribute=attribute)
        assert out.read_bytes() == expected, name
        assert stats["attribute"] == isogrid.load(out).stats["attribute"] != None  # noqa: E711
    with pytest.raises(ValueError, match="surface's samples"):
        isogrid.dask.extract(str(store), iso_normalized=0.5, output=tmp_path / "bad.cgc",
                             attribute=np.zeros((3, 3, 3), np.float32))
    assert not (tmp_path / "bad.cgc").exists()
    # One channel of a (c, z, y, x) Zarr as the attribute: attribute_index picks it, as
    # extract's does, and an attribute without it fails naming the argument.
    channels = tmp_path / "channels.zarr"
    zc = zarr.open(str(channels), mode="w", shape=(2, *a.shape), chunks=(1, *CHUNKS), dtype=np.float32,
                   dimension_names=["c", "z", "y", "x"], zarr_format=3)
    zc[0], zc[1] = field, -field
    expected = isogrid.extract(a, iso_normalized=0.5, attribute=channels, attribute_index={"c": 1})
    assert expected.attribute_info["name"] == "channels.zarr c=1"
    np.testing.assert_array_equal(
        expected.attribute, isogrid.extract(a, iso_normalized=0.5, attribute=-field).attribute
    )
    out = tmp_path / "channel.cgc"
    isogrid.dask.extract(str(store), iso_normalized=0.5, output=out, tile_bytes=TILE_BYTES,
                         attribute=channels, attribute_index={"c": 1})
    assert out.read_bytes() == expected.to_bytes()
    with pytest.raises(ValueError, match=r'with attribute_index=, e.g. attribute_index=\{"c": 0\}'):
        isogrid.dask.extract(str(store), iso_normalized=0.5, output=tmp_path / "bad.cgc", attribute=channels)
    assert not (tmp_path / "bad.cgc").exists()
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".")]


class Stop(Exception):
    pass


def counting_tasks(monkeypatch):
    """Counts the tile tasks (one-pass tiles, scans and emit jobs) that run, on dask's scheduler in
    this process (a cluster another test left as the current client would run them elsewhere)."""
    import functools

    monkeypatch.setattr(isogrid.dask, "_client", lambda client: None)
    monkeypatch.setitem(dask.config.config, "scheduler", "threads")
    ran = []
    for name in ("_extract", "_emit", "_scan"):
        task = getattr(isogrid.dask, name)

        def counted(*args, _task=task, _name=name):
            ran.append(_name)
            return _task(*args)

        monkeypatch.setattr(isogrid.dask, name, functools.wraps(task)(counted))
    return ran


@pytest.mark.parametrize("dtype,kwargs", [(np.uint8, {"iso": 100}), (np.float32, {"iso": 0.0})])
def test_progress_counts_every_task_and_an_exception_in_it_stops_the_run(tmp_path, monkeypatch, dtype, kwargs):
    # 45 x 38 x 41 samples in tiles of one block: 3 x 3 x 3 = 27 tiles, then (float32: the
    # quantiser waits for the range) one emit job per tile with cells.
    a = volume(dtype)
    source = da.from_array(a, chunks=CHUNKS)
    ran = counting_tasks(monkeypatch)
    calls = []
    out = tmp_path / "out.cgc"
    isogrid.dask.extract(source, **kwargs, output=out, tile_shape=(16, 16, 16),
                         progress=lambda done, total: calls.append((done, total)))
    assert out.read_bytes() == in_process_bytes(a, tmp_path, **kwargs)
    assert [d for d, _ in calls] == list(range(1, len(ran) + 1))
    assert calls[26][1] == 27 and calls[-1][1] == len(ran)
    emits = ran.count("_emit")
    assert (emits == 0) == (dtype == np.uint8)
    os.remove(out)
    os.remove(tmp_path / "reference.cgc")

    # Stopped (as Ctrl-C stops it: KeyboardInterrupt comes out of the same call) after 3 tasks,
    # in the tile pass and in the emit pass: the rest of the tasks do not run, and nothing is left.
    for stop_at, error in [(3, Stop), (3, KeyboardInterrupt), (29, Stop)]:
        if stop_at > 27 and dtype == np.uint8:
            continue
        ran.clear()

        def stop(done, total, stop_at=stop_at, error=error):
            if done == stop_at:
                raise error(f"stopped at {done} of {total}")

        with pytest.raises(error, match=f"stopped at {stop_at} of"):
            isogrid.dask.extract(source, **kwargs, output=out, tile_shape=(16, 16, 16), progress=stop)
        # Tasks already handed out finish; the local pass holds at most a window of results.
        window = 2 * (os.cpu_count() or 1)
        assert len(ran) < 27 + emits and len(ran) <= stop_at + 2 * window + 2, (stop_at, len(ran))
        assert os.listdir(tmp_path) == [], os.listdir(tmp_path)
    with pytest.raises(ValueError, match="callable"):
        isogrid.dask.extract(source, **kwargs, output=out, progress=3)


def test_ctrl_c_stops_a_run_and_leaves_no_file(tmp_path):
    # A real SIGINT to a process running a long extraction (4096 one-block tiles): it ends with
    # KeyboardInterrupt soon after, and the output folder is empty.
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    script = f"""
import sys, numpy as np, dask, dask.array as da, isogrid.dask
x = np.linspace(-1, 1, 257, dtype=np.float32)
a = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)
def started(done, total):
    if done == 1:
        print("started", flush=True)
with dask.config.set(scheduler="threads"):
    isogrid.dask.extract(da.from_array(a, chunks=64), iso=0.5, output={str(out_dir / 'out.cgc')!r},
                         tile_shape=(16, 16, 16), progress=started)
print("finished", flush=True)
"""
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    assert child.stdout.readline().strip() == "started"
    sent = time.perf_counter()
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=60)
    latency = time.perf_counter() - sent
    assert child.returncode != 0 and "finished" not in stdout, stderr
    assert "KeyboardInterrupt" in stderr, stderr
    assert latency < 10, latency
    assert os.listdir(out_dir) == []


def label_volume():
    """Touching labels (z, y, x), uint32: blocky supervoxels whose boundaries shift with z, a ball
    across them, and background 0, on a shape that is not whole blocks."""
    z, y, x = np.meshgrid(*(np.arange(n) for n in (70, 38, 41)), indexing="ij")
    v = (1 + x // 9 + 10 * (y // 7) + 100 * ((z + (x * y) % 5) // 11)).astype(np.uint32)
    ball = (z - 35) ** 2 + (y - 19) ** 2 + (x - 20) ** 2 < 12**2
    v[ball] = 5000
    v[(x + y + z) % 17 == 0] = 0
    return v


@pytest.mark.parametrize("smooth", [None, 1.0], ids=["binary", "smoothed"])
# 1 byte: runs of block rows, each task stopping at its output cap; 40 planes' bytes: runs of one
# block row (a layer's 17 planes exceed a task's quarter); 140 planes' bytes: slabs of two block
# layers; 1 GiB: the whole volume in one slab.
@pytest.mark.parametrize(
    "tile_bytes",
    [1, 41 * 38 * 4 * 40, 41 * 38 * 4 * 140, 1 << 30],
    ids=["capped-row-runs", "row-runs", "two-layer-slabs", "whole"],
)
def test_labels_are_byte_identical_to_in_memory(tmp_path, smooth, tile_bytes):
    a = label_volume()
    kwargs = {"labels": "all"} if smooth is None else {"labels": "all", "smooth": smooth}
    expected = in_process_bytes(a, tmp_path, spacing=(0.5, 0.75, 2.0), **kwargs)
    out = tmp_path / "dask.cgc"
    stats = isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), output=out, spacing=(0.5, 0.75, 2.0),
                                 tile_bytes=tile_bytes, **kwargs)
    assert out.read_bytes() == expected
    grid = isogrid.load(out)
    assert stats["labels"] == grid.labels and len(stats["labels"]) > 50
    assert stats["active_cells"] == grid.stats["active_cells"]
    assert sorted(os.listdir(tmp_path)) == ["dask.cgc", "reference.cgc"]


@pytest.mark.parametrize("smooth", [None, 1.0], ids=["binary", "smoothed"])
def test_labels_are_the_bytes_the_cli_streams(tmp_path, cli, smooth):
    # The CLI streams a raw file (read by region) slab by slab within --max-memory.
    a = label_volume()
    raw = tmp_path / "labels.raw"
    a.tofile(raw)
    cmd = [cli, "extract", str(raw), "--raw-shape", "41,38,70", "--raw-type", "u32", "--labels", "all",
           "--max-memory", "60M", "-o", str(tmp_path / "cli.cgc")]
    kwargs = {"labels": "all"}
    if smooth is not None:
        cmd += ["--smooth", str(smooth)]
        kwargs["smooth"] = smooth
    subprocess.run(cmd, capture_output=True, check=True)
    isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), output=tmp_path / "dask.cgc", tile_bytes=1, **kwargs)
    assert (tmp_path / "cli.cgc").read_bytes() == (tmp_path / "dask.cgc").read_bytes()


def test_labels_take_a_selection_and_a_colour_table_as_extract_does(tmp_path):
    a = label_volume()
    table = tmp_path / "table.txt"
    table.write_text("5000 Ball 10 20 30 0\n11 Block 1 2 3 0\n77777 Absent 1 1 1 0\n")
    # 77777 is selected and absent: a notice. (A label of the table left out of the selection is
    # not news: below, 11 alone.)
    with pytest.warns(UserWarning, match="1 label of the table is not among"):
        expected = in_process_bytes(a, tmp_path, labels=[11, 5000, 12, 77777], label_table=table)
    out = tmp_path / "dask.cgc"
    with pytest.warns(UserWarning, match="1 label of the table is not among"):
        stats = isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), output=out, labels=[11, 5000, 12, 77777],
                                     label_table=table, tile_bytes=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), output=tmp_path / "one.cgc", labels=[11],
                             label_table=table, tile_bytes=1)
    assert out.read_bytes() == expected
    assert [(l["value"], l["name"]) for l in stats["labels"]] == [(11, "Block"), (12, "label 12"), (5000, "Ball")]
    with pytest.raises(ValueError, match="labels takes the place"):
        isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), output=out, labels="all", iso=3)
    with pytest.raises(ValueError, match="need it"):
        isogrid.dask.extract(da.from_array(a, chunks=CHUNKS), output=out, iso=3, smooth=1.0)


def test_label_progress_counts_blocks_and_a_stop_leaves_no_file(tmp_path):
    a = label_volume()
    source = da.from_array(a, chunks=CHUNKS)
    calls = []
    out = tmp_path / "out.cgc"
    # 3 x 3 x 5 blocks; the whole volume in one slab, so one call.
    isogrid.dask.extract(source, labels="all", output=out, tile_bytes=1 << 30,
                         progress=lambda done, total: calls.append((done, total)))
    assert calls == [(45, 45)]
    os.remove(out)
    # One block layer a slab and no room for output: each task covers one run (a block per
    # thread) and leaves the rest of its layer to the next round; every block is counted once.
    calls.clear()
    isogrid.dask.extract(source, labels="all", output=out, tile_bytes=1,
                         progress=lambda done, total: calls.append((done, total)))
    assert len(calls) > 5 and {t for _, t in calls} == {45}, calls
    assert [d for d, _ in calls] == sorted(d for d, _ in calls) and calls[-1] == (45, 45), calls
    os.remove(out)
    # Two σ: the runs' tasks have other keys, so that a client from an earlier test does not
    # hand the second run the first one's cancelled futures.
    for error, smooth in ((Stop, 1.0), (KeyboardInterrupt, 0.5)):
        seen = []

        def stop(done, total, error=error, seen=seen):
            seen.append(done)
            if len(seen) == 2:
                raise error(f"stopped at {done} of {total}")

        with pytest.raises(error, match="stopped at [0-9]+ of 45"):
            isogrid.dask.extract(source, labels="all", smooth=smooth, output=out, tile_bytes=1, progress=stop)
        assert os.listdir(tmp_path) == [], os.listdir(tmp_path)


def test_a_label_slab_task_stops_on_its_flag():
    # A label slab task watches the flag its run gives it (the run's own, or on a cluster the one
    # its watcher sets): cancelled before it starts it raises at once, and cancelled while it runs
    # it raises instead of finishing its slab. Left alone it gives the slab's fragment.
    from isogrid import _isogrid

    cells = np.random.default_rng(5).integers(1, 6000, (24, 24, 24), dtype=np.uint16)
    a = cells.repeat(8, 0).repeat(8, 1).repeat(8, 2)  # 192³ samples, touching 8³ labels
    dims = a.shape[::-1]
    blocks = (0, ((a.shape[2] - 1 + 15) // 16) * ((a.shape[1] - 1 + 15) // 16) * ((a.shape[0] - 1 + 15) // 16))
    start = time.perf_counter()
    covered, fragment = _isogrid._label_slab(a, dims, blocks, "all", 1.0, 1 << 40)
    assert covered == blocks and len(fragment) > 0
    whole = time.perf_counter() - start
    assert whole > 0.2, f"the slab took {whole:.2f} s: too quick to cancel mid-way"
    flag = _isogrid._TaskCancel()
    flag.cancel()
    with pytest.raises(ValueError, match="interrupted"):
        _isogrid._label_slab(a, dims, blocks, "all", 1.0, 1 << 40, None, flag)
    flag = _isogrid._TaskCancel()
    timer = threading.Timer(0.02, flag.cancel)
    timer.start()
    with pytest.raises(ValueError, match="interrupted"):
        _isogrid._label_slab(a, dims, blocks, "all", 1.0, 1 << 40, None, flag)
    timer.join()
    assert flag.cancelled


# A slow tile: uint8 noise, nearly every cell active at 127.5 (uint8 at iso in data units runs in
# one pass, so the tile's one task scans and writes its output), beside a thin quick one of zeros.
SLOW_TILE = 416


def quick_and_slow_tiles():
    """(z, y, x) dask array of two tiles along z: noise (every cell active: seconds), `SLOW_TILE`
    samples on a side plus the halo, then one block layer of zeros (no active cell: done in
    moments). Its chunks are NumPy's, so that both tiles start at once and the quick one ends
    while the slow one has nearly all of its work ahead."""
    n = SLOW_TILE
    a = np.zeros((n + 17, n + 1, n + 1), dtype=np.uint8)
    a[: n + 1] = np.random.default_rng(7).integers(0, 256, a[: n + 1].shape, dtype=np.uint8)
    return da.from_array(a, chunks=(n, n + 1, n + 1))


def taken_digest(path):
    """The SHA-256 of the file `path`, which is then removed."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for piece in iter(lambda: f.read(1 << 24), b""):
            digest.update(piece)
    os.remove(path)
    return digest.hexdigest()


def run_tiles(source, out, tile_shape, **kwargs):
    isogrid.dask.extract(source, iso=127.5, output=out, tile_shape=tile_shape,
                         tile_bytes=16 * SLOW_TILE ** 3, **kwargs)


def stop_mid_tile(source, out_dir, tile_shape, error, **kwargs):
    """Runs the two tiles, raising `error` from the progress callback once the quick tile is
    done (the slow one has just started); returns the time of the raise (`time.time`, which the
    worker processes of a LocalCluster share)."""
    raised = []

    def progress(done, total):
        if not raised:
            raised.append(time.time())
            raise error("stop")

    with pytest.raises(error, match="stop"):
        isogrid.dask.extract(source, iso=127.5, output=out_dir / "out.cgc", tile_shape=tile_shape,
                             tile_bytes=16 * SLOW_TILE ** 3, progress=progress, **kwargs)
    return raised[0]


def running_tiles(dask_worker):
    """The tile tasks a worker's threads still run: executing, or cancelled while executing (a
    cancelled future's task runs on in its thread until it returns)."""
    return sum(1 for key, task in dask_worker.state.tasks.items()
               if str(key).startswith("('extract-")
               and (task.state == "executing" or (task.state == "cancelled" and task.previous == "executing")))


async def tiles_end(dask_worker, deadline):
    """Run in a worker's event loop (which must go on, to hear of cancelled tasks): the time
    (`time.time`) its last running tile task ended, looked at every 5 ms, or None at `deadline`."""
    import asyncio

    while running_tiles(dask_worker):
        if time.time() > deadline:
            return None
        await asyncio.sleep(0.005)
    return time.time()


@pytest.mark.parametrize("error", [Stop, KeyboardInterrupt])
@pytest.mark.parametrize("scheduler", ["threads", "client"])
def test_a_stop_reaches_a_running_tile_task(tmp_path, monkeypatch, scheduler, error):
    # The tile task running when the run stops ends within a block row of its tile, not at its
    # end: it runs on for a small part of the slow tile's time, and nothing is left behind.
    # (Before, a running task finished its tile: the driver waited for it on the threaded
    # scheduler, and on a cluster the worker's thread ran it on after its future was cancelled.)
    source = quick_and_slow_tiles()
    tile_shape = (SLOW_TILE, SLOW_TILE, SLOW_TILE)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    # The files are 650 MB each: compared by digest, and removed at once (pytest keeps its
    # temporary folders).
    reference = tmp_path / "reference.cgc"
    isogrid.extract(source.compute(), iso=127.5).save(reference)
    expected = taken_digest(reference)
    if scheduler == "threads":
        monkeypatch.setattr(isogrid.dask, "_client", lambda client: None)
        monkeypatch.setitem(dask.config.config, "scheduler", "threads")
        # The slow tile's own time: its task's (the run also copies the output into place).
        seconds = []
        task = isogrid.dask._extract

        def timed(*args):
            start = time.perf_counter()
            try:
                return task(*args)
            finally:
                seconds.append(time.perf_counter() - start)

        monkeypatch.setattr(isogrid.dask, "_extract", timed)
        run_tiles(source, out_dir / "full.cgc", tile_shape)
        assert taken_digest(out_dir / "full.cgc") == expected
        slow = max(seconds)
        assert slow > 1.0, f"the slow tile took {slow:.2f} s: too quick to stop mid-way"
        raised = stop_mid_tile(source, out_dir, tile_shape, error)
        after = time.time() - raised
        assert after < 0.4 * slow, f"returned {after:.2f} s after the raise; the slow tile takes {slow:.2f} s"
        assert os.listdir(out_dir) == [], os.listdir(out_dir)
        return
    # A worker process: the stop crosses to it through the run's distributed Event.
    # The tiles' Rust code on one thread: the worker's Python threads (its event loop, the task's
    # watcher) keep a core, and the slow tile runs long enough to see it cut short.
    with distributed.LocalCluster(n_workers=1, processes=True, threads_per_worker=2, memory_limit="4GiB",
                                  dashboard_address=None, env={"RAYON_NUM_THREADS": "1"}) as cluster, \
            distributed.Client(cluster) as client:
        with distributed.get_task_stream(client) as stream:
            run_tiles(source, out_dir / "full.cgc", tile_shape, client=client)
        assert taken_digest(out_dir / "full.cgc") == expected
        slow = max(sum(s["stop"] - s["start"] for s in task["startstops"] if s["action"] == "compute")
                   for task in stream.data if str(task["key"]).startswith("('extract-"))
        assert slow > 1.0, f"the slow tile took {slow:.2f} s: too quick to stop mid-way"
        raised = stop_mid_tile(source, out_dir, tile_shape, error, client=client)
        assert os.listdir(out_dir) == [], os.listdir(out_dir)
        # The driver does not wait for a worker's tasks: the slow tile must stop on the worker.
        (ended,) = client.run(tiles_end, deadline=raised + slow).values()
        assert ended is not None, "the slow tile ran on to its end"
        after = ended - raised
        # Run to its end, the slow tile went on for 0.79-0.85 of its time after the raise (it has
        # just started then); stopped, it ends as soon as the cancel crosses the scheduler to the
        # worker, which on two busy cores has taken up to half of a 1.4 s tile.
        assert after < 0.6 * slow, f"the worker ran the tile {after:.2f} s after the raise; it takes {slow:.2f} s"

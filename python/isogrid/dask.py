"""Isosurface extraction spread over a Dask cluster (``pip install isogrid[dask]``).

    import isogrid.dask
    stats = isogrid.dask.extract("volume.zarr", iso_normalized=0.5, output="volume.cgc")

Every cell of the clustered grid cell structure (paper §3.1) belongs to exactly one 16³ block,
and a block reads only its own samples plus one more on its high sides. A *tile*, a box of whole
blocks, therefore extracts on its own, from its samples plus a one-sample halo on its high sides,
and its blocks are exactly those of the whole-volume extraction: there are no seams to stitch.
The run is:

1. with ``iso_normalized``, a Dask reduction for the value range (NaN ignored);
2. one task per tile counts each block's active cells (*scan*) and, where it can, also writes the
   tile's metacells and corner records (*one pass*): when the codes corner values are stored as
   are known before the whole volume has been seen (the value range is known, or the type is
   stored as it is: uint8, uint16 at 16 bits, any type at 32 bits) and the output fits what
   ``tile_bytes`` leaves beside the tile's samples. The driver keeps such output in a scratch
   file beside ``output`` (it takes up to the output's size until the end) and adds the counts
   up in block order, which fixes every block's place in the file;
3. one task per *emit job* (a tile that gave no output and holds active cells, halved until it
   fits ``tile_bytes``) writes its metacells and corner records; the driver copies the one-pass
   output into place, places each job's result at its offsets as it arrives and writes the
   header last, into a temporary file renamed at the end.

So a uint8 or uint16 source with ``iso`` in data units is read once, and twice with
``iso_normalized``; other types are read once more, when their tiles are emitted.

Tiles are cut along x, y and z so that a task's samples stay near ``tile_bytes`` whatever the
size of a plane, and along the source's chunks where those are whole blocks. The file is
byte-identical to ``isogrid.extract(volume).save(output)`` of the same samples, for any chunking,
tiling and worker count, and when a worker dies mid-run (Dask reruns its tasks; their results
are the same bytes). The driver holds 21 bytes per block and one result at a time; each task
holds one tile. Tasks read the source's chunks themselves, each pass being one graph, so that a
chunk two tiles read (one holding a halo) is computed once per pass.

**Label volumes** (``labels=``, as ``isogrid extract --labels``) go by *slabs* of whole block
layers instead, each a task: a label's block reads its 17 samples per axis plus, with
``smooth=σ``, the Gaussian's radius ⌈3σ⌉ more on every side, so a slab of layers ``l0..l1``
reads the planes ``16·l0 − r .. 16·l1 + r`` (clipped), whole in x and y; where one layer's planes
exceed a task's share, a task is a run of block rows of one layer and reads only their rows
(``16·k0 − r .. 16·k1 + r``) of the layer's planes. Each task runs the label
pass on its slab and returns its blocks' labels, counts and output, stopping early once that
output fills what ``tile_bytes`` leaves beside its planes (a dense surface, such as supervoxels',
outweighs its samples); the blocks it did not reach, from the middle of a layer on, go to a task
of a further round. Slabs go to dask's threaded scheduler in windows of twice its threads, so that
a free thread does not read the chunks of slabs far ahead. The driver keeps the output in a
scratch file beside ``output``, adds the counts up in block order as fragments arrive (in any
order), and writes the file once every block is in: byte-identical to
``isogrid.extract(volume, labels=...).save(output)`` and to ``isogrid extract --labels`` streamed
within ``--max-memory``, for any slab size and worker count.

Axes: a Zarr store or group is read as ``isogrid extract`` reads it (OME-Zarr levels, axes by
name, ``index`` for the others, spacing and origin from the metadata), by the same Rust code.
Any other source is indexed ``[z, y, x]`` (NumPy's C order): its last axis is x, the one that
varies fastest, and ``spacing`` and ``origin`` are (x, y, z).
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import os
import queue
import threading
import time
import uuid
import warnings
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple

import numpy as np

try:
    import dask
    import dask.array as da
except ImportError as err:  # pragma: no cover - depends on the environment
    raise ImportError("isogrid.dask needs dask: pip install 'isogrid[dask]'") from err

from . import (
    _attribute_index_needs_attribute,
    _indices,
    _isogrid,
    _int,
    _iso_pair,
    _label_selection,
    _prepare,
    _sample_dtype,
    _triple,
    _volume_of,
    _warn_if_empty,
)

__all__ = ["extract"]

# Cells per block edge, from the extension: the tiles follow the library's blocks.
BLOCK_CELLS: int = _isogrid.BLOCK_CELLS
DEFAULT_TILE_BYTES = 64 << 20


def extract(
    source: Any,
    iso: Optional[float] = None,
    iso_normalized: Optional[float] = None,
    *,
    output: "str | os.PathLike[str]",
    precision: Optional[int] = None,
    spacing: Optional[Sequence[float]] = None,
    origin: Optional[Sequence[float]] = None,
    client: Any = None,
    component: Optional[str] = None,
    level: int = 0,
    index: Optional[Dict[str, int]] = None,
    tile_bytes: int = DEFAULT_TILE_BYTES,
    tile_shape: Optional[Sequence[int]] = None,
    attribute: Any = None,
    attribute_precision: int = 16,
    progress: Optional[Callable[[int, int], Any]] = None,
    labels: Any = None,
    smooth: Optional[float] = None,
    label_table: "Optional[str | os.PathLike[str]]" = None,
    attribute_index: Optional[Dict[str, int]] = None,
) -> Dict[str, Any]:
    """Extracts the active cells of a 3-D volume on Dask and writes them to the ``.cgc`` ``output``.

    Args:
        source: a Zarr store's path or URL (anything fsspec opens, e.g. ``s3://…``) holding an
            array or an OME-Zarr 0.4/0.5 image, a zarr array or group, a dask array or a NumPy
            array. Zarr sources are read as :func:`isogrid.load_volume` and ``isogrid extract``
            read them: axes mapped to x, y and z by name, spacing and origin from the OME-Zarr
            ``coordinateTransformations``. Other arrays are 3-D, indexed ``[z, y, x]``. Samples
            are read as :func:`isogrid.extract` reads them: 8 to 64-bit integers, float32 and
            float64 as they are, int8 as int16, bool as uint8, float16 as float32.
        iso, iso_normalized: the isovalue in data units, or as a fraction of the value range
            (exactly one).
        output: the ``.cgc`` file, written atomically (nothing is left under its name on error).
        precision: bits per stored corner, 1, 4, 8, 16 or 32; default 8 for uint8, 16 otherwise.
        spacing, origin: (x, y, z) sample spacing and position of sample (0, 0, 0); default the
            OME-Zarr image's, else 1 and 0.
        client: a ``distributed.Client``; default the current one, else dask's default scheduler
            in this process, which on one machine is the fastest (nothing is pickled or sent
            between processes; the tasks' Rust code releases the GIL).
        component: an array inside the Zarr store at ``source``, e.g. ``"0"``.
        level: the OME-Zarr resolution level (0 = full resolution), as ``isogrid extract --level``.
        index: the entry to read of every Zarr axis other than x, y and z that has more than one,
            e.g. ``{"t": 0, "c": 1}``, as ``isogrid extract --index``.
        tile_bytes: the samples plus output one task holds, about: tiles take half of it for
            their samples, and emit jobs halve a tile whose output would not fit the rest; with
            ``labels``, slabs take a quarter for their planes (held twice: the source's chunks
            and the slab made of them), and a slab task whose output fills the rest (at least
            half) stops there, leaving its other blocks to a further task. A task never holds
            less than one block (17³ samples; with ``labels``, a block row's 17 rows of 17
            planes, and the smoothing halo).
        tile_shape: the (z, y, x) samples a tile covers, each a multiple of 16 (a tile reads one
            more along each axis, its halo); default: picked from ``tile_bytes`` and the chunks.
        attribute: a second volume to colour the surface by, as :func:`isogrid.extract` takes
            it: the path of a volume file or Zarr store (read by region where its format allows,
            resampled in world space when its grid differs), or an array indexed ``[z, y, x]`` on
            the surface's samples (a dask array is computed into memory). Sampled by the driver
            once the surface is extracted (the labels' surfaces too); the file is the one
            ``isogrid.extract(..., attribute=...)`` writes.
        attribute_precision: bits per stored attribute value, 8, 16 or 32.
        attribute_index: with an ``attribute`` path, the entry to read of each of its axes beyond
            x, y and z, e.g. ``{"t": 3}`` (``isogrid extract --color-index``).
        labels: instead of an isovalue, the surface of each label of a label volume, as
            :func:`isogrid.extract` takes it (``"all"``, a label, a list, or ``"1,5-9"``); the
            statistics then list the labels (``stats["labels"]``, as ``LabelGrid.labels``). An
            OME-Zarr label image's ``image-label`` names and colours apply when ``source`` is
            its local path.
        smooth: with ``labels``, the σ in voxels of the Gaussian that smooths each indicator
            (default 0, none).
        label_table: with ``labels``, a colour table file that names and colours the labels
            (FreeSurfer LUT, 3D Slicer ``.ctbl`` or ITK-SNAP), over the image's own names.
        progress: called as ``progress(done, total)`` in this process each time a task finishes:
            ``done`` tasks (tiles, then emit jobs) out of the ``total`` planned so far, which
            grows by the emit jobs once the tiles are counted; with ``labels``, ``done`` blocks
            out of the volume's ``total``. If it raises, on Ctrl-C
            (``KeyboardInterrupt``), or when a task fails or its future is cancelled, no further
            result is taken, tasks not yet started are dropped, tasks running stop within a block
            row of their tile, a label slab's between two blocks (on dask's threaded or synchronous scheduler and on a
            ``distributed`` cluster; on the processes scheduler they finish their tile), the
            exception is raised, and neither ``output`` nor any temporary file is left.

    Returns:
        The statistics ``isogrid extract --json`` prints: dims, iso, precision, active_cells,
        metacells, metacell_slots, clusters, blocks, nonempty_blocks, bytes {blocks, metacells,
        cells, paper_total}, bytes_per_cell and seconds {read, extract, write}.
    """
    start = time.perf_counter()
    if progress is not None and not callable(progress):
        raise ValueError("progress must be a callable taking (done, total)")
    counter = _Counter(progress)
    if labels is None:
        if smooth is not None or label_table is not None:
            raise ValueError("smooth and label_table apply to labels=, and need it")
        iso, iso_normalized = _iso_pair(iso, iso_normalized)
    elif iso is not None or iso_normalized is not None:
        raise ValueError("labels takes the place of iso and iso_normalized")
    bits = None if precision is None else _int(precision, "precision")
    # Checked here, by the Rust rule, so that a typo fails before the value-range pass.
    if bits is not None:
        _isogrid._check_precision(bits)
    if labels is None and iso_normalized is not None and not 0.0 <= iso_normalized <= 1.0:
        raise ValueError(f"normalised isovalue {iso_normalized} is outside [0, 1]")
    budget = _int(tile_bytes, "tile_bytes", 1)
    out = os.fspath(output)
    parent = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(parent):
        raise FileNotFoundError(f"{out}: the output folder {parent} does not exist")
    if os.path.isdir(out):
        raise IsADirectoryError(f"{out}: is a folder, not a .cgc file")

    indices = None if index is None else [(str(a), _int(i, "index", 0)) for a, i in dict(index).items()]
    array, geometry = _dask_array(source, component, _int(level, "level", 0), indices)
    spacing3 = geometry["spacing"] if spacing is None else _triple(spacing, "spacing")
    origin3 = geometry["origin"] if origin is None else _triple(origin, "origin")
    dtype = _sample_dtype(array.dtype)
    if array.dtype != dtype:
        array = array.astype(dtype)
    nz, ny, nx = (int(n) for n in array.shape)
    if min(nz, ny, nx) < 1:
        raise ValueError(f"the volume is empty (shape {array.shape})")
    read = time.perf_counter() - start

    run = _Runner(_client(client))
    if labels is not None:
        writer = _isogrid._LabelWriter(
            (nx, ny, nz), dtype.name, spacing3, origin3, _label_selection(labels),
            0.0 if smooth is None else float(smooth), parent, bits, geometry["direction"]
        )
        names_of = os.fspath(source) if isinstance(source, (str, os.PathLike)) else None
        stats = _written_with_attribute(
            out,
            lambda path: _extract_labels(array, writer, run, counter, budget, (nx, ny, nz), dtype.itemsize,
                                         _label_selection(labels), 0.0 if smooth is None else float(smooth),
                                         bits, path, label_table, names_of),
            attribute, ((nx, ny, nz), spacing3, origin3, geometry["direction"]), attribute_precision,
            attribute_index,
        )
        stats["seconds"] = {"read": read, "extract": time.perf_counter() - start - read, "write": 0.0}
        return stats
    stop = run.stop
    blocks = 1
    for n in (nx, ny, nz):
        blocks *= -(-(n - 1) // BLOCK_CELLS)
    value_range = None
    if iso_normalized is not None or blocks == 0:
        value_range = run.value_range(array)
    extraction = _isogrid._TileExtraction(
        (nx, ny, nz), dtype.name, spacing3, origin3, iso, iso_normalized, bits, value_range, geometry["direction"]
    )

    # Pass 1: tiles of whole blocks (plus the halo on their high sides), in any order.
    chunks = _Chunks(array)
    dims = (nx, ny, nz)
    if tile_shape is None:
        # Half the budget for the samples, the other half for the tile's output, so that tiles
        # seldom need to be halved into emit jobs (halves cut their chunks apart).
        tile = _tile_blocks(dims, array.chunks[::-1], dtype.itemsize, max(1, budget // 2))
    else:
        tile = _tile_shape_blocks(tile_shape)
    one_pass = extraction.one_pass_task()
    if one_pass is not None:
        extraction.spool_in(parent)
        tiles = []
        for box in _tiles(dims, tile):
            samples = _samples(box, dims)
            sample_bytes = dtype.itemsize * int(np.prod([hi - lo for lo, hi in samples]))
            output_bytes = max(0, budget - sample_bytes)
            tiles.append((samples, (one_pass, tuple(b[0] for b in box), output_bytes)))
        for fragment in counter.counted(run.as_completed(chunks.tasks(_extract, tiles, stop)), len(tiles)):
            extraction.add_tile(fragment)
    else:
        scans = [(_samples(box, dims), (dims, tuple(b[0] for b in box), extraction.iso)) for box in _tiles(dims, tile)]
        # In completion order (add_scan takes tiles in any order), so a stop ends the pass early.
        for fragment in counter.counted(run.as_completed(chunks.tasks(_scan, scans, stop)), len(scans)):
            extraction.add_scan(fragment)

    # Pass 2: emit jobs for the tiles that gave no output, written at their offsets as they
    # complete, after the one-pass tiles' output.
    jobs = extraction.plan_emits(tile, budget)
    emits = counter.counted(
        run.as_completed(
            chunks.tasks(_emit, [(samples, (job, index)) for index, (samples, job) in enumerate(jobs)], stop)
        ),
        len(jobs),
    )
    stats = _written_with_attribute(
        out, lambda path: extraction.write(path, emits), attribute,
        ((nx, ny, nz), spacing3, origin3, geometry["direction"]), attribute_precision, attribute_index,
    )
    stats["seconds"] = {"read": read, "extract": time.perf_counter() - start - read, "write": 0.0}
    if stats["active_cells"] == 0:
        # As isogrid.extract warns; the empty grid's file is small, its header says why.
        _warn_if_empty(_isogrid.load(out))
    return stats


def _extract_labels(array: "da.Array", writer: Any, run: "_Runner", counter: "_Counter", budget: int,
                    dims: Tuple[int, int, int], itemsize: int, selection: str, smooth: float, bits: Optional[int],
                    out: str, label_table: Any, names_of: Optional[str]) -> Dict[str, Any]:
    """`labels=` of :func:`extract`: one task per slab of block layers, whose planes (its own and
    the smoothing halo) take about a quarter of `budget`, held twice (the source's chunks it
    reads and the slab assembled from them), its output the rest, or at least half of `budget`.
    Where one layer's planes alone take more than the quarter, a task is a run of block rows of
    one layer instead, reading those rows of the layer's planes. A task whose output fills its share stops there, and the
    blocks it did not reach go to a task of the next round (which reads their planes again): so
    every task holds about `budget`, however dense the surface. Progress counts blocks."""
    nx, ny, nz = dims
    nbx, nby = (_blocks(nx), _blocks(ny)) if min(dims) > 1 else (0, 0)
    per_layer = nbx * nby
    layers = _blocks(nz) if per_layer else 0

    def span(k: int) -> int:
        """Samples across k blocks and the halo on both sides: a slab of k block layers reads as
        many planes, a run of k block rows within a layer as many rows of each of its planes."""
        return BLOCK_CELLS * k + 1 + 2 * writer.halo

    plane = nx * ny * itemsize
    if plane * span(1) <= budget // 4:
        step = max(1, (budget // 4 // plane - 1 - 2 * writer.halo) // BLOCK_CELLS)
        pending = [(l0 * per_layer, min(l0 + step, layers) * per_layer) for l0 in range(0, layers, step)]
    else:
        # One layer's planes alone exceed the share: runs of block rows, each reading its rows.
        row = nx * itemsize * span(1)
        step = max(1, (budget // 4 // row - 1 - 2 * writer.halo) // BLOCK_CELLS)
        pending = [(l * per_layer + r0 * nbx, l * per_layer + min(r0 + step, nby) * nbx)
                   for l in range(layers) for r0 in range(0, nby, step)]
    planned = layers * per_layer
    chunks = _Chunks(array)
    while pending:
        slabs = []
        for b0, b1 in pending:
            y0, y1, z0, z1 = writer.sample_box((b0, b1))
            output_cap = max(budget - 2 * nx * itemsize * (y1 - y0) * (z1 - z0), budget // 2)
            slabs.append((((0, nx), (y0, y1), (z0, z1)), (dims, (b0, b1), selection, smooth, output_cap, bits)))
        asked = dict(pending)
        pending = []
        # On dask's threaded scheduler a free thread runs whatever is ready, the source chunks of
        # slabs far ahead included, while the others run slab tasks: a window of slabs at a time
        # bounds what it reads ahead (the chunk holding a window's last halo plane is read again
        # by the next window).
        window = run.window if run.local else len(slabs)
        for first in range(0, len(slabs), window):
            tasks = chunks.tasks(_label_slab, slabs[first : first + window], run.stop)
            results = counter.counted(run.as_completed(tasks), planned, lambda r: r[0][1] - r[0][0])
            planned = 0
            for (b0, end), fragment in results:
                writer.add(fragment)
                del fragment
                if end < asked[b0]:
                    pending.append((end, asked[b0]))
    stats, notices = writer.write(out, None if label_table is None else os.fspath(label_table), names_of)
    for notice in notices:
        warnings.warn(notice, stacklevel=3)
    if stats["active_cells"] == 0:
        # As isogrid.extract_labels warns, from the file's header and label table.
        _warn_if_empty(_isogrid.load(out))
    return stats


def _label_slab(pieces: List[np.ndarray], places: List[Tuple[int, int, int]], shape: Tuple[int, int, int],
                stop: Any, dims: Tuple[int, int, int], blocks: Tuple[int, int], selection: str, smooth: float,
                output_cap: int, bits: Optional[int]) -> Tuple[Tuple[int, int], bytes]:
    """Task: the label pass over one run of blocks, up to its output cap (GIL released in Rust)."""
    with _watching(stop) as cancel:
        return _isogrid._label_slab(_assemble(pieces, places, shape), dims, blocks, selection, smooth, output_cap,
                                    bits, cancel)


class _Counter:
    """Work finished (tasks, or the blocks of a label extraction) out of that planned, told to the
    caller's ``progress(done, total)``."""

    def __init__(self, callback: Optional[Callable[[int, int], Any]]) -> None:
        self.callback = callback
        self.done = 0
        self.total = 0

    def counted(self, results: Iterable[Any], planned: int,
                weight: Optional[Callable[[Any], int]] = None) -> Iterator[Any]:
        """`results`, a pass of `planned` units (tasks, or what `weight` counts of each result),
        counting each as it is taken. An exception from the callback leaves the pass's iterator,
        which ends the pass (see `_Runner`)."""
        self.total += planned
        try:
            for result in results:
                self.done += 1 if weight is None else weight(result)
                if self.callback is not None:
                    self.callback(self.done, self.total)
                yield result
        finally:
            close = getattr(results, "close", None)
            if close is not None:
                close()


def _written_with_attribute(out: str, write: Callable[[str], Dict[str, Any]], attribute: Any,
                            grid: Tuple[Any, ...], precision: int,
                            index: Optional[Dict[str, int]]) -> Dict[str, Any]:
    """Writes the grid with `write(path)` (which gives its statistics) to `out`. With an
    attribute, the grid goes to a file beside the output, gets its attribute (`grid`: the
    surface's dims, spacing, origin and direction), then takes the output's name: on any error
    nothing is left under it."""
    _attribute_index_needs_attribute(attribute, index)
    if attribute is None:
        return write(out)
    bits = _int(precision, "attribute_precision")
    surface = os.path.join(os.path.dirname(os.path.abspath(out)), f".{os.path.basename(out)}.surface{os.getpid()}")
    try:
        stats = write(surface)
        _attach_attribute(surface, attribute, *grid, bits, index)
        os.replace(surface, out)
    finally:
        if os.path.exists(surface):
            os.remove(surface)
    stats["attribute"] = _isogrid.load(out).stats["attribute"]
    return stats


def _attach_attribute(path: str, attribute: Any, dims: Tuple[int, int, int], spacing: Tuple[float, ...],
                      origin: Tuple[float, ...], direction: Any, bits: int,
                      index: Optional[Dict[str, int]]) -> None:
    """Samples `attribute` (a path, whose extra axes `index` picks from, or an array [z, y, x]
    on the surface's samples) at the cells of the `.cgc` file `path`, rewriting it."""
    if isinstance(attribute, (str, os.PathLike)):
        _isogrid._attach_attribute(
            path, attribute_path=os.fspath(attribute), bits=bits, attribute_index=_indices(index, "attribute_index")
        )
        return
    array = np.asarray(_volume_of(attribute, index=index, keyword="attribute_index"))
    if array.shape != dims[::-1]:
        raise ValueError(
            f"an attribute array of shape {array.shape} (z, y, x) lies on the surface's samples, "
            f"shape {dims[::-1]}; give a path to resample another grid"
        )
    prepared, fortran = _prepare(array)
    direction = [list(map(float, row)) for row in direction]
    _isogrid._attach_attribute(
        path, array=(prepared, fortran, list(spacing), list(origin), direction, None, "attribute", bits), bits=bits
    )


Box = Tuple[Tuple[int, int], Tuple[int, int], Tuple[int, int]]


def _blocks(n: int) -> int:
    """Blocks along an axis of `n` samples."""
    return -(-(n - 1) // BLOCK_CELLS)


def _tile_blocks(dims: Tuple[int, int, int], chunks: Tuple[Tuple[int, ...], ...], itemsize: int,
                 budget: int) -> Tuple[int, int, int]:
    """The (x, y, z) blocks of a tile whose samples stay within `budget` bytes where one block
    allows. Along an axis whose chunks are whole blocks a tile is whole chunks, so that it reads
    its chunks plus thin halo cuts of the next ones, not parts of a chunk that other tiles share.
    Tiles grow along x first, then y, then z: long rows are one run of the block table."""
    counts = [max(1, _blocks(n)) for n in dims]

    def unit(axis_chunks: Tuple[int, ...]) -> int:
        depth = axis_chunks[0]
        whole = depth % BLOCK_CELLS == 0 and all(c == depth for c in axis_chunks[:-1])
        return depth // BLOCK_CELLS if whole else 1

    def cost(k: List[int]) -> int:
        size = itemsize
        for n, b in zip(dims, k):
            size *= min(BLOCK_CELLS * b + 1, n)
        return size

    units = [min(unit(c), n) for c, n in zip(chunks, counts)]
    tile = list(units)
    while cost(tile) > budget and max(tile) > 1:
        # Even one chunk is too much: halve the longest axis, z before y before x.
        axis = max((2, 1, 0), key=lambda a: tile[a])
        tile[axis] = max(1, tile[axis] // 2)
        units[axis] = 1
    for axis in (0, 1, 2):
        while tile[axis] < counts[axis]:
            grown = list(tile)
            grown[axis] = min(counts[axis], tile[axis] + units[axis])
            if cost(grown) > budget:
                break
            tile = grown
    return tile[0], tile[1], tile[2]


def _tile_shape_blocks(tile_shape: Sequence[int]) -> Tuple[int, int, int]:
    """`tile_shape` (z, y, x samples, multiples of 16) as (x, y, z) blocks."""
    shape = [_int(n, "tile_shape", 1) for n in tile_shape]
    if len(shape) != 3 or any(n % BLOCK_CELLS for n in shape):
        raise ValueError(f"tile_shape must be three multiples of 16 samples (z, y, x), not {tuple(tile_shape)}")
    z, y, x = (n // BLOCK_CELLS for n in shape)
    return x, y, z


def _tiles(dims: Tuple[int, int, int], tile: Tuple[int, int, int]) -> List[Box]:
    """The boxes of `tile` blocks (x, y, z ranges of blocks) covering the volume, in block order;
    none when an axis has a single sample (no block)."""
    counts = [_blocks(n) for n in dims]
    if min(counts) == 0:
        return []
    cuts = [[(b, min(b + k, n)) for b in range(0, n, k)] for n, k in zip(counts, tile)]
    return [(x, y, z) for z in cuts[2] for y in cuts[1] for x in cuts[0]]


def _samples(box: Box, dims: Tuple[int, int, int]) -> Box:
    """The (x, y, z) sample ranges the blocks of `box` read, halo included."""
    return tuple(  # type: ignore[return-value]
        (BLOCK_CELLS * b0, min(BLOCK_CELLS * b1 + 1, n)) for (b0, b1), n in zip(box, dims)
    )


def _scan(pieces: List[np.ndarray], places: List[Tuple[int, int, int]], shape: Tuple[int, int, int], stop: Any,
          dims: Tuple[int, int, int], first_block: Tuple[int, int, int], iso: float) -> bytes:
    """Task: pass 1 of one tile (GIL released in Rust)."""
    with _watching(stop) as cancel:
        return _isogrid._scan_tile(_assemble(pieces, places, shape), dims, first_block, iso, cancel)


def _extract(pieces: List[np.ndarray], places: List[Tuple[int, int, int]], shape: Tuple[int, int, int], stop: Any,
             task: bytes, first_block: Tuple[int, int, int], output_bytes: int) -> bytes:
    """Task: one pass over one tile, scan and (when it fits `output_bytes`) output (GIL released
    in Rust)."""
    with _watching(stop) as cancel:
        return _isogrid._extract_tile(_assemble(pieces, places, shape), task, first_block, output_bytes, cancel)


def _emit(pieces: List[np.ndarray], places: List[Tuple[int, int, int]], shape: Tuple[int, int, int], stop: Any,
          job: bytes, index: int) -> bytes:
    """Task: pass 2 of one emit job (GIL released in Rust)."""
    with _watching(stop) as cancel:
        return _isogrid._emit_tile(_assemble(pieces, places, shape), job, index, cancel)


# How often a distributed tile task's watcher looks at its worker's own record of the task (the
# driver cancels the futures of a stopped run; a client may cancel them too), and how often it
# asks the scheduler whether its run's stop event is set (one quick call per running task per
# period). Waiting on the event instead left a wait pending in the scheduler after each task,
# which the scheduler logs as an error when the cluster closes right after a run.
STOP_LOOK_SECONDS = 0.02
STOP_ASK_SECONDS = 0.2


@contextlib.contextmanager
def _watching(stop: Any) -> Iterator[Any]:
    """The `_TaskCancel` flag a tile task runs on, from the run's `stop` (see `_Runner.stop`):
    the driver's own flag in this process; for a distributed run (`stop` is the name of a
    `distributed.Event`), a flag of the task's own that a watcher thread cancels once the
    worker has marked the task cancelled or the event is set; None (the processes scheduler) for
    none."""
    if not isinstance(stop, str):
        yield stop
        return
    from distributed import Event, get_client, get_worker
    from distributed.worker import thread_state

    cancel = _isogrid._TaskCancel()
    event = Event(stop, client=get_client())
    worker, key = get_worker(), getattr(thread_state, "key", None)
    finished = threading.Event()

    def cancelled_here() -> bool:
        task = worker.state.tasks.get(key)
        return task is not None and task.state == "cancelled"

    def watch() -> None:
        looks = max(1, round(STOP_ASK_SECONDS / STOP_LOOK_SECONDS))
        for look in itertools.count(1):
            if finished.wait(STOP_LOOK_SECONDS):
                return
            try:
                if cancelled_here() or (look % looks == 0 and event.is_set()):
                    cancel.cancel()
                    return
            except Exception:  # the scheduler is gone: the task's result has nowhere to go
                cancel.cancel()
                return

    watcher = threading.Thread(target=watch, name="isogrid-tile-stop", daemon=True)
    watcher.start()
    try:
        yield cancel
    finally:
        finished.set()


def _assemble(pieces: List[np.ndarray], places: List[Tuple[int, int, int]], shape: Tuple[int, int, int]) -> np.ndarray:
    """The C-ordered tile of `shape` that `pieces` (source chunks or parts of them) tile, each
    placed at its (z, y, x) corner: the one copy of the samples a task makes."""
    if len(pieces) == 1 and pieces[0].shape == shape and pieces[0].flags.c_contiguous:
        return pieces[0]
    tile = np.empty(shape, dtype=pieces[0].dtype)
    for piece, (z, y, x) in zip(pieces, places):
        tile[z : z + piece.shape[0], y : y + piece.shape[1], x : x + piece.shape[2]] = piece
    return tile


def _cut(chunk: np.ndarray, z0: int, z1: int, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
    """Task: samples [z0:z1, y0:y1, x0:x1] of a chunk, copied so that the chunk can be let go."""
    return np.array(chunk[z0:z1, y0:y1, x0:x1], order="C", copy=True)


class _Chunks:
    """The source's chunks, and the tasks of a pass that read boxes of samples from them.

    A tile's task depends on the chunks it covers whole directly, and on a small *cut* task where
    it needs only part of a chunk (its halo, or a chunk that two tiles share), so that within one
    graph every chunk is computed once and only the samples a tile needs move between workers.
    (Slicing the dask array instead lets dask fuse each tile's slices with the chunks' own tasks:
    every tile then recomputes the chunks holding its halo.) A pass's tasks are written into one
    graph layer by hand: building them one `dask.delayed` call at a time cost milliseconds per
    tile on the driver, before any task could start.
    """

    def __init__(self, array: "da.Array") -> None:
        (self.array,) = dask.optimize(_chunks_as_tasks(array))
        # Chunk bounds along z, y and x.
        self.bounds = [np.cumsum((0,) + tuple(c)) for c in array.chunks]

    def _spans(self, axis: int, lo: int, hi: int) -> Iterator[Tuple[int, int, int]]:
        """(chunk index, start inside it, end inside it) of the chunks that samples lo..hi of
        `axis` (z, y, x) meet, with the chunks' starts."""
        bounds = self.bounds[axis]
        first = int(np.searchsorted(bounds, lo, side="right")) - 1
        for index in range(first, len(bounds) - 1):
            start, end = int(bounds[index]), int(bounds[index + 1])
            if start >= hi:
                return
            yield index, max(lo, start) - start, min(hi, end) - start

    def tasks(self, function: Any, items: Sequence[Tuple[Box, Tuple[Any, ...]]], stop: Any) -> List[Any]:
        """One delayed `function(pieces, places, shape, stop, *args)` per (samples, args) of
        `items`, `samples` being (x, y, z) sample ranges, all in one graph layer; `stop` is the
        run's (`_Runner.stop`)."""
        from dask.base import tokenize
        from dask.delayed import Delayed
        from dask.highlevelgraph import HighLevelGraph

        source = self.array.name
        # The run's stop is in the name (not in the token: a flag is not hashed): two runs' tasks
        # on one cluster watch their own.
        name = f"{function.__name__.strip('_')}-{tokenize(source, function.__name__, items)}-{id(stop):x}"
        cut_name = f"cut-{source}"
        layer: Dict[Any, Any] = {}
        keys = []
        for number, (samples, args) in enumerate(items):
            (x0, x1), (y0, y1), (z0, z1) = samples
            pieces, places = [], []
            for k, za, zb in self._spans(0, z0, z1):
                for j, ya, yb in self._spans(1, y0, y1):
                    for i, xa, xb in self._spans(2, x0, x1):
                        chunk = (source, k, j, i)
                        sizes = tuple(int(self.bounds[a][n + 1] - self.bounds[a][n]) for a, n in enumerate((k, j, i)))
                        if (za, ya, xa) == (0, 0, 0) and (zb, yb, xb) == sizes:
                            pieces.append(chunk)
                        else:
                            # Named by chunk and box, so that tiles asking for the same part share it.
                            cut = (cut_name, k, j, i, za, zb, ya, yb, xa, xb)
                            layer[cut] = (_cut, chunk, za, zb, ya, yb, xa, xb)
                            pieces.append(cut)
                        places.append((int(self.bounds[0][k]) + za - z0, int(self.bounds[1][j]) + ya - y0,
                                       int(self.bounds[2][i]) + xa - x0))
            key = (name, number)
            shape = (z1 - z0, y1 - y0, x1 - x0)
            # Every other argument is numbers or bytes, which the graph cannot take for a task or key.
            layer[key] = (function, pieces, places, shape, stop) + tuple(args)
            keys.append(key)
        graph = HighLevelGraph.from_collections(name, layer, dependencies=[self.array])
        return [Delayed(key, graph, layer=name) for key in keys]


def _chunks_as_tasks(array: "da.Array") -> "da.Array":
    """`array`, with a task that passes each chunk on where its chunks are futures (an array
    persisted on a cluster). A tile task names its chunks inside a list, and dask reads such a
    name as the chunk only where the chunk is a task of the graph: a persisted chunk reached the
    task as its name, a tuple ("'tuple' object has no attribute 'dtype'")."""
    try:
        from distributed import Future
    except ImportError:
        return array
    from dask.highlevelgraph import MaterializedLayer

    layer = array.dask.layers.get(array.name)
    if isinstance(layer, MaterializedLayer) and any(isinstance(v, Future) for v in layer.mapping.values()):
        return array.map_blocks(np.asarray, dtype=array.dtype)
    return array


def _dask_array(
    source: Any, component: Optional[str], level: int, indices: Optional[List[Tuple[str, int]]]
) -> Tuple["da.Array", Dict[str, Any]]:
    """`source` as a 3-D dask array indexed [z, y, x], and its spacing, origin and direction
    (x, y, z), checked before any task runs."""
    geometry: Dict[str, Any] = {"spacing": (1.0, 1.0, 1.0), "origin": (0.0, 0.0, 0.0), "direction": None}
    if isinstance(source, (str, os.PathLike)):
        path = os.fspath(source)
        # A local path that is not there is the same error isogrid.extract and load_volume give.
        if "://" not in path and not os.path.exists(path):
            raise FileNotFoundError(errno.ENOENT, "no such file or folder", path)
        import zarr

        try:
            opened = zarr.open(path, mode="r", path=component) if component else zarr.open(path, mode="r")
        except Exception as err:  # zarr raises several kinds for a missing or foreign store
            raise ValueError(f"{path}: cannot open as Zarr: {err}") from err
        array, geometry = _from_zarr(opened, path + ("/" + component if component else ""), level, indices)
    elif type(source).__module__.startswith("zarr"):
        array, geometry = _from_zarr(source, str(getattr(source, "store_path", "the zarr source")), level, indices)
    else:
        if level != 0 or indices:
            raise ValueError("level and index pick from a Zarr source; slice a dask or NumPy array instead")
        array = source if isinstance(source, da.Array) else da.asarray(source)
    if array.ndim != 3:
        raise ValueError(
            f"expected a 3-D array (z, y, x), got {array.ndim} dimension"
            f"{'' if array.ndim == 1 else 's'} (shape {array.shape})"
        )
    if any(np.isnan(n) for n in array.shape):
        raise ValueError(f"the array's shape {array.shape} is not known")
    return array, geometry


def _from_zarr(
    node: Any, location: str, level: int, indices: Optional[List[Tuple[str, int]]]
) -> Tuple["da.Array", Dict[str, Any]]:
    """A zarr array, or the OME-Zarr image a zarr group holds, as the volume `isogrid extract`
    reads from it: the Rust reader's own metadata rules pick the level's array, map its axes to
    x, y and z by name, pick the `indices` entries of the others and give the geometry."""
    import json

    import zarr

    attrs = None
    if isinstance(node, zarr.Group):
        attrs = json.dumps(node.attrs.asdict())
        node = node[_isogrid._ome_level_path(location, attrs, level)]
        if not isinstance(node, zarr.Array):
            raise ValueError(f"{location}: level {level} of the OME-Zarr image is not an array")
    names = getattr(node.metadata, "dimension_names", None) or node.attrs.get("_ARRAY_DIMENSIONS")
    if names is not None and not all(isinstance(n, str) for n in names):
        names = None
    picked = _isogrid._zarr_selection(location, list(node.shape), names, attrs, level, indices)
    array = da.from_zarr(node)
    fixed = dict(picked["fixed"])
    array = array[tuple(fixed.get(axis, slice(None)) for axis in range(array.ndim))]
    kept = [axis for axis in range(node.ndim) if axis not in fixed]
    x, y, z = (kept.index(axis) for axis in picked["spatial"])
    if (z, y, x) != (0, 1, 2):
        array = array.transpose(z, y, x)
    return array, picked


def _in_process_scheduler() -> bool:
    """Whether dask's scheduler for delayed tasks (without a client) runs them in this process."""
    import dask.local
    import dask.threaded
    from dask.base import get_scheduler

    return get_scheduler(collections=[dask.delayed(0)]) in (dask.threaded.get, dask.local.get_sync)


class _Channel:
    """A bounded queue from the tasks of a local pass to the driver, which can be closed."""

    END = object()

    class Closed(Exception):
        """The driver stopped reading: the pass is abandoned."""

    def __init__(self, size: int) -> None:
        self.queue: "queue.Queue[Any]" = queue.Queue(size)
        self.closed = threading.Event()

    def put(self, item: Any) -> None:
        """Waits for room; raises `Closed` once the driver has stopped reading."""
        while not self.closed.is_set():
            try:
                self.queue.put(item, timeout=0.1)
                return
            except queue.Full:
                continue
        raise _Channel.Closed()


def _hand_over(result: Any, channel: _Channel) -> None:
    """Task: passes a result to the driver (a local pass), keeping none in the graph."""
    channel.put(result)


def _client(client: Any) -> Any:
    """The distributed client to use: the one given, else the current one, else None."""
    if client is not None:
        return client
    try:
        from distributed import default_client
    except ImportError:
        return None
    try:
        return default_client()
    except ValueError:
        return None


class _Runner:
    """Runs delayed tasks on a distributed client, or on dask's default scheduler.

    A pass is one graph, so that tiles reading the same chunk (one holding a halo) share one
    computation of it, and the scheduler's ordering keeps only a few tiles' chunks in memory. On a
    client results are gathered (and released) one by one. Dask's local schedulers return a
    graph's results all at once, so a pass runs on the threaded or synchronous scheduler in a
    background thread, each task handing its result to the driver through a bounded queue (tasks
    wait while it is full). On another local scheduler (processes, whose tasks cannot reach the
    queue) a pass runs a window of tasks at a time, and a chunk that two windows read is computed
    in both.

    The driver stopping a pass before its end (an error, the caller's progress callback raising,
    Ctrl-C, a cancelled future) drops the tasks not yet started and sets `stop`, which the tasks
    running watch (see `_watching`): they end within a block row of their tile. In this process
    `stop` is a `_TaskCancel` flag the tasks share; on a client it is the name of a
    `distributed.Event`; on the processes scheduler None (running tasks finish their tile).
    """

    def __init__(self, client: Any) -> None:
        self.client = client
        self.window = 2 * (os.cpu_count() or 1)
        self.local = client is None and _in_process_scheduler()
        self.stop: Any = None
        self._event: Any = None
        if client is not None:
            from distributed import Event

            self.stop = f"isogrid-stop-{uuid.uuid4().hex}"
            self._event = Event(self.stop, client=client)
        elif self.local:
            self.stop = _isogrid._TaskCancel()

    def _stop_running(self) -> None:
        """Tells the tasks still running to stop (the driver has stopped taking results)."""
        if self._event is not None:
            try:
                self._event.set()
            except Exception:  # the cluster is gone, and its tasks with it
                pass
        elif self.stop is not None:
            self.stop.cancel()

    def value_range(self, array: "da.Array") -> Tuple[float, float]:
        """(min, max) of the samples, NaN ignored; (nan, nan) when none is finite."""
        if array.dtype.kind != "f":
            lo, hi = self._compute([array.min(), array.max()])
            return float(lo), float(hi)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN chunks
            lo, hi = self._compute([da.nanmin(array), da.nanmax(array)])
        return float(lo), float(hi)

    def _compute(self, tasks: List[Any]) -> List[Any]:
        if self.client is not None:
            return list(self.client.gather(self.client.compute(tasks)))
        return list(dask.compute(*tasks))

    def _windows(self, tasks: List[Any], window: int) -> Iterator[Any]:
        pending = iter(tasks)
        while True:
            batch = list(itertools.islice(pending, window))
            if not batch:
                return
            # Culled to the window's tasks: the pass's tasks share one graph.
            yield from dask.compute(*batch, optimize_graph=True)

    def _handed_over(self, tasks: List[Any]) -> Iterator[Any]:
        """Results of `tasks`, one graph on the local scheduler in a background thread, in the
        order they complete."""
        from dask.delayed import Delayed
        from dask.highlevelgraph import HighLevelGraph

        channel = _Channel(self.window)
        name = f"hand-over-{id(channel)}"
        layer = {(name, n): (_hand_over, task.key, channel) for n, task in enumerate(tasks)}
        graph = HighLevelGraph.from_collections(name, layer, dependencies=tasks)
        handed = [Delayed((name, n), graph, layer=name) for n in range(len(tasks))]
        failure: List[BaseException] = []

        def run() -> None:
            try:
                dask.compute(*handed, optimize_graph=True)
            except BaseException as err:  # handed to the driver below
                failure.append(err)
            finally:
                try:
                    channel.put(_Channel.END)
                except _Channel.Closed:
                    pass  # the driver has stopped reading

        thread = threading.Thread(target=run, name="isogrid-dask-pass", daemon=True)
        thread.start()
        ended = False
        try:
            while True:
                item = channel.queue.get()
                if item is _Channel.END:
                    break
                yield item
            if failure and not isinstance(failure[0], _Channel.Closed):
                raise failure[0]
            ended = True
        finally:
            # The driver stopped (an error, or it is done): tasks still running stop within a
            # block row, or at their hand-over, and the pass ends.
            if not ended:
                self._stop_running()
            channel.closed.set()
            thread.join()

    def as_completed(self, tasks: List[Any]) -> Iterator[Any]:
        """Results in completion order (in task order without a client). Closing the iterator
        ends the pass: tasks not yet started do not run."""
        if self.client is None:
            if not tasks:
                return
            if self.local:
                yield from self._handed_over(tasks)
            else:
                yield from self._windows(tasks, self.window)
            return
        from distributed import as_completed

        futures = self.client.compute(tasks, optimize_graph=True)
        ended = False
        try:
            for future in as_completed(futures):
                result = future.result()
                future.release()
                yield result
            ended = True
        finally:
            if not ended:
                self._stop_running()
                for future in futures:
                    if not future.done():
                        future.cancel()

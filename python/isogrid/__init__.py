"""isogrid: isosurfaces as clustered grid cells (CGC), from NumPy.

Extracts the active cells of a scalar volume into the clustered grid cell structure of Nysjö's
*Clustered Grid Cell Data Structure for Isosurface Rendering* (§3.1): 16³-cell blocks, clusters of
2×2×2 metacells and, per active cell, its eight corner values.

    import isogrid
    grid = isogrid.extract(isogrid.load_volume("head.nii.gz"), iso_normalized=0.5)
    print(grid.stats["active_cells"]); grid.save("head.cgc")

Axis convention
---------------
isogrid's coordinates are always (x, y, z), and **x is the axis that varies fastest in memory**:

* a C-ordered array (NumPy's default) of shape ``(nz, ny, nx)`` — indexed ``a[z, y, x]`` — and
* a Fortran-ordered array of shape ``(nx, ny, nz)`` — indexed ``a[x, y, z]``, as nibabel returns —

describe the same volume of ``nx × ny × nz`` samples, and give the same grid; ``a`` and
``np.asfortranarray(a.transpose())`` are interchangeable. Both are used without copying. Other
layouts are copied first: an array that is neither C- nor Fortran-contiguous is read as Fortran
order when its first axis has the smaller stride, otherwise as C order (an array that is both, i.e.
with at most one axis longer than 1, counts as C order).

Everything else is in (x, y, z) order: ``spacing=(sx, sy, sz)``, ``origin``, grid ``dims``
``(nx, ny, nz)``, cell positions, and world coordinates. Mesh vertices (:func:`marching_cubes`)
are the volume's world (patient) coordinates by default: sample (i, j, k) sits at
``origin + i·sx·d_i + j·sy·d_j + k·sz·d_k``, the origin and direction rows being a
:class:`Volume`'s (e.g. the file's, or the mesh frame :func:`voxelize` returns), else zero and
identity; ``space="index"`` gives (i, j, k) instead. A :class:`CellGrid` keeps the origin and
directions in ``info``, as the ``.cgc`` files of the command line do; its ``world_bounds`` and the
renderer place sample (0, 0, 0) at zero. :func:`load_volume` follows the same rule: it returns a C array of shape
``(nz, ny, nx)`` and ``spacing``/``origin`` as (x, y, z).

For scikit-image's conventions (array-axis order, ``level=``, four return values) use
:func:`isogrid.skimage.marching_cubes`, a drop-in for ``skimage.measure.marching_cubes``. For
volumes that do not fit in memory, :func:`isogrid.dask.extract` (``import isogrid.dask``, with the
``dask`` extra) spreads the extraction over a Dask cluster and writes the ``.cgc`` file.

An array with more than three axes is accepted when the extra ones have length 1 and are the
slowest in memory: ``(nx, ny, nz, 1)`` in Fortran order, as nibabel returns many NIfTI volumes, or
``(1, nz, ny, nx)`` in C order.

Samples of type uint8, uint16, int16, uint32, int32, uint64, int64, float32 and float64 are used as
they are (no copy); int8 becomes int16, bool becomes uint8 and float16 becomes float32 (exact
copies). A sample is *inside* when ``value >= iso``, decided exactly in the sample's own type (a
uint32 16777217 is above 16777216.5, though no float32 tells the two apart).

Errors: bad arguments raise ``ValueError``; files that cannot be opened raise ``OSError`` (e.g.
``FileNotFoundError``); malformed or unsupported files raise :class:`IsogridError`, a ``ValueError``.
An isovalue that no cell crosses, or a label volume none of whose selected labels has a boundary,
gives an empty grid and an :class:`EmptySurfaceWarning` that says why (as the command line's
one-line note does).
"""

from __future__ import annotations

import contextlib
import operator
import os
import sys
import warnings
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

def _extension_missing() -> bool:
    """Whether this package folder lacks the compiled extension ``_isogrid``."""
    import importlib.machinery

    here = os.path.dirname(__file__)
    return not any(
        os.path.exists(os.path.join(here, "_isogrid" + suffix))
        for suffix in importlib.machinery.EXTENSION_SUFFIXES
    )


try:
    from . import _isogrid
except ImportError as err:
    # Run from python/ (or with it on sys.path), `isogrid` is the source folder, which has no
    # compiled extension; Python then blames "a circular import", which sends people the wrong way.
    if not _extension_missing():
        raise
    raise ImportError(
        f"isogrid's compiled extension (_isogrid) is not in {os.path.dirname(__file__)}: that is "
        "isogrid's source folder, found first because it is in the current directory or on "
        "sys.path. Run Python from another folder to use the installed package, or build the "
        "extension in place (maturin develop)."
    ) from err
from ._isogrid import CellGrid, IsogridError, LabelGrid  # noqa: E402

__version__: str = _isogrid.__version__

# New bindings (e.g. rendering) go here: a thin wrapper that prepares arrays with `_prepare` and
# calls the native function of the same name, plus an entry in __all__ and in _isogrid.pyi.
__all__ = [
    "CellGrid",
    "EmptySurfaceWarning",
    "IsogridError",
    "LabelGrid",
    "Volume",
    "extract",
    "extract_labels",
    "label_statistics",
    "load",
    "load_volume",
    "marching_cubes",
    "render",
    "voxelize",
]

Triple = Tuple[float, float, float]
PathLike = Union[str, "os.PathLike[str]"]


@contextlib.contextmanager
def _vulkan_device_select_quieted() -> Iterator[None]:
    """Mesa's Vulkan device-selection layer asks a Wayland compositor for the default GPU, and where
    there is no session libwayland prints ``error: XDG_RUNTIME_DIR is invalid or not set`` once per
    adapter lookup. On headless machines (no display, no runtime directory) there is no default to
    ask for: the layer is turned off with its documented switch, ``NODEVICE_SELECT=1``, while a
    render looks for a GPU, unless the user steers it. Only then: set at import, the variable would
    reach every child process the user's program starts."""
    env = os.environ
    headless = not any(k in env for k in ("XDG_RUNTIME_DIR", "WAYLAND_DISPLAY", "DISPLAY"))
    steered = any(k in env for k in ("NODEVICE_SELECT", "DRI_PRIME", "MESA_VK_DEVICE_SELECT"))
    if not headless or steered:
        yield
        return
    env["NODEVICE_SELECT"] = "1"
    try:
        yield
    finally:
        env.pop("NODEVICE_SELECT", None)


class EmptySurfaceWarning(RuntimeWarning):
    """:func:`extract` found no cell that crosses the isovalue, or :func:`extract_labels` no selected
    label with a boundary: the grid, and its surface, are empty."""


def _warn_if_empty(grid: CellGrid, samples: Optional[np.ndarray] = None) -> None:
    """An :class:`EmptySurfaceWarning` saying why, when ``grid`` has no active cell: the reason
    the CLI's note gives. ``samples``: the volume it was extracted from, where at hand, so that a
    volume without a finite sample is named as such."""
    if grid.active_cells != 0:
        return
    all_nan = samples is not None and samples.dtype.kind == "f" and not np.isfinite(samples).any()
    warnings.warn(_isogrid._empty_surface_note(grid, all_nan), EmptySurfaceWarning, stacklevel=_caller_level())


class Volume:
    """Samples plus geometry, as :func:`load_volume` and :func:`voxelize` return.

    ``array`` is C-ordered with shape ``(nz, ny, nx)`` (index it ``array[z, y, x]``);
    ``spacing`` and ``origin`` are ``(x, y, z)`` in the file's units (usually mm); ``direction``
    rows are the world directions of the x, y, z axes (metadata). ``frame`` names the convention
    of those world coordinates: ``"LPS"`` (DICOM, MetaImage, NRRD's ``left-posterior-superior``),
    ``"RAS"`` (NIfTI, NRRD's ``right-anterior-superior``) or ``None`` (none known); an attribute
    of the other convention than its surface is taken into the surface's before it is sampled. A
    Volume can be passed wherever an array is accepted, and then also supplies the spacing.
    """

    __slots__ = ("array", "spacing", "origin", "direction", "frame")

    def __init__(
        self,
        array: np.ndarray,
        spacing: Sequence[float] = (1.0, 1.0, 1.0),
        origin: Sequence[float] = (0.0, 0.0, 0.0),
        direction: Sequence[Sequence[float]] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
        frame: Optional[str] = None,
    ) -> None:
        self.array: np.ndarray = array
        self.spacing: Triple = _triple(spacing, "spacing")
        self.origin: Triple = _triple(origin, "origin")
        self.direction: Tuple[Triple, Triple, Triple] = tuple(  # type: ignore[assignment]
            _triple(row, "direction row") for row in direction
        )
        if frame not in (None, "LPS", "RAS"):
            raise ValueError(f'frame must be "LPS", "RAS" or None, not {frame!r}')
        self.frame: Optional[str] = frame

    @property
    def axes(self) -> Optional[str]:
        """The anatomical direction each of the x, y and z axes points closest to, as radiology
        tools write it (``"RAS"``, FreeSurfer's ``"LIA"``, a DICOM axial series' ``"LPS"``), or
        ``None`` where ``frame`` is."""
        return _isogrid._axis_codes(self.direction, self.frame)

    @property
    def dims(self) -> Tuple[int, int, int]:
        """Samples per axis, (nx, ny, nz), by the axis rule of this module."""
        _, fortran = _layout(np.asarray(self.array))
        shape = self.array.shape
        return tuple(shape if fortran else shape[::-1])  # type: ignore[return-value]

    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> np.ndarray:
        if copy:
            return np.array(self.array, dtype=dtype, copy=True)
        return np.asarray(self.array, dtype=dtype)

    def __repr__(self) -> str:
        return (
            f"Volume(dims={self.dims}, dtype={self.array.dtype}, spacing={self.spacing}, "
            f"origin={self.origin})"
        )


def extract(
    array: Union[np.ndarray, Volume, PathLike, Any],
    iso: Optional[float] = None,
    iso_normalized: Optional[float] = None,
    spacing: Optional[Sequence[float]] = None,
    precision: Optional[int] = None,
    threads: Optional[int] = None,
    series: Optional[str] = None,
    origin: Optional[Sequence[float]] = None,
    direction: Optional[Sequence[Sequence[float]]] = None,
    attribute: Union[np.ndarray, Volume, PathLike, None] = None,
    attribute_precision: int = 16,
    progress: Optional[Callable[[int, int], Any]] = None,
    labels: Union[str, int, Iterable[int], None] = None,
    smooth: Optional[float] = None,
    label_table: Optional[PathLike] = None,
    labels_of: Optional[str] = None,
    index: Optional[Dict[str, int]] = None,
    attribute_index: Optional[Dict[str, int]] = None,
) -> CellGrid:
    """Extracts the active cells of a 3-D volume into clustered grid cells.

    Args:
        array: 3-D samples, a :class:`Volume` (which also supplies its spacing), or the path of a
            volume file, read with :func:`load_volume`. The axis that varies
            fastest in memory is x: a C array of shape (nz, ny, nx) and a Fortran array of shape
            (nx, ny, nz) are read in place. The module's kept dtypes are not copied when
            contiguous; other types and layouts are converted first (see the module docs).
        iso: isovalue in data units; a sample is inside when ``value >= iso``.
        iso_normalized: isovalue as a fraction of the finite value range, ``min + t·(max − min)``
            (the paper uses 0.5). Give exactly one of ``iso`` and ``iso_normalized``.
        spacing: sample spacing ``(sx, sy, sz)``; default the Volume's, else (1, 1, 1). A Volume's
            origin and directions are kept in the grid's ``info`` (as ``isogrid extract`` keeps
            them in the ``.cgc`` file).
        precision: bits per stored corner, 1, 4, 8, 16 or 32; default 8 for uint8, 16 otherwise.
        threads: worker threads (default all cores); the result is the same for any count.
        series: when ``array`` is the path of a DICOM folder, the SeriesInstanceUID to read, as
            :func:`load_volume` (and the CLI's ``--series``) takes it.
        origin, direction: the position ``(x, y, z)`` of sample (0, 0, 0) and the rows of world
            directions of the x, y, z axes, kept in the grid's ``info``; default the Volume's, else
            zero and identity.
        attribute: a second volume to colour the surface by (``isogrid extract --color-by``):
            each active cell stores its value at the cell's surface point (the centroid of the
            edge crossings). An array of the surface's shape lies on the surface's samples; a
            :class:`Volume` or a path brings its own geometry and is resampled trilinearly in
            world space (origin, spacing, direction), NaN outside it. Read it back as
            ``grid.attribute``; :func:`render` draws it through a colour map.
        attribute_precision: bits per stored attribute value: 8 or 16 (codes over the values'
            range on the surface) or 32 (float32).
        progress: called as ``progress(done, total)`` about ten times a second while the surface
            is extracted (blocks scanned and emitted). If it raises, or on Ctrl-C, extraction
            stops within a block row and the exception is raised.
        labels, smooth, label_table, labels_of: instead of an isovalue, the surfaces of a label
            volume's labels, as ``isogrid extract --labels`` gives them: the call is then
            :func:`extract_labels` (see there) with these arguments and the attribute.
        index: when ``array`` is a path, the entry to read of each axis beyond x, y and z, as
            :func:`load_volume` takes it (``{"t": 3}`` of a 4-D NIfTI or MGH file, ``{"c": 1}`` of a
            Zarr image or TIFF hyperstack; ``isogrid extract --index``).
        attribute_index: the same for an ``attribute`` given as a path (``--color-index``); the
            attribute is then named after both, e.g. ``"pet.nii.gz t=3"``.

    The GIL is released while extracting; do not modify ``array`` from another thread meanwhile.

    Returns:
        The :class:`CellGrid` (a :class:`LabelGrid` with ``labels``); where it has no active cell,
        an :class:`EmptySurfaceWarning` says why (the isovalue outside the samples' range, or a
        volume one sample thick).
    """
    if labels is not None:
        if iso is not None or iso_normalized is not None:
            raise ValueError("labels takes the place of iso and iso_normalized")
        return extract_labels(
            array, labels, smooth=smooth, spacing=spacing, precision=precision, threads=threads,
            series=series, origin=origin, direction=direction, label_table=label_table,
            labels_of=labels_of, progress=progress, attribute=attribute,
            attribute_precision=attribute_precision, index=index, attribute_index=attribute_index,
        )
    iso, iso_normalized = _iso_pair(iso, iso_normalized)
    if smooth is not None:
        raise ValueError("smooth smooths label indicators, and needs labels")
    if label_table is not None or labels_of is not None:
        raise ValueError("label_table and labels_of name the labels of labels=, and need it")
    _attribute_index_needs_attribute(attribute, attribute_index)
    prepared, fortran, spacing3, origin, direction, frame = _placed(array, series, spacing, origin, direction, index)
    attribute_arg = None
    if attribute is not None:
        attribute_arg = _attribute_arg(
            attribute, prepared, fortran, spacing3, origin, direction, frame,
            _int(attribute_precision, "attribute_precision"), attribute_index,
        )
    grid = _isogrid.extract(
        prepared,
        fortran,
        spacing3,
        iso=iso,
        iso_normalized=iso_normalized,
        precision=None if precision is None else _int(precision, "precision"),
        threads=None if threads is None else _int(threads, "threads", 1),
        origin=None if origin is None else _triple(origin, "origin"),
        direction=None if direction is None else [_triple(row, "direction row") for row in direction],
        attribute=attribute_arg,
        progress=progress,
        frame=frame,
    )
    _warn_if_empty(grid, prepared)
    return grid


def extract_labels(
    array: Union[np.ndarray, Volume, PathLike, Any],
    labels: Union[str, int, Iterable[int], None] = None,
    smooth: Optional[float] = None,
    spacing: Optional[Sequence[float]] = None,
    precision: Optional[int] = None,
    threads: Optional[int] = None,
    series: Optional[str] = None,
    origin: Optional[Sequence[float]] = None,
    direction: Optional[Sequence[Sequence[float]]] = None,
    label_table: Optional[PathLike] = None,
    labels_of: Optional[str] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    attribute: Union[np.ndarray, Volume, PathLike, None] = None,
    attribute_precision: int = 16,
    index: Optional[Dict[str, int]] = None,
    attribute_index: Optional[Dict[str, int]] = None,
) -> LabelGrid:
    """Extracts the surface of every selected label of a label volume in one pass
    (``isogrid extract --labels``).

    Each label's surface is the isosurface at 1/2 of its indicator (1 inside the label, 0
    elsewhere); where two labels touch, both surfaces pass through the same points.

    Args:
        array: 3-D integer labels (uint8 to uint64, int8 to int64; a float array only if every
            value is an integer), a :class:`Volume`, or the path of a label volume file. Axes and
            layouts as :func:`extract` reads them.
        labels: which labels: ``None`` or ``"all"`` (every label but 0, the background), a label,
            a list of labels, or a string such as ``"1,5-9"``; also by name (``"liver,spleen"``,
            in any case), the names the file gives (a folder of masks, a ``.seg.nrrd``, an
            OME-Zarr label image) or ``label_table``'s, which win.
        smooth: the σ in voxels of a Gaussian that smooths each indicator first, so surfaces are
            not chamfered (0 or None: none).
        spacing, precision, threads, series, origin, direction: as :func:`extract` takes them;
            ``precision`` is the bits per stored corner (default 1 without smoothing).
        label_table: a colour table file that names and colours the labels
            (``isogrid extract --label-table``): a FreeSurfer LUT, a 3D Slicer ``.ctbl``, an
            ITK-SNAP label description, or a CSV/TSV with a header naming its columns (a BIDS
            ``dseg.tsv``: ``index``, ``name``, ``color``), told apart by content. Labels it lists that the grid
            lacks give a :class:`UserWarning`. When ``array`` is a path, the file's own names and
            colours come first (a 3D Slicer ``.seg.nrrd``, whose overlapping layers become labels
            of their own; an OME-Zarr label image), and the table's win over them.
        labels_of: with the path of an OME-Zarr image, the name of its label image to extract
            (``image.zarr/labels/NAME``, ``isogrid extract --labels-of``).
        progress: called as ``progress(done, total)`` about ten times a second while the labels
            are extracted (blocks made). If it raises, or on Ctrl-C, extraction stops between
            blocks and the exception is raised.
        attribute, attribute_precision: a second volume to colour the labels' surfaces by
            (``isogrid extract --labels ... --color-by``), sampled at each active cell's surface
            point as :func:`extract` samples it: an array on the label volume's samples, or a
            :class:`Volume` or path resampled in world space.
        index, attribute_index: the entries of axes beyond x, y and z to read of ``array`` and
            ``attribute`` when they are paths, as :func:`extract` takes them.

    The GIL is released while extracting; do not modify ``array`` from another thread meanwhile.

    Returns:
        The :class:`LabelGrid`: ``grid.labels`` gives each label's value, name, colour, cell count
        and cell box, ``grid.meshes()`` each label's ``(vertices, faces)``, and :func:`render`
        draws it in the labels' colours (by the attribute's colour map when it has one). Where it has no active cell, an
        :class:`EmptySurfaceWarning` says why (no selected label in the volume, one label filling
        it, or a volume one sample thick).
    """
    selection = _label_selection("all" if labels is None else labels)
    common = dict(
        smooth=0.0 if smooth is None else float(smooth),
        precision=None if precision is None else _int(precision, "precision"),
        threads=None if threads is None else _int(threads, "threads", 1),
        label_table=None if label_table is None else os.fspath(label_table),
        progress=progress,
    )
    if isinstance(array, (str, os.PathLike)):
        # The file's own names and colours, and its layers, come with it.
        grid, notices = _isogrid.extract_labels_file(
            os.fspath(array),
            selection,
            labels_of=labels_of,
            series=series,
            spacing=None if spacing is None else _triple(spacing, "spacing"),
            origin=None if origin is None else _triple(origin, "origin"),
            direction=None if direction is None else [_triple(row, "direction row") for row in direction],
            index=_indices(index, "index"),
            **common,
        )
        grid = _with_attribute_of(grid, attribute, attribute_precision, threads, attribute_index)
        _warn_if_empty(grid)
        return _with_notices(grid, notices)
    if labels_of is not None:
        raise ValueError("labels_of names a label image of an OME-Zarr image, and needs its path")
    prepared, fortran, spacing3, origin, direction, frame = _placed(array, series, spacing, origin, direction, index)
    grid, notices = _isogrid.extract_labels(
        prepared,
        fortran,
        spacing3,
        selection,
        origin=None if origin is None else _triple(origin, "origin"),
        direction=None if direction is None else [_triple(row, "direction row") for row in direction],
        frame=frame,
        **common,
    )
    grid = _with_attribute_of(grid, attribute, attribute_precision, threads, attribute_index)
    _warn_if_empty(grid)
    return _with_notices(grid, notices)


def label_statistics(
    array: Union[np.ndarray, Volume, PathLike, Any],
    labels: Union[str, int, Iterable[int], None] = None,
    spacing: Optional[Sequence[float]] = None,
    label_table: Optional[PathLike] = None,
    labels_of: Optional[str] = None,
    series: Optional[str] = None,
    index: Optional[Dict[str, int]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> List[Dict[str, Any]]:
    """Segment statistics of a label volume, before any surface is extracted
    (``isogrid info VOLUME --labels``): each selected label's voxels, volume, box, name and colour.

    Args:
        array: 3-D integer labels, a :class:`Volume`, or the path of a label volume file, as
            :func:`extract_labels` takes it. A path is read by region where its format allows
            (Zarr, uncompressed NIfTI, NRRD and others), so a volume larger than memory is counted
            slab by slab.
        labels: which labels, as :func:`extract_labels` selects them: ``None`` or ``"all"``
            (every label but the background 0), a label, a list, ``"1,5-9"``, or names.
        spacing: the voxel's size along each axis, replacing the file's or the Volume's (default:
            theirs, or 1 for an array): volumes are in its units cubed.
        label_table, labels_of, series, index: as :func:`extract_labels` takes them.
        progress: called as ``progress(done, total)`` about ten times a second while a file is
            read by region (blocks counted), and once at the end (an array is counted in one
            step). If it raises, or on Ctrl-C, counting stops and the exception is raised.

    Returns:
        One dict per label present, by increasing value, with the keys of
        ``isogrid info --labels --json``: ``value``, ``name`` and ``color`` (``"#rrggbbaa"``) as
        :func:`extract_labels` names the label, ``voxels`` (samples holding it), ``volume``
        (``voxels`` times the product of the spacing) and ``lo``, ``hi`` (its voxels' box in
        sample indices, ``[lo, hi)`` along x, y and z). Labels a colour table lists that the volume lacks
        give a :class:`UserWarning`.
    """
    selection = _label_selection("all" if labels is None else labels)
    table = None if label_table is None else os.fspath(label_table)
    if isinstance(array, (str, os.PathLike)):
        stats, notices = _isogrid.label_statistics_file(
            os.fspath(array),
            selection,
            labels_of=labels_of,
            label_table=table,
            series=series,
            spacing=None if spacing is None else _triple(spacing, "spacing"),
            index=_indices(index, "index"),
            progress=progress,
        )
        return _with_notices(stats, notices)
    if labels_of is not None:
        raise ValueError("labels_of names a label image of an OME-Zarr image, and needs its path")
    prepared, fortran, spacing3, _, _, _ = _placed(array, series, spacing, None, None, index)
    stats, notices = _isogrid.label_statistics(
        prepared, fortran, spacing3, selection, label_table=table, progress=progress
    )
    return _with_notices(stats, notices)


def _with_attribute_of(
    grid: CellGrid, attribute: Any, precision: int, threads: Optional[int], index: Optional[Dict[str, int]] = None
) -> Any:
    """``grid`` with ``attribute`` (a path, whose extra axes ``index`` picks from, a
    :class:`Volume`, or an array on the grid's samples and geometry) sampled at its cells;
    ``grid`` itself without one."""
    _attribute_index_needs_attribute(attribute, index)
    if attribute is None:
        return grid
    bits = _int(precision, "attribute_precision")
    threads = None if threads is None else _int(threads, "threads", 1)
    if isinstance(attribute, (str, os.PathLike)):
        return _isogrid._with_attribute(
            grid, attribute_path=os.fspath(attribute), bits=bits, threads=threads,
            attribute_index=_indices(index, "attribute_index"),
        )
    info = grid.info
    attribute = _volume_of(attribute, index=index, keyword="attribute_index")
    prepared, fortran = _prepare(attribute)
    if isinstance(attribute, Volume):
        place = (attribute.spacing, attribute.origin, attribute.direction, attribute.frame)
    else:
        dims = prepared.shape if fortran else prepared.shape[::-1]
        if tuple(dims) != tuple(info["dims"]):
            raise ValueError(
                f"an attribute array of {tuple(dims)} samples (x, y, z) lies on the labels' grid of "
                f"{tuple(info['dims'])}; pass a Volume with its own geometry to resample it"
            )
        place = (info["spacing"], info["origin"], info["direction"], info["frame"])
    spacing, origin, direction, frame = place
    arg = (
        prepared, fortran, _triple(spacing, "spacing"), _triple(origin, "origin"),
        [_triple(row, "direction row") for row in direction], frame, "attribute", bits,
    )
    return _isogrid._with_attribute(grid, array=arg, bits=bits, threads=threads)


def _placed(
    array: Any,
    series: Optional[str],
    spacing: Optional[Sequence[float]],
    origin: Optional[Sequence[float]],
    direction: Optional[Sequence[Sequence[float]]],
    index: Optional[Dict[str, int]] = None,
) -> Tuple[np.ndarray, bool, Triple, Any, Any, Optional[str]]:
    """The samples of ``array`` (an array, a Volume or a path, whose extra axes ``index`` picks
    from) as the extension takes them, with its spacing, origin and direction (the arguments
    where given, else a Volume's own) and a Volume's world frame."""
    array = _volume_of(array, series, index)
    spacing3 = _spacing_of(array, spacing)
    frame = None
    if isinstance(array, Volume):
        origin = array.origin if origin is None else origin
        direction = array.direction if direction is None else direction
        frame = array.frame
    prepared, fortran = _prepare(array)
    return prepared, fortran, spacing3, origin, direction, frame


def _with_notices(result: Any, notices: Sequence[str]) -> Any:
    """The result (a grid, statistics), after each notice of its making as a :class:`UserWarning`,
    attributed to the caller's line outside this package."""
    for notice in notices:
        warnings.warn(notice, UserWarning, stacklevel=_caller_level())
    return result


def _caller_level() -> int:
    """The ``stacklevel`` of the first frame outside this module, seen from its caller."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] == __name__:
        frame, level = frame.f_back, level + 1
    return level


def _label_selection(labels: Any, name: str = "labels") -> str:
    """`labels` of :func:`extract` (or ``show``/``hide`` of :func:`render`, ``name``) as the
    selection text the extension parses (``all``, ``1,5-9,liver``): a string, a label, or a list
    of labels and names."""
    if isinstance(labels, str):
        return labels
    if isinstance(labels, (int, np.integer)) and not isinstance(labels, bool):
        return str(int(labels))
    try:
        values = [v if isinstance(v, str) else str(_int(v, "a label", minimum=-(2**63))) for v in labels]
    except TypeError:
        raise ValueError(
            f"{name} must be 'all', a label or a list of labels and names, not {labels!r}"
        ) from None
    if not values:
        raise ValueError(f"{name} is an empty list")
    return ",".join(values)


def _attribute_arg(
    attribute: Any,
    surface: np.ndarray,
    fortran: bool,
    spacing: Triple,
    origin: Optional[Sequence[float]],
    direction: Optional[Sequence[Sequence[float]]],
    frame: Optional[str],
    bits: int,
    index: Optional[Dict[str, int]] = None,
) -> Tuple[Any, ...]:
    """The attribute of :func:`extract` as the extension takes it: (array, fortran, spacing,
    origin, direction, frame, name, bits), an array on the surface's samples taking the surface's
    geometry and world frame; a path's extra axes picked by ``index`` (``attribute_index``) and
    named with it, as the CLI names ``--color-by FILE --color-index t=3``."""
    name = "attribute"
    if isinstance(attribute, (str, os.PathLike)):
        name = os.path.basename(os.fspath(attribute))
        if index:
            name += " " + ",".join(f"{a}={i}" for a, i in (_indices(index, "attribute_index") or []))
    attribute = _volume_of(attribute, index=index, keyword="attribute_index")
    prepared, attribute_fortran = _prepare(attribute)
    if isinstance(attribute, Volume):
        return (prepared, attribute_fortran, attribute.spacing, attribute.origin, attribute.direction, attribute.frame,
                name, bits)
    dims = prepared.shape if attribute_fortran else prepared.shape[::-1]
    surface_dims = surface.shape if fortran else surface.shape[::-1]
    if tuple(dims) != tuple(surface_dims):
        raise ValueError(
            f"an attribute array of {tuple(dims)} samples (x, y, z) lies on the surface's grid of "
            f"{tuple(surface_dims)}; pass a Volume with its own geometry to resample it"
        )
    return (
        prepared,
        attribute_fortran,
        spacing,
        None if origin is None else _triple(origin, "origin"),
        None if direction is None else [_triple(row, "direction row") for row in direction],
        frame,
        name,
        bits,
    )


def load(path: PathLike) -> CellGrid:
    """Opens a ``.cgc`` file written by :meth:`CellGrid.save` or ``isogrid extract -o``.

    The file is memory-mapped and fully validated (sizes, checksums, pointers) before use; the
    grid's ``blocks``, ``metacells`` and ``cells`` views then read the page cache directly.
    """
    return _isogrid.load(os.fspath(path))


def load_volume(
    path: PathLike,
    raw_shape: Optional[Sequence[int]] = None,
    raw_dtype: Any = None,
    big_endian: bool = False,
    series: Optional[str] = None,
    level: int = 0,
    index: Optional[Dict[str, int]] = None,
) -> Volume:
    """Reads a volume file: NIfTI-1 and NIfTI-2 (``.nii``, ``.nii.gz``, ``.hdr``/``.img`` pairs), NRRD (``.nrrd``, ``.nhdr``), NumPy
    ``.npy``, TIFF stacks or a folder of TIFF slices, a DICOM series (a folder), MetaImage
    (``.mha``, ``.mhd`` + data file; raw or zlib), FreeSurfer MGH (``.mgh``, ``.mgz``), MRC/CCP4 maps
    (``.mrc``, ``.map``, ``.ccp4``,
    ``.mrcs``), VTK XML image data (``.vti``), Zarr v2/v3 and OME-Zarr 0.4/0.5 (a folder, or an ``http://`` URL), or headerless
    raw samples. Other names are recognised by their content.

    Samples keep the file's storage order (no reorientation or resampling) and come back as a
    :class:`Volume` whose ``array`` is C-ordered with shape ``(nz, ny, nx)`` — the reader's buffer
    handed to NumPy without a copy — and whose ``spacing``/``origin`` are (x, y, z). MRC maps are
    the one exception to the storage order: their columns, rows and sections are permuted to
    x, y, z by the header's MAPC/MAPR/MAPS, as ChimeraX shows them.
    ``extract(load_volume(p), ...)`` therefore matches ``isogrid extract p`` on the command line.

    Args:
        raw_shape: for raw files, samples per axis **(nx, ny, nz)**, x fastest — the order of the
            CLI's ``--raw-shape X,Y,Z``, i.e. the reverse of the returned array's shape.
        raw_dtype: for raw files, uint8, uint16, int16, uint32, int32, uint64, int64, float32 or
            float64 (any NumPy dtype spelling;
            an explicit ``'>'`` byte order implies ``big_endian``).
        big_endian: raw samples are big-endian.
        series: for DICOM, the SeriesInstanceUID to read (the CLI's ``--series``); by default
            the series with the most slices is read and a :class:`UserWarning` names the others.
            A UID the folder does not hold is an error that lists the series it has.
        level: OME-Zarr resolution level (0 = full resolution).
        index: Zarr axes other than x, y, z and the entry to read of each, e.g.
            ``{"t": 0, "c": 1}``; 4-D and 5-D arrays need it (the error names the axes). It also
            picks the channel and time point of an ImageJ hyperstack or OME-TIFF with several
            (``{"c": 1}``), and the volume of a 4-D NIfTI or MGH file (``{"t": 3}``).
    """
    dtype_name = None
    if raw_dtype is not None:
        dt = np.dtype(raw_dtype)
        big_endian = big_endian or dt.byteorder == ">"
        dtype_name = dt.newbyteorder("=").name
    shape = None
    if raw_shape is not None:
        shape = [_int(n, "raw_shape", 1) for n in raw_shape]
        if len(shape) != 3:
            raise ValueError(f"raw_shape must be three positive integers (nx, ny, nz), not {tuple(raw_shape)}")
    if series is not None and not isinstance(series, str):
        raise TypeError(f"series must be a SeriesInstanceUID string, not {type(series).__name__}")
    return _load(path, shape, dtype_name, bool(big_endian), series, _int(level, "level", 0), index, "index")


def _load(path: PathLike, shape: Optional[Sequence[int]], dtype_name: Optional[str], big_endian: bool,
          series: Optional[str], level: int, index: Optional[Dict[str, int]], keyword: str) -> Volume:
    """:func:`load_volume` with its arguments checked; errors about ``index`` name ``keyword``
    (``index`` or ``attribute_index``), the argument that gave it."""
    d = _isogrid.load_volume(
        os.fspath(path), shape, dtype_name, big_endian, series, level, _indices(index, keyword), keyword
    )
    for notice in d["notices"]:
        warnings.warn(f"{os.fspath(path)}: {notice}", UserWarning, stacklevel=_caller_level())
    return Volume(d["array"], d["spacing"], d["origin"], d["direction"], d.get("frame"))


def _attribute_index_needs_attribute(attribute: Any, attribute_index: Optional[Dict[str, int]]) -> None:
    if attribute is None and attribute_index is not None:
        raise ValueError("attribute_index picks from the axes of an attribute path, and needs attribute")


def _indices(index: Optional[Dict[str, int]], name: str) -> Optional[List[Tuple[str, int]]]:
    """``index`` (``{"t": 3}``) as the extension takes it: (axis, entry) pairs."""
    if index is None:
        return None
    if not isinstance(index, dict):
        raise TypeError(f"{name} must be a dict of axis name to entry, e.g. {{'t': 0}}, not {type(index).__name__}")
    return [(str(a), _int(i, name, 0)) for a, i in index.items()]


def marching_cubes(
    array: Union[np.ndarray, Volume, PathLike, Any],
    iso: Optional[float] = None,
    iso_normalized: Optional[float] = None,
    spacing: Optional[Sequence[float]] = None,
    threads: Optional[int] = None,
    series: Optional[str] = None,
    space: str = "world",
    attribute: Union[np.ndarray, Volume, PathLike, None] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    index: Optional[Dict[str, int]] = None,
    attribute_index: Optional[Dict[str, int]] = None,
) -> Tuple[np.ndarray, ...]:
    """Marching Cubes isosurface of a 3-D volume: the indexed mesh baseline of the paper.

    ``array``, ``iso``, ``iso_normalized``, ``spacing`` and ``series`` are read as by
    :func:`extract`. ``space`` is ``"world"`` or ``"index"`` (see below). ``attribute`` is a
    second volume as :func:`extract` takes it (an array on the same samples, or a
    :class:`Volume` or path resampled in world space): its trilinear value at every vertex comes
    back as a third array, float32 of shape (V,), NaN outside it. ``progress`` is called as
    ``progress(done, total)`` (sample planes) while it runs; if it raises, or on Ctrl-C, the work
    stops within a slab and the exception is raised. ``index`` and ``attribute_index`` pick the
    entries of extra axes of ``array`` and ``attribute`` when they are paths, as for
    :func:`extract`.

    Returns:
        ``(vertices, faces)``: vertices float32 of shape (V, 3) as **(x, y, z)**. In ``"world"``
        space (the default) sample (i, j, k) is at ``origin + i·sx·d_i + j·sy·d_j + k·sz·d_k``
        with a :class:`Volume`'s origin and direction rows ``d_i, d_j, d_k`` (zero and identity
        for a bare array): the volume's patient space, where nibabel's affine, 3D Slicer and
        ITK-SNAP place the image. In ``"index"`` space it is at ``(i, j, k)``. For a C array
        ``a[z, y, x]`` the columns are reversed relative to its axes. Faces uint32 of shape
        (T, 3), counter-clockwise seen from outside
        (where value < iso). One vertex per crossed edge, no duplicates: where crossings fall
        exactly on a sample (integer data at an integer iso), the edges meeting there share one
        vertex and the triangles that collapse are dropped, so no triangle has zero area.
        Where there is no triangle, an :class:`EmptySurfaceWarning` says why, as for
        :func:`extract`.
    """
    iso, iso_normalized = _iso_pair(iso, iso_normalized)
    array = _volume_of(array, series, index)
    spacing3 = _spacing_of(array, spacing)
    if space not in ("world", "index"):
        raise ValueError(f"space must be 'world' or 'index', not {space!r}")
    origin = array.origin if isinstance(array, Volume) else None
    direction = array.direction if isinstance(array, Volume) else None
    frame = array.frame if isinstance(array, Volume) else None
    prepared, fortran = _prepare(array)
    _attribute_index_needs_attribute(attribute, attribute_index)
    attribute_arg = None
    if attribute is not None:
        attribute_arg = _attribute_arg(attribute, prepared, fortran, spacing3, origin, direction, frame, 32,
                                       attribute_index)
    mesh = _isogrid.marching_cubes(
        prepared,
        fortran,
        spacing3,
        iso=iso,
        iso_normalized=iso_normalized,
        threads=None if threads is None else _int(threads, "threads", 1),
        origin=origin,
        direction=direction,
        index_space=space == "index",
        attribute=attribute_arg,
        progress=progress,
        frame=frame,
    )
    if len(mesh[1]) == 0:
        # As extract warns, and `isogrid mc` notes.
        note = _isogrid._isosurface_empty_note(prepared, fortran, iso=iso, iso_normalized=iso_normalized)
        warnings.warn(note, EmptySurfaceWarning, stacklevel=_caller_level())
    return mesh  # type: ignore[no-any-return]


def voxelize(
    vertices: Any,
    faces: Any,
    resolution: int = 256,
    supersample: int = 3,
    padding: int = 2,
    cube: bool = False,
    threads: Optional[int] = None,
) -> Volume:
    """Solid voxelisation of a triangle mesh into an 8-bit coverage volume (paper §4).

    The mesh's bounding box spans ``resolution − 2·padding`` samples along its longest axis with
    ``padding`` empty samples on each side; each sample is split into ``supersample³`` fine
    voxels, inside by a three-axis ray-parity vote (robust to small holes), and stores
    ``round(255 · inside fraction)``. Render or extract it at ``iso_normalized=0.5``. With
    ``cube=True`` every axis gets ``resolution`` samples and the mesh is centred (the paper's
    datasets are cubes, e.g. the 512³ Dragon).

    Args:
        vertices: (V, 3) positions (x, y, z), any real dtype (used as float32).
        faces: (T, 3) vertex indices, any integer dtype.

    Returns:
        A :class:`Volume`: uint8 ``array`` of shape (nz, ny, nx), cubic ``spacing`` in mesh units
        and ``origin`` = world position of sample (0, 0, 0) in mesh coordinates, so that
        ``marching_cubes(voxelize(v, f), iso_normalized=0.5)`` lands on the mesh ``(v, f)``.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float32)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1:] != (3,):
        raise ValueError(f"vertices must have shape (V, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1:] != (3,):
        raise ValueError(f"faces must have shape (T, 3), got {f.shape}")
    if f.dtype.kind not in "iu":
        raise ValueError(f"faces must be integers, got dtype {f.dtype}")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"face indices must lie in 0..{len(v) - 1}")
    f = np.ascontiguousarray(f, dtype=np.uint32)
    d = _isogrid.voxelize(
        v,
        f,
        _int(resolution, "resolution", 1),
        _int(supersample, "supersample", 1),
        _int(padding, "padding"),
        cube=bool(cube),
        threads=None if threads is None else _int(threads, "threads", 1),
    )
    return Volume(d["array"], d["spacing"], d["origin"], d["direction"], d.get("frame"))


# --- preparing arguments -------------------------------------------------------------------------

_KEPT = {
    np.dtype(t)
    for t in (
        np.uint8,
        np.uint16,
        np.int16,
        np.float32,
        np.uint32,
        np.int32,
        np.uint64,
        np.int64,
        np.float64,
    )
}


def render(
    grid: "CellGrid",
    camera: Any = 1,
    size: Tuple[int, int] = (640, 480),
    mode: str = "cgc",
    backend: str = "auto",
    aovs: Sequence[str] = (),
    frames: int = 1,
    spp: int = 16,
    bounces: int = 3,
    threads: Optional[int] = None,
    traversal: str = "blocks",
    env: Optional[Union[str, "os.PathLike[str]"]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    cmap: Optional[str] = None,
    clim: Optional[Tuple[float, float]] = None,
    show: Optional[Union[str, Sequence[int]]] = None,
    hide: Optional[Union[str, Sequence[int]]] = None,
    frame: str = "grid",
) -> Any:
    """An image of the isosurface, as ``isogrid render`` draws it.

    World space is the grid's: sample ``(i, j, k)`` at ``(i·sx, j·sy, k·sz)``; pixel (0, 0) is the
    top-left and each pixel's ray passes through its centre.

    Args:
        grid: a :class:`CellGrid` or :class:`LabelGrid` (from :func:`extract`, :func:`extract_labels` or :func:`load`).
        camera: ``1`` (front) or ``2`` (oblique) for the standard views of the box ``frame``
            names, or ``(eye, target, up, fovy_degrees)`` with points as (x, y, z) in index ×
            spacing units (sample (i, j, k) at (i·sx, j·sy, k·sz)).
        size: ``(width, height)`` in pixels.
        mode: ``"cgc"`` (cell rasterisation with EWA normals on a GPU; ray traced on the CPU),
            ``"cgc-noewa"`` (GPU only), ``"pathtrace"`` (``spp`` samples per pixel under
            ``env``; the GPU takes one sample per frame) or, for a label grid, ``"mc"`` (GPU
            only: the Marching Cubes meshes of its labels' cells, in their colours, or by the
            attribute with each vertex the mean of its label's cells around it).
        backend: ``"auto"`` (a hardware GPU adapter when there is one; with only a software one
            such as lavapipe, whichever was measured faster for the mode, see
            ``docs/benchmarks-render-policy.md``; else the CPU), ``"gpu"`` (any adapter, lavapipe
            included) or ``"cpu"``.
        aovs: any of ``"depth"`` (H×W float32 eye distance, +inf on misses), ``"normal"``
            (H×W×3 float32 unit world normal, NaN on misses), ``"cluster"`` (H×W uint32,
            4294967295 on misses), ``"value"`` (H×W float32, the grid's attribute at the hit
            cell, NaN on misses; grids with an attribute), ``"label"`` (H×W uint64, the label
            value under the pixel, 18446744073709551615 on misses; label grids),
            ``"backend"`` (which backend rendered).
        frames: on the GPU, how many times the view is rendered (the visibility buffer converges).
        spp: path tracing: samples per pixel, on either backend.
        bounces: path tracing: scatterings per path.
        threads: CPU worker threads (default: all cores).
        traversal: on the CPU, how rays find the cells they may cross: ``"blocks"`` (the paper's
            block walk) or ``"bvh"`` (a hierarchy over the metacells: each ray a little faster,
            but slower to build); the same image either way.
        env: path tracing: an equirectangular ``.hdr`` or ``.exr`` map (+y up), or ``None`` for
            the built-in sky.
        cmap: colour map of a grid with an attribute: ``"viridis"`` (default), ``"magma"``,
            ``"inferno"``, ``"plasma"``, ``"cividis"``, ``"turbo"``, ``"gray"`` or ``"rdbu"``. A grid
            with an attribute is always drawn in colour, by either backend in every mode (path
            tracing takes the colour as albedo), a label grid with one too (its labels' colours
            otherwise).
        clim: ``(lo, hi)``, the values the map spans (default the attribute's range on the surface).
        show: a label grid: draw only these labels, as ``"1,5-9,liver"`` or a list of values and
            names (``[1, "liver"]``; a name picks the labels that have it, in any case; default
            all).
        hide: a label grid: do not draw these labels (``"0,3"`` or a list); their neighbours
            show their own surfaces where they touched them. A value or name naming no label of
            the grid raises ValueError.
        frame: what the standard views frame: ``"grid"`` (the grid's box) or ``"surface"`` (the
            box of the active cells; with ``show``/``hide``, of the shown labels'), as ``isogrid
            render --frame``.
        progress: called as ``progress(done, total)`` about ten times a second while the render
            runs, with ``done`` increasing (image rows of each pass on the CPU, frames on the GPU)
            and once at the end. If it raises, the render stops within a tile or a frame and the
            exception propagates. Ctrl-C stops the render the same way.

    The grid is drawn in index × spacing space (the camera's coordinates; directions are not
    applied); where its axes are a mirror image of the world's (FreeSurfer's LIA, FSL's LAS), the
    image is mirrored back, so that it shows the world as it lies rather than left and right
    swapped.

    Returns:
        The sRGB image as a uint8 array of shape (H, W, 3); with ``aovs``, ``(image, {name: value})``.
    """
    if not isinstance(grid, CellGrid):
        raise ValueError(f"render needs a CellGrid, got {type(grid).__name__}")
    w, h = (_int(v, "size", 1) for v in size)
    names = tuple(aovs)
    for name in names:
        if name not in ("depth", "normal", "cluster", "value", "label", "backend"):
            raise ValueError(
                f"unknown AOV {name!r} (depth, normal, cluster, value, label or backend)"
            )
    if "value" in names and grid.attribute is None:
        raise ValueError("the value AOV is the grid's attribute, and the grid has none")
    if "label" in names and grid.labels is None:
        raise ValueError("the label AOV needs a label grid (extract with labels=...)")
    with _vulkan_device_select_quieted():
        out = _isogrid.render(
            grid,
            camera,
            w,
            h,
            str(mode),
            str(backend),
            frames=_int(frames, "frames", 1),
            spp=_int(spp, "spp", 1),
            bounces=_int(bounces, "bounces"),
            threads=None if threads is None else _int(threads, "threads", 1),
            traversal=str(traversal),
            env=None if env is None else os.fspath(env),
            progress=progress,
            cmap=None if cmap is None else str(cmap),
            clim=None if clim is None else (float(clim[0]), float(clim[1])),
            show=None if show is None else _label_selection(show, "show"),
            hide=None if hide is None else _label_selection(hide, "hide"),
            frame=str(frame),
        )
    if not names:
        return out["image"]
    return out["image"], {name: out[name] for name in names}


def _sample_dtype(dtype: np.dtype) -> np.dtype:
    """The supported type samples of `dtype` are read as (see the module docs)."""
    if dtype.kind == "b":
        return np.dtype(np.uint8)
    if dtype.kind not in "iuf":
        raise ValueError(f"unsupported sample dtype {dtype}: expected a real number type")
    native = dtype.newbyteorder("=")
    if native in _KEPT:
        return native
    if native == np.dtype(np.int8):
        return np.dtype(np.int16)
    if native == np.dtype(np.float16):
        return np.dtype(np.float32)
    raise ValueError(f"unsupported sample dtype {dtype}")


def _layout(a: np.ndarray) -> Tuple[np.ndarray, bool]:
    """(a, whether x is its first axis): the axis rule of the module docs."""
    if a.flags.c_contiguous:
        return a, False
    if a.flags.f_contiguous:
        return a, True
    return a, abs(a.strides[0]) < abs(a.strides[-1])


def _prepare(array: Any) -> Tuple[np.ndarray, bool]:
    """A 3-D, supported-type, aligned array contiguous in its own order (copied only if needed)."""
    if isinstance(array, Volume):
        array = array.array
    a = np.asarray(array)
    if a.ndim > 3:
        # nibabel returns many NIfTI volumes as (x, y, z, 1): length-1 axes after the volume's
        # three (the slowest in memory: last in Fortran order, first in C order) are dropped.
        _, fortran = _layout(a)
        while a.ndim > 3 and (a.shape[-1] if fortran else a.shape[0]) == 1:
            a = a[..., 0] if fortran else a[0]
    if a.ndim != 3:
        raise ValueError(
            f"expected a 3-D array, got {a.ndim} dimension{'' if a.ndim == 1 else 's'} (shape {a.shape})"
        )
    _, fortran = _layout(a)
    order = "F" if fortran else "C"
    return np.require(a, dtype=_sample_dtype(a.dtype), requirements=[order, "A"]), fortran


def _volume_of(
    array: Any, series: Optional[str] = None, index: Optional[Dict[str, int]] = None, keyword: str = "index"
) -> Any:
    """A path is read with :func:`load_volume` (picking DICOM ``series`` and the entries
    ``index``, given as the argument ``keyword``); arrays and Volumes pass through."""
    if isinstance(array, (str, os.PathLike)):
        if series is not None and not isinstance(series, str):
            raise TypeError(f"series must be a SeriesInstanceUID string, not {type(series).__name__}")
        return _load(array, None, None, False, series, 0, index, keyword)
    if series is not None:
        raise ValueError("series picks a DICOM series when reading a path; this input is not a path")
    if index is not None:
        raise ValueError(
            f"{keyword} picks entries of a path's axes beyond x, y and z; this input is an array or "
            "Volume already (slice it, or give load_volume's index= when loading it)"
        )
    return array


def _spacing_of(array: Any, spacing: Optional[Sequence[float]]) -> Triple:
    if spacing is None:
        return array.spacing if isinstance(array, Volume) else (1.0, 1.0, 1.0)
    return _triple(spacing, "spacing")


def _triple(values: Sequence[float], name: str) -> Triple:
    t = tuple(float(v) for v in values)
    if len(t) != 3:
        raise ValueError(f"{name} must have 3 values (x, y, z), got {len(t)}")
    return t  # type: ignore[return-value]


def _iso_pair(iso: Optional[float], iso_normalized: Optional[float]) -> Tuple[Optional[float], Optional[float]]:
    if (iso is None) == (iso_normalized is None):
        raise ValueError("give exactly one of iso and iso_normalized")
    return (
        None if iso is None else float(iso),
        None if iso_normalized is None else float(iso_normalized),
    )


def _int(value: Any, name: str, minimum: int = 0) -> int:
    """`value` as an int >= minimum; floats and bools are refused rather than truncated."""
    try:
        if isinstance(value, bool):
            raise TypeError
        n = operator.index(value)
    except TypeError:
        raise ValueError(f"{name} must be an integer, not {value!r}") from None
    if n < minimum:
        raise ValueError(f"{name} must be at least {minimum}, not {n}")
    return n


# Last: it uses the helpers above.
from . import skimage  # noqa: E402

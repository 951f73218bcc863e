"""Type stubs of the native module; use the wrappers in `isogrid` (they prepare the arrays)."""

import os
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, "os.PathLike[str]"]

__version__: str
BLOCK_CELLS: int

class IsogridError(ValueError):
    """A file isogrid cannot use: malformed, truncated, inconsistent or of an unsupported kind."""

class CellGrid:
    """Clustered grid cells (paper §3.1) of one isosurface."""

    def __new__(cls, data: bytes) -> "CellGrid":
        """A grid from the bytes of a ``.cgc`` file, fully validated."""
    def to_bytes(self) -> bytes:
        """The grid as the bytes of a ``.cgc`` file (what ``save`` writes)."""
    def __reduce__(self) -> Tuple[Any, Tuple[bytes]]: ...

    @property
    def stats(self) -> Dict[str, Any]:
        """dims, iso, precision, active_cells, metacells, metacell_slots, clusters, blocks,
        nonempty_blocks, bytes {blocks, metacells, cells, paper_total}, bytes_per_cell, attribute
        (None, or {name, bits, range, bytes, bytes_per_cell}), and labels for a label volume's grid."""
    @property
    def info(self) -> Dict[str, Any]:
        """dims, spacing, origin, direction, frame ("LPS", "RAS" or None), axes (e.g. "LIA", or
        None), scalar_type, value_range, iso, precision, iso_code, mapping {offset, step,
        iso_code}, world_bounds."""
    @property
    def active_cells(self) -> int: ...
    @property
    def is_mapped(self) -> bool: ...
    @property
    def attribute(self) -> Optional[npt.NDArray[np.float32]]:
        """The per-cell attribute's values (one per active cell, NaN where none), or None."""
    @property
    def attribute_codes(self) -> Optional[np.ndarray]:
        """The attribute as stored: a read-only view of uint8/uint16 codes or float32 values."""
    @property
    def attribute_info(self) -> Optional[Dict[str, Any]]:
        """name, bits (8, 16 or 32) and range (finite, on the surface) of the attribute, or None."""
    @property
    def labels(self) -> Optional[List[Dict[str, Any]]]:
        """For a label volume's grid: value, name, color ("#rrggbbaa"), cells, lo, hi per label."""
    @property
    def cluster_labels(self) -> Optional[npt.NDArray[np.uint32]]:
        """For a label volume's grid: each cluster's index into ``labels``."""
    @property
    def blocks(self) -> np.ndarray:
        """Read-only, fields metacell_count u4, metacell_pointer u4, min f4, max f4."""
    @property
    def metacells(self) -> np.ndarray:
        """Read-only, fields position (3,)u2, cell_mask u2, cell_pointer u4."""
    @property
    def cells(self) -> npt.NDArray[np.uint8]:
        """Read-only, shape (active_cells, bytes_per_cell)."""
    def cell_positions(self) -> npt.NDArray[np.uint32]: ...
    def corners(self) -> npt.NDArray[np.float32]: ...
    def save(self, path: _Path) -> None:
        """Writes a ``.cgc`` file, or to a name ending in ``.cgcz`` its packed transfer form (what
        ``isogrid pack`` writes, for the web viewer); atomically."""

class LabelGrid(CellGrid):
    """The grid of a label volume: each cluster belongs to one label."""

    def __new__(cls, data: bytes) -> "LabelGrid":
        """A label grid from the bytes of a ``.cgc`` file that holds labels, fully validated."""
    def meshes(
        self, space: str = "world", threads: Optional[int] = None, *, values: bool = False
    ) -> Dict[int, Tuple[npt.NDArray[Any], ...]]:
        """Each label's (vertices float32, faces uint32), by label value, in the order of
        ``labels``; with ``values=True`` also the grid's attribute at the vertices (float32)."""
    def write_meshes(self, path: _Path, space: str = "world", threads: Optional[int] = None) -> None:
        """Each label's mesh written as ``isogrid mc --labels -o PATH`` writes it: a ``.glb`` or
        ``.vtp``, a neuroglancer folder, or one file per label from a template such as
        ``"organs/{name}.stl"``."""

def extract(
    array: np.ndarray,
    fortran: bool,
    spacing: Sequence[float],
    iso: Optional[float] = None,
    iso_normalized: Optional[float] = None,
    precision: Optional[int] = None,
    threads: Optional[int] = None,
    origin: Optional[Sequence[float]] = None,
    direction: Optional[Sequence[Sequence[float]]] = None,
    attribute: Optional[Tuple[Any, ...]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    frame: Optional[str] = None,
) -> CellGrid: ...
def extract_labels(
    array: np.ndarray,
    fortran: bool,
    spacing: Sequence[float],
    labels: str,
    smooth: float = 0.0,
    precision: Optional[int] = None,
    threads: Optional[int] = None,
    origin: Optional[Sequence[float]] = None,
    direction: Optional[Sequence[Sequence[float]]] = None,
    label_table: Optional[_Path] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    frame: Optional[str] = None,
) -> Tuple[LabelGrid, List[str]]: ...
def extract_labels_file(
    path: _Path,
    labels: str,
    smooth: float = 0.0,
    precision: Optional[int] = None,
    threads: Optional[int] = None,
    labels_of: Optional[str] = None,
    label_table: Optional[_Path] = None,
    series: Optional[str] = None,
    spacing: Optional[Sequence[float]] = None,
    origin: Optional[Sequence[float]] = None,
    direction: Optional[Sequence[Sequence[float]]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    index: Optional[Sequence[Tuple[str, int]]] = None,
) -> Tuple[LabelGrid, List[str]]: ...
def label_statistics(
    array: np.ndarray,
    fortran: bool,
    spacing: Sequence[float],
    labels: str,
    label_table: Optional[_Path] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> Tuple[List[Dict[str, Any]], List[str]]: ...
def label_statistics_file(
    path: _Path,
    labels: str,
    labels_of: Optional[str] = None,
    label_table: Optional[_Path] = None,
    series: Optional[str] = None,
    spacing: Optional[Sequence[float]] = None,
    index: Optional[Sequence[Tuple[str, int]]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> Tuple[List[Dict[str, Any]], List[str]]: ...
def load(path: _Path) -> Union[CellGrid, LabelGrid]: ...
def _attach_attribute(
    path: _Path,
    attribute_path: Optional[_Path] = None,
    array: Optional[Tuple[Any, ...]] = None,
    bits: int = 16,
    threads: Optional[int] = None,
    attribute_index: Optional[Sequence[Tuple[str, int]]] = None,
) -> None: ...
def _with_attribute(
    grid: CellGrid,
    attribute_path: Optional[_Path] = None,
    array: Optional[Tuple[Any, ...]] = None,
    bits: int = 16,
    threads: Optional[int] = None,
    attribute_index: Optional[Sequence[Tuple[str, int]]] = None,
) -> Union[CellGrid, LabelGrid]: ...
def _empty_surface_note(grid: CellGrid, all_nan: bool = False) -> str: ...
def _axis_codes(direction: Sequence[Sequence[float]], frame: Optional[str] = None) -> Optional[str]: ...
def _isosurface_empty_note(
    array: np.ndarray,
    fortran: bool,
    iso: Optional[float] = None,
    iso_normalized: Optional[float] = None,
) -> str: ...
def marching_cubes(
    array: np.ndarray,
    fortran: bool,
    spacing: Sequence[float],
    iso: Optional[float] = None,
    iso_normalized: Optional[float] = None,
    threads: Optional[int] = None,
    origin: Optional[Sequence[float]] = None,
    above: bool = False,
    direction: Optional[Sequence[Sequence[float]]] = None,
    index_space: bool = False,
    attribute: Optional[Tuple[Any, ...]] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    frame: Optional[str] = None,
) -> Tuple[np.ndarray, ...]: ...
def skimage_normals_values(
    array: np.ndarray,
    fortran: bool,
    positions: npt.NDArray[np.float32],
    faces: npt.NDArray[np.uint32],
    level: float,
) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
def load_volume(
    path: _Path,
    raw_shape: Optional[Sequence[int]] = None,
    raw_dtype: Optional[str] = None,
    big_endian: bool = False,
    series: Optional[str] = None,
    level: int = 0,
    index: Optional[Sequence[Tuple[str, int]]] = None,
    index_keyword: str = "index",
) -> Dict[str, Any]: ...
def voxelize(
    vertices: npt.NDArray[np.float32],
    faces: npt.NDArray[np.uint32],
    resolution: int,
    supersample: int = 3,
    padding: int = 2,
    cube: bool = False,
    threads: Optional[int] = None,
) -> Dict[str, Any]: ...
def render(
    grid: CellGrid,
    camera: Any,
    width: int,
    height: int,
    mode: str,
    backend: str,
    frames: int = 1,
    spp: int = 16,
    bounces: int = 3,
    threads: Optional[int] = None,
    traversal: str = "blocks",
    env: Optional[_Path] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    cmap: Optional[str] = None,
    clim: Optional[Tuple[float, float]] = None,
    show: Optional[str] = None,
    hide: Optional[str] = None,
    frame: str = "grid",
) -> Dict[str, Any]: ...

# Tiled extraction, driven by `isogrid.dask`.
def _ome_level_path(location: str, attrs_json: str, level: int) -> str: ...
def _zarr_selection(
    location: str,
    shape: Sequence[int],
    axes: Optional[Sequence[str]] = None,
    group_attrs: Optional[str] = None,
    level: int = 0,
    index: Optional[Sequence[Tuple[str, int]]] = None,
) -> Dict[str, Any]: ...
def _check_precision(bits: int) -> None: ...
class _TaskCancel:
    """The stop flag the running tile tasks of one `isogrid.dask` pass watch, in this process."""

    def __new__(cls) -> "_TaskCancel": ...
    def cancel(self) -> None: ...
    @property
    def cancelled(self) -> bool: ...

def _scan_tile(
    tile: npt.NDArray[Any],
    volume_dims: Tuple[int, int, int],
    first_block: Tuple[int, int, int],
    iso: float,
    cancel: Optional[_TaskCancel] = None,
) -> bytes: ...
def _emit_tile(tile: npt.NDArray[Any], job: bytes, index: int, cancel: Optional[_TaskCancel] = None) -> bytes: ...
def _extract_tile(
    tile: npt.NDArray[Any],
    task: bytes,
    first_block: Tuple[int, int, int],
    output_bytes: int,
    cancel: Optional[_TaskCancel] = None,
) -> bytes: ...

class _TileExtraction:
    """Collects scan or one-pass tile fragments, plans emit jobs and writes the `.cgc` file."""

    def __new__(
        cls,
        dims: Tuple[int, int, int],
        dtype: str,
        spacing: Sequence[float],
        origin: Sequence[float],
        iso: Optional[float] = None,
        iso_normalized: Optional[float] = None,
        precision: Optional[int] = None,
        value_range: Optional[Tuple[float, float]] = None,
        direction: Optional[Sequence[Sequence[float]]] = None,
    ) -> "_TileExtraction": ...
    @property
    def iso(self) -> float: ...
    def add_scan(self, fragment: bytes) -> None: ...
    def one_pass_task(self) -> Optional[bytes]: ...
    def spool_in(self, dir: _Path) -> None: ...
    def add_tile(self, fragment: bytes) -> None: ...
    def plan_emits(
        self, tile_blocks: Tuple[int, int, int], job_bytes: int
    ) -> List[Tuple[Tuple[Tuple[int, int], Tuple[int, int], Tuple[int, int]], bytes]]: ...
    def write(self, path: _Path, fragments: Iterable[bytes]) -> Dict[str, Any]: ...

# Label extraction by runs of blocks, each task's output capped, driven by `isogrid.dask`.
def _label_slab(
    slab: npt.NDArray[Any],
    volume_dims: Tuple[int, int, int],
    blocks: Tuple[int, int],
    labels: str,
    smooth: float,
    output_cap: int,
    precision: Optional[int] = None,
    cancel: Optional[_TaskCancel] = None,
) -> Tuple[Tuple[int, int], bytes]: ...

class _LabelWriter:
    """Collects label slab fragments in any order and writes the `.cgc` file."""

    def __new__(
        cls,
        dims: Tuple[int, int, int],
        dtype: str,
        spacing: Sequence[float],
        origin: Sequence[float],
        labels: str,
        smooth: float,
        spool_dir: _Path,
        precision: Optional[int] = None,
        direction: Optional[Sequence[Sequence[float]]] = None,
    ) -> "_LabelWriter": ...
    @property
    def halo(self) -> int: ...
    def sample_box(self, blocks: Tuple[int, int]) -> Tuple[int, int, int, int]: ...
    def add(self, fragment: bytes) -> None: ...
    def write(
        self, path: _Path, label_table: Optional[_Path] = None, names_of: Optional[_Path] = None
    ) -> Tuple[Dict[str, Any], List[str]]: ...

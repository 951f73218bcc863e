"""Shared volumes and the reference active-cell computation for the binding tests."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def sphere(shape_zyx=(20, 24, 28), centre_xyz=(13.0, 11.0, 9.0), radius=8.0, dtype=np.float32):
    """C array a[z, y, x] = radius − distance to centre (> 0 inside), as `dtype`."""
    z, y, x = np.mgrid[0 : shape_zyx[0], 0 : shape_zyx[1], 0 : shape_zyx[2]]
    cx, cy, cz = centre_xyz
    d = np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2)
    return (radius - d).astype(dtype)


def active_cells_xyz(a_zyx, iso):
    """Active cells of a C array a[z, y, x] by brute force: sorted (x, y, z) rows."""
    inside = a_zyx >= iso
    nz, ny, nx = inside.shape
    count = np.zeros((nz - 1, ny - 1, nx - 1), dtype=np.int32)
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                count += inside[dz : nz - 1 + dz, dy : ny - 1 + dy, dx : nx - 1 + dx]
    zyx = np.argwhere((count > 0) & (count < 8))
    return sort_rows(zyx[:, ::-1])


def sort_rows(rows):
    rows = np.asarray(rows, dtype=np.int64)
    return rows[np.lexsort(rows.T[::-1])] if len(rows) else rows.reshape(0, 3)


def same_grid(g1, g2):
    """Two grids are the same when stats, info and all three buffers agree byte for byte."""
    return (
        g1.stats == g2.stats
        and g1.info == g2.info
        and g1.blocks.tobytes() == g2.blocks.tobytes()
        and g1.metacells.tobytes() == g2.metacells.tobytes()
        and g1.cells.tobytes() == g2.cells.tobytes()
    )


@pytest.fixture(scope="session")
def cli():
    """The `isogrid` binary: $ISOGRID_CLI, this checkout's build, or one on PATH; else skip."""
    candidates = [os.environ.get("ISOGRID_CLI")]
    # Release first; a debug build (e.g. left by `cargo test`) gives the same output, slower.
    for profile in ("release", "debug"):
        if os.environ.get("CARGO_TARGET_DIR"):
            candidates.append(os.path.join(os.environ["CARGO_TARGET_DIR"], profile, "isogrid"))
        candidates.append(str(REPO / "target" / profile / "isogrid"))
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    found = shutil.which("isogrid")
    if found:
        return found
    pytest.skip(
        "isogrid CLI not built: run `cargo build --release -p isogrid-cli` in the repository "
        "(or set ISOGRID_CLI=/path/to/isogrid)"
    )


def vtk_reads_vti(path):
    """VTK's `vtkXMLImageDataReader`'s view of a `.vti` (the reference the `.vti` reader is
    checked against): (z, y, x) point scalars, spacing, the world position of the extent's first
    sample, and the axes' world directions as rows."""
    vtk = pytest.importorskip("vtk")
    from vtk.util import numpy_support

    reader = vtk.vtkXMLImageDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    image = reader.GetOutput()
    nx, ny, nz = image.GetDimensions()
    values = numpy_support.vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
    e = image.GetExtent()
    first = [0.0, 0.0, 0.0]
    image.TransformIndexToPhysicalPoint(e[0], e[2], e[4], first)
    d = image.GetDirectionMatrix()
    rows = np.array([[d.GetElement(r, a) for r in range(3)] for a in range(3)])
    return np.ascontiguousarray(values), tuple(image.GetSpacing()), first, rows

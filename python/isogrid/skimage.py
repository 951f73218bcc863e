"""A drop-in for ``skimage.measure.marching_cubes``, on isogrid's Marching Cubes.

    from isogrid.skimage import marching_cubes
    verts, faces, normals, values = marching_cubes(volume, level=0.5, spacing=(2.0, 1.0, 1.0))

Same arguments, same errors for bad ones, and ``verts, faces, normals, values`` with scikit-image's
conventions and dtypes: coordinates in array-axis order ``(axis 0, axis 1, axis 2)`` scaled by
``spacing``; a sample is inside when ``value > level`` (Lewiner et al.'s rule); with
``gradient_direction="descent"`` the right-hand normal of every face points up the gradient
(scikit-image's left-hand rule), with ``"ascent"`` down it; ``normals`` point down the gradient
(−∇f from differences along the cells' edges, weighted and summed per face as scikit-image
does, not scaled by ``spacing``); ``values`` is
scikit-image's "maximum value of the data near each vertex": over the faces using the vertex, the
largest ``max(0, max(c − level)) − min(0, min(c − level))`` of the corners ``c`` of the face's cell.

Where the result differs from scikit-image, and why:

* Ambiguous cells. scikit-image's default ``method="lewiner"`` resolves them with Lewiner's
  face and interior tests and may add a vertex in the cell's centre; isogrid keeps the inside
  corners of an ambiguous face apart (its ``"lorensen"``-like rule, which also keeps the mesh
  watertight). Both are valid surfaces; they differ only in those cells. ``method`` is checked but
  does not change the result.
* Normals: where the two meshes cut a cell's polygon into triangles differently, the per-face
  sums that make a normal differ too; they still point the same way almost everywhere.
* Crossings exactly on a sample (integer data at an integer level): scikit-image makes one vertex
  per crossed edge there, all at the same position, and zero-area triangles unless
  ``allow_degenerate=False`` merges them. isogrid always gives the merged mesh: one vertex per
  sample and no zero-area triangle, the same mesh scikit-image gives with
  ``allow_degenerate=False`` (whose normals and values come from the first of the merged
  vertices only; isogrid's from all their faces).
* Speed: the surface is extracted in Rust on all cores, normals and values in Rust on one, with
  the GIL released.
"""

from __future__ import annotations

from typing import Any, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from . import _isogrid, _prepare

__all__ = ["marching_cubes"]


def marching_cubes(
    volume: npt.NDArray[Any],
    level: Optional[float] = None,
    *,
    spacing: Sequence[float] = (1.0, 1.0, 1.0),
    gradient_direction: str = "descent",
    step_size: int = 1,
    allow_degenerate: bool = True,
    method: str = "lewiner",
    mask: Optional[npt.NDArray[Any]] = None,
) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Marching Cubes isosurface of a 3-D array, as ``skimage.measure.marching_cubes`` returns it.

    Args:
        volume: (M, N, P) array of real numbers.
        level: isovalue; default ``(min + max) / 2`` of the volume (computed in float32, as
            scikit-image does). Must lie within the data range.
        spacing: sample spacing along (M, N, P).
        gradient_direction: ``"descent"`` (the object holds the higher values) or ``"ascent"``;
            flips the faces' winding.
        step_size: march cubes of ``step_size`` samples (the volume subsampled).
        allow_degenerate: accepted for compatibility; the mesh never has zero-area triangles from
            crossings on samples (see the module notes), and with ``False`` any other face with two
            equal vertex positions is removed as scikit-image does.
        method: ``"lewiner"`` or ``"lorensen"``, checked for compatibility; see the module notes.
        mask: boolean (M, N, P) array; a cell is marched only when ``mask`` is true at its far
            corner (scikit-image's rule). Only the bounding box of those cells is marched, so a
            small mask costs little.

    Returns:
        ``verts`` (V, 3) float32 (float64 when ``spacing`` is not all ones, as in scikit-image),
        ``faces`` (F, 3) int32 (int64 with ``allow_degenerate=False``), ``normals`` (V, 3) float32,
        ``values`` (V,) float32.

    Raises:
        ValueError: not a 3-D array, smaller than 2×2×2, ``level`` outside the data range, bad
            ``spacing``, ``step_size``, ``method``, ``gradient_direction`` or ``mask`` shape.
        RuntimeError: no surface at ``level``.
    """
    if method not in ("lewiner", "lorensen"):
        raise ValueError("method should be either 'lewiner' or 'lorensen'")
    if not isinstance(volume, np.ndarray) or volume.ndim != 3:
        raise ValueError("Input volume should be a 3D numpy array.")
    if min(volume.shape) < 2:
        raise ValueError("Input array must be at least 2x2x2.")
    if volume.dtype.kind not in "biuf":
        raise ValueError(f"unsupported volume dtype {volume.dtype}: expected real numbers")
    lo, hi = np.float32(volume.min()), np.float32(volume.max())
    if level is None:
        level_f32 = np.float32(0.5) * (lo + hi)
    else:
        if float(level) < lo or float(level) > hi:
            raise ValueError("Surface level must be within volume data range.")
        level_f32 = np.float32(level)
    # scikit-image compares float32 samples with a float32 level.
    level = float(level_f32)
    if len(spacing) != 3:
        raise ValueError("`spacing` must consist of three floats.")
    step = int(step_size)
    if step < 1:
        raise ValueError("step_size must be at least one.")
    if gradient_direction not in ("descent", "ascent"):
        raise ValueError(f"Incorrect input {gradient_direction} in `gradient_direction`, see docstring.")
    if mask is not None and mask.shape != volume.shape:
        raise ValueError("volume and mask must have the same shape.")

    samples = volume[::step, ::step, ::step] if step > 1 else volume
    if samples.dtype.kind in "iuf" and samples.dtype.itemsize >= 4:
        # scikit-image marches float32 samples: 32/64-bit ones are rounded as it rounds them
        # (isogrid.marching_cubes keeps them exact).
        samples = samples.astype(np.float32, copy=False)
    prepared, fortran = _prepare(samples)
    # With a mask, only the samples of the cells it marches (cell c where the mask holds at
    # c + 1) are marched: the box around them, one sample below for the cells' low corners.
    lo = np.zeros(3, dtype=np.intp)
    marched, fortran_mc = prepared, fortran
    cells_ok = None
    if mask is not None:
        cells_ok = np.asarray(mask, dtype=bool)[::step, ::step, ::step][1:, 1:, 1:]
        hit = [np.flatnonzero(cells_ok.any(axis=tuple(b for b in range(3) if b != a))) for a in range(3)]
        if any(len(h) == 0 for h in hit):
            raise RuntimeError("No surface found at the given iso value.")
        lo = np.array([h[0] for h in hit], dtype=np.intp)
        hi = np.array([h[-1] + 2 for h in hit], dtype=np.intp)
        marched = samples[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]]
        cells_ok = cells_ok[lo[0] : hi[0] - 1, lo[1] : hi[1] - 1, lo[2] : hi[2] - 1]
        marched, fortran_mc = _prepare(marched)
    xyz, tris = _isogrid.marching_cubes(marched, fortran_mc, (1.0, 1.0, 1.0), iso=level, above=True)
    # isogrid's (x, y, z) is the array's axes reversed for a C array and as they are for a
    # Fortran one; its faces wind counter-clockwise seen from outside in (x, y, z).
    verts = xyz[:, ::-1] if not fortran_mc else xyz
    faces = tris.astype(np.int32)
    if fortran_mc == (gradient_direction == "descent"):
        faces = faces[:, ::-1]
    if cells_ok is not None:
        verts, faces = _keep_masked_cells(verts, faces, cells_ok)
        # Back to the whole array's indices, where normals and values are sampled.
        verts = verts + lo.astype(np.float32)
    if len(verts) == 0:
        raise RuntimeError("No surface found at the given iso value.")
    verts = np.ascontiguousarray(verts)
    faces = np.ascontiguousarray(faces)
    # Normals and values in isogrid's (x, y, z), then back to the array's axes.
    xyz = verts if fortran else verts[:, ::-1]
    normals, values = _isogrid.skimage_normals_values(
        prepared, fortran, np.ascontiguousarray(xyz), faces.astype(np.uint32), level
    )
    if not fortran:
        normals = np.ascontiguousarray(normals[:, ::-1])
    if step > 1:
        verts = verts * np.float32(step)
    if not np.array_equal(spacing, (1, 1, 1)):
        verts = verts * np.r_[spacing]
    if allow_degenerate:
        return verts, faces, normals, values
    v, f, n, val = _remove_degenerate_faces(verts.astype(np.float32), faces, normals, values)
    return v, f, n, val


def _keep_masked_cells(
    verts: np.ndarray, faces: np.ndarray, cells_ok: np.ndarray
) -> Tuple[np.ndarray, np.ndarray]:
    """Drops the faces of cells not marched under the mask, then the vertices no face uses.

    A face's cell is the one holding its centroid: isogrid never puts three vertices of one face
    of a cell into one triangle, so the centroid is inside its cell, not on a shared face.
    """
    centroid = verts[faces].mean(axis=1)
    cell = np.clip(np.floor(centroid).astype(np.intp), 0, np.array(cells_ok.shape) - 1)
    faces = faces[cells_ok[cell[:, 0], cell[:, 1], cell[:, 2]]]
    used = np.zeros(len(verts), dtype=bool)
    used[faces.ravel()] = True
    renumber = np.cumsum(used) - 1
    return verts[used], renumber[faces].astype(faces.dtype)


def _remove_degenerate_faces(
    verts: np.ndarray, faces: np.ndarray, *arrays: np.ndarray
) -> Tuple[np.ndarray, ...]:
    """scikit-image's ``allow_degenerate=False``: faces with two equal vertex positions are
    dropped and those vertices merged into the lower index, in face order."""
    merged = np.arange(len(verts), dtype=np.int32)
    p = verts[faces]
    same = [np.all(p[:, a] == p[:, b], axis=1) for a, b in ((0, 1), (0, 2), (1, 2))]
    degenerate = same[0] | same[1] | same[2]
    for j in np.flatnonzero(degenerate):
        for (a, b), eq in zip(((0, 1), (0, 2), (1, 2)), same):
            if eq[j]:
                i1, i2 = faces[j, a], faces[j, b]
                merged[i1] = merged[i2] = min(merged[i1], merged[i2])
    kept = merged == np.arange(len(verts))
    renumber = np.cumsum(kept) - 1
    faces2 = renumber[merged[faces[~degenerate]]]
    return (verts[kept], faces2) + tuple(a[kept] for a in arrays)

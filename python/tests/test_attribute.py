"""Colour by a second volume: ``extract(..., attribute=)``, ``grid.attribute`` and ``render`` with
``cmap``/``clim``, against a reference computed here with numpy and scipy: each active cell's surface
point (the centroid of its edge crossings, from ``grid.corners()``) sampled trilinearly with
``scipy.ndimage.map_coordinates``."""

import numpy as np
import pytest
from scipy import ndimage

import isogrid


def _sphere(n=40, spacing=(1.0, 1.0, 1.0)):
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float64)
    c = (n - 1) / 2
    r = np.sqrt((x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2)
    return np.clip(255 - 10 * r, 0, 255).astype(np.uint8)


def _surface_points(grid):
    """(N, 3) index-space (x, y, z) surface point of every active cell, in cell order."""
    corners = grid.corners().astype(np.float64)
    iso = float(grid.info["iso_code"])
    offsets = np.array([[c & 1, c >> 1 & 1, c >> 2 & 1] for c in range(8)], dtype=np.float64)
    total = np.zeros((len(corners), 3))
    count = np.zeros(len(corners))
    for axis in range(3):
        for c in range(8):
            if c >> axis & 1:
                continue
            d = c | 1 << axis
            a, b = corners[:, c], corners[:, d]
            crosses = (a >= iso) != (b >= iso)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.clip((iso - a) / (b - a), 0, 1)
            point = np.repeat(offsets[c][None, :], len(corners), axis=0)
            point[:, axis] = t
            total[crosses] += point[crosses]
            count[crosses] += 1
    return grid.cell_positions().astype(np.float64) + total / count[:, None]


def test_attribute_on_the_same_grid_is_the_trilinear_value_at_each_surface_point():
    sphere = _sphere()
    rng = np.random.default_rng(3)
    field = ndimage.gaussian_filter(rng.normal(size=sphere.shape), 2).astype(np.float32)
    grid = isogrid.extract(sphere, iso=127.5, attribute=field, attribute_precision=32)
    assert grid.attribute_info == {"name": "attribute", "bits": 32, "range": pytest.approx(grid.attribute_info["range"])}
    p = _surface_points(grid)
    # field is indexed [z, y, x].
    expected = ndimage.map_coordinates(field.astype(np.float64), [p[:, 2], p[:, 1], p[:, 0]], order=1)
    np.testing.assert_allclose(grid.attribute, expected, rtol=0, atol=1e-5)
    lo, hi = grid.attribute_info["range"]
    assert lo == pytest.approx(expected.min(), abs=1e-5) and hi == pytest.approx(expected.max(), abs=1e-5)
    # 16-bit codes are within half a code step of the range.
    coded = isogrid.extract(sphere, iso=127.5, attribute=field)
    assert coded.attribute_info["bits"] == 16
    np.testing.assert_allclose(coded.attribute, expected, rtol=0, atol=(hi - lo) / 65534 / 2 + 1e-6)


def test_a_volume_attribute_is_resampled_in_world_space_with_nan_outside():
    surface = isogrid.Volume(_sphere(36), spacing=(1.0, 1.5, 2.0), origin=(-20.0, 5.0, 30.0))
    c, s = np.cos(0.5), np.sin(0.5)
    direction = ((c, s, 0.0), (-s, c, 0.0), (0.0, 0.0, 1.0))
    spacing, origin = (1.7, 1.9, 2.5), (-10.0, 2.0, 40.0)
    rng = np.random.default_rng(5)
    data = ndimage.gaussian_filter(rng.normal(size=(14, 30, 34)), 1.5).astype(np.float32)  # [z, y, x]
    attribute = isogrid.Volume(data, spacing=spacing, origin=origin, direction=direction)
    grid = isogrid.extract(surface, iso=127.5, attribute=attribute, attribute_precision=32)
    p = _surface_points(grid)
    # Index → world for each volume: world = origin + Σ_a p_a · spacing_a · direction_a.
    world = np.asarray(surface.origin) + (p * np.asarray(surface.spacing)) @ np.asarray(surface.direction)
    m = np.asarray(direction) * np.asarray(spacing)[:, None]  # rows: world step of each index axis
    q = np.linalg.solve(m.T, (world - np.asarray(origin)).T).T  # attribute index (x, y, z)
    expected = ndimage.map_coordinates(
        data.astype(np.float64), [q[:, 2], q[:, 1], q[:, 0]], order=1, mode="constant", cval=np.nan
    )
    extent = np.array([33, 29, 13], dtype=np.float64)
    margin = np.minimum(q, extent - q).min(axis=1)
    inside, outside = margin > 1e-6, margin < -1e-6
    assert inside.sum() > 300 and outside.sum() > 300, (inside.sum(), outside.sum())
    np.testing.assert_allclose(grid.attribute[inside], expected[inside], rtol=0, atol=1e-4)
    assert np.isnan(grid.attribute[outside]).all()


def test_attributes_survive_files_and_pickles_and_render_in_colour(tmp_path):
    sphere = _sphere(32)
    z, y, x = np.mgrid[:32, :32, :32]
    field = (x + 2.0 * y).astype(np.float32)
    grid = isogrid.extract(sphere, iso=127.5, attribute=field)
    path = tmp_path / "c.cgc"
    grid.save(path)
    loaded = isogrid.load(path)
    np.testing.assert_array_equal(loaded.attribute, grid.attribute)
    assert loaded.attribute_info == grid.attribute_info
    import pickle

    np.testing.assert_array_equal(pickle.loads(pickle.dumps(grid)).attribute, grid.attribute)
    # The stored codes, without a copy: they decode to the values.
    codes = grid.attribute_codes
    assert codes.dtype == np.uint16 and not codes.flags.writeable and codes.base is not None
    lo_, hi_ = grid.attribute_info["range"]
    decoded = np.where(codes == 0xFFFF, np.nan, lo_ + codes * ((hi_ - lo_) / 0xFFFE))
    np.testing.assert_allclose(decoded, grid.attribute, rtol=1e-6, atol=1e-6 * (hi_ - lo_))
    image, aovs = isogrid.render(grid, size=(64, 48), backend="cpu", aovs=("value", "depth"), cmap="gray")
    hit = np.isfinite(aovs["depth"])
    assert hit.sum() > 200
    assert np.isnan(aovs["value"][~hit]).all()
    lo, hi = grid.attribute_info["range"]
    assert (aovs["value"][hit] >= lo - 1e-3).all() and (aovs["value"][hit] <= hi + 1e-3).all()
    # gray: every hit pixel is grey; viridis is not.
    assert (image[hit][:, 0] == image[hit][:, 1]).all() and (image[hit][:, 1] == image[hit][:, 2]).all()
    colour = isogrid.render(grid, size=(64, 48), backend="cpu")
    assert (colour[hit][:, 0] != colour[hit][:, 2]).mean() > 0.9
    # The GPU renderer shows the same values (the same cells under nearly every pixel).
    try:
        _, gpu = isogrid.render(grid, size=(64, 48), backend="gpu", aovs=("value", "depth"))
    except Exception as e:
        assert "no GPU adapter" in str(e)
    else:
        both = hit & np.isfinite(gpu["depth"])
        assert both.sum() > 0.95 * hit.sum()
        close = np.abs(gpu["value"][both] - aovs["value"][both]) <= 0.01 * (hi - lo)
        assert close.mean() > 0.97


def test_bad_attributes_and_colour_keywords_are_refused():
    sphere = _sphere(24)
    with pytest.raises(ValueError, match="surface's grid"):
        isogrid.extract(sphere, iso=127.5, attribute=np.zeros((10, 10, 10), np.float32))
    with pytest.raises(ValueError, match="8, 16 or 32"):
        isogrid.extract(sphere, iso=127.5, attribute=sphere, attribute_precision=12)
    far = isogrid.Volume(np.zeros((8, 8, 8), np.float32), origin=(500.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="does not overlap"):
        isogrid.extract(sphere, iso=127.5, attribute=far)
    plain = isogrid.extract(sphere, iso=127.5)
    assert plain.attribute is None and plain.attribute_info is None
    with pytest.raises(ValueError, match="has none"):
        isogrid.render(plain, size=(32, 24), cmap="magma")
    with pytest.raises(ValueError, match="has none"):
        isogrid.render(plain, size=(32, 24), aovs=("value",))
    coloured = isogrid.extract(sphere, iso=127.5, attribute=sphere)
    with pytest.raises(ValueError, match="viridis"):
        isogrid.render(coloured, size=(32, 24), cmap="jet")
    with pytest.raises(ValueError):
        isogrid.render(coloured, size=(32, 24), clim=(1.0, 1.0))


def test_mc_color_by_writes_a_vertex_scalar_that_meshlab_reads(cli, tmp_path):
    """``isogrid mc --color-by`` writes the attribute as the PLY vertex property ``quality``,
    which MeshLab (through pymeshlab) loads as its vertex scalar, vertex for vertex."""
    import subprocess

    import pymeshlab

    z, y, x = np.mgrid[:28, :28, :28]
    np.save(tmp_path / "s.npy", _sphere(28))
    np.save(tmp_path / "f.npy", (x + 2.0 * y - z).astype(np.float32))
    ply = tmp_path / "m.ply"
    subprocess.run(
        [cli, "mc", tmp_path / "s.npy", "--iso", "127.5", "--color-by", tmp_path / "f.npy", "-o", ply],
        check=True,
        capture_output=True,
    )
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(ply))
    mesh = ms.current_mesh()
    assert mesh.has_vertex_scalar()
    p = mesh.vertex_matrix()  # world = index (x, y, z) here: spacing 1, origin 0
    np.testing.assert_allclose(mesh.vertex_scalar_array(), p[:, 0] + 2 * p[:, 1] - p[:, 2], atol=1e-3)
    assert len(p) > 300


def test_mc_color_by_writes_a_vtp_point_array_that_vtk_reads(cli, tmp_path):
    """``isogrid mc -o mesh.vtp``: VTK's XML PolyData reader (ParaView's, through PyVista) reads
    the same vertices and triangles as the PLY, and with ``--color-by`` the attribute as the
    active point scalars under the attribute's name (XML-escaped in the file), NaN outside it."""
    import subprocess

    pv = pytest.importorskip("pyvista")
    import pymeshlab

    z, y, x = np.mgrid[:28, :28, :28]
    np.save(tmp_path / "s.npy", _sphere(28))
    field = (x + 2.0 * y - z).astype(np.float32)
    field[:, :, :14] = np.nan  # no value on the low-x half
    name = 'f&<"q">.npy'
    np.save(tmp_path / name, field)
    meshes = {}
    for out, extra in (("m.ply", []), ("m.vtp", []), ("plain.vtp", None)):
        color = [] if extra is None else ["--color-by", tmp_path / name]
        subprocess.run(
            [cli, "mc", tmp_path / "s.npy", "--iso", "127.5", *color, "-o", tmp_path / out],
            check=True,
            capture_output=True,
        )
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(tmp_path / "m.ply"))
    ply = ms.current_mesh()
    for out in ("m.vtp", "plain.vtp"):
        vtp = pv.read(tmp_path / out)
        np.testing.assert_array_equal(vtp.points, ply.vertex_matrix().astype(np.float32))
        np.testing.assert_array_equal(vtp.faces.reshape(-1, 4)[:, 1:], ply.face_matrix())
        meshes[out] = vtp
    assert meshes["plain.vtp"].point_data.keys() == []
    vtp = meshes["m.vtp"]
    assert vtp.active_scalars_name == name
    values = vtp[name]
    np.testing.assert_array_equal(values, ply.vertex_scalar_array().astype(np.float32))
    p = vtp.points
    outside = p[:, 0] < 13
    inside = p[:, 0] > 14
    assert np.isnan(values[outside]).all() and outside.sum() > 50
    np.testing.assert_allclose(values[inside], (p[:, 0] + 2 * p[:, 1] - p[:, 2])[inside], atol=1e-3)


def test_stats_carry_the_attribute_as_the_cli_json_does(cli, tmp_path):
    import json
    import subprocess

    np.save(tmp_path / "s.npy", _sphere(24))
    np.save(tmp_path / "a.npy", _sphere(24).astype(np.float32) * 0.5)
    report = json.loads(
        subprocess.run(
            [cli, "extract", tmp_path / "s.npy", "--iso", "127.5", "--color-by", tmp_path / "a.npy", "--json"],
            check=True,
            capture_output=True,
        ).stdout
    )
    grid = isogrid.extract(tmp_path / "s.npy", iso=127.5, attribute=tmp_path / "a.npy")
    assert grid.stats["attribute"] == report["attribute"]
    assert isogrid.extract(_sphere(24), iso=127.5).stats["attribute"] is None


def test_marching_cubes_returns_the_attribute_at_every_vertex():
    """The third array is the attribute at each vertex: exact for a field linear in position (on
    the same samples, and through a Volume of other geometry in world space)."""
    sphere = isogrid.Volume(_sphere(30), spacing=(1.0, 1.5, 0.5), origin=(3.0, -2.0, 1.0))
    z, y, x = np.mgrid[:30, :30, :30].astype(np.float64)
    world = [1.0 * x + 3.0, 1.5 * y - 2.0, 0.5 * z + 1.0]
    field = (world[0] - 2 * world[1] + world[2]).astype(np.float32)
    vertices, faces, values = isogrid.marching_cubes(sphere, iso=127.5, attribute=field)
    assert len(values) == len(vertices) > 500
    expected = vertices[:, 0] - 2 * vertices[:, 1] + vertices[:, 2]  # world-space vertices
    np.testing.assert_allclose(values, expected, atol=1e-3)
    # Another sampling of the same field: half the resolution, shifted origin.
    coarse_z, coarse_y, coarse_x = np.mgrid[:18, :26, :17].astype(np.float64)
    coarse = isogrid.Volume(
        (2.0 * coarse_x - 1.0 - 2 * (3.0 * coarse_y - 4.0) + (1.2 * coarse_z)).astype(np.float32),
        spacing=(2.0, 3.0, 1.2), origin=(-1.0, -4.0, 0.0),
    )
    _, _, resampled = isogrid.marching_cubes(sphere, iso=127.5, attribute=coarse)
    np.testing.assert_allclose(resampled, expected, atol=1e-3)
    assert len(isogrid.marching_cubes(sphere, iso=127.5)) == 2


def test_an_attribute_in_the_other_world_convention_is_sampled_where_it_lies(cli, tmp_path):
    """SimpleITK writes one image as NIfTI (RAS world coordinates) and as MetaImage (ITK's LPS),
    the same place in its physical space. A surface of either file coloured by an attribute in
    either file takes the attribute's values at the same points: the attribute's coordinates are
    taken into the surface's convention (before, a NIfTI surface took an LPS attribute mirrored
    in x and y). The CLI, in memory and streamed, and Python agree; marching cubes too."""
    import subprocess

    sitk = pytest.importorskip("SimpleITK")
    z, y, x = np.mgrid[:36, :32, :28].astype(np.float32)
    # An off-centre ball, so that a mirrored attribute would be sampled elsewhere.
    ball = 9 - np.sqrt((x - 11.5) ** 2 + (y - 18) ** 2 + (z - 15) ** 2)
    field = x + 2 * y - 0.5 * z
    for name, array in (("ct", ball), ("pet", field)):
        image = sitk.GetImageFromArray(array.astype(np.float32))
        image.SetOrigin((-30.0, 12.5, 5.0))
        image.SetSpacing((1.5, 1.0, 0.75))
        image.SetDirection((0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0))
        for extension in ("nii.gz", "nii", "mha"):
            sitk.WriteImage(image, str(tmp_path / f"{name}.{extension}"))
    assert isogrid.load_volume(tmp_path / "ct.nii.gz").frame == "RAS"
    assert isogrid.load_volume(tmp_path / "pet.mha").frame == "LPS"
    reference = isogrid.extract(tmp_path / "ct.mha", iso=0, attribute=tmp_path / "pet.mha")
    expected = np.asarray(reference.attribute)
    assert np.isfinite(expected).all() and len(expected) > 500
    for surface in ("ct.nii.gz", "ct.nii", "ct.mha"):
        for attribute in ("pet.nii.gz", "pet.mha"):
            for source in (tmp_path / attribute, isogrid.load_volume(tmp_path / attribute)):
                grid = isogrid.extract(tmp_path / surface, iso=0, attribute=source)
                np.testing.assert_array_equal(np.asarray(grid.attribute), expected, err_msg=f"{surface} {attribute}")
            # Streamed (an uncompressed NIfTI is read by slabs): the frame goes through its file.
            for extra in ([], ["--max-memory", "64M"]):
                out = tmp_path / "out.cgc"
                run = subprocess.run([cli, "extract", tmp_path / surface, "--iso", "0", "--color-by",
                                      tmp_path / attribute, "-o", out, *extra], capture_output=True, text=True)
                assert run.returncode == 0, run.stderr
                assert ("taken into" in run.stderr) == (surface.endswith("mha") != attribute.endswith("mha")), run.stderr
                np.testing.assert_array_equal(np.asarray(isogrid.load(out).attribute), expected)
    # The values are the field at the surface points: x + 2y - z/2 in the volume's index space.
    p = _surface_points(reference)
    np.testing.assert_allclose(expected, p[:, 0] + 2 * p[:, 1] - 0.5 * p[:, 2], atol=0.01)
    # Marching cubes: every vertex of a NIfTI surface takes the MetaImage attribute as the other way.
    vertices, _, values = isogrid.marching_cubes(tmp_path / "ct.nii.gz", iso=0, attribute=tmp_path / "pet.mha",
                                                 space="index")
    np.testing.assert_allclose(values, vertices[:, 0] + 2 * vertices[:, 1] - 0.5 * vertices[:, 2], atol=1e-3)

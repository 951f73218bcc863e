"""``isogrid mc --labels``: the glTF binary read back with pygltflib, the VTK XML PolyData with
VTK's reader (through PyVista) and the neuroglancer precomputed folder read as its specification
lays it out, against Marching Cubes of each label's indicator by scikit-image (the same crossed
edges: one vertex at the midpoint of each) and the labels' names and colours from
``extract_labels``; per-vertex values against the attribute at the vertices and against the
grid's cells."""

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import isogrid
from test_labels import _cell_labels, _labels

pygltflib = pytest.importorskip("pygltflib")
measure = pytest.importorskip("skimage.measure")


def _accessor(gltf, blob, index, dtype, width):
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    return np.frombuffer(blob, dtype, count=acc.count * width, offset=start).reshape(-1, width)


def _glb_values(path):
    """{label value: its meshes' ``_VALUE`` vertex attribute} of a .glb, with the accessors' names."""
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    values, names = {}, set()
    for node_index in gltf.scenes[gltf.scene].nodes:
        node = gltf.nodes[node_index]
        index = gltf.meshes[node.mesh].primitives[0].attributes._VALUE
        accessor = gltf.accessors[index]
        assert (accessor.componentType, accessor.type) == (pygltflib.FLOAT, pygltflib.SCALAR)
        names.add(accessor.name)
        values[int(node.extras["label"])] = _accessor(gltf, blob, index, "<f4", 1)[:, 0]
    return values, names


def _glb_meshes(path):
    """{label value: (name, base colour, positions, triangles, normals)} of a .glb."""
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    meshes = {}
    for node_index in gltf.scenes[gltf.scene].nodes:
        node = gltf.nodes[node_index]
        primitive = gltf.meshes[node.mesh].primitives[0]
        assert primitive.mode == pygltflib.TRIANGLES
        assert gltf.accessors[primitive.indices].componentType == pygltflib.UNSIGNED_INT
        positions = _accessor(gltf, blob, primitive.attributes.POSITION, "<f4", 3)
        acc = gltf.accessors[primitive.attributes.POSITION]
        np.testing.assert_array_equal(acc.min, positions.min(axis=0))
        np.testing.assert_array_equal(acc.max, positions.max(axis=0))
        triangles = _accessor(gltf, blob, primitive.indices, "<u4", 1).reshape(-1, 3)
        normals = _accessor(gltf, blob, primitive.attributes.NORMAL, "<f4", 3)
        colour = gltf.materials[primitive.material].pbrMetallicRoughness.baseColorFactor
        meshes[int(node.extras["label"])] = (node.name, colour, positions, triangles, normals)
    return meshes


def _srgb_to_linear(c):
    c = c / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _mc(cli, path, out, *extra):
    return subprocess.run(
        [cli, "mc", path, "--labels", "all", "--space", "index", "-o", out, "--json", *extra],
        check=True,
        capture_output=True,
        text=True,
    ).stdout


def _vertex_set(positions):
    return set(map(tuple, np.round(np.asarray(positions, np.float64), 5).tolist()))


def test_glb_has_each_labels_marching_cubes_surface_named_and_coloured(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    report = json.loads(_mc(cli, path, tmp_path / "labels.glb"))
    meshes = _glb_meshes(tmp_path / "labels.glb")
    table = {l["value"]: l for l in isogrid.extract_labels(a, labels="all").labels}
    assert sorted(meshes) == sorted(table) == sorted(set(np.unique(a).tolist()) - {0})
    assert report["labels"] == len(meshes)
    assert report["triangles"] == sum(len(m[3]) for m in meshes.values())
    for value, (name, colour, positions, triangles, normals) in meshes.items():
        assert name == table[value]["name"]
        rgba = np.array([int(table[value]["color"][i : i + 2], 16) for i in (1, 3, 5, 7)], float)
        np.testing.assert_allclose(colour[:3], _srgb_to_linear(rgba[:3]), atol=1e-6)
        # scikit-image's Marching Cubes of the indicator (z, y, x): the same crossed edges.
        verts, faces, _, _ = measure.marching_cubes((a == value).astype(np.float32), 0.5)
        assert _vertex_set(positions) == _vertex_set(verts[:, ::-1]), value
        assert len(positions) == len(verts)
        area = measure.mesh_surface_area(positions, triangles)
        reference = measure.mesh_surface_area(verts, faces)
        # Ambiguous faces are split differently (scikit-image follows Lewiner's asymptotic rule).
        assert area == pytest.approx(reference, rel=0.02), value
        # Closed (no label reaches the volume's border) and wound outwards: every edge twice, once
        # in each direction, and an enclosed volume between the lone voxel's octahedron (1/6) and
        # the voxels' cubes.
        edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
        forward = set(map(tuple, edges.tolist()))
        assert len(forward) == len(edges)
        assert forward == set(map(tuple, edges[:, ::-1].tolist()))
        p = positions[triangles].astype(np.float64)
        volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
        voxels = int((a == value).sum())
        assert voxels / 6 - 1e-9 <= volume <= voxels, (value, volume, voxels)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-5)


def test_precomputed_folder_follows_neuroglancers_legacy_mesh_layout(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    _mc(cli, path, tmp_path / "labels.glb")
    glb = _glb_meshes(tmp_path / "labels.glb")
    folder = tmp_path / "meshes"
    _mc(cli, path, folder)
    info = json.loads((folder / "info").read_text())
    assert info == {"@type": "neuroglancer_legacy_mesh", "segment_properties": "segment_properties"}
    properties = json.loads((folder / info["segment_properties"] / "info").read_text())
    assert properties["@type"] == "neuroglancer_segment_properties"
    ids = properties["inline"]["ids"]
    assert sorted(int(i) for i in ids) == sorted(glb)
    (label_property,) = properties["inline"]["properties"]
    assert label_property["type"] == "label"
    assert dict(zip(ids, label_property["values"])) == {str(v): m[0] for v, m in glb.items()}
    for value, (_, _, positions, triangles, _) in glb.items():
        manifest = json.loads((folder / f"{value}:0").read_text())
        (fragment,) = manifest["fragments"]
        body = (folder / fragment).read_bytes()
        n = int(np.frombuffer(body[:4], "<u4")[0])
        vertices = np.frombuffer(body[4 : 4 + 12 * n], "<f4").reshape(-1, 3)
        rest = body[4 + 12 * n :]
        assert len(rest) % 12 == 0
        np.testing.assert_array_equal(vertices, positions)
        np.testing.assert_array_equal(np.frombuffer(rest, "<u4").reshape(-1, 3), triangles)
    # A folder is written only where nothing is.
    failed = subprocess.run(
        [cli, "mc", path, "--labels", "all", "-o", folder], capture_output=True, text=True
    )
    assert failed.returncode == 1
    assert "already exists" in failed.stderr and failed.stderr.count("\n") == 1


def _vtp_meshes(path):
    """{label value: (name, sRGB colour, positions, triangles, point arrays)} of a label .vtp, as
    VTK's reader gives it, split by the triangles' ``label`` cell array."""
    pv = pytest.importorskip("pyvista")
    vtp = pv.read(path)
    labels = vtp.cell_data["label"]
    colours = vtp.cell_data["label_color"]
    assert colours.dtype == np.uint8 and colours.shape == (vtp.n_cells, 3)
    triangles = vtp.faces.reshape(-1, 4)
    assert (triangles[:, 0] == 3).all()
    triangles = triangles[:, 1:]
    names = dict(zip(vtp.field_data["label_values"].tolist(), vtp.field_data["label_names"].tolist()))
    meshes = {}
    for value in np.unique(labels).tolist():
        mine = labels == value
        assert len(set(map(tuple, colours[mine].tolist()))) == 1
        used = np.unique(triangles[mine])
        # Each label's vertices are its own, one run of the points.
        assert (used == np.arange(used[0], used[-1] + 1)).all()
        arrays = {k: vtp.point_data[k][used] for k in vtp.point_data.keys()}
        meshes[value] = (names[value], colours[mine][0], vtp.points[used], triangles[mine] - used[0], arrays)
    assert sorted(meshes) == sorted(names)
    return meshes, vtp


def test_vtp_holds_the_glb_meshes_with_each_triangles_label_name_and_colour(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    _mc(cli, path, tmp_path / "labels.glb")
    report = json.loads(_mc(cli, path, tmp_path / "labels.vtp"))
    glb = _glb_meshes(tmp_path / "labels.glb")
    vtp, whole = _vtp_meshes(tmp_path / "labels.vtp")
    assert report["triangles"] == whole.n_cells and report["vertices"] == whole.n_points
    assert whole.cell_data["label"].dtype == np.int64 and 60000 in vtp
    assert whole.point_data.keys() == []
    table = {l["value"]: l for l in isogrid.extract_labels(a, labels="all").labels}
    assert sorted(vtp) == sorted(glb)
    for value, (name, colour, positions, triangles, _) in vtp.items():
        assert name == table[value]["name"] == glb[value][0]
        assert colour.tolist() == [int(table[value]["color"][i : i + 2], 16) for i in (1, 3, 5)]
        np.testing.assert_array_equal(positions, glb[value][2])
        np.testing.assert_array_equal(triangles, glb[value][3])


def test_vtp_labels_keep_their_values_beyond_int64_and_below_zero(cli, tmp_path):
    """Connectomics ids past 2^63 are a UInt64 cell array; a signed volume's negative labels an
    Int64 one."""
    a = _labels()
    for dtype, values in ((np.uint64, [2**63 + 5, 2**64 - 2]), (np.int32, [-7, 12])):
        b = np.zeros(a.shape, dtype)
        b[a == 4], b[a == 9] = values
        path = tmp_path / f"{np.dtype(dtype).name}.npy"
        np.save(path, b)
        _mc(cli, path, tmp_path / f"{np.dtype(dtype).name}.vtp")
        vtp, whole = _vtp_meshes(tmp_path / f"{np.dtype(dtype).name}.vtp")
        assert whole.cell_data["label"].dtype == (np.uint64 if dtype == np.uint64 else np.int64)
        assert sorted(vtp) == sorted(values)
        assert sorted(whole.field_data["label_values"].tolist()) == sorted(values)


def test_label_meshes_carry_the_color_by_values_at_their_vertices(cli, tmp_path):
    """``mc --labels --color-by``: a field linear in position, which trilinear sampling gives
    exactly, at every vertex of every label, in the .glb's ``_VALUE`` and the .vtp's point array
    alike; from a .cgc with its own attribute, each vertex takes the mean of the values of its
    label's cells around the vertex's edge, found here from the grid's cells."""
    a = _labels()
    path, field_path = tmp_path / "labels.npy", tmp_path / "field.npy"
    np.save(path, a)
    z, y, x = np.mgrid[: a.shape[0], : a.shape[1], : a.shape[2]].astype(np.float32)
    np.save(field_path, x + 2 * y + 3 * z)
    _mc(cli, path, tmp_path / "labels.glb", "--color-by", field_path)
    _mc(cli, path, tmp_path / "labels.vtp", "--color-by", field_path)
    glb = _glb_meshes(tmp_path / "labels.glb")
    values, names = _glb_values(tmp_path / "labels.glb")
    assert names == {"field.npy"}
    vtp, whole = _vtp_meshes(tmp_path / "labels.vtp")
    assert whole.active_scalars_name == "field.npy"
    assert sorted(values) == sorted(vtp) == sorted(glb)
    for value, (_, _, positions, _, arrays) in vtp.items():
        p = positions.astype(np.float64)
        np.testing.assert_allclose(arrays["field.npy"], p[:, 0] + 2 * p[:, 1] + 3 * p[:, 2], atol=1e-4)
        np.testing.assert_array_equal(values[value], arrays["field.npy"])

    # A .cgc with its attribute, stored as f32.
    cgc = tmp_path / "labels.cgc"
    subprocess.run(
        [cli, "extract", path, "--labels", "all", "--color-by", field_path, "--attribute-precision", "32", "-o", cgc],
        check=True,
        capture_output=True,
    )
    _mc(cli, cgc, tmp_path / "cells.vtp")
    cells, _ = _vtp_meshes(tmp_path / "cells.vtp")
    # Neuroglancer's format has no place for the values: written without them, and said so.
    ng = subprocess.run([cli, "mc", cgc, "--labels", "all", "-o", tmp_path / "ng"], capture_output=True, text=True)
    assert ng.returncode == 0 and (tmp_path / "ng" / "info").exists(), ng.stderr
    assert 'the attribute "field.npy" is left out' in ng.stderr
    grid = isogrid.load(cgc)
    nx, ny, _ = grid.info["dims"]
    label_of = np.array([l["value"] for l in grid.labels])[_cell_labels(grid)]
    cell = grid.cell_positions().astype(np.int64)
    held = {(int(v), int(k)): float(f) for v, k, f in zip(label_of, cell[:, 0] + nx * (cell[:, 1] + ny * cell[:, 2]), grid.attribute)}
    for value, (_, _, positions, _, arrays) in cells.items():
        expected = []
        for p in positions.astype(np.float64):
            # Binary labels: each vertex is the midpoint of an edge along the axis where p is half-way.
            axis = int(np.argmax(np.abs(p - np.round(p))))
            low = np.floor(p).astype(np.int64)
            around = []
            for du in (0, -1):
                for dv in (0, -1):
                    c = low.copy()
                    others = [k for k in range(3) if k != axis]
                    c[others[0]] += du
                    c[others[1]] += dv
                    key = (value, int(c[0] + nx * (c[1] + ny * c[2])))
                    if key in held and (c >= 0).all():
                        around.append(held[key])
            assert around, (value, p)
            expected.append(np.mean(around))
        np.testing.assert_allclose(arrays["field.npy"], expected, rtol=0, atol=1e-4)
        # The cells' values lie within a cell of the vertex: x + 2y + 3z moves by at most 6 there.
        q = positions.astype(np.float64)
        assert np.abs(arrays["field.npy"] - (q[:, 0] + 2 * q[:, 1] + 3 * q[:, 2])).max() <= 6
    # Python's meshes give the same vertices and values.
    for value, (vertices, _, values) in grid.meshes(space="index", values=True).items():
        np.testing.assert_array_equal(vertices, cells[value][2])
        np.testing.assert_array_equal(values, cells[value][4]["field.npy"])
    with pytest.raises(ValueError, match="has none"):
        isogrid.extract_labels(a).meshes(values=True)


def test_one_file_per_label_from_a_template(cli, tmp_path):
    """``-o "organs/{name}.stl"``: each label's mesh as its own binary STL (read back with
    trimesh), named after the label, the triangles of the .glb's mesh with outward normals; a
    .vtp per label keeps the --color-by values; names are made safe as file names, two labels
    given one file are refused, and a failed run writes nothing."""
    trimesh = pytest.importorskip("trimesh")
    a = _labels()
    path, field_path = tmp_path / "labels.npy", tmp_path / "field.npy"
    np.save(path, a)
    z, y, x = np.mgrid[: a.shape[0], : a.shape[1], : a.shape[2]].astype(np.float32)
    np.save(field_path, x + 2 * y + 3 * z)
    _mc(cli, path, tmp_path / "labels.glb")
    glb = _glb_meshes(tmp_path / "labels.glb")
    lut = tmp_path / "names.txt"
    lut.write_text("4 left/right 255 0 0 0\n9 Nine 0 255 0 0\n17 sheet 0 0 255 0\n")
    report = json.loads(_mc(cli, path, tmp_path / "organs" / "{name}.stl", "--label-table", lut))
    names = {4: "left_right", 9: "Nine", 17: "sheet", 3: "label 3", 60000: "label 60000"}
    assert sorted(p.name for p in (tmp_path / "organs").iterdir()) == sorted(f"{n}.stl" for n in names.values())
    assert report["triangles"] == sum(len(m[3]) for m in glb.values())
    for value, name in names.items():
        body = (tmp_path / "organs" / f"{name}.stl").read_bytes()
        assert not body.startswith(b"solid")
        stl = trimesh.load(tmp_path / "organs" / f"{name}.stl", file_type="stl", process=False)
        _, _, positions, triangles, _ = glb[value]
        assert len(stl.faces) == len(triangles)
        corners = np.asarray(stl.vertices)[np.asarray(stl.faces)]
        np.testing.assert_array_equal(corners, positions[triangles])
        # The file's normals, as written (trimesh keeps them), point out: along the winding's.
        stored = np.frombuffer(body[84:], np.dtype([("n", "<f4", 3), ("p", "<f4", 9), ("a", "<u2")]))["n"]
        winding = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        winding /= np.linalg.norm(winding, axis=1, keepdims=True)
        np.testing.assert_allclose(stored, winding, atol=1e-5)
    # Another format into the existing folder, beside what is there; with the attribute.
    _mc(cli, path, tmp_path / "organs" / "{value}.vtp", "--color-by", field_path)
    assert len(list((tmp_path / "organs").iterdir())) == 10
    for value in names:
        pv = pytest.importorskip("pyvista")
        mesh = pv.read(tmp_path / "organs" / f"{value}.vtp")
        np.testing.assert_array_equal(mesh.points, glb[value][2])
        p = mesh.points.astype(np.float64)
        np.testing.assert_allclose(mesh["field.npy"], p[:, 0] + 2 * p[:, 1] + 3 * p[:, 2], atol=1e-4)
    # Refused, writing nothing.
    lut.write_text("4 same 255 0 0 0\n9 Same 0 255 0 0\n")
    for extra, message in [
        (["--label-table", lut], "labels 4 and 9 would both be written as"),
        (["--color-by", field_path], "STL files carry no per-vertex values"),
    ]:
        failed = subprocess.run(
            [cli, "mc", path, "--labels", "all", "-o", tmp_path / "new" / "{name}.stl", *extra],
            capture_output=True, text=True,
        )
        assert failed.returncode == 1 and message in failed.stderr, failed.stderr
        assert failed.stderr.strip().count("\n") == 0
        assert not (tmp_path / "new").exists()


def test_python_writes_the_cli_label_mesh_files(cli, tmp_path):
    """``LabelGrid.write_meshes(path)`` writes the bytes ``isogrid mc GRID.cgc --labels all -o
    path`` writes, in every output kind, with the grid's attribute where the format keeps it."""
    a = _labels()
    path, field_path = tmp_path / "labels.npy", tmp_path / "field.npy"
    np.save(path, a)
    np.save(field_path, np.arange(a.size, dtype=np.float32).reshape(a.shape))
    cgc = tmp_path / "labels.cgc"
    subprocess.run([cli, "extract", path, "--labels", "all", "--color-by", field_path, "-o", cgc], check=True,
                   capture_output=True)
    grid = isogrid.load(cgc)
    (tmp_path / "cli").mkdir()
    (tmp_path / "py").mkdir()
    for name in ("all.glb", "all.vtp", "ng", "each/{name}.stl", "each/{value}.ply", "each/{value}.glb"):
        subprocess.run([cli, "mc", cgc, "--labels", "all", "-o", tmp_path / "cli" / name], check=True,
                       capture_output=True)
        grid.write_meshes(tmp_path / "py" / name)
    cli_files = sorted(p.relative_to(tmp_path / "cli") for p in (tmp_path / "cli").rglob("*") if p.is_file())
    py_files = sorted(p.relative_to(tmp_path / "py") for p in (tmp_path / "py").rglob("*") if p.is_file())
    assert cli_files == py_files and len(cli_files) > 20
    for f in cli_files:
        assert (tmp_path / "cli" / f).read_bytes() == (tmp_path / "py" / f).read_bytes(), f
    assert b"quality" in (tmp_path / "py" / "each" / "4.ply").read_bytes()[:400]
    with pytest.raises(ValueError, match="label meshes are written as"):
        grid.write_meshes(tmp_path / "x.ply")


def test_refusals_are_one_line_and_write_nothing(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    cases = [
        (["--labels", "5", "-o", tmp_path / "none.glb"], "no selected label with a surface"),
        (["--labels", "all", "-o", tmp_path / "labels.ply"], "written as .glb"),
        (["--iso", "1", "--smooth", "1", "-o", tmp_path / "x.ply"], "needs --labels"),
        (["--labels", "all", "--color-by", path, "-o", tmp_path / "folder"], "carry no per-vertex values"),
        # Missing folders are found before the work, naming the folder.
        (["--labels", "all", "-o", tmp_path / "a" / "b" / "{name}.stl"], f"the folder {tmp_path / 'a'} does not exist"),
        (["--labels", "all", "-o", tmp_path / "a" / "all.glb"], f"the folder {tmp_path / 'a'} does not exist"),
        (["--labels", "all", "-o", tmp_path / "a" / "ng"], f"the folder {tmp_path / 'a'} does not exist"),
        (["--iso", "1", "-o", tmp_path / "a" / "x.stl"], f"the folder {tmp_path / 'a'} does not exist"),
        (["--labels", "all", "-o", tmp_path / "{name}" / "{value}.stl"], "fill in the file name, not a folder"),
    ]
    for args, message in cases:
        failed = subprocess.run([cli, "mc", path, *args], capture_output=True, text=True)
        assert failed.returncode != 0, args
        assert message in failed.stderr, (args, failed.stderr)
        assert failed.stderr.strip().count("\n") == 0 or "Usage" in failed.stderr, failed.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["labels.npy"]


def test_python_label_meshes_are_the_cli_glb_meshes(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    _mc(cli, path, tmp_path / "labels.glb")
    glb = _glb_meshes(tmp_path / "labels.glb")
    grid = isogrid.extract_labels(a)
    meshes = grid.meshes(space="index")
    assert list(meshes) == [label["value"] for label in grid.labels]
    for value, (vertices, faces) in meshes.items():
        assert vertices.dtype == np.float32 and vertices.shape[1] == 3
        assert faces.dtype == np.uint32 and faces.shape[1] == 3
        np.testing.assert_array_equal(vertices, glb[value][2])
        np.testing.assert_array_equal(faces, glb[value][3])
    # World space: the array's own frame here is index space scaled by the spacing.
    spaced = isogrid.extract_labels(a, spacing=(0.5, 1.0, 2.0))
    for value, (world, _) in spaced.meshes().items():
        np.testing.assert_allclose(world, meshes[value][0] * np.array([0.5, 1.0, 2.0], np.float32), rtol=1e-6)
    assert not hasattr(isogrid.extract(a.astype(np.float32), iso=1), "meshes")
    with pytest.raises(ValueError, match="space"):
        grid.meshes(space="voxel")


def test_a_slicer_segmentation_meshes_with_its_own_names_and_layers(cli, tmp_path):
    """mc --labels reads a .seg.nrrd as extract --labels does: every (layer, value) label of a
    two-layer file, with the names and colours its segments give."""
    seg = Path(__file__).resolve().parents[2] / "crates/isogrid-io/tests/fixtures/labels/two_layers.seg.nrrd"
    grid = tmp_path / "seg.cgc"
    subprocess.run([cli, "extract", seg, "--labels", "all", "-o", grid], check=True, capture_output=True)
    info = json.loads(
        subprocess.run([cli, "info", grid, "--json"], check=True, capture_output=True, text=True).stdout
    )
    _mc(cli, seg, tmp_path / "seg.glb")
    meshes = _glb_meshes(tmp_path / "seg.glb")
    listed = {int(l["value"]): l["name"] for l in info["labels"]}
    assert len(listed) >= 4
    assert {value: m[0] for value, m in meshes.items()} == listed

"""``isogrid mc --labels``: the glTF binary read back with pygltflib and the neuroglancer
precomputed folder read as its specification lays it out, against Marching Cubes of each label's
indicator by scikit-image (the same crossed edges: one vertex at the midpoint of each) and the
labels' names and colours from ``extract_labels``."""

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import isogrid
from test_labels import _labels

pygltflib = pytest.importorskip("pygltflib")
measure = pytest.importorskip("skimage.measure")


def _accessor(gltf, blob, index, dtype, width):
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    return np.frombuffer(blob, dtype, count=acc.count * width, offset=start).reshape(-1, width)


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


def test_refusals_are_one_line_and_write_nothing(cli, tmp_path):
    a = _labels()
    path = tmp_path / "labels.npy"
    np.save(path, a)
    cases = [
        (["--labels", "5", "-o", tmp_path / "none.glb"], "no selected label with a surface"),
        (["--labels", "all", "-o", tmp_path / "labels.ply"], "written as .glb"),
        (["--iso", "1", "--smooth", "1", "-o", tmp_path / "x.ply"], "needs --labels"),
        (["--labels", "all", "--color-by", path, "-o", tmp_path / "y.glb"], "carry no per-vertex values"),
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

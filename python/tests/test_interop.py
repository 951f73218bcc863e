"""The paths into PyVista, trimesh and napari that docs/interop.md shows, and the napari example's
surface: the meshes must arrive where the volume's surface is, closed and wound outwards."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import isogrid

DOCS = Path(__file__).resolve().parents[2] / "docs"


def _ball(n=40, radius=12.0):
    """(z, y, x) float32 distance-like field: inside (>= 0) within `radius` of an off-centre point."""
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float32)
    return radius - np.sqrt((x - 21.3) ** 2 + (y - 18.7) ** 2 + (z - 20.1) ** 2)


def test_trimesh_takes_the_mesh_closed_with_the_balls_volume():
    trimesh = pytest.importorskip("trimesh")
    volume = isogrid.Volume(_ball(), spacing=(0.5, 1.0, 2.0), origin=(10.0, -5.0, 3.0))
    vertices, faces = isogrid.marching_cubes(volume, iso=0.0)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert len(mesh.vertices) == len(vertices)
    assert mesh.is_watertight and mesh.is_winding_consistent
    # Wound outwards: a positive volume near the ellipsoid's (radius 12 voxels, scaled per axis).
    expected = 4 / 3 * np.pi * 12**3 * 0.5 * 1.0 * 2.0
    assert mesh.volume == pytest.approx(expected, rel=0.02)
    # World space: the centre (21.3, 18.7, 20.1) voxels scaled by the spacing, plus the origin.
    centre = np.array([10 + 0.5 * 21.3, -5 + 18.7, 3 + 2 * 20.1])
    np.testing.assert_allclose(mesh.center_mass, centre, atol=0.05)


def test_the_mc_stl_is_the_mesh_a_slicer_gets(cli, tmp_path):
    """``isogrid mc -o ball.stl`` (3D printing): trimesh reads the binary STL as the world-space
    mesh ``marching_cubes`` gives, merged back to a closed solid of the ball's volume."""
    import subprocess

    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "ball.nrrd"
    nrrd = pytest.importorskip("nrrd")
    nrrd.write(str(path), _ball().transpose().copy(order="F"), {"space directions": np.diag([0.5, 1.0, 2.0]),
               "space origin": [10.0, -5.0, 3.0], "space": "left-posterior-superior"})
    subprocess.run([cli, "mc", path, "--iso", "0", "-o", tmp_path / "ball.stl"], check=True, capture_output=True)
    vertices, faces = isogrid.marching_cubes(path, iso=0.0)
    stl = trimesh.load(tmp_path / "ball.stl", file_type="stl")  # merges the corners STL repeats
    assert len(stl.faces) == len(faces) and len(stl.vertices) == len(vertices)
    np.testing.assert_array_equal(np.sort(stl.vertices, axis=0), np.sort(vertices, axis=0))
    assert stl.is_watertight and stl.is_winding_consistent
    assert stl.volume == pytest.approx(trimesh.Trimesh(vertices, faces, process=False).volume, rel=1e-6)
    assert stl.volume > 0


def test_the_mc_glb_is_the_mesh_with_its_values_for_blender_and_the_web(cli, tmp_path):
    """``isogrid mc -o ball.glb --color-by f``: trimesh reads the glTF as the world-space mesh
    ``marching_cubes`` gives, closed and wound outwards, pygltflib finds the attribute as the vertex
    attribute ``_VALUE`` (named after the attribute file) equal to the PLY's ``quality``, and an
    empty surface is a glTF with no scene that both open."""
    import subprocess

    trimesh = pytest.importorskip("trimesh")
    pygltflib = pytest.importorskip("pygltflib")
    nrrd = pytest.importorskip("nrrd")
    path = tmp_path / "ball.nrrd"
    header = {"space directions": np.diag([0.5, 1.0, 2.0]), "space origin": [10.0, -5.0, 3.0],
              "space": "left-posterior-superior"}
    nrrd.write(str(path), _ball().transpose().copy(order="F"), header)
    z, y, x = np.mgrid[:40, :40, :40].astype(np.float32)
    nrrd.write(str(tmp_path / "f.nrrd"), (x + 2 * y - z).transpose().copy(order="F"), header)
    for out in ("ball.glb", "ball.ply"):
        subprocess.run([cli, "mc", path, "--iso", "0", "--color-by", tmp_path / "f.nrrd", "-o", tmp_path / out],
                       check=True, capture_output=True)
    vertices, faces = isogrid.marching_cubes(path, iso=0.0)
    scene = trimesh.load(tmp_path / "ball.glb", process=False)
    (mesh,) = scene.geometry.values()
    np.testing.assert_array_equal(mesh.vertices, vertices)
    np.testing.assert_array_equal(mesh.faces, faces)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    gltf = pygltflib.GLTF2().load(str(tmp_path / "ball.glb"))
    (node,) = [gltf.nodes[i] for i in gltf.scenes[gltf.scene].nodes]
    assert node.name == "isosurface"
    accessor = gltf.accessors[gltf.meshes[node.mesh].primitives[0].attributes._VALUE]
    assert accessor.name == "f.nrrd" and accessor.count == len(vertices)
    view = gltf.bufferViews[accessor.bufferView]
    values = np.frombuffer(gltf.binary_blob(), "<f4", accessor.count, view.byteOffset + (accessor.byteOffset or 0))
    ply = (tmp_path / "ball.ply").read_bytes()
    assert b"property float quality" in ply[:400]
    quality = np.frombuffer(ply[ply.index(b"end_header\n") + 11:], "<f4", len(vertices) * 4).reshape(-1, 4)[:, 3]
    np.testing.assert_array_equal(values, quality)
    # The attribute shares the surface's patient space: its index at each world vertex, x + 2y - z.
    index = (vertices - np.array([10.0, -5.0, 3.0])) / np.array([0.5, 1.0, 2.0])
    np.testing.assert_allclose(values, index[:, 0] + 2 * index[:, 1] - index[:, 2], atol=1e-3)
    # Nothing above the isovalue: an empty glTF, not an error.
    subprocess.run([cli, "mc", path, "--iso", "100", "-o", tmp_path / "empty.glb"], check=True, capture_output=True)
    empty = pygltflib.GLTF2().load(str(tmp_path / "empty.glb"))
    assert empty.nodes == [] and empty.scene is None
    assert len(trimesh.load(tmp_path / "empty.glb").geometry) == 0


def test_pyvista_takes_the_mesh_and_its_attribute():
    pv = pytest.importorskip("pyvista")
    ball = _ball()
    z, y, x = np.mgrid[: ball.shape[0], : ball.shape[1], : ball.shape[2]]
    attribute = (x + 2 * y).astype(np.float32)
    vertices, faces, values = isogrid.marching_cubes(ball, iso=0.0, attribute=attribute)
    mesh = pv.PolyData.from_regular_faces(vertices, faces)
    mesh.point_data["attribute"] = values
    assert mesh.n_points == len(vertices) and mesh.n_cells == len(faces)
    points = np.asarray(mesh.points)
    # The attribute is linear, so trilinear interpolation is exact: x + 2y at each vertex (x, y, z).
    np.testing.assert_allclose(mesh.point_data["attribute"], points[:, 0] + 2 * points[:, 1], atol=1e-3)
    # Outward normals: from the centre towards each vertex.
    normals = np.asarray(mesh.compute_normals(point_normals=True, cell_normals=False, auto_orient_normals=False).point_data["Normals"])
    outward = points - np.array([21.3, 18.7, 20.1])
    assert (np.einsum("ij,ij->i", normals, outward) > 0).mean() > 0.99


def test_napari_example_surface_lies_on_the_image():
    pytest.importorskip("napari")
    from napari.layers import Image, Surface

    spec = importlib.util.spec_from_file_location("napari_example", DOCS / "napari-example.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)  # defines functions only; main() is not run
    volume = example.blob_volume(48)
    for iso in (-0.5, 0.0, 0.7):
        layer = Surface(example.surface_data(volume, iso))
        vertices = np.asarray(layer.data[0])
        assert len(vertices) > 100
        # In the image's (z, y, x) data coordinates, each vertex is where the volume crosses iso:
        # trilinear interpolation of the volume there gives iso.
        from scipy.ndimage import map_coordinates

        at = map_coordinates(volume, vertices.T, order=1)
        np.testing.assert_allclose(at, iso, atol=1e-4)
        image = Image(volume)
        assert np.all(vertices >= 0) and np.all(vertices <= np.array(volume.shape) - 1)
        assert image.ndim == layer.ndim == 3

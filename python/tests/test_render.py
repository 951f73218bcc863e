"""isogrid.render: shapes, AOV conventions, cameras, backends and errors (the renderers themselves
are tested in Rust against reference ray casters)."""
import numpy as np
import pytest

import isogrid
from conftest import sphere


@pytest.fixture(scope="module")
def grid():
    return isogrid.extract(sphere(), iso=0.0)  # centre (13, 11, 9), radius 8


def test_cpu_render_has_image_and_aovs_with_miss_conventions(grid):
    image, aov = isogrid.render(grid, size=(40, 30), backend="cpu", aovs=("depth", "normal", "cluster", "backend"))
    assert image.shape == (30, 40, 3) and image.dtype == np.uint8
    assert aov["backend"] == "cpu"
    depth, normal, cluster = aov["depth"], aov["normal"], aov["cluster"]
    assert depth.shape == (30, 40) and depth.dtype == np.float32
    assert normal.shape == (30, 40, 3) and cluster.dtype == np.uint32
    miss = cluster == np.iinfo(np.uint32).max
    assert 0 < miss.sum() < miss.size
    assert np.all(np.isinf(depth[miss])) and np.all(np.isfinite(depth[~miss]))
    assert np.all(np.isnan(normal[miss]))
    assert np.allclose(np.linalg.norm(normal[~miss], axis=-1), 1.0, atol=1e-3)
    # Background pixels have the background colour; the sphere is brighter.
    assert image[~miss].mean() > image[miss].mean()


def test_both_traversals_draw_the_same_depth(grid):
    depth = {t: isogrid.render(grid, camera=2, size=(64, 48), backend="cpu", traversal=t, aovs=("depth",))[1]["depth"]
             for t in ("blocks", "bvh")}
    hit = np.isfinite(depth["blocks"])
    assert 100 < hit.sum() < hit.size
    assert np.array_equal(hit, np.isfinite(depth["bvh"]))
    assert np.allclose(depth["blocks"][hit], depth["bvh"][hit], rtol=1e-6, atol=0)
    with pytest.raises(ValueError, match="traversal"):
        isogrid.render(grid, size=(4, 4), backend="cpu", traversal="octree")


def test_explicit_camera_looks_where_it_is_told(grid):
    eye, centre = (13.0, 11.0, 80.0), (13.0, 11.0, 9.0)
    toward = isogrid.render(grid, camera=(eye, centre, (0, 1, 0), 30.0), size=(16, 16), backend="cpu",
                            aovs=("depth",))[1]["depth"]
    away = isogrid.render(grid, camera=(eye, (13.0, 11.0, 200.0), (0, 1, 0), 30.0), size=(16, 16),
                          backend="cpu", aovs=("depth",))[1]["depth"]
    # The ray through the middle meets the sphere's near pole at distance 80 − 9 − 8 = 63.
    assert abs(toward[8, 8] - 63.0) < 0.5
    assert np.all(np.isinf(away))


def test_auto_backend_agrees_with_the_cpu_tracer(grid):
    _, gpu = isogrid.render(grid, camera=2, size=(48, 36), aovs=("depth", "backend"))
    _, cpu = isogrid.render(grid, camera=2, size=(48, 36), backend="cpu", aovs=("depth",))
    if gpu["backend"] != "gpu":
        pytest.skip("no GPU adapter (install mesa-vulkan-drivers for lavapipe)")
    a, b = gpu["depth"], cpu["depth"]
    assert np.mean(np.isfinite(a) == np.isfinite(b)) >= 0.99
    both = np.isfinite(a) & np.isfinite(b)
    assert both.sum() > 100
    assert np.mean(np.abs(a[both] - b[both]) <= 0.05) >= 0.99


def test_bad_arguments_raise_value_error(grid):
    with pytest.raises(ValueError, match="mode"):
        isogrid.render(grid, mode="wireframe")
    with pytest.raises(ValueError, match="backend"):
        isogrid.render(grid, backend="tpu")
    with pytest.raises(ValueError, match="camera"):
        isogrid.render(grid, camera="front")
    with pytest.raises(ValueError, match="view 3"):
        isogrid.render(grid, camera=3)
    with pytest.raises(ValueError, match="AOV"):
        isogrid.render(grid, aovs=("albedo",))
    with pytest.raises(ValueError, match="GPU"):
        isogrid.render(grid, mode="cgc-noewa", backend="cpu")
    with pytest.raises(ValueError, match="CellGrid"):
        isogrid.render(np.zeros((4, 4, 4)))

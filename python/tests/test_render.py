"""isogrid.render: shapes, AOV conventions, cameras, backends and errors (the renderers themselves
are tested in Rust against reference ray casters)."""
from pathlib import Path

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


def test_gpu_backend_agrees_with_the_cpu_tracer(grid):
    gpu_or_skip(grid)
    _, gpu = isogrid.render(grid, camera=2, size=(48, 36), backend="gpu", aovs=("depth", "backend"))
    _, cpu = isogrid.render(grid, camera=2, size=(48, 36), backend="cpu", aovs=("depth",))
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


def write_hdr(path, rgb):
    """A Radiance .hdr file (flat RGBE scanlines) of a float array rgb[row, column, channel]."""
    h, w, _ = rgb.shape
    peak = rgb.max(axis=-1)
    mantissa, exponent = np.frexp(peak)
    scale = np.where(peak > 0, mantissa * 256.0 / np.where(peak > 0, peak, 1), 0)
    rgbe = np.zeros((h, w, 4), dtype=np.uint8)
    rgbe[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(peak > 0, exponent + 128, 0).astype(np.uint8)
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    path.write_bytes(header + rgbe.tobytes())


def latitude_map(path):
    """Green above the horizon, dim red below: the same along every longitude, so the map's
    orientation about the vertical axis cannot matter."""
    rgb = np.zeros((8, 16, 3), dtype=np.float32)
    rgb[:4] = (0.1, 0.9, 0.2)
    rgb[4:] = (0.3, 0.05, 0.05)
    write_hdr(path, rgb)
    return path


def gpu_or_skip(grid):
    try:
        _, aov = isogrid.render(grid, size=(8, 8), backend="gpu", aovs=("backend",))
    except ValueError as e:
        pytest.skip(f"no GPU adapter (install mesa-vulkan-drivers for lavapipe): {e}")
    assert aov["backend"] == "gpu"


def test_env_map_lights_path_tracing_alike_on_cpu_and_gpu(grid, tmp_path):
    gpu_or_skip(grid)
    env = latitude_map(tmp_path / "latitude.hdr")
    kw = dict(camera=2, size=(48, 36), mode="pathtrace", spp=64, aovs=("cluster", "backend"))
    cpu, cpu_aov = isogrid.render(grid, backend="cpu", env=env, **kw)
    gpu, gpu_aov = isogrid.render(grid, backend="gpu", env=str(env), **kw)
    sky, _ = isogrid.render(grid, backend="cpu", **kw)
    assert (cpu_aov["backend"], gpu_aov["backend"]) == ("cpu", "gpu")
    hit = cpu_aov["cluster"] != np.iinfo(np.uint32).max
    assert np.mean(hit == (gpu_aov["cluster"] != np.iinfo(np.uint32).max)) >= 0.97
    for region in (hit, ~hit):
        a, b = cpu[region].mean(axis=0), gpu[region].mean(axis=0)
        assert np.all(np.abs(a - b) <= 10), (a, b)
    # The map is what lit it: view 2 looks down, so the background is the map's lower half,
    # linear (0.3, 0.05, 0.05) in sRGB, on both backends; the built-in sky looks different.
    srgb = np.array([149, 63, 63])
    for image in (cpu, gpu):
        assert np.all(np.abs(np.median(image[~hit], axis=0) - srgb) <= 2), np.median(image[~hit], axis=0)
    assert np.abs(sky.astype(float) - cpu.astype(float)).mean() > 20


def test_gpu_path_tracing_takes_one_sample_per_frame(grid):
    gpu_or_skip(grid)
    kw = dict(camera=2, size=(64, 48), mode="pathtrace", backend="gpu", aovs=("depth", "backend"))
    one, aov = isogrid.render(grid, spp=1, **kw)
    few, _ = isogrid.render(grid, spp=8, **kw)
    more, _ = isogrid.render(grid, spp=32, **kw)
    many, _ = isogrid.render(grid, spp=256, **kw)
    assert aov["backend"] == "gpu"
    hit = np.isfinite(aov["depth"])
    assert hit.sum() > 100
    # Samples accumulate over frames: the noise on the surface shrinks towards the 256-sample
    # image (measured on lavapipe: mean error 25, 17, 11 sRGB units at 1, 8, 32 samples); the
    # directly seen environment needs no samples.
    err = lambda img: np.abs(img[hit].astype(float) - many[hit].astype(float)).mean()  # noqa: E731
    assert err(one) > err(few) > err(more)
    assert err(more) < 0.6 * err(one)
    assert np.array_equal(one[~hit], many[~hit])


def test_progress_is_called_with_increasing_counts(grid):
    calls = []
    isogrid.render(grid, size=(96, 72), mode="pathtrace", spp=64, backend="cpu",
                   progress=lambda done, total: calls.append((done, total)))
    assert calls, "never called"
    done = [d for d, _ in calls]
    assert done == sorted(done)
    assert {t for _, t in calls} == {65 * 72}  # rows of the primary pass and of 64 sample passes
    assert calls[-1] == (65 * 72, 65 * 72)
    with pytest.raises(ValueError, match="callable"):
        isogrid.render(grid, size=(8, 8), backend="cpu", progress=3)


def test_raising_in_progress_stops_the_render(grid):
    class Stop(Exception):
        pass

    calls = []

    def stop_after_two(done, total):
        calls.append((done, total))
        if len(calls) == 2:
            raise Stop("enough")

    # Hours of work at 100000 samples per pixel: only cancelling ends it.
    with pytest.raises(Stop, match="enough"):
        isogrid.render(grid, size=(96, 72), mode="pathtrace", spp=100000, backend="cpu",
                       progress=stop_after_two)
    assert len(calls) == 2 and calls[1][0] < calls[1][1]


def test_ctrl_c_stops_a_render(tmp_path):
    """SIGINT in a process rendering for hours: KeyboardInterrupt within seconds."""
    import signal
    import subprocess
    import sys
    import time

    script = (
        "import sys, numpy as np, isogrid\n"
        "from conftest import sphere\n"
        "g = isogrid.extract(sphere(), iso=0.0)\n"
        "print('rendering', flush=True)\n"
        "try:\n"
        "    isogrid.render(g, size=(96, 72), mode='pathtrace', spp=100000, backend='cpu')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True)\n"
        "    sys.exit(3)\n"
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                             cwd=str(Path(__file__).parent))
    assert child.stdout.readline().strip() == "rendering"
    time.sleep(1.0)
    child.send_signal(signal.SIGINT)
    try:
        out, _ = child.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        child.kill()
        pytest.fail("still rendering 60 s after Ctrl-C")
    assert child.returncode == 3 and "interrupted" in out

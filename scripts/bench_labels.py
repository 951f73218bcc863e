#!/usr/bin/env python3
"""Label surfaces: isogrid's `extract(..., labels="all")` against vtkSurfaceNets3D (with and
without its smoothing), vtkDiscreteFlyingEdges3D, zmesh and scikit-image one label at a time, at
1 and 2 threads, on the Desikan-Killiany atlas (data/atlas-desikankilliany.nii.gz,
scripts/fetch_data.sh atlas), PyVista's bundled frog tissues (frog_tissues.vti) and 256³ Voronoi
supervoxels made here. Each run is a fresh process that loads the labels from a .npy copy first,
so its peak-memory growth is the extraction's. Prints markdown tables for
docs/benchmarks-labels.md.

    python scripts/bench_labels.py            # needs isogrid (python/), vtk, pyvista, zmesh,
                                              # scikit-image, nibabel, scipy in the running Python;
                                              # --volumes=atlas,frog for some of them
    python scripts/bench_labels.py --smooth   # also the --smooth table (scipy)
    python scripts/bench_labels.py --stream   # only the streamed table: `isogrid extract --labels`
                                              # of 512³ supervoxels in memory and within
                                              # --max-memory (the CLI of target/release, or
                                              # $ISOGRID_CLI; numpy, scipy)
    python scripts/bench_labels.py --stream-2048  # the same 50,000 supervoxels at 2048³ as a Zarr
                                              # (zarr-python; 17 GB of samples, compressed), streamed
    python scripts/bench_labels.py --dask-budgets # isogrid.dask.extract of the 512³ supervoxels
                                              # from a Zarr copy, at several tile_bytes
    python scripts/bench_labels.py --census   # `isogrid info --labels all` (voxels and boxes of
                                              # every label) against numpy.unique + scipy
                                              # find_objects, on the three volumes
    python scripts/bench_labels.py --precision  # the corner precision of smoothed labels (σ = 1):
                                              # file size, and how far 4- and 8-bit corners move
                                              # the surface from f32 corners (vtk for the mesh size)
    python scripts/bench_labels.py --masks    # a TotalSegmentator-like folder of 117 NIfTI masks
                                              # (the frog's 25 tissues and 92 empty ones, written
                                              # by nibabel): `isogrid extract FOLDER --labels all`
                                              # against nibabel + numpy + vtkSurfaceNets3D
"""

import hashlib
import json
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "data")
VOLUMES = {
    "atlas": "atlas-desikankilliany.nii.gz",
    # PyVista's bundled examples/frog_tissues.vti (pyvista, a test dependency), read with VTK.
    "frog": "pyvista:frog_tissues.vti",
    # Generated here: 256³ supervoxels, the Voronoi cells of 6,250 random seeds (the density of
    # 50,000 labels in 512³), as u16.
    "supervoxels": None,
}
SUPERVOXELS = (256, 6250)
REPEATS = 5


def npy_of(name):
    """The volume as data/bench-labels-NAME.npy, (z, y, x) C order, with its spacing (x, y, z)."""
    path = os.path.join(DATA, f"bench-labels-{name}.npy")
    if VOLUMES[name] is None:
        n, seeds = SUPERVOXELS
        if not os.path.exists(path):
            from scipy.spatial import cKDTree

            rng = np.random.default_rng(40)
            tree = cKDTree(rng.uniform(0, n, size=(seeds, 3)))
            grid = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
            labels = np.empty(n**3, np.uint16)
            for start in range(0, n**3, 1 << 22):
                labels[start : start + (1 << 22)] = tree.query(grid[start : start + (1 << 22)], workers=2)[1] + 1
            np.save(path, labels.reshape(n, n, n))
        return path, (1.0, 1.0, 1.0), "uint16", (n, n, n)
    if VOLUMES[name].startswith("pyvista:"):
        import pyvista
        import vtk
        from vtk.util import numpy_support

        reader = vtk.vtkXMLImageDataReader()
        reader.SetFileName(os.path.join(os.path.dirname(pyvista.examples.__file__), VOLUMES[name][8:]))
        reader.Update()
        image = reader.GetOutput()
        nx, ny, nz = image.GetDimensions()
        a = numpy_support.vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
        spacing = tuple(float(s) for s in image.GetSpacing())
        if not os.path.exists(path):
            np.save(path, a)
        return path, spacing, str(a.dtype), a.shape
    src = os.path.join(DATA, VOLUMES[name])
    if src.endswith(".nii.gz"):
        import nibabel

        img = nibabel.load(src)
        a = np.asarray(img.dataobj)
        spacing = tuple(float(s) for s in img.header.get_zooms()[:3])
        a = np.ascontiguousarray(a.transpose(2, 1, 0))  # (x, y, z) → (z, y, x)
    else:
        import SimpleITK as sitk

        img = sitk.ReadImage(src)
        a = sitk.GetArrayFromImage(img)  # (z, y, x)
        spacing = tuple(float(s) for s in img.GetSpacing())
    if not os.path.exists(path):
        np.save(path, a)
    return path, spacing, str(a.dtype), a.shape


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def peak_rss_bytes():
    """This process's peak resident memory. VmHWM, not getrusage's ru_maxrss: Linux carries
    ru_maxrss over exec, so a child would report its parent's peak."""
    with open("/proc/self/status") as f:
        line = next(l for l in f if l.startswith("VmHWM:"))
    return int(line.split()[1]) * 1024


def best_of(make, run):
    """Best seconds of `run(make())` over REPEATS runs, fewer once 30 s have gone (one label at a
    time on 6,250 supervoxels takes minutes); `make` builds the inputs outside the timing. Returns
    the seconds and the last output, which stays alive for the peak."""
    times = []
    out = None
    while len(times) < REPEATS and sum(times) < 30:
        out = None  # one output alive at a time
        args = make()
        start = time.perf_counter()
        out = run(args)
        times.append(time.perf_counter() - start)
    return min(times), out


def run_isogrid(path, spacing, smooth, threads):
    import isogrid

    a = np.load(path)
    before = rss_bytes()
    seconds, grid = best_of(
        lambda: None,
        lambda _: isogrid.extract(a, labels="all", smooth=smooth, spacing=spacing, threads=threads),
    )
    peak = peak_rss_bytes()
    labels = grid.labels
    return {
        "seconds": seconds,
        "peak_growth": peak - before,
        "bytes": len(grid.to_bytes()),
        "cells": grid.active_cells,
        "labels": len(labels),
        "empty_labels": sum(1 for l in labels if l["cells"] == 0),
    }


def updated(algorithm):
    algorithm.Update()
    return algorithm


def vtk_image(path, spacing, threads):
    """The labels as vtkImageData sharing the array's memory, and VTK's SMP backend set for
    `threads`: Sequential for one, the wheel's STDThread pool of `threads` otherwise."""
    import vtk
    from vtk.util import numpy_support

    if threads == 1:
        vtk.vtkSMPTools.SetBackend("Sequential")
    else:
        vtk.vtkSMPTools.SetBackend("STDThread")
        vtk.vtkSMPTools.Initialize(threads)
    a = np.load(path)
    image = vtk.vtkImageData()
    image.SetDimensions(a.shape[2], a.shape[1], a.shape[0])
    image.SetSpacing(*spacing)
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(a.ravel(order="C"), deep=False))
    values = np.unique(a)
    return a, image, values[values != 0]


def run_vtk_mesher(path, spacing, threads, make, compact):
    """Times `make(image, values)`'s VTK filter over the labels; its mesh's points and cells,
    VTK's own count of its memory and `compact(points, cells)`."""
    _, image, values = vtk_image(path, spacing, threads)
    before = rss_bytes()
    seconds, algorithm = best_of(lambda: make(image, values), updated)
    peak = peak_rss_bytes()
    mesh = algorithm.GetOutput()
    points = mesh.GetNumberOfPoints()
    cells = mesh.GetNumberOfCells()
    return {
        "seconds": seconds,
        "peak_growth": peak - before,
        "points": points,
        "faces": cells,
        "held_bytes": mesh.GetActualMemorySize() * 1024,  # GetActualMemorySize is in KiB
        "compact_bytes": compact(points, cells),
    }


def run_vtk(path, spacing, smooth, threads):
    """vtkSurfaceNets3D, every non-zero label set, quads out (each with its two boundary labels).
    Compact: the paper's Table 3 count of MC meshes, 6 B per vertex (snorm16) and 4 B per index,
    plus the two labels of each quad at 2 B each."""
    import vtk

    def make(image, values):
        nets = vtk.vtkSurfaceNets3D()
        nets.SetInputData(image)
        nets.SetBackgroundLabel(0)
        nets.SetOutputMeshTypeToQuads()
        nets.SetSmoothing(bool(smooth))
        nets.SetNumberOfLabels(len(values))
        for i, v in enumerate(values):
            nets.SetLabel(i, float(v))
        return nets

    return run_vtk_mesher(path, spacing, threads, make, lambda points, quads: points * 6 + quads * (16 + 4))


def run_dfe(path, spacing, smooth, threads):
    """vtkDiscreteFlyingEdges3D, one contour value per non-zero label: triangles, each point's
    label as its scalar. Compact: 6 B per vertex and 12 B per triangle (Table 3), plus each point's
    label at 2 B."""
    import vtk

    def make(image, values):
        dfe = vtk.vtkDiscreteFlyingEdges3D()
        dfe.SetInputData(image)
        dfe.SetNumberOfContours(len(values))
        for i, v in enumerate(values):
            dfe.SetValue(i, float(v))
        return dfe

    return run_vtk_mesher(path, spacing, threads, make, lambda points, triangles: points * 8 + triangles * 12)


def run_zmesh(path, spacing, smooth, threads):
    """zmesh's multi-label marching cubes (one thread: zmesh has no parallel mode), then every
    label's mesh taken out with `get`, as a user reads them; no normals, no simplification."""
    import zmesh

    a = np.load(path)
    before = rss_bytes()
    xyz = np.asfortranarray(a.transpose(2, 1, 0))  # zmesh takes (x, y, z) arrays

    def run(_):
        mesher = zmesh.Mesher(spacing)
        mesher.mesh(xyz)
        meshes = [mesher.get(label, normals=False) for label in mesher.ids()]
        mesher.clear()
        return meshes

    seconds, meshes = best_of(lambda: None, run)
    peak = peak_rss_bytes()
    points = sum(len(m.vertices) for m in meshes)
    triangles = sum(len(m.faces) for m in meshes)
    return {
        "seconds": seconds,
        "peak_growth": peak - before,
        "points": points,
        "faces": triangles,
        "held_bytes": sum(m.vertices.nbytes + m.faces.nbytes for m in meshes),
        "compact_bytes": points * 6 + triangles * 12,
    }


def run_skimage(path, spacing, smooth, threads):
    """scikit-image's marching_cubes one label at a time, each on its box (scipy's find_objects)
    grown by one sample, shifted back into place; labels spread over `threads` Python threads."""
    from concurrent.futures import ThreadPoolExecutor

    from scipy import ndimage
    from skimage.measure import marching_cubes

    a = np.load(path)
    before = rss_bytes()
    zyx_spacing = tuple(spacing[::-1])

    def one(item):
        index, box = item
        lo = [max(b.start - 1, 0) for b in box]
        hi = [min(b.stop + 1, n) for b, n in zip(box, a.shape)]
        verts, faces, _, _ = marching_cubes(
            a[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]] == index + 1, 0.5, spacing=zyx_spacing
        )
        verts += np.array(lo, np.float32) * zyx_spacing
        return verts, faces

    def run(_):
        boxes = [(i, b) for i, b in enumerate(ndimage.find_objects(a)) if b is not None]
        with ThreadPoolExecutor(threads) as pool:
            return list(pool.map(one, boxes))

    seconds, meshes = best_of(lambda: None, run)
    peak = peak_rss_bytes()
    points = sum(len(v) for v, _ in meshes)
    triangles = sum(len(f) for _, f in meshes)
    return {
        "seconds": seconds,
        "peak_growth": peak - before,
        "points": points,
        "faces": triangles,
        "held_bytes": sum(v.nbytes + f.nbytes for v, f in meshes),
        "compact_bytes": points * 6 + triangles * 12,
    }


# (row, tool, smoothing, thread counts), isogrid first in each group: the peers' rows compare the
# .cgc of the same smoothing with their mesh.
PEERS = [
    ("isogrid, σ = 0", "isogrid", 0.0, (1, 2)),
    ("vtkSurfaceNets3D", "vtk", False, (1, 2)),
    ("vtkDiscreteFlyingEdges3D", "dfe", False, (1, 2)),
    ("zmesh", "zmesh", False, (1,)),
    ("scikit-image, one label at a time", "skimage", False, (1, 2)),
    ("isogrid, σ = 1", "isogrid", 1.0, (1, 2)),
    ("vtkSurfaceNets3D, smoothing", "vtk", True, (1, 2)),
]

TOOLS = {"isogrid": run_isogrid, "vtk": run_vtk, "dfe": run_dfe, "zmesh": run_zmesh, "skimage": run_skimage}


def child(tool, path, spacing, smooth, threads):
    print(json.dumps(TOOLS[tool](path, tuple(spacing), smooth, threads)))


def measure(tool, path, spacing, smooth, threads=1):
    out = subprocess.run(
        [sys.executable, __file__, "child", tool, path, json.dumps(spacing), json.dumps(smooth), str(threads)],
        check=True,
        capture_output=True,
        text=True,
        env={**os.environ, "OMP_NUM_THREADS": str(threads), "RAYON_NUM_THREADS": str(threads)},
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def mb(n):
    return f"{n / 1e6:.1f} MB"


def flips(a, sigma):
    """Fraction of each label's voxels (summed over labels) whose membership the smoothing changes:
    samples of L whose smoothed indicator is below 1/2, plus others at or above it."""
    from scipy import ndimage

    changed = 0
    total = 0
    for v in np.unique(a):
        if v == 0:
            continue
        inside = a == v
        s = ndimage.gaussian_filter(inside.astype(np.float32), sigma, mode="nearest", truncate=3.0)
        changed += int(np.count_nonzero(inside != (s >= 0.5)))
        total += int(np.count_nonzero(inside))
    return changed / total


# The streamed figure: 512³ supervoxels, the Voronoi cells of 50,000 random seeds, as u16.
STREAMED = (512, 50_000)


def supervoxels_512():
    """data/bench-labels-supervoxels512.npy (read whole by `isogrid extract`) and the same samples
    as data/bench-labels-supervoxels512.raw (read by region, so streamed within --max-memory)."""
    n, seeds = STREAMED
    npy = os.path.join(DATA, "bench-labels-supervoxels512.npy")
    raw = npy[: -len(".npy")] + ".raw"
    if not (os.path.exists(npy) and os.path.exists(raw)):
        from scipy.spatial import cKDTree

        rng = np.random.default_rng(40)
        tree = cKDTree(rng.uniform(0, n, size=(seeds, 3)))
        labels = np.lib.format.open_memmap(npy, mode="w+", dtype=np.uint16, shape=(n, n, n))
        y, x = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        for z in range(n):
            points = np.stack([np.full(n * n, z), y.ravel(), x.ravel()], axis=-1)
            labels[z] = (tree.query(points, workers=2)[1] + 1).reshape(n, n)
        labels.flush()
        labels.tofile(raw)
        del labels
    return npy, raw, n


def supervoxels_2048():
    """data/bench-labels-supervoxels2048.zarr: the Voronoi cells of the 512³ volume's 50,000 seeds
    scaled by 4, sampled at 2048³, as u16 in a Zarr v3 array (zstd chunks of 16×512×512, z y x).

    Exact without a nearest-seed query per sample: Voronoi cells are convex, so where the eight
    512³ samples around a 4×4×4 cube of 2048³ samples (at 4 × their index) share a label, so does
    the whole cube. Only samples of cubes whose corners differ, and the last 4 planes, rows and
    columns, which no 512³ sample bounds from above, are queried."""
    import zarr
    from scipy.spatial import cKDTree

    path = os.path.join(DATA, "bench-labels-supervoxels2048.zarr")
    done = path + ".complete"
    if os.path.exists(done):
        return path, 2048
    coarse_path, _, m = supervoxels_512()
    coarse = np.load(coarse_path, mmap_mode="r")
    n, scale, depth = 4 * m, 4, 16
    rng = np.random.default_rng(40)
    tree = cKDTree(rng.uniform(0, m, size=(STREAMED[1], 3)) * scale)
    out = zarr.create_array(path, shape=(n, n, n), chunks=(depth, 512, 512), dtype="uint16",
                            overwrite=True)
    fine = np.arange(n)
    ys, xs = np.meshgrid(fine, fine, indexing="ij")
    cy, cx = np.minimum(ys // scale, m - 2), np.minimum(xs // scale, m - 2)
    bounded_yx = (ys < scale * (m - 1)) & (xs < scale * (m - 1))
    slab = np.empty((depth, n, n), np.uint16)
    queried = 0
    for z in range(n):
        cz = min(z // scale, m - 2)
        corners = coarse[cz : cz + 2].astype(np.int64)
        first = corners[0, :-1, :-1]
        uniform = np.ones(first.shape, bool)
        for dz in (0, 1):
            for dy in (0, 1):
                for dx in (0, 1):
                    uniform &= corners[dz, dy : dy + m - 1, dx : dx + m - 1] == first
        known = uniform[cy, cx] & bounded_yx & (z < scale * (m - 1))
        labels = np.where(known, first[cy, cx], 0).astype(np.uint16)
        ask = ~known
        points = np.stack([np.full(int(ask.sum()), z), ys[ask], xs[ask]], axis=-1)
        labels[ask] = tree.query(points, workers=2)[1] + 1
        queried += len(points)
        # The convexity shortcut, checked against the query on samples it answered.
        check = rng.choice(np.flatnonzero(known.ravel()), size=min(1000, int(known.sum())), replace=False)
        at = np.stack([np.full(len(check), z), ys.ravel()[check], xs.ravel()[check]], axis=-1)
        assert np.array_equal(labels.ravel()[check], tree.query(at)[1] + 1), f"plane {z}"
        slab[z % depth] = labels
        if z % depth == depth - 1:
            out[z - depth + 1 : z + 1] = slab
            print(f"  {z + 1} of {n} planes, {100 * queried / ((z + 1) * n * n):.0f} % queried",
                  file=sys.stderr, flush=True)
    open(done, "w").close()
    return path, n


def sha256_of(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for piece in iter(lambda: f.read(1 << 24), b""):
            digest.update(piece)
    return digest.hexdigest()


def stream_2048_table():
    """`isogrid extract --labels all` of the 2048³ supervoxels, streamed from the Zarr within
    `--max-memory`, one run each, and `isogrid.dask.extract` of the same Zarr on the threaded
    scheduler; the files must be byte-identical (compared by SHA-256, one 6 GB file at a time)."""
    path, n = supervoxels_2048()
    out = os.path.join(DATA, "bench-labels-out2048.cgc")
    print("| 2048³ supervoxels, 50,000 labels | --max-memory | seconds | peak resident memory | .cgc |")
    print("|---|---|---|---|---|")
    digests = []
    for budget in ("1280M", "3G"):
        seconds, peak = timed_cli(["extract", path, "--labels", "all", "--max-memory", budget,
                                   "-o", out])
        size = os.path.getsize(out)
        digests.append(sha256_of(out))
        os.remove(out)
        print(f"| streamed (Zarr, read by region) | {budget} | {seconds:.1f} | {mb(peak)} | {mb(size)} |",
              flush=True)
    script = (
        "import sys, time, dask, dask.array as da, isogrid.dask\n"
        "dask.config.set(scheduler='threads')\n"
        "start = time.perf_counter()\n"
        "isogrid.dask.extract(da.from_zarr(sys.argv[1]), labels='all', output=sys.argv[2])\n"
        "print(time.perf_counter() - start)\n"
    )
    report = os.path.join(DATA, "bench-labels-time.txt")
    done = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", report, sys.executable, "-c", script,
                           path, out], check=True, capture_output=True, text=True)
    with open(report) as f:
        peak = int(f.read().split()[-1]) * 1024
    os.remove(report)
    size = os.path.getsize(out)
    digests.append(sha256_of(out))
    os.remove(out)
    print(f"| isogrid.dask.extract (threads, default tiles) | - | {float(done.stdout.split()[-1]):.1f} | "
          f"{mb(peak)} | {mb(size)} |", flush=True)
    print(f"byte-identical: {len(set(digests)) == 1}")


def timed_cli(args):
    """Wall seconds and peak resident memory (bytes) of `isogrid args`, from GNU time."""
    cli = os.environ.get("ISOGRID_CLI") or os.path.join(ROOT, "target", "release", "isogrid")
    report = os.path.join(DATA, "bench-labels-time.txt")
    subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", report, cli] + args, check=True,
                   stdout=subprocess.DEVNULL)
    with open(report) as f:
        seconds, kib = f.read().split()[-2:]
    os.remove(report)
    return float(seconds), int(kib) * 1024


def stream_table():
    """`isogrid extract --labels all` of the 512³ supervoxels read whole (.npy) and streamed (raw,
    `--max-memory`), one run each; the two files must be byte-identical."""
    npy, raw, n = supervoxels_512()
    out = os.path.join(DATA, "bench-labels-out.cgc")
    print("| 512³ supervoxels, 50,000 labels | --max-memory | seconds | peak resident memory | .cgc |")
    print("|---|---|---|---|---|")
    outputs = []
    for how, args in [
        ("in memory (.npy read whole)", [npy]),
        ("streamed (raw, read by region)", [raw, "--raw-shape", f"{n},{n},{n}", "--raw-type", "u16",
                                            "--max-memory", "512M"]),
        ("streamed (raw, read by region)", [raw, "--raw-shape", f"{n},{n},{n}", "--raw-type", "u16",
                                            "--max-memory", "128M"]),
    ]:
        seconds, peak = timed_cli(["extract"] + args + ["--labels", "all", "-o", out])
        budget = args[-1] if "--max-memory" in args else "-"
        size = os.path.getsize(out)
        outputs.append(hashlib.sha256(open(out, "rb").read()).hexdigest())
        os.remove(out)
        print(f"| {how} | {budget} | {seconds:.1f} | {mb(peak)} | {mb(size)} |", flush=True)
    print(f"byte-identical: {len(set(outputs)) == 1}")


def dask_budget_table():
    """`isogrid.dask.extract(da.from_zarr(...), labels="all", tile_bytes=T)` of the 512³
    supervoxels (a Zarr copy of the .npy, chunks of 64 planes), dask's threaded scheduler on 2
    threads, one fresh process per budget, against the CLI's in-memory file. The source is read
    chunk by chunk, so the peak is the extraction's and dask's, not a copy of the input."""
    import zarr

    npy, _, n = supervoxels_512()
    path = os.path.join(DATA, "bench-labels-supervoxels512.zarr")
    done = os.path.join(path, ".complete")
    if not os.path.exists(done):
        source = np.load(npy, mmap_mode="r")
        out = zarr.create_array(path, shape=source.shape, chunks=(64, n, n), dtype="uint16", overwrite=True)
        for z in range(0, n, 64):
            out[z : z + 64] = source[z : z + 64]
        open(done, "w").close()
    reference = os.path.join(DATA, "bench-labels-out.cgc")
    timed_cli(["extract", npy, "--labels", "all", "-o", reference])
    expected = sha256_of(reference)
    os.remove(reference)
    script = (
        "import sys, time, dask, dask.array as da, isogrid.dask\n"
        "dask.config.set(scheduler='threads', num_workers=2)\n"
        "calls = []\n"
        "start = time.perf_counter()\n"
        "isogrid.dask.extract(da.from_zarr(sys.argv[1]), labels='all', output=sys.argv[2],\n"
        "                     tile_bytes=int(sys.argv[3]), progress=lambda d, t: calls.append(d))\n"
        "print(time.perf_counter() - start, len(calls))\n"
    )
    out = os.path.join(DATA, "bench-labels-dask.cgc")
    report = os.path.join(DATA, "bench-labels-time.txt")
    print("| tile_bytes | seconds | tasks | peak resident memory | same file as the CLI |")
    print("|---|---|---|---|---|")
    for mib in (16, 64, 256):
        run = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", report, sys.executable, "-c", script,
                              path, out, str(mib << 20)], check=True, capture_output=True, text=True)
        with open(report) as f:
            peak = int(f.read().split()[-1]) * 1024
        os.remove(report)
        seconds, tasks = run.stdout.split()[-2:]
        same = sha256_of(out) == expected
        os.remove(out)
        print(f"| {mib} MiB | {float(seconds):.1f} | {tasks} | {peak / 2**20:.0f} MiB | {'yes' if same else 'NO'} |",
              flush=True)


MASK_FILES = 117  # TotalSegmentator's structures


def masks_folder():
    """data/bench-masks/: the frog tissues as one NIfTI mask each (`tissue_NN.nii.gz`), and empty
    masks (`absent_NNN.nii.gz`) up to MASK_FILES files, as TotalSegmentator writes a mask for
    every structure it looks for; with the frog's spacing. Returns the folder."""
    import nibabel

    folder = os.path.join(DATA, "bench-masks")
    if os.path.isdir(folder) and len(os.listdir(folder)) == MASK_FILES:
        return folder
    os.makedirs(folder, exist_ok=True)
    path, spacing, _, _ = npy_of("frog")
    a = np.load(path).transpose(2, 1, 0)  # (x, y, z), as nibabel writes it
    affine = np.diag(list(spacing) + [1.0])
    values = [int(v) for v in np.unique(a) if v != 0]
    for v in values:
        nibabel.save(nibabel.Nifti1Image((a == v).astype(np.uint8), affine), os.path.join(folder, f"tissue_{v:02d}.nii.gz"))
    for k in range(MASK_FILES - len(values)):
        nibabel.save(nibabel.Nifti1Image(np.zeros(a.shape, np.uint8), affine), os.path.join(folder, f"absent_{k:03d}.nii.gz"))
    return folder


def masks_peer(folder):
    """Child: what a Python user does with such a folder before a surface tool: nibabel loads
    each mask, numpy numbers it into one label volume (mask i in name order is label i + 1, as
    isogrid numbers them), and vtkSurfaceNets3D takes every label's surface. Prints JSON."""
    import glob

    import nibabel
    import vtk
    from vtk.util import numpy_support

    start = time.perf_counter()
    files = sorted(glob.glob(os.path.join(folder, "*.nii.gz")))
    first = nibabel.load(files[0])
    labels = np.zeros(first.shape, np.uint8)
    for i, f in enumerate(files):
        labels[np.asarray(nibabel.load(f).dataobj) != 0] = i + 1
    combined = time.perf_counter() - start
    vtk.vtkSMPTools.SetBackend("Sequential")
    z = np.ascontiguousarray(labels.transpose(2, 1, 0))
    image = vtk.vtkImageData()
    image.SetDimensions(z.shape[2], z.shape[1], z.shape[0])
    image.SetSpacing(*(float(s) for s in first.header.get_zooms()[:3]))
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(z.ravel(), deep=False))
    values = [v for v in np.unique(z) if v != 0]
    nets = vtk.vtkSurfaceNets3D()
    nets.SetInputData(image)
    nets.SetBackgroundLabel(0)
    nets.SetOutputMeshTypeToQuads()
    nets.SetSmoothing(False)
    nets.SetNumberOfLabels(len(values))
    for i, v in enumerate(values):
        nets.SetLabel(i, float(v))
    nets.Update()
    total = time.perf_counter() - start
    print(json.dumps({"combine": combined, "total": total, "labels": len(values), "peak": peak_rss_bytes(),
                      "quads": nets.GetOutput().GetNumberOfCells()}))


def masks_table():
    """One run each: `isogrid extract FOLDER --labels all` at 1 and 2 threads (GNU time: wall
    seconds and peak resident memory) and the Python pipeline of `masks_peer` (1 thread)."""
    folder = masks_folder()
    out = os.path.join(DATA, "bench-masks-out.cgc")
    print(f"| {MASK_FILES} NIfTI masks of the frog's 500×470×136 grid (25 tissues, 92 empty) | seconds | peak resident memory | output |")
    print("|---|---|---|---|")
    for threads in (1, 2):
        seconds, peak = timed_cli(["extract", folder, "--labels", "all", "--threads", str(threads), "-o", out])
        report = json.loads(subprocess.run(
            [os.environ.get("ISOGRID_CLI") or os.path.join(ROOT, "target", "release", "isogrid"), "info", out, "--json"],
            check=True, capture_output=True, text=True).stdout)
        cells, labels = report["active_cells"], len(report["labels"])
        print(f"| isogrid extract, {threads} thread{'s' * (threads > 1)} | {seconds:.1f} | {mb(peak)} | {cells:,} cells, {labels} labels, {mb(os.path.getsize(out))} |", flush=True)
    os.remove(out)
    run = subprocess.run([sys.executable, __file__, "child-masks", folder], check=True, capture_output=True, text=True)
    r = json.loads(run.stdout.strip().splitlines()[-1])
    print(f"| nibabel + numpy (numbering the masks: {r['combine']:.1f} s) + vtkSurfaceNets3D, 1 thread | "
          f"{r['total']:.1f} | {mb(r['peak'])} | {r['quads']:,} quads, {r['labels']} labels |")


def census_peer(path):
    """Child: what a Python user does for segment statistics: numpy loads the labels, counts each
    value (np.unique) and scipy.ndimage.find_objects gives each label's box. Prints JSON."""
    from scipy import ndimage

    start = time.perf_counter()
    labels = np.load(path)
    values, counts = np.unique(labels, return_counts=True)
    boxes = ndimage.find_objects(labels)
    seconds = time.perf_counter() - start
    print(json.dumps({"seconds": seconds, "labels": int((values != 0).sum()), "peak": peak_rss_bytes(),
                      "boxes": sum(b is not None for b in boxes)}))


def census_table():
    """`isogrid info X.npy --labels all --json` (GNU time: wall seconds and peak resident memory,
    reading included) against numpy + scipy in a fresh process, best of 5 each, on the three
    volumes of the main table."""
    print("| volume | isogrid info --labels all | peak memory | numpy.unique + scipy find_objects | peak memory | labels |")
    print("|---|---|---|---|---|---|")
    for name in VOLUMES:
        path = npy_of(name)[0]
        ours = min(timed_cli(["info", path, "--labels", "all", "--json"]) for _ in range(5))
        peers = []
        for _ in range(5):
            run = subprocess.run([sys.executable, __file__, "child-census", path], check=True,
                                 capture_output=True, text=True)
            peers.append(json.loads(run.stdout.strip().splitlines()[-1]))
        peer = min(peers, key=lambda r: r["seconds"])
        print(f"| {name} | {ours[0]:.2f} s | {mb(ours[1])} | {peer['seconds']:.2f} s | {mb(peer['peak'])} | {peer['labels']:,} |",
              flush=True)


def vertex_shifts(grid, exact):
    """Per-vertex distances (index space, voxels) and per-face normal angles (degrees) between the
    Marching Cubes meshes of two label grids with the same cells: quantising the corners keeps
    each corner's side, so both meshes have the same vertices (one per crossed edge) and faces,
    and only the crossing along each edge moves."""
    shifts, angles = [], []
    approx_meshes, exact_meshes = grid.meshes(space="index"), exact.meshes(space="index")
    for value, (v1, f1) in exact_meshes.items():
        v0, f0 = approx_meshes[value]
        assert v0.shape == v1.shape and np.array_equal(f0, f1), f"label {value}: meshes differ in shape"
        shifts.append(np.linalg.norm(v0 - v1, axis=1))
        n0 = np.cross(v0[f0[:, 1]] - v0[f0[:, 0]], v0[f0[:, 2]] - v0[f0[:, 0]])
        n1 = np.cross(v1[f1[:, 1]] - v1[f1[:, 0]], v1[f1[:, 2]] - v1[f1[:, 0]])
        l0, l1 = np.linalg.norm(n0, axis=1), np.linalg.norm(n1, axis=1)
        ok = (l0 > 1e-9) & (l1 > 1e-9)
        cos = np.clip((n0[ok] * n1[ok]).sum(axis=1) / (l0[ok] * l1[ok]), -1.0, 1.0)
        angles.append(np.degrees(np.arccos(cos)))
    return np.concatenate(shifts), np.concatenate(angles)


def precision_table():
    """Smoothed labels (σ = 1) at 4 and 8 bits per corner against f32 corners."""
    import isogrid

    print("| volume | bits per corner | .cgc | / SurfaceNets' mesh in memory | vertex shift, mean / 99th percentile / largest (voxels) | face normal angle, mean / 99th percentile (degrees) |")
    print("|---|---|---|---|---|---|")
    for name in VOLUMES:
        path, spacing, _, _ = npy_of(name)
        nets = measure("vtk", path, list(spacing), 1.0)["held_bytes"]
        a = np.load(path)
        exact = isogrid.extract_labels(a, smooth=1.0, spacing=spacing, precision=32)
        for bits in (4, 8):
            grid = isogrid.extract_labels(a, smooth=1.0, spacing=spacing, precision=bits)
            size = len(grid.to_bytes())
            d, angle = vertex_shifts(grid, exact)
            print(
                f"| {name} | {bits} | {mb(size)} | {size / nets:.2f} | "
                f"{d.mean():.3f} / {np.percentile(d, 99):.3f} / {d.max():.3f} | "
                f"{angle.mean():.1f} / {np.percentile(angle, 99):.1f} |",
                flush=True,
            )


def main():
    if "--precision" in sys.argv:
        precision_table()
        return
    if "--census" in sys.argv:
        census_table()
        return
    if "--masks" in sys.argv:
        masks_table()
        return
    if "--dask-budgets" in sys.argv:
        dask_budget_table()
        return
    if "--stream" in sys.argv:
        stream_table()
        return
    if "--stream-2048" in sys.argv:
        stream_2048_table()
        return
    smooth_table = "--smooth" in sys.argv
    only = [a.split("=", 1)[1] for a in sys.argv if a.startswith("--volumes=")]
    names = only[0].split(",") if only else list(VOLUMES)
    for name in names:
        path, spacing, dtype, shape = npy_of(name)
        dims = "×".join(str(d) for d in shape[::-1])
        print(f"\n### {name}: {dims} {dtype}\n")
        print("| tool | 1 thread | 2 threads | peak memory growth, 1 / 2 threads | output | in memory | compact | .cgc / in memory | .cgc / compact |")
        print("|---|---|---|---|---|---|---|---|---|")
        cgc = {}
        nets = {}
        for label, tool, smooth, thread_counts in PEERS:
            runs = [measure(tool, path, list(spacing), smooth, t) for t in thread_counts]
            one = runs[0]
            two = f"{runs[1]['seconds']:.3f} s" if len(runs) > 1 else "(one thread)"
            peaks = " / ".join(mb(r["peak_growth"]) for r in runs)
            if tool == "isogrid":
                cgc[smooth] = one["bytes"]
                print(f"| {label} | {one['seconds']:.3f} s | {two} | {peaks} | {one['cells']:,} cells, "
                      f"{one['labels']} labels | {mb(one['bytes'])} (.cgc) | | | |", flush=True)
                continue
            key = bool(smooth)
            if tool == "vtk":
                nets[key] = one["seconds"]
            kind = "quads" if tool == "vtk" else "triangles"
            print(f"| {label} | {one['seconds']:.3f} s | {two} | {peaks} | {one['points']:,} vertices, "
                  f"{one['faces']:,} {kind} | {mb(one['held_bytes'])} | {mb(one['compact_bytes'])} | "
                  f"{cgc[key] / one['held_bytes']:.2f} | {cgc[key] / one['compact_bytes']:.2f} |", flush=True)
    if smooth_table:
        print()
        print("| volume | σ | seconds | active cells | .cgc bytes | labels without cells | voxels changing label |")
        print("|---|---|---|---|---|---|---|")
        for name in ("atlas", "frog"):  # the flip count takes one filter per label
            path, spacing, _, _ = npy_of(name)
            a = np.load(path)
            for sigma in (0.0, 0.5, 0.75, 1.0, 1.5, 2.0):
                g = measure("isogrid", path, list(spacing), sigma)
                flip = flips(a, sigma) if sigma else 0.0
                print(
                    f"| {name} | {sigma:g} | {g['seconds']:.3f} | {g['cells']:,} | {mb(g['bytes'])} | "
                    f"{g['empty_labels']} of {g['labels']} | {100 * flip:.1f} % |",
                    flush=True,
                )


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "child-census":
        census_peer(sys.argv[2])
    elif len(sys.argv) > 1 and sys.argv[1] == "child-masks":
        masks_peer(sys.argv[2])
    elif len(sys.argv) > 1 and sys.argv[1] == "child":
        child(sys.argv[2], sys.argv[3], json.loads(sys.argv[4]), json.loads(sys.argv[5]), int(sys.argv[6]))
    else:
        main()

#!/usr/bin/env python3
"""Extraction benchmark: isogrid vs VTK's vtkFlyingEdges3D vs scikit-image, on the same volumes, in one run.

Fetches the real data (scripts/fetch_data.sh), builds the release CLI, then for each dataset times
  - isogrid CGC extraction (`isogrid extract --json`, extraction only, volume already in memory) at 1 and 2 threads,
  - isogrid Marching Cubes (`isogrid mc --json`) at 1 and 2 threads,
  - vtkFlyingEdges3D (PyPI vtk; single-threaded wheel) on the same samples as a vtkImageData,
  - skimage.measure.marching_cubes on the same samples,
each the best of --repeat runs, and writes docs/benchmarks.md with the machine it ran on.

Needs: pip install numpy vtk scikit-image nibabel pynrrd
"""
import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

DATASETS = [
    ("MNI152 T1 (nilearn)", "data/mni152_t1.nii.gz"),
    ("Dragon 512³ (voxelised, cube)", "data/dragon512.nrrd"),
]

# Paper Table 3, Dragon row (GTX 1070 machine, Ryzen 7 2700).
PAPER_DRAGON = dict(active_cells=668_804, metacell_slots=182_400, mb=7.5, seconds=0.8,
                    vertices=668_860, triangles=1_337_714, mc_mb=20.1, mc_seconds=1.5)


def load_xyz(path):
    """Samples as a numpy array indexed [x, y, z] (x fastest in the file), as isogrid reads them."""
    if path.endswith((".nii", ".nii.gz")):
        import nibabel
        img = nibabel.load(path)
        # isogrid keeps stored integer types and applies scl_slope only when it is not (1, 0) or unset.
        return np.asanyarray(img.dataobj)
    if path.endswith(".nrrd"):
        import nrrd
        data, _ = nrrd.read(path)  # pynrrd returns [x, y, z] (Fortran) order by default
        return data
    raise ValueError(path)


def best_of(repeat, fn):
    times, result = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return min(times), result


def isogrid_json(exe, args):
    out = subprocess.run([exe] + args + ["--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def bench_isogrid(exe, path, iso, repeat):
    rows = {}
    for threads in (1, 2):
        runs = [isogrid_json(exe, ["extract", path, "--iso", repr(iso), "--threads", str(threads)]) for _ in range(repeat)]
        best = min(runs, key=lambda r: r["seconds"]["extract"])
        rows[f"cgc{threads}"] = best
        runs = [isogrid_json(exe, ["mc", path, "--iso", repr(iso), "--threads", str(threads)]) for _ in range(repeat)]
        rows[f"mc{threads}"] = min(runs, key=lambda r: r["seconds"]["extract"])
    return rows


def vtk_image(vol, deep=True):
    """`vol` (indexed [x, y, z]) as a vtkImageData; deep=False shares the samples (no copy: the volume
    must be x-fastest in memory, e.g. the transpose of a C-order [z, y, x] array)."""
    import vtk
    from vtk.util import numpy_support
    nx, ny, nz = vol.shape
    image = vtk.vtkImageData()
    image.SetDimensions(nx, ny, nz)
    flat = np.ascontiguousarray(vol.ravel(order="F"))  # x fastest, as VTK expects
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(flat, deep=deep))
    return image


def flying_edges(image, iso):
    """vtkFlyingEdges3D on `image` at `iso` (no normals, gradients or scalars); the output polydata."""
    import vtk
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(image)
    fe.SetValue(0, iso)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    fe.Update()
    return fe.GetOutput()


def bench_vtk(vol, iso, repeat):
    image = vtk_image(vol)

    def run():
        out = flying_edges(image, iso)
        return out.GetNumberOfPoints(), out.GetNumberOfPolys()

    return best_of(repeat, run)


def skimage_mesh(vol, iso):
    """skimage.measure.marching_cubes (Lewiner, degenerate triangles kept): (vertices, faces)."""
    from skimage import measure
    verts, faces, _, _ = measure.marching_cubes(vol, level=iso, method="lewiner", allow_degenerate=True)
    return verts, faces


def bench_skimage(vol, iso, repeat):
    def run():
        verts, faces = skimage_mesh(vol, iso)
        return len(verts), len(faces)

    return best_of(repeat, run)


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            mem = f"{int(f.readline().split()[1]) / 1024 / 1024:.0f} GiB"
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {mem}, {platform.system()} {platform.release()}"


def versions():
    import vtk
    import skimage
    return f"vtk {vtk.vtkVersion.GetVTKVersion()}, scikit-image {skimage.__version__}, numpy {np.__version__}, Python {platform.python_version()}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--skimage-repeat", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "benchmarks.md"))
    args = ap.parse_args()
    os.chdir(ROOT)
    subprocess.run(["bash", "scripts/fetch_data.sh"], check=True)
    subprocess.run(["cargo", "build", "--release", "--quiet", "-p", "isogrid-cli"], check=True)
    target = json.loads(subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps"], check=True,
                                       capture_output=True, text=True).stdout)["target_directory"]
    exe = os.path.join(target, "release", "isogrid")

    results = []
    for name, path in DATASETS:
        vol = load_xyz(path)
        lo, hi = float(vol.min()), float(vol.max())
        iso = lo + 0.5 * (hi - lo)  # the paper's normalised 0.5 (half-integer on 0..255 data: no ties)
        print(f"{name}: {vol.shape} {vol.dtype}, iso {iso}", file=sys.stderr)
        ours = bench_isogrid(exe, path, iso, args.repeat)
        vtk_s, (vtk_v, vtk_t) = bench_vtk(vol, iso, args.repeat)
        sk_s, (sk_v, sk_t) = bench_skimage(vol, iso, args.skimage_repeat)
        results.append(dict(name=name, path=path, shape=vol.shape, dtype=str(vol.dtype), iso=iso, ours=ours,
                            vtk=(vtk_s, vtk_v, vtk_t), skimage=(sk_s, sk_v, sk_t)))
        print(json.dumps(results[-1], default=str), file=sys.stderr)

    write_report(args.out, results, args)


def write_report(path, results, args):
    L = []
    L.append("# Extraction benchmarks")
    L.append("")
    L.append(f"Written by `scripts/bench_extract.py` on {datetime.date.today().isoformat()}; all numbers below come from one run.")
    L.append("")
    L.append(f"- Machine: {machine()}")
    L.append(f"- Peers: {versions()}")
    L.append(f"- Times are the best of {args.repeat} runs (scikit-image: {args.skimage_repeat}), extraction only, on a volume already in memory.")
    L.append("  isogrid times come from its `--json` output (`seconds.extract`); VTK and scikit-image are timed around the filter call in Python.")
    L.append("- Isovalue: the paper's normalised 0.5, i.e. `min + 0.5·(max − min)`.")
    L.append("- The machine is shared and noisy: compare ratios within this run, not with other runs.")
    L.append("")
    L.append("## Clustered grid cells vs Marching Cubes (paper Table 3)")
    L.append("")
    L.append("| volume | active cells | metacell slots | CGC MB | B/cell | MC vertices | MC triangles | MC MB | CGC / MC memory |")
    L.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in results:
        c, m = r["ours"]["cgc1"], r["ours"]["mc1"]
        L.append(f"| {r['name']} {r['shape'][0]}×{r['shape'][1]}×{r['shape'][2]} {r['dtype']} | {c['active_cells']:,} | {c['metacell_slots']:,} | "
                 f"{c['bytes']['paper_total'] / 1e6:.2f} | {c['bytes_per_cell']:.2f} | {m['vertices']:,} | {m['triangles']:,} | "
                 f"{m['bytes'] / 1e6:.2f} | {100 * c['bytes']['paper_total'] / m['bytes']:.1f} % |")
    p = PAPER_DRAGON
    L.append(f"| *paper: Dragon 512³ u8* | *{p['active_cells']:,}* | *{p['metacell_slots']:,}* | *{p['mb']}* | | *{p['vertices']:,}* | "
             f"*{p['triangles']:,}* | *{p['mc_mb']}* | *{100 * p['mb'] / p['mc_mb']:.1f} %* |")
    L.append("")
    L.append("Memory is the paper's accounting: CGC = metacell slots × 12 B + active cells × corner bytes; MC = 6 B/vertex (snorm16) + 12 B/triangle.")
    L.append("B/cell also counts the block volume (16 B per 16³ block), as §3.5 does.")
    L.append("")
    L.append("## Extraction time (seconds)")
    L.append("")
    L.append("| volume | CGC 1 thread | CGC 2 threads | our MC 1 thread | our MC 2 threads | vtkFlyingEdges3D | skimage marching_cubes | FE / CGC (1 thr) | FE / CGC (2 thr) |")
    L.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in results:
        o = r["ours"]
        c1, c2 = o["cgc1"]["seconds"]["extract"], o["cgc2"]["seconds"]["extract"]
        m1, m2 = o["mc1"]["seconds"]["extract"], o["mc2"]["seconds"]["extract"]
        fe, sk = r["vtk"][0], r["skimage"][0]
        L.append(f"| {r['name']} | {c1:.4f} | {c2:.4f} | {m1:.4f} | {m2:.4f} | {fe:.4f} | {sk:.3f} | {fe / c1:.1f}× | {fe / c2:.1f}× |")
    L.append(f"| *paper: Dragon (Ryzen 7 2700)* | *{p['seconds']}* | | *{p['mc_seconds']}* | | | | | |")
    L.append("")
    L.append("## Cross-check of the meshes")
    L.append("")
    L.append("One vertex per crossed edge: our MC, Flying Edges and scikit-image (Lewiner) should agree on the vertex count.")
    L.append("")
    L.append("| volume | our MC vertices / triangles | vtkFlyingEdges3D | scikit-image |")
    L.append("|---|---:|---:|---:|")
    for r in results:
        m = r["ours"]["mc1"]
        L.append(f"| {r['name']} | {m['vertices']:,} / {m['triangles']:,} | {r['vtk'][1]:,} / {r['vtk'][2]:,} | {r['skimage'][1]:,} / {r['skimage'][2]:,} |")
    L.append("")
    L.append("## Targets (issue 2)")
    L.append("")
    for r in results:
        o = r["ours"]
        c1, c2, fe = o["cgc1"]["seconds"]["extract"], o["cgc2"]["seconds"]["extract"], r["vtk"][0]
        ratio = o["cgc1"]["bytes"]["paper_total"] / o["mc1"]["bytes"]
        L.append(f"- {r['name']}: 1 thread {fe / c1:.1f}× Flying Edges (target ≥ 3×: {'met' if fe / c1 >= 3 else 'NOT met'}); "
                 f"2 threads {fe / c2:.1f}× (target ≥ 5×: {'met' if fe / c2 >= 5 else 'NOT met'}); "
                 f"memory {100 * ratio:.1f} % of MC (target ≤ 37 %: {'met' if ratio <= 0.37 else 'NOT met'})")
    dragon = [r for r in results if "Dragon" in r["name"]]
    if dragon:
        c2 = dragon[0]["ours"]["cgc2"]["seconds"]["extract"]
        L.append(f"- Dragon 512³ at 2 threads: {c2:.3f} s (target ≤ 0.1 s: {'met' if c2 <= 0.1 else 'NOT met'})")
    L.append("")
    with open(path, "w") as f:
        f.write("\n".join(L))
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()

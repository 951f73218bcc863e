#!/usr/bin/env python3
"""Volumes larger than memory: isogrid streaming against isogrid in memory, VTK Flying Edges in
memory and a chunked Dask + scikit-image peer, on one generated volume; time, peak resident memory
and MB/s of samples, for docs/benchmarks-scale.md.

The volume comes from the generator (`isogrid generate FIELD --size N`, u8, its surface at u8
127.5). From that NRRD the script builds
  - a Zarr v3 array (chunks 64³, zstd level 1), which `isogrid extract` streams within
    `--max-memory` and the Dask peer reads chunk by chunk, and
  - a MetaImage header (`.mhd`, `HeaderSize = -1`) naming the NRRD's samples: MetaImage is not a
    region-readable input, so `isogrid extract` reads it whole (the in-memory path) without a
    second copy of the samples on disk.
Then it runs, each as its own process under `/usr/bin/time -v` (peak RSS is its "Maximum
resident set size"):
  - `isogrid extract` in memory (the `.mhd`), and streamed from the Zarr and from the NRRD under
    each of `--budgets`; every streamed `.cgc` must be byte-identical to the in-memory one;
  - vtkFlyingEdges3D (scripts/bench_extract.py's call) on the samples read whole into memory,
    threaded with vtkSMPTools' STDThread backend;
  - the chunked peer: `dask.array.map_overlap` over the Zarr in `--dask-chunk`³ chunks with a
    one-sample halo on the upper side of each axis (`boundary='none'`), so every cell belongs to
    exactly one chunk, and scikit-image's `marching_cubes` (bench_extract.py's call) per chunk,
    on dask's threaded scheduler; the per-chunk meshes are kept (vertices on chunk faces appear
    once per chunk: not merged). `--dask-slab Z` runs it on the first Z planes only and scales
    its time by N / Z.
All runs use the same isovalue (`--iso`, default 127.5) and thread count. Prints a Markdown table
and the issue's targets, met or not.

    python scripts/bench_scale.py --size 2048 --field sphere --budgets 512M,1G,4G

Needs: target/release/isogrid (cargo build --release -p isogrid-cli), /usr/bin/time (GNU time),
numpy, zarr (v3), dask, scikit-image and vtk (pip install numpy zarr dask scikit-image vtk), and
about 1.1 × N³ bytes of free disk in --workdir plus the grids; about 1.2 × N³ bytes of free memory
for the in-memory runs.
"""
import argparse
import filecmp
import json
import os
import re
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def run_timed(cmd):
    """Runs cmd under /usr/bin/time -v; returns (stdout, wall s, peak RSS bytes, CPU %, load)."""
    load = os.getloadavg()[0]
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{proc.stderr[-3000:]}")
    rss_kib = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1))
    cpu = int(re.search(r"Percent of CPU this job got: (\d+)%", proc.stderr).group(1))
    return proc.stdout, wall, rss_kib * 1024, cpu, load


def nrrd_data_offset(path, size):
    """Where the samples of an attached raw u8 NRRD (the generator's output) start."""
    return os.path.getsize(path) - size**3


def nrrd_samples(path, size):
    """The samples of the generator's NRRD as a read-only memmap indexed (z, y, x)."""
    offset = nrrd_data_offset(path, size)
    return np.memmap(path, dtype=np.uint8, mode="r", offset=offset, shape=(size, size, size))


def read_samples(path, size):
    """The samples of the generator's NRRD read whole into anonymous memory, indexed (z, y, x).
    read(2), not a memmap: mapped file pages would count in the peer's RSS twice."""
    samples = np.empty(size**3, dtype=np.uint8)
    view = memoryview(samples)
    with open(path, "rb", buffering=0) as f:
        f.seek(nrrd_data_offset(path, size))
        done = 0
        while done < len(view):
            n = f.readinto(view[done:])
            if not n:
                sys.exit(f"{path}: ends before its {size}³ samples")
            done += n
    return samples.reshape(size, size, size)


def write_inputs(isogrid, workdir, field, size, chunk):
    """The generator's NRRD, a `.mhd` header over its samples and a Zarr copy; their paths."""
    import zarr
    from zarr.codecs import ZstdCodec

    stem = os.path.join(workdir, f"{field}{size}")
    nrrd, mhd, store = stem + ".nrrd", stem + ".mhd", stem + ".zarr"
    if not os.path.exists(nrrd):
        _, wall, rss, _, load = run_timed(
            [isogrid, "generate", field, "--size", str(size), "-o", nrrd]
        )
        print(f"generated {nrrd} in {wall:.0f} s, peak RSS {rss / 2**20:.0f} MiB, load {load:.1f}",
              file=sys.stderr)
    with open(mhd, "w") as f:
        f.write(
            "ObjectType = Image\nNDims = 3\n"
            f"DimSize = {size} {size} {size}\nElementType = MET_UCHAR\n"
            f"HeaderSize = -1\nElementDataFile = {os.path.basename(nrrd)}\n"
        )
    if not os.path.exists(store):
        start = time.perf_counter()
        samples = nrrd_samples(nrrd, size)  # (z, y, x): the NRRD's first axis (x) varies fastest
        tmp = store + ".tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        a = zarr.create_array(
            store=tmp,
            shape=samples.shape,
            dtype=np.uint8,
            chunks=(chunk, chunk, chunk),
            compressors=ZstdCodec(level=1),
            dimension_names=("z", "y", "x"),
        )
        for z in range(0, size, chunk):
            a[z : z + chunk] = samples[z : z + chunk]
        os.replace(tmp, store)
        print(f"wrote {store} in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return nrrd, mhd, store


def vtk_peer(args):
    """Child process: the samples read whole, then vtkFlyingEdges3D; prints one JSON object."""
    import vtk
    from bench_extract import flying_edges, vtk_image

    smp = vtk.vtkSMPTools
    if not smp.SetBackend("STDThread"):
        sys.exit("this vtk has no STDThread SMP backend")
    smp.Initialize(args.threads)
    start = time.perf_counter()
    samples = read_samples(args.nrrd, args.size)
    read = time.perf_counter() - start
    image = vtk_image(samples.T, deep=False)  # samples.T is [x, y, z] with x fastest: no copy
    out = flying_edges(image, args.iso)
    print(json.dumps(dict(
        read=read,
        extract=time.perf_counter() - start - read,
        vertices=out.GetNumberOfPoints(),
        triangles=out.GetNumberOfPolys(),
        backend=f"{smp.GetBackend()} × {smp.GetEstimatedNumberOfThreads()}",
    )))


def dask_peer(args):
    """Child process: Dask map_overlap + scikit-image marching_cubes per chunk over the Zarr;
    prints one JSON object."""
    import dask
    import dask.array as da
    from bench_extract import skimage_mesh

    c = args.dask_chunk
    samples = da.from_zarr(args.zarr, chunks=(c, c, c))
    if args.dask_slab:
        samples = samples[: args.dask_slab]

    def mesh_chunk(block, block_info=None):
        # The block is the chunk plus one sample above on each axis (none past the volume's end):
        # its cells are exactly the chunk's, so no triangle is made twice.
        origin = np.array(block_info[None]["chunk-location"], dtype=np.float32) * c
        mesh = np.empty((1, 1, 1), dtype=object)
        if min(block.shape) >= 2 and block.min() < args.iso < block.max():
            verts, faces = skimage_mesh(block, args.iso)
            mesh[0, 0, 0] = (verts + origin, faces)
        else:
            mesh[0, 0, 0] = (np.empty((0, 3), np.float32), np.empty((0, 3), np.int32))
        return mesh

    meshes = da.map_overlap(
        mesh_chunk,
        samples,
        depth={axis: (0, 1) for axis in range(3)},
        boundary="none",
        trim=False,
        dtype=object,
        chunks=(1, 1, 1),
        meta=np.empty((0, 0, 0), dtype=object),
    )
    start = time.perf_counter()
    with dask.config.set(scheduler="threads", num_workers=args.threads):
        result = meshes.compute()
    seconds = time.perf_counter() - start
    parts = list(result.ravel())
    print(json.dumps(dict(
        extract=seconds,
        chunks=len(parts),
        planes=int(samples.shape[0]),
        vertices=sum(len(v) for v, _ in parts),
        triangles=sum(len(f) for _, f in parts),
    )))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=2048)
    parser.add_argument("--field", default="sphere", help="isogrid generate's field")
    parser.add_argument("--iso", type=float, default=127.5, help="isovalue for every run")
    parser.add_argument("--budgets", default="1G,4G", help="--max-memory values for streaming")
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--chunk", type=int, default=64, help="Zarr chunk edge")
    parser.add_argument("--dask-chunk", type=int, default=256, help="Dask chunk edge")
    parser.add_argument("--dask-slab", type=int, default=0,
                        help="run the Dask peer on the first Z planes only and scale its time")
    parser.add_argument("--skip", default="", help="comma list of runs to leave out: vtk,dask,nrrd")
    parser.add_argument("--workdir", default="data/bench-scale")
    parser.add_argument("--isogrid", default="target/release/isogrid")
    parser.add_argument("--peer", choices=("vtk", "dask"), help=argparse.SUPPRESS)
    parser.add_argument("--nrrd", help=argparse.SUPPRESS)
    parser.add_argument("--zarr", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.peer == "vtk":
        return vtk_peer(args)
    if args.peer == "dask":
        return dask_peer(args)

    if not os.path.exists(args.isogrid):
        sys.exit(f"no {args.isogrid}: cargo build --release -p isogrid-cli")
    skip = set(filter(None, args.skip.split(",")))
    os.makedirs(args.workdir, exist_ok=True)
    nrrd, mhd, store = write_inputs(args.isogrid, args.workdir, args.field, args.size, args.chunk)
    n = args.size
    volume_mb = n**3 / 1e6
    budgets = args.budgets.split(",")
    common = ["--iso", repr(args.iso), "--threads", str(args.threads), "--json"]
    peer = [sys.executable, os.path.abspath(__file__), "--size", str(n), "--iso", repr(args.iso),
            "--threads", str(args.threads)]
    rows = []

    def row(name, budget, wall, rss, cpu, load, output, identical, seconds=None):
        rows.append(dict(name=name, budget=budget, wall=wall, rss=rss, cpu=cpu, load=load,
                         output=output, identical=identical, seconds=seconds or wall))
        print(f"{name} {budget}: {wall:.1f} s, {rss / 2**20:.0f} MiB, {cpu} % CPU, load {load:.1f}",
              file=sys.stderr)

    reference = os.path.join(args.workdir, "memory.cgc")
    out, wall, rss, cpu, load = run_timed(
        [args.isogrid, "extract", mhd, "-o", reference, *common])
    stats = json.loads(out)
    grid_mb = os.path.getsize(reference) / 1e6
    cells = f"{stats['active_cells'] / 1e6:.1f} M active cells, {grid_mb:.0f} MB `.cgc`"
    s = stats["seconds"]
    row("isogrid in memory (`.mhd` over the NRRD, read whole)", "—", wall, rss, cpu, load,
        f"{cells}; read {s['read']:.0f} s, extract {s['extract']:.0f} s, write {s['write']:.0f} s",
        "reference")

    streams = [("isogrid streamed (Zarr, 64³ zstd chunks)", store, b) for b in budgets]
    if "nrrd" not in skip:
        streams += [("isogrid streamed (NRRD, read by region)", nrrd, b) for b in budgets]
    for name, source, budget in streams:
        streamed = os.path.join(args.workdir, f"stream-{budget}.cgc")
        out, wall, rss, cpu, load = run_timed(
            [args.isogrid, "extract", source, "--max-memory", budget, "-o", streamed, *common])
        identical = filecmp.cmp(reference, streamed, shallow=False)
        os.remove(streamed)
        row(name, budget, wall, rss, cpu, load, cells, "yes" if identical else "**NO**")

    if "vtk" not in skip:
        out, wall, rss, cpu, load = run_timed([*peer, "--peer", "vtk", "--nrrd", nrrd])
        v = json.loads(out)
        row(f"VTK vtkFlyingEdges3D in memory ({v['backend']} threads)", "—", wall, rss, cpu, load,
            f"{v['triangles'] / 1e6:.1f} M triangles, {v['vertices'] / 1e6:.1f} M vertices; "
            f"read {v['read']:.0f} s, extract {v['extract']:.0f} s", "—")
    if "dask" not in skip:
        out, wall, rss, cpu, load = run_timed(
            [*peer, "--peer", "dask", "--zarr", store, "--dask-chunk", str(args.dask_chunk),
             "--dask-slab", str(args.dask_slab)])
        d = json.loads(out)
        scale = n / d["planes"]
        note = f"{d['triangles'] / 1e6:.1f} M triangles in {d['chunks']} chunk meshes"
        if scale != 1:
            note += (f" (first {d['planes']} planes; time × {scale:g} = {wall * scale:.0f} s; "
                     f"the RSS is the slab's)")
        row(f"Dask `map_overlap` + scikit-image `marching_cubes` ({args.dask_chunk}³ chunks)", "—",
            wall * scale, rss, cpu, load, note, "—", seconds=wall * scale)

    print(f"\n{n}³ u8 {args.field} ({volume_mb / 1e3:.2f} GB of samples), --iso {args.iso}, "
          f"{args.threads} threads, {args.isogrid}\n")
    print("| run | `--max-memory` | wall s | peak RSS MiB | MB/s of samples | CPU % | load | output | identical |")
    print("|---|---|---:|---:|---:|---:|---:|---|---|")
    for r in rows:
        print(f"| {r['name']} | {r['budget']} | {r['wall']:.1f} | {r['rss'] / 2**20:,.0f} | "
              f"{volume_mb / r['wall']:.0f} | {r['cpu']} | {r['load']:.1f} | {r['output']} | "
              f"{r['identical']} |")

    print("\nTargets:")
    memory = rows[0]
    streamed = [r for r in rows if r["name"].startswith("isogrid streamed")]
    dask_rows = [r for r in rows if r["name"].startswith("Dask")]
    for r in streamed:
        from_isogrid = r["budget"].upper().rstrip("B")
        unit = {"K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
        budget = float(from_isogrid[:-1]) * unit[from_isogrid[-1]] if from_isogrid[-1] in unit \
            else float(from_isogrid)
        ratio = memory["wall"] / r["wall"]
        line = (f"- {r['name']}, {r['budget']}: peak RSS {r['rss'] / 2**20:.0f} MiB against a budget "
                f"of {budget / 2**20:.0f} MiB (under it: {'met' if r['rss'] <= budget else 'NOT met'}); "
                f"throughput {100 * ratio:.0f} % of in memory (≥ 80 %: "
                f"{'met' if ratio >= 0.8 else 'NOT met'})")
        for d in dask_rows:
            speed, mem = d["seconds"] / r["wall"], r["rss"] / d["rss"]
            line += (f"; {speed:.1f}× the Dask peer's speed (≥ 10×: "
                     f"{'met' if speed >= 10 else 'NOT met'}) at {100 * mem:.0f} % of its peak RSS "
                     f"(≤ 33 %: {'met' if mem <= 1 / 3 else 'NOT met'})")
        print(line)
    os.remove(reference)


if __name__ == "__main__":
    main()

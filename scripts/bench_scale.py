#!/usr/bin/env python3
"""Streaming extraction against in-memory extraction on one volume stored as Zarr: time, peak
resident memory and MB/s of samples read, for docs/benchmarks-scale.md.

The volume comes from the generator (`isogrid generate hairball --size N`, u8). The script
converts its samples, plane block by plane block, into
  - a Zarr v3 array (chunks 64³, zstd) that `isogrid extract` streams within `--max-memory`, and
  - a C-order `.npy` holding the same samples, which `isogrid extract` reads whole (the in-memory
    path),
then runs `isogrid extract --iso-normalized 0.5 --json` on each under `/usr/bin/time -v` (peak RSS
is its "Maximum resident set size") and checks that every streamed `.cgc` is byte-identical to the
in-memory one. Prints a Markdown table.

    python3 scripts/bench_scale.py --size 2048 --budgets 1G,4G [--isogrid target/release/isogrid]

Needs zarr-python (pip install zarr) and about 2.3 × N³ bytes of free disk in --workdir (the
generated NRRD, the `.npy`, the Zarr array and two grids). The VTK and Dask peers of the issue's
benchmark are not run here.
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


def run_timed(cmd):
    """Runs cmd under /usr/bin/time -v; returns (stdout, wall seconds, peak RSS in bytes)."""
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{proc.stderr[-2000:]}")
    rss_kib = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1))
    return proc.stdout, wall, rss_kib * 1024


def nrrd_samples(path, size):
    """The samples of an attached raw u8 NRRD (the generator's output) as a read-only memmap."""
    count = size**3
    offset = os.path.getsize(path) - count
    return np.memmap(path, dtype=np.uint8, mode="r", offset=offset, shape=(size, size, size))


def write_inputs(isogrid, workdir, size, chunk):
    import zarr
    from zarr.codecs import ZstdCodec

    nrrd = os.path.join(workdir, f"hairball{size}.nrrd")
    npy = os.path.join(workdir, f"hairball{size}.npy")
    store = os.path.join(workdir, f"hairball{size}.zarr")
    if not os.path.exists(nrrd):
        subprocess.run([isogrid, "generate", "hairball", "--size", str(size), "-o", nrrd], check=True)
    samples = nrrd_samples(nrrd, size)  # (z, y, x): the NRRD's first axis (x) varies fastest
    if not os.path.exists(npy):
        out = np.lib.format.open_memmap(npy + ".tmp", mode="w+", dtype=np.uint8, shape=samples.shape)
        for z in range(0, size, chunk):
            out[z : z + chunk] = samples[z : z + chunk]
        out.flush()
        del out
        os.replace(npy + ".tmp", npy)
    if not os.path.exists(store):
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
    return npy, store


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=2048)
    parser.add_argument("--budgets", default="1G,4G", help="--max-memory values for streaming")
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--chunk", type=int, default=64)
    parser.add_argument("--workdir", default="data/bench-scale")
    parser.add_argument("--isogrid", default=None, help="binary (default: target/release, then debug)")
    args = parser.parse_args()
    isogrid = args.isogrid or next(
        (p for p in ("target/release/isogrid", "target/debug/isogrid") if os.path.exists(p)), None
    )
    if isogrid is None:
        sys.exit("no isogrid binary: cargo build --release -p isogrid-cli")
    os.makedirs(args.workdir, exist_ok=True)
    npy, store = write_inputs(isogrid, args.workdir, args.size, args.chunk)
    volume_mb = args.size**3 / 1e6
    common = ["--iso-normalized", "0.5", "--threads", str(args.threads), "--json"]

    rows = []
    reference = os.path.join(args.workdir, "memory.cgc")
    out, wall, rss = run_timed([isogrid, "extract", npy, "-o", reference, *common])
    stats = json.loads(out)
    rows.append(("in memory (`.npy`)", "—", wall, rss, stats))
    for budget in args.budgets.split(","):
        streamed = os.path.join(args.workdir, f"stream-{budget}.cgc")
        out, wall, rss = run_timed(
            [isogrid, "extract", store, "--max-memory", budget, "-o", streamed, *common]
        )
        if not filecmp.cmp(reference, streamed, shallow=False):
            sys.exit(f"streamed file with --max-memory {budget} differs from the in-memory one")
        rows.append((f"streamed (Zarr, 64³ zstd chunks)", budget, wall, rss, json.loads(out)))
        os.remove(streamed)

    print(f"{args.size}³ u8 hairball ({volume_mb / 1e3:.2f} GB of samples), --iso-normalized 0.5, "
          f"{args.threads} threads, {isogrid}; active cells {stats['active_cells']}, "
          f"grid {os.path.getsize(reference) / 1e6:.0f} MB\n")
    print("| run | --max-memory | wall s | peak RSS MiB | MB/s of samples | identical |")
    print("|---|---|---|---|---|---|")
    for name, budget, wall, rss, s in rows:
        print(f"| {name} | {budget} | {wall:.1f} | {rss / 2**20:.0f} | {volume_mb / wall:.0f} | yes |")


if __name__ == "__main__":
    main()

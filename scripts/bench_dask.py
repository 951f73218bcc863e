"""Times isogrid.dask.extract on a LocalCluster of 1 and then 2 worker processes.

The volume is a u8 gyroid computed chunk by chunk as a dask array (no disk), N³ samples. Each
worker is one process with one dask thread and one rayon thread (RAYON_NUM_THREADS=1), so 1 and 2
workers use 1 and 2 cores. Every run's file must be byte-identical to the first one's, and (for
sizes that fit in memory) to the in-process isogrid.extract of the same samples. Each row gives
the workers' peak resident memory (getrusage, over the worker process's life: the extraction and
the one computation of the source before it).

    python scripts/bench_dask.py [--zarr] [N ...]   # default 512; one Markdown table row per run

With --zarr the volume is first written to a Zarr store (zarr-python's default codec, 128³
chunks) in a temporary folder, and the runs read that path instead of computing the samples.
"""

import os
import resource
import sys
import tempfile
import time

import numpy as np
import dask.array as da
from distributed import Client, LocalCluster

import isogrid
import isogrid.dask

CHUNK = 128


def gyroid_chunk(block_info=None):
    (z0, z1), (y0, y1), (x0, x1) = block_info[None]["array-location"]
    f = np.float32(2 * np.pi / 64.0)
    axis = [np.arange(a, b, dtype=np.float32) * f for a, b in ((x0, x1), (y0, y1), (z0, z1))]
    (sx, sy, sz), (cx, cy, cz) = [np.sin(a) for a in axis], [np.cos(a) for a in axis]
    # sin x cos y + sin y cos z + sin z cos x, from per-axis vectors (cheap to compute).
    v = (
        sx[None, None, :] * cy[None, :, None]
        + sy[None, :, None] * cz[:, None, None]
        + sz[:, None, None] * cx[None, None, :]
    )
    return np.clip((v + np.float32(1.5)) * np.float32(85), 0, 255).astype(np.uint8)


def peak_rss_mib():
    """This process's peak resident memory, in MiB (run on each worker)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def gyroid(n):
    return da.map_blocks(gyroid_chunk, chunks=((CHUNK,) * (n // CHUNK),) * 3, dtype=np.uint8)


def main():
    use_zarr = "--zarr" in sys.argv[1:]
    sizes = [int(a) for a in sys.argv[1:] if a != "--zarr"] or [512]
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            source = gyroid(n)
            if use_zarr:
                store = os.path.join(tmp, f"gyroid{n}.zarr")
                t = time.perf_counter()
                source.to_zarr(store)
                print(f"| {n}³ | written to Zarr in {time.perf_counter() - t:.1f} s | — | — |")
                source = da.from_zarr(store)
            reference = None
            if n <= 512:
                path = os.path.join(tmp, "reference.cgc")
                t = time.perf_counter()
                array = source.compute()
                made = time.perf_counter() - t
                t = time.perf_counter()
                isogrid.extract(array, iso_normalized=0.5, threads=1).save(path)
                print(f"| {n}³ | in process, 1 thread (samples made first in {made:.1f} s) | "
                      f"{time.perf_counter() - t:.1f} s | — |")
                reference = open(path, "rb").read()
                del array
            first = None
            for workers in (1, 2):
                cluster = LocalCluster(
                    n_workers=workers,
                    processes=True,
                    threads_per_worker=1,
                    memory_limit="3GiB",
                    dashboard_address=None,
                    env={"RAYON_NUM_THREADS": "1"},
                )
                client = Client(cluster)
                t = time.perf_counter()
                client.compute(source.max()).result()  # computing the source once, for scale
                source_seconds = time.perf_counter() - t
                out = os.path.join(tmp, f"dask{workers}.cgc")
                t = time.perf_counter()
                stats = isogrid.dask.extract(source, iso_normalized=0.5, output=out, client=client)
                seconds = time.perf_counter() - t
                peaks = sorted(client.run(peak_rss_mib).values())
                client.close()
                cluster.close()
                data = open(out, "rb").read()
                first = first or data
                same = data == first and (reference is None or data == reference)
                print(f"| {n}³ | LocalCluster, {workers} worker{'s' if workers > 1 else ''} | "
                      f"{seconds:.1f} s | source computed once: {source_seconds:.1f} s; "
                      f"{stats['active_cells']:,} cells; peak RSS per worker "
                      f"{', '.join(f'{p:.0f}' for p in peaks)} MiB; "
                      f"{'byte-identical' if same else 'BYTES DIFFER'} |", flush=True)


if __name__ == "__main__":
    main()

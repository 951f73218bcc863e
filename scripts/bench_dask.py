"""Times isogrid.dask.extract on a LocalCluster of 1 and then 2 worker processes.

The volume is a u8 field computed chunk by chunk as a dask array (no disk), N³ samples: the
squared distance from the centre scaled to 0..255, as the sum of three per-axis uint8 terms
(85 d² / (N/2)², rounded down), one pass over each chunk, so computing it costs little next to
the extraction. The isovalue is given in data units (iso=43: a sphere of radius about 0.36 N),
which spares the value-range pass over the source that iso_normalized needs; the sphere keeps
the .cgc small (a few hundred MB at 4096³).

Each worker is one process with one dask thread and one rayon thread (RAYON_NUM_THREADS=1), so 1
and 2 workers use 1 and 2 cores. Every run's file must be byte-identical to the first one's, and
(for N <= 1024) to the in-process isogrid.extract of the same samples. Each row gives the
workers' peak resident memory (VmHWM over the worker process's life), and while a run goes
a line every 60 s gives each worker's current and peak resident memory (so a run cut short
still says what it held). CPU seconds are this process's (the driver, and the LocalCluster's
scheduler, which runs in it) and the workers' summed, over the extraction.

    python scripts/bench_dask.py [--zarr] [--workers 1,2] [--source-once] [--tile-bytes B]
                                 [--row-parts P] [--local] [--no-cluster] [N ...]

Chunks are one block layer deep, 1/16 of the rows and whole rows: (16, N/16, N), 16 MiB at
N = 4096; --row-parts P makes them 1/P of the rows instead (fewer, larger chunks and tasks). --tile-bytes B passes tile_bytes=B (default isogrid.dask's, 64 MiB).
--source-once first times one computation of the source (source.max()), for scale. --local
first times the run with no client, on dask's threaded scheduler in this process, with as many
threads as each worker count (its peak RSS is this process's, reset before each run);
--no-cluster skips the LocalCluster runs. With --zarr
the volume is first written to a Zarr store in a temporary folder, and the runs read that path.
"""

import os
import sys
import tempfile
import threading
import time

import numpy as np
import dask
import dask.array as da
from distributed import Client, LocalCluster

import isogrid
import isogrid.dask

ISO = 43  # a sphere of radius about 0.36 N


def sphere_chunk(n, block_info=None):
    (z0, z1), (y0, y1), (x0, x1) = block_info[None]["array-location"]
    c = n // 2
    # 85 d² / c² per axis, at most 85, so that the three add up in uint8 without overflow: the
    # squared distance from the centre, scaled to 0..255, in one pass over the chunk.
    tx, ty, tz = (((np.arange(a, b, dtype=np.int64) - c) ** 2 * 85 // (c * c)).astype(np.uint8)
                  for a, b in ((x0, x1), (y0, y1), (z0, z1)))
    return (tz[:, None, None] + ty[None, :, None]) + tx[None, None, :]


def sphere(n, row_parts=16):
    chunks = (16, max(16, n // row_parts), n)
    return da.map_blocks(
        sphere_chunk, n, chunks=tuple(_cuts(n, c) for c in chunks), dtype=np.uint8
    )


def _cuts(n, c):
    return (c,) * (n // c) + ((n % c,) if n % c else ())


def _status_mib(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024
    raise KeyError(field)


def peak_rss_mib():
    """This process's peak resident memory, in MiB (run on each worker). VmHWM, not getrusage's
    ru_maxrss: a spawned worker inherits the driver's ru_maxrss across fork and exec."""
    return _status_mib("VmHWM")


def reset_peak_rss():
    """Resets this process's VmHWM to its current RSS (Linux: clear_refs 5)."""
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def rss_now_mib():
    return _status_mib("VmRSS")


def watch(client, start, stop):
    """Prints each worker's current and peak RSS every 60 s until `stop` is set."""
    while not stop.wait(60):
        try:
            now = client.run(rss_now_mib)
            peak = client.run(peak_rss_mib)
        except Exception as err:  # the cluster is closing
            print(f"  watch: {err}", flush=True)
            return
        load = os.getloadavg()[0]
        print(f"  {time.perf_counter() - start:7.0f} s: RSS now/peak MiB "
              + ", ".join(f"{now[w]:.0f}/{peak[w]:.0f}" for w in sorted(now))
              + f"; load {load:.1f}", flush=True)


def main():
    args = sys.argv[1:]
    use_zarr = "--zarr" in args
    local = "--local" in args
    cluster_runs = "--no-cluster" not in args
    source_once = "--source-once" in args
    worker_counts = [1, 2]
    if "--workers" in args:
        worker_counts = [int(w) for w in args[args.index("--workers") + 1].split(",")]
        del args[args.index("--workers") : args.index("--workers") + 2]
    tile_bytes = isogrid.dask.DEFAULT_TILE_BYTES
    row_parts = 16
    if "--row-parts" in args:
        row_parts = int(args[args.index("--row-parts") + 1])
        del args[args.index("--row-parts") : args.index("--row-parts") + 2]
    if "--tile-bytes" in args:
        tile_bytes = int(args[args.index("--tile-bytes") + 1])
        del args[args.index("--tile-bytes") : args.index("--tile-bytes") + 2]
    sizes = [int(a) for a in args if not a.startswith("--")] or [512]
    with tempfile.TemporaryDirectory(dir=os.environ.get("BENCH_TMP")) as tmp:
        for n in sizes:
            source = sphere(n, row_parts)
            print(f"| {n}³ | chunks {source.chunksize}, {source.npartitions} of them | — | — |", flush=True)
            if use_zarr:
                store = os.path.join(tmp, f"sphere{n}.zarr")
                t = time.perf_counter()
                source.to_zarr(store)
                print(f"| {n}³ | written to Zarr in {time.perf_counter() - t:.1f} s | — | — |")
                source = da.from_zarr(store)
            reference = None
            if n <= 1024:
                path = os.path.join(tmp, "reference.cgc")
                t = time.perf_counter()
                array = source.compute(scheduler="synchronous")
                made = time.perf_counter() - t
                t = time.perf_counter()
                isogrid.extract(array, iso=ISO, threads=1).save(path)
                print(f"| {n}³ | in process, 1 thread (samples made first in {made:.1f} s) | "
                      f"{time.perf_counter() - t:.1f} s | — |", flush=True)
                reference = open(path, "rb").read()
                del array
            first = None
            for threads in worker_counts if local else []:
                out = os.path.join(tmp, "local.cgc")
                reset_peak_rss()
                load = os.getloadavg()[0]
                t, cpu = time.perf_counter(), time.process_time()
                with dask.config.set(scheduler="threads", num_workers=threads):
                    stats = isogrid.dask.extract(source, iso=ISO, output=out, tile_bytes=tile_bytes)
                seconds, cpu = time.perf_counter() - t, time.process_time() - cpu
                size = os.path.getsize(out)
                data = open(out, "rb").read() if size < (4 << 30) else None
                first = first or data
                same = data == first and (reference is None or data == reference)
                print(f"| {n}³ | no client, threaded scheduler, {threads} thread{'s' if threads > 1 else ''} | {seconds:.1f} s | "
                      f"{stats['active_cells']:,} cells, {size / 1e6:.0f} MB; peak RSS of the process "
                      f"{peak_rss_mib():.0f} MiB; CPU {cpu:.0f} s; load at start {load:.1f}, at end "
                      f"{os.getloadavg()[0]:.1f}; {'byte-identical' if same else 'BYTES DIFFER'} |", flush=True)
            for workers in worker_counts if cluster_runs else []:
                cluster = LocalCluster(
                    n_workers=workers,
                    processes=True,
                    threads_per_worker=1,
                    memory_limit="4GiB",
                    dashboard_address=None,
                    env={"RAYON_NUM_THREADS": "1"},
                )
                client = Client(cluster)
                note = ""
                if source_once:
                    t = time.perf_counter()
                    client.compute(source.max()).result()
                    note = f"source computed once: {time.perf_counter() - t:.1f} s; "
                out = os.path.join(tmp, f"dask{workers}.cgc")
                t = time.perf_counter()
                stop = threading.Event()
                watcher = threading.Thread(target=watch, args=(client, t, stop), daemon=True)
                watcher.start()
                load = os.getloadavg()[0]
                # CPU seconds of this process (the driver and, in a LocalCluster, the scheduler)
                # and of each worker process over the run: where the cores went.
                driver_cpu = time.process_time()
                worker_cpu = client.run(time.process_time)
                stats = isogrid.dask.extract(source, iso=ISO, output=out, client=client, tile_bytes=tile_bytes)
                seconds = time.perf_counter() - t
                driver_cpu = time.process_time() - driver_cpu
                worker_cpu = sum(v - worker_cpu[w] for w, v in client.run(time.process_time).items())
                stop.set()
                watcher.join()
                peaks = sorted(client.run(peak_rss_mib).values())
                client.close()
                cluster.close()
                size = os.path.getsize(out)
                data = open(out, "rb").read() if size < (4 << 30) else None
                first = first or data
                same = data == first and (reference is None or data == reference)
                print(f"| {n}³ | LocalCluster, {workers} worker{'s' if workers > 1 else ''} | "
                      f"{seconds:.1f} s | {note}{stats['active_cells']:,} cells, "
                      f"{size / 1e6:.0f} MB; peak RSS per worker "
                      f"{', '.join(f'{p:.0f}' for p in peaks)} MiB; CPU {driver_cpu:.0f} s driver and "
                      f"scheduler, {worker_cpu:.0f} s workers; load at start {load:.1f}, "
                      f"at end {os.getloadavg()[0]:.1f}; "
                      f"{'byte-identical' if same else 'BYTES DIFFER'} |", flush=True)


if __name__ == "__main__":
    main()

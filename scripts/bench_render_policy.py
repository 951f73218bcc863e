#!/usr/bin/env python3
"""Times `isogrid.render` on a software GPU adapter (lavapipe) against the CPU tracer, per mode and
size, to set the `backend="auto"` rule for machines whose only adapter is a software one
(`isogrid_render::policy::software_adapter_wins`; table in docs/benchmarks-render-policy.md).

Each case runs in a fresh process, as a first render in a script does: "first" includes opening the
device and building its pipelines (GPU) or building the tracer (CPU); "again" is a second render of
the same request in that process. Needs the package built (`bash python/test.sh` does that).

    python/.venv/bin/python scripts/bench_render_policy.py [--samples 16] [--field gyroid|sphere]
"""

import argparse
import json
import subprocess
import sys

CASE = r"""
import json, sys, time
import numpy as np
import isogrid
field, n, mode, w, h, backend, spp = sys.argv[1:]
n, w, h, spp = int(n), int(w), int(h), int(spp)
t = np.linspace(0, 4 * np.pi, n, dtype=np.float32)
z, y, x = np.meshgrid(t, t, t, indexing="ij")
if field == "gyroid":
    v = np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)
else:
    c = 2 * np.pi
    v = 1.5 * np.pi - np.sqrt((x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2)
grid = isogrid.extract(v, iso=0.0)
times = []
for _ in range(2):
    start = time.perf_counter()
    _, aov = isogrid.render(grid, camera=2, size=(w, h), mode=mode, backend=backend, spp=spp,
                            aovs=("backend",))
    times.append(time.perf_counter() - start)
    assert aov["backend"] == backend, aov["backend"]
print(json.dumps({"first": times[0], "again": times[1], "cells": grid.active_cells}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=16, help="path tracing samples per pixel")
    ap.add_argument("--field", default="gyroid", choices=["gyroid", "sphere"])
    ap.add_argument("--n", type=int, default=128, help="samples per axis of the volume")
    ap.add_argument("--sizes", default="320x240,1920x1080")
    ap.add_argument("--modes", default="cgc,pathtrace")
    args = ap.parse_args()
    print(f"{args.field} {args.n}³, camera 2, path tracing {args.samples} spp, 3 bounces, built-in sky\n")
    print("| mode | size | backend | first render (s) | again (s) |")
    print("|---|---|---|---|---|")
    for mode in args.modes.split(","):
        for size in args.sizes.split(","):
            w, h = size.split("x")
            for backend in ("cpu", "gpu"):
                out = subprocess.run(
                    [sys.executable, "-c", CASE, args.field, str(args.n), mode, w, h, backend,
                     str(args.samples)],
                    capture_output=True, text=True)
                if out.returncode != 0:
                    print(f"| {mode} | {size} | {backend} | failed: {out.stderr.strip().splitlines()[-1]} | |")
                    continue
                r = json.loads(out.stdout.strip().splitlines()[-1])
                print(f"| {mode} | {size} | {backend} | {r['first']:.3f} | {r['again']:.3f} |", flush=True)


if __name__ == "__main__":
    main()

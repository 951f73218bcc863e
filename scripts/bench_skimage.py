#!/usr/bin/env python3
"""isogrid.skimage.marching_cubes against skimage.measure.marching_cubes: one timed run each on a
few synthetic volumes, written as a section of docs/benchmarks.md (replacing an earlier one).

    python/.venv/bin/python scripts/bench_skimage.py [--sizes 64 128 256] [--no-write]

Needs the isogrid package (bash python/test.sh installs it into python/.venv) and scikit-image.
Both are called as a user would, on a float32 volume already in memory, with the default
arguments; isogrid uses every core (its surface extraction releases the GIL and runs in
parallel; normals and values are Rust on the same pool), scikit-image one.
"""
import argparse
import os
import platform
import re
import time

import numpy as np
import skimage
from skimage.measure import marching_cubes as sk_marching_cubes

import isogrid
from isogrid import _isogrid
from isogrid.skimage import marching_cubes

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "benchmarks.md")
HEADING = "## isogrid.skimage.marching_cubes vs scikit-image"


def ball(n):
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float32)
    c = (n - 1) / 2 + 0.3
    return (0.4 * n - np.sqrt((x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2)).astype(np.float32)


def gyroid(n):
    s = 12 * np.pi / n
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float32) * np.float32(s)
    return (np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)).astype(np.float32)


def timed(fn, *args, **kw):
    start = time.perf_counter()
    out = fn(*args, **kw)
    return time.perf_counter() - start, out


def machine():
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            names = [l.split(":", 1)[1].strip() for l in f if l.startswith("model name")]
        cpu = f"{names[0]}, {len(names)} logical cores" if names else cpu
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
        mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return f"{cpu}{mem}, {platform.system()} {platform.release()}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rows = []
    for name, make in (("ball", ball), ("gyroid", gyroid)):
        for n in args.sizes:
            vol = make(n)
            level = 0.0
            marching_cubes(ball(8), 0.0)  # load and warm up
            ours_s, ours = timed(marching_cubes, vol, level)
            surface_s, _ = timed(_isogrid.marching_cubes, vol, False, (1.0, 1.0, 1.0), iso=level, above=True)
            sk_s, sk = timed(sk_marching_cubes, vol, level)
            rows.append(
                f"| {name} {n}³ float32 | {len(ours[0]):,} / {len(ours[1]):,} | {len(sk[0]):,} / {len(sk[1]):,} "
                f"| {ours_s:.3f} | {surface_s:.3f} | {sk_s:.3f} | {sk_s / ours_s:.1f}× |"
            )
            print(rows[-1], flush=True)
    section = "\n".join(
        [
            HEADING,
            "",
            f"Written by `scripts/bench_skimage.py`: one run of each call, default arguments, level 0, "
            f"volume already in memory. Machine: {machine()}; isogrid {isogrid.__version__}, "
            f"scikit-image {skimage.__version__}, numpy {np.__version__}, Python {platform.python_version()}. "
            "isogrid extracts on all cores (GIL released) and computes normals and values in Rust; "
            "scikit-image runs on one core. The machine is shared: read the ratios, not the seconds.",
            "",
            "| volume | isogrid vertices / faces | scikit-image vertices / faces | isogrid s | of which the surface s | scikit-image s | speed-up |",
            "|---|---:|---:|---:|---:|---:|---:|",
            *rows,
            "",
            "\"Of which the surface\" is the Rust Marching Cubes call alone (all cores); the rest is the "
            "per-vertex normals and values, formed per face as scikit-image forms them (Rust, gathered "
            "per vertex), and the array reordering. Where the surface crosses nearly every cell (the gyroid) "
            "that second part dominates and isogrid is slightly behind; on a closed surface in a larger "
            "volume isogrid is ahead.",
            "",
            "Vertex counts differ only where scikit-image's Lewiner method adds a vertex in the centre of an "
            "ambiguous cell, and face counts there too (see `python/tests/test_skimage.py` for what is compared).",
            "",
        ]
    )
    if args.no_write:
        print(section)
        return
    with open(DOC) as f:
        text = f.read()
    pattern = re.compile(re.escape(HEADING) + r".*?(?=\n## |\Z)", re.S)
    text = pattern.sub(section.rstrip("\n"), text) if pattern.search(text) else text.rstrip("\n") + "\n\n" + section
    with open(DOC, "w") as f:
        f.write(text if text.endswith("\n") else text + "\n")
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()

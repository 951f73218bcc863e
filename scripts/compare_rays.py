#!/usr/bin/env python3
"""Two builds of the CPU tracer side by side on the same rays: did a change move ray throughput?

For a refactor that must not change speed (a move of the tracer between crates, a split of its
types), timing one build today and the other tomorrow compares two different machines: this host
is shared and its load drifts by tens of percent within minutes. So, in one run:
  1. build the grid and the rays once (with build A), so both builds trace the very same input;
  2. `isogrid bench rays --threads 1` of A and B in alternating rounds, each process pinned to one
     core, best of --repeat per build and per traversal (Samples3, Exact, BVH);
  3. instructions counted by `valgrind --tool=callgrind` inside the timed call alone
     (`GridTracer::closest_hits`, the same name in both builds), for one pass of --callgrind-rays
     rays per build and traversal: a count does not depend on the host's load, so it separates a
     real change in the hot code from noise in the timings, and it leaves out what the process does
     around the tracing (start-up, reading the grid and the rays) which the timings leave out too.
Hits must agree exactly between the builds (same rays, same grid): a difference is reported.

Usage: python3 scripts/compare_rays.py A_BINARY B_BINARY [--labels before,after] [--rays 300000]
Needs: numpy, taskset, valgrind; data from scripts/fetch_data.sh. Build both binaries with
`cargo build --profile profiling -p isogrid-cli` (target/profiling/isogrid: release code with line
tables, which callgrind's report needs; the release profile carries no debug info).
"""
import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile

import numpy as np

from bench_rays import DATASETS, ROOT, run_json, write_rays

TRAVERSALS = [("Samples3", ["--traversal", "blocks"]),
              ("Exact", ["--traversal", "blocks", "--exact"]),
              ("BVH", ["--traversal", "bvh"])]


def bench(binary, cgc, rays_path, extra):
    cmd = ["taskset", "-c", "0", binary, "bench", "rays", cgc, "--rays-file", rays_path,
           "--threads", "1", "--json", *extra]
    return run_json(cmd)


def cost(report):
    """CPU seconds of the tracing where the binary reports them (steadier than wall time on a
    shared core: time spent descheduled does not count), else wall seconds."""
    return report.get("cpu_seconds") or report["seconds"]


def instructions(binary, cgc, rays_path, extra):
    """Instructions executed inside the timed call, `GridTracer::closest_hits`, and its callees."""
    cmd = ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
           "--toggle-collect=*GridTracer::closest_hits*", binary, "bench", "rays", cgc,
           "--rays-file", rays_path, "--threads", "1", "--json", *extra]
    res = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return int(re.search(r"Collected : (\d+)", res.stderr).group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--labels", default="A,B")
    ap.add_argument("--rays", type=int, default=300_000)
    ap.add_argument("--callgrind-rays", type=int, default=20_000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    label_a, label_b = args.labels.split(",")
    model = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo")
                  if l.startswith("model name")), "unknown")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, rel in DATASETS.items():
            path = os.path.join(ROOT, rel)
            if not os.path.exists(path):
                print(f"skipping {name}: {rel} missing (scripts/fetch_data.sh)", file=sys.stderr)
                continue
            cgc = os.path.join(tmp, "grid.cgc")
            run_json([args.a, "extract", path, "--iso-normalized", "0.5", "-o", cgc, "--json"])
            probe = run_json([args.a, "bench", "rays", cgc, "--rays", "1", "--json"])
            lo, hi = (np.array(v) for v in probe["world_bounds"])
            rays = os.path.join(tmp, "rays.bin")
            few = os.path.join(tmp, "few.bin")
            write_rays(rays, lo, hi, args.rays, args.seed)
            write_rays(few, lo, hi, args.callgrind_rays, args.seed + 1)
            for trav, extra in TRAVERSALS:
                best = {label_a: None, label_b: None}
                for _ in range(args.repeat):
                    for label, binary in ((label_a, args.a), (label_b, args.b)):
                        r = bench(binary, cgc, rays, extra)
                        if best[label] is None or cost(r) < cost(best[label]):
                            best[label] = r
                ir = {label: instructions(binary, cgc, few, extra)
                      for label, binary in ((label_a, args.a), (label_b, args.b))}
                row = {
                    "dataset": name, "traversal": trav,
                    "rays_per_s": {k: args.rays / cost(v) for k, v in best.items()},
                    "hits": {k: v["hits"] for k, v in best.items()},
                    "instructions": ir,
                }
                print(json.dumps(row), file=sys.stderr)
                rows.append(row)
    print(f"Machine: {model}, {os.cpu_count()} logical CPUs, shared (load during the run: "
          f"{os.getloadavg()[0]:.1f}); {platform.system()} {platform.release()}. "
          f"{args.rays:,} rays, rays per CPU second, best of {args.repeat} alternating rounds, "
          f"pinned to core 0; "
          f"instructions: callgrind inside `GridTracer::closest_hits`, {args.callgrind_rays:,} "
          f"rays, per ray.\n")
    print(f"| dataset | traversal | {label_a} rays/s | {label_b} rays/s | {label_b}/{label_a} "
          f"| {label_a} instructions/ray | {label_b} instructions/ray | {label_b}/{label_a} | hits equal |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---|")
    for r in rows:
        ra, rb = r["rays_per_s"][label_a], r["rays_per_s"][label_b]
        ia, ib = r["instructions"][label_a], r["instructions"][label_b]
        same = "yes" if r["hits"][label_a] == r["hits"][label_b] else \
            f"no ({r['hits'][label_a]} vs {r['hits'][label_b]})"
        print(f"| {r['dataset']} | {r['traversal']} | {ra:,.0f} | {rb:,.0f} | {rb / ra:.3f} "
              f"| {ia / args.callgrind_rays:,.1f} | {ib / args.callgrind_rays:,.1f} | {ib / ia:.4f} "
              f"| {same} |")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Closest-hit ray throughput: isogrid's CPU tracer on clustered grid cells vs Embree on the
Marching Cubes mesh of the same isosurface (paper §3.6; issue 4).

For each dataset at normalised isovalue 0.5:
  1. `isogrid extract` -> .cgc (bytes = blocks + metacells + cells) and `isogrid mc` -> .ply;
  2. N rays, origins uniform in the volume's world box and directions uniform on the sphere, drawn
     here with numpy from --seed and written as raw f32 so both tracers get the very same rays;
  3. `isogrid bench rays --rays-file ... --threads 1` (Samples3 and --exact), pinned to one core;
  4. Embree 4 through embreex (rtcIntersect1 per ray, scene flags default), in a child process
     pinned to one core; memory = growth of the process RSS while the scene is built and committed
     (vertex + index buffers Embree holds, plus its BVH).
Best of --repeat rounds (15 by default: Embree's rays/s on this shared host moves by up to 40 %
within minutes, and a run of five rounds once fell wholly inside one of its slow spells),
interleaved; each round times one pass of every tracer, each in its own process. Writes a Markdown report (and JSON) with the machine and versions.

Usage: python3 scripts/bench_rays.py [--rays 1000000] [--seed 1] [--out docs/benchmarks-rays.md]
Needs: pip install embreex trimesh numpy; a release build (cargo build --release -p isogrid-cli);
data from scripts/fetch_data.sh.
"""
import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATASETS = {
    "MNI152 T1": "data/mni152_t1.nii.gz",
    "Dragon 512³": "data/dragon512.nrrd",
}


def run_json(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def pinned(cmd):
    return ["taskset", "-c", "0", *cmd]


def write_rays(path, lo, hi, count, seed):
    """`count` rays as raw little-endian f32 (origin, direction): origins uniform in the box
    [lo, hi], directions uniform on the sphere, from numpy's generator seeded with `seed`."""
    rng = np.random.default_rng(seed)
    origins = lo + (hi - lo) * rng.random((count, 3))
    d = rng.standard_normal((count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    np.hstack([origins, d]).astype("<f4").tofile(path)


def read_ply(path):
    """Binary little-endian PLY as written by `isogrid mc`: float xyz, uchar/uint face lists."""
    with open(path, "rb") as f:
        header = b""
        while not header.endswith(b"end_header\n"):
            header += f.readline()
        lines = header.decode().splitlines()
        nv = int(next(l for l in lines if l.startswith("element vertex")).split()[-1])
        nf = int(next(l for l in lines if l.startswith("element face")).split()[-1])
        vertices = np.frombuffer(f.read(12 * nv), dtype="<f4").reshape(nv, 3)
        faces = np.frombuffer(f.read(13 * nf), dtype=np.uint8).reshape(nf, 13)
        assert (faces[:, 0] == 3).all()
        indices = faces[:, 1:].copy().view("<u4").reshape(nf, 3)
    return np.ascontiguousarray(vertices), np.ascontiguousarray(indices.astype(np.int32))


EMBREE_CHILD = r"""
import json, sys, time, numpy as np
sys.path.insert(0, sys.argv[1])
from bench_rays import read_ply
from embreex import rtcore_scene as rs, mesh_construction as mc

def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024

ply, rays_path, t_path, repeat = sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5])
vertices, indices = read_ply(ply)
rays = np.fromfile(rays_path, dtype="<f4").reshape(-1, 6)
origins = np.ascontiguousarray(rays[:, :3])
directions = np.ascontiguousarray(rays[:, 3:])
before = rss()
scene = rs.EmbreeScene()
mc.TriangleMesh(scene, vertices, indices)
start = time.perf_counter()
scene.run(origins[:1], directions[:1])  # commits the scene: builds the BVH
build = time.perf_counter() - start
grown = rss() - before
best = float("inf")
for _ in range(repeat):
    start = time.perf_counter()
    prim = scene.run(origins, directions)
    best = min(best, time.perf_counter() - start)
out = scene.run(origins, directions, output=1)
t = np.where(out["primID"] >= 0, out["tfar"], np.inf).astype(np.float32)
np.save(t_path, t)
print(json.dumps({"seconds": best, "hits": int((prim >= 0).sum()), "rss_bytes": grown,
                  "build_seconds": build}))
"""


def embree(ply, rays_path, t_path, repeat):
    cmd = pinned([sys.executable, "-c", EMBREE_CHILD, os.path.join(ROOT, "scripts"), ply,
                  rays_path, t_path, str(repeat)])
    return run_json(cmd)


def ours(binary, cgc, rays_path, t_path, exact, repeat, traversal="blocks"):
    best = None
    for _ in range(repeat):
        cmd = [binary, "bench", "rays", cgc, "--rays-file", rays_path, "--threads", "1",
               "--json", "--t-out", t_path, "--traversal", traversal]
        if exact:
            cmd.append("--exact")
        r = run_json(pinned(cmd))
        if best is None or r["seconds"] < best["seconds"]:
            best = r
    return best


def agreement(t_a, t_b):
    a, b = np.load(t_a), np.load(t_b)
    both = np.isfinite(a) & np.isfinite(b)
    either = np.isfinite(a) | np.isfinite(b)
    return {
        "hit_agreement": float((np.isfinite(a) == np.isfinite(b)).mean()),
        "both_hit": int(both.sum()),
        "only_one": int((either & ~both).sum()),
        "median_abs_dt": float(np.median(np.abs(a[both] - b[both]))) if both.any() else None,
    }


def machine():
    model = "unknown"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return model, os.cpu_count()


def version(module):
    try:
        from importlib.metadata import version as v
        return v(module)
    except Exception:
        return "?"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--binary", default=os.path.join(ROOT, "target/release/isogrid"))
    ap.add_argument("--out", default=os.path.join(ROOT, "docs/benchmarks-rays.md"))
    args = ap.parse_args()
    binary = os.environ.get("ISOGRID", args.binary)
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, rel in DATASETS.items():
            path = os.path.join(ROOT, rel)
            if not os.path.exists(path):
                print(f"skipping {name}: {rel} missing (scripts/fetch_data.sh)", file=sys.stderr)
                continue
            cgc = os.path.join(tmp, "grid.cgc")
            ply = os.path.join(tmp, "mesh.ply")
            grid = run_json([binary, "extract", path, "--iso-normalized", "0.5", "-o", cgc, "--json"])
            mesh = run_json([binary, "mc", path, "--iso-normalized", "0.5", "-o", ply, "--json"])
            probe = run_json([binary, "bench", "rays", cgc, "--rays", "1", "--json"])
            lo, hi = (np.array(v) for v in probe["world_bounds"])
            rays_path = os.path.join(tmp, "rays.bin")
            write_rays(rays_path, lo, hi, args.rays, args.seed)
            t = {k: os.path.join(tmp, f"t_{k}.npy") for k in ("s3", "exact", "bvh", "embree")}
            # Rounds of one run each, interleaved, best per tracer: the host's load drifts over
            # minutes, and ratios taken from runs minutes apart drifted with it.
            rounds = [
                (ours(binary, cgc, rays_path, t["s3"], False, 1),
                 ours(binary, cgc, rays_path, t["exact"], True, 1),
                 ours(binary, cgc, rays_path, t["bvh"], False, 1, "bvh"),
                 embree(ply, rays_path, t["embree"], 1))
                for _ in range(args.repeat)
            ]
            s3, ex, bvh, em = (min((r[k] for r in rounds), key=lambda x: x["seconds"])
                               for k in range(4))
            # Each round's BVH and Embree passes run back to back, so their ratio shares that
            # moment's load; best-of ratios can pair a quiet spell of one with a busy one of the other.
            paired = sorted(r[3]["seconds"] / r[2]["seconds"] for r in rounds)
            row = {
                "dataset": name,
                "dims": grid["dims"],
                "active_cells": grid["active_cells"],
                "triangles": mesh["triangles"],
                "vertices": mesh["vertices"],
                "rays": args.rays,
                "samples3": s3,
                "exact": ex,
                "bvh": bvh,
                "embree": em,
                "bvh_vs_embree_per_round": paired,
                "cgc_bytes": s3["bytes"],
                "embree_buffers_estimate": 12 * mesh["vertices"] + 12 * mesh["triangles"],
                "exact_vs_embree": agreement(t["exact"], t["embree"]),
                "samples3_vs_exact": agreement(t["s3"], t["exact"]),
                "bvh_vs_samples3": agreement(t["bvh"], t["s3"]),
            }
            print(json.dumps(row), file=sys.stderr)
            results.append(row)
    write_report(args, results)


def write_report(args, results):
    model, cpus = machine()
    simd = {r["bvh"].get("simd", "?") for r in results}

    def simd_note():
        names = {"avx2": "AVX2 with FMA", "baseline": "SSE2 (the x86-64 baseline)"}
        return " / ".join(sorted(names.get(s, s) for s in simd))

    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                         text=True).stdout.strip()
    lines = [
        "# Ray tracing benchmark: CGC traversal vs Embree on the MC mesh",
        "",
        "Generated by `scripts/bench_rays.py` (issue 4, paper §3.6). Closest-hit queries, **one thread**,",
        "each process pinned to core 0 with `taskset`. The same rays go to both tracers: origins uniform in",
        "the volume's world box, directions uniform on the sphere (numpy, seed "
        f"{args.seed}), {args.rays:,} rays per dataset; best of {args.repeat} rounds,",
        "interleaved; each round times one pass of every tracer, each in its own process. Isovalue: normalised 0.5.",
        "",
        f"- Machine: {model}, {cpus} logical CPUs, shared with other jobs (timings are noisy), "
        f"{platform.system()} {platform.release()}",
        f"- Date: {datetime.date.today().isoformat()}; isogrid commit {git} (release build); "
        f"embreex {version('embreex')} (Embree 4), numpy {version('numpy')}, Python {platform.python_version()}",
        "- isogrid: `isogrid bench rays GRID.cgc --rays-file RAYS --threads 1` — `Samples3` (the paper's three",
        "  samples per cell: entry, middle, exit, then refined) and `Exact` (first root of the cubic), both",
        "  through the block DDA (the default); `BVH` = `Samples3` with `--traversal bvh`, an 8-wide BVH over",
        "  the metacells regrouped by space into leaf clusters of up to 15 (the paper's future work, §3.6)",
        "  in place of the block DDA. Box tests in",
        f"  {simd_note()} (picked at run time, as Embree picks its own).",
        "- Embree: `embreex` `EmbreeScene.run` (a loop of `rtcIntersect1`, default build quality) over an",
        "  indexed `TriangleMesh` of the `isogrid mc` output (float32 vertices).",
        "- Memory: CGC = blocks + metacell slots + corner records + the tracer's own octant empty-space",
        "  map (8 B per block), packed cluster bounds (4 B per cluster) and a 64 B record per cluster of",
        "  its metacells' positions. CGC with BVH = the grid's own buffers + the BVH tracer's 128 B nodes,",
        "  its leaf clusters (16 slots of 12 B plus a 4 B grid cluster per slot) and a 64 B record per leaf",
        "  (it builds neither the empty-space map nor the packed bounds). Embree = growth",
        "  of the process RSS while the mesh is handed to Embree and the scene committed (Embree's copy of",
        "  the vertex and index buffers plus the BVH); the buffers alone are 12 B/vertex + 12 B/triangle.",
        "",
        "| dataset | active cells | triangles | ours Samples3 rays/s | ours Exact rays/s | ours BVH rays/s | Embree rays/s | hits S3 / Exact / BVH / Embree | CGC MB (with BVH) | Embree MB (buffers) | CGC / Embree memory |",
        "|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|",
    ]
    for r in results:
        n = r["rays"]
        s3, ex, bvh, em = r["samples3"], r["exact"], r["bvh"], r["embree"]
        lines.append(
            f"| {r['dataset']} {'x'.join(map(str, r['dims']))} | {r['active_cells']:,} | {r['triangles']:,} "
            f"| {n / s3['seconds']:,.0f} | {n / ex['seconds']:,.0f} | {n / bvh['seconds']:,.0f} | {n / em['seconds']:,.0f} "
            f"| {s3['hits']:,} / {ex['hits']:,} / {bvh['hits']:,} / {em['hits']:,} "
            f"| {r['cgc_bytes'] / 1e6:.2f} ({bvh['bytes'] / 1e6:.2f}) | {em['rss_bytes'] / 1e6:.1f} ({r['embree_buffers_estimate'] / 1e6:.1f}) "
            f"| {max(r['cgc_bytes'], bvh['bytes']) / max(em['rss_bytes'], 1):.2f} |"
        )
    lines += ["", "Agreement on the same rays (hit or miss; distance where both hit):", ""]
    for r in results:
        a, b = r["exact_vs_embree"], r["samples3_vs_exact"]
        lo, hi = r["samples3"]["world_bounds"]
        voxel = min((hi[i] - lo[i]) / max(r["dims"][i] - 1, 1) for i in range(3))
        lines.append(
            f"- {r['dataset']}: Exact vs Embree agree on hit/miss for {100 * a['hit_agreement']:.2f} % of rays; "
            f"where both hit, median |Δt| = {a['median_abs_dt'] / voxel:.4f} voxel (the MC mesh is a "
            f"piecewise-linear approximation of the trilinear surface). Samples3 vs Exact agree on "
            f"{100 * b['hit_agreement']:.4f} % of rays (median |Δt| {b['median_abs_dt'] / voxel:.1e} voxel). "
            f"BVH vs Samples3 (same crossing, other traversal): {100 * r['bvh_vs_samples3']['hit_agreement']:.4f} % "
            f"agree, {r['bvh_vs_samples3']['only_one']:,} rays differ."
        )
    lines += [
        "",
        "Target (issue 4): CPU closest-hit rays/s at 1 thread ≥ Embree's on the MC mesh, with ≤ 1/3 of its memory.",
        "",
    ]
    lines += [
        "Speed is read two ways, and counts as met only when both reach 1: the best rays/s of each",
        "tracer over all rounds, and the median over rounds of the BVH's rays/s over Embree's in the same",
        "round (the two passes run back to back, so they share the host's load; the range is the lowest",
        "and highest round).",
        "",
    ]
    for r in results:
        best = max(r["rays"] / r[k]["seconds"] for k in ("samples3", "exact", "bvh"))
        em = r["rays"] / r["embree"]["seconds"]
        paired = r["bvh_vs_embree_per_round"]
        median = statistics.median(paired)
        mem = max(r["cgc_bytes"], r["bvh"]["bytes"]) / max(r["embree"]["rss_bytes"], 1)
        lines.append(
            f"- {r['dataset']}: speed {'met' if best >= em and median >= 1 else 'NOT met'} "
            f"(best ours {best / em:.2f}× Embree; per round {median:.2f}×, {paired[0]:.2f}–{paired[-1]:.2f}×), "
            f"memory {'met' if mem <= 1 / 3 else 'NOT met'} ({mem:.2f}× Embree's)."
        )
    lines += [
        "",
        "Notes: the default CGC traversal is a block DDA that leaps across empty space with an octant",
        "distance map (per block and ray octant, the largest empty cube growing that way); per non-empty",
        "block it tests the cluster bounds (a packed copy of slot 15, contiguous per block). The BVH",
        "traversal instead regroups the metacells by space into leaf clusters of up to 15 (stored as the",
        "grid stores clusters, with boxes of about half the area of the grid's Morton-order clusters) under",
        "an 8-wide hierarchy; its memory above includes that copy. With AVX2, a ray first meets a gate that",
        "builds its node constants in four f64 lanes and tests the root, and ends there when it passes none",
        "of the root's children (four in five of the dragon's misses); the gates of 64 rays run back to",
        "back before any of those rays that pass is traversed. Either way, an entered cluster's 15",
        "metacell boxes are tested from a 64 B per-cluster record of their",
        "positions (8 lanes at a time with AVX2, 4 with SSE2), a candidate metacell's cells are walked",
        "nearest first by its mid-planes, and one corner record is read per cell the ray crosses",
        "(prefetched). On the dragon a ray that hits executes about seven times the instructions of one",
        "that misses (cachegrind): near the surface it passes through about three active cells before",
        "it crosses. Embree traverses a SIMD BVH over the mesh. `docs/design/tracing.md` has the",
        "measurements behind these choices.",
        "Hit/miss agreement with Embree is limited by the MC mesh",
        "approximating the trilinear surface, not by the tracer (the tests compare `Exact` with a",
        "brute-force reference to 1e-4 voxel).",
        "",
        "Raw results (JSON):", "", "```json", json.dumps(results, indent=1), "```", ""]
    with open(args.out, "w") as f:
        f.write("\n".join(lines))
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()

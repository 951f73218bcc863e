#!/usr/bin/env python3
"""GPU frame time with and without colour by an attribute, one run, at 1920x1080.

For each dataset, extracts the surface twice with the release CLI (plain, and with
`--color-by ATTR`, 16-bit values), renders both with `isogrid render --backend gpu --json` in
modes cgc (the default compute raster and the hardware raster) and cgc-noewa from views 1 and 2,
and the MC baseline from the volumes (with and without `--color-by`), and prints a Markdown table of the timestamp-query
medians (frame, raster, shade; ms) and the cost of colour, frame time coloured / plain − 1.

Datasets: the MNI152 T1 surface coloured by its grey-matter map (`scripts/fetch_data.sh mni152`,
or `--data DIR` holding mni152_t1.nii.gz and mni152_gm.nii.gz), and the built-in hairball at
--hairball-size coloured by the built-in sphere field of the same size (same grid).

    python3 scripts/bench_gpu_color.py [--exe target/release/isogrid] [--frames 10] [--out FILE.md]
"""
import argparse
import os
import tempfile

from gpu_render_bench import add_options, emit, fmt, render_gpu_ms, run


def datasets(exe, data, tmp, hairball):
    t1, gm = os.path.join(data, "mni152_t1.nii.gz"), os.path.join(data, "mni152_gm.nii.gz")
    if os.path.exists(t1) and os.path.exists(gm):
        yield "MNI152 T1 × grey matter", t1, gm
    hb, sphere = os.path.join(tmp, "hairball.nrrd"), os.path.join(tmp, "sphere.nrrd")
    run(exe, ["generate", "hairball", "--size", str(hairball), "-o", hb])
    run(exe, ["generate", "sphere", "--size", str(hairball), "-o", sphere])
    yield f"Hairball {hairball}³ × sphere field", hb, sphere


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(ap)
    ap.add_argument("--hairball-size", type=int, default=512)
    args = ap.parse_args()
    rows = []
    adapter = None
    with tempfile.TemporaryDirectory() as tmp:
        for name, surface, attribute in datasets(args.exe, args.data, tmp, args.hairball_size):
            plain, colored = os.path.join(tmp, "plain.cgc"), os.path.join(tmp, "colored.cgc")
            base = ["extract", surface, "--iso-normalized", "0.5", "--json"]
            cells = run(args.exe, base + ["-o", plain])["active_cells"]
            run(args.exe, base + ["--color-by", attribute, "-o", colored])
            volume = [surface, "--iso-normalized", "0.5"]
            modes = [
                ("cgc", [plain], [colored], []),
                ("cgc, hardware raster", [plain], [colored], ["--cell-raster", "hardware"]),
                ("cgc-noewa", [plain], [colored], ["--mode", "cgc-noewa"]),
                ("mc", volume, volume + ["--color-by", attribute], ["--mode", "mc"]),
            ]
            for mode, plain_input, colored_input, extra in modes:
                for view in ["1", "2"]:
                    times = {}
                    for label, source in [("plain", plain_input), ("colour", colored_input)]:
                        adapter, times[label] = render_gpu_ms(args, source, extra, view)
                    p, c = times["plain"], times["colour"]
                    cost = (c["frame_ms"] / p["frame_ms"] - 1) if p.get("frame_ms") and c.get("frame_ms") else None
                    rows.append((f"{name}, view {view}", mode, cells, p, c, cost))
    lines = [
        f"Adapter: **{adapter}**; {args.size}, {args.frames} frames per render, timestamp-query medians "
        "over frames after the first (ms); `scripts/bench_gpu_color.py`.",
        "",
        "| scene | mode | cells | frame plain | frame coloured | colour costs | shade plain | shade coloured | raster plain | raster coloured |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for scene, mode, cells, p, c, cost in rows:
        lines.append(
            f"| {scene} | {mode} | {cells:,} | {fmt(p.get('frame_ms'))} | {fmt(c.get('frame_ms'))} | "
            f"{'n/a' if cost is None else f'{100 * cost:+.1f} %'} | {fmt(p.get('shade_ms'))} | {fmt(c.get('shade_ms'))} | "
            f"{fmt(p.get('raster_ms'))} | {fmt(c.get('raster_ms'))} |"
        )
    emit(lines, args.out)


if __name__ == "__main__":
    main()

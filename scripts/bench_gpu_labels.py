#!/usr/bin/env python3
"""GPU frame time of label grids with every label shown, one run, at 1920x1080.

For each label volume, extracts the surface of every label with the release CLI
(`extract --labels all`, no smoothing, the default) and renders the .cgc with
`isogrid render --backend gpu --json` from views 1 and 2 in modes cgc (the default compute raster
and the hardware raster) and cgc-noewa, and the label volume's Marching Cubes mesh (`--mode mc
--labels all`). Beside each label grid, for scale, the same volume's single grey surface at
isovalue 0.5 (the boundary of the labelled region against the background). Prints a Markdown
table of the timestamp-query medians (frame, raster, shade; ms).

Volumes (`scripts/fetch_data.sh atlas frog`, and `scripts/bench_labels.py`'s 512³ supervoxels as a
Zarr store), from --data DIR: atlas-desikankilliany.nii.gz (83 labels), frog_tissues.vti (25
labels), bench-labels-supervoxels512.zarr (about 50,000 labels); missing ones are skipped.

    python3 scripts/bench_gpu_labels.py [--exe target/release/isogrid] [--frames 10] [--out FILE.md]
"""
import argparse
import os
import tempfile

from gpu_render_bench import add_options, emit, fmt, render_gpu_ms, run

VOLUMES = [
    ("Desikan-Killiany atlas", "atlas-desikankilliany.nii.gz"),
    ("frog tissues", "frog_tissues.vti"),
    ("supervoxels 512³", "bench-labels-supervoxels512.zarr"),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(ap)
    args = ap.parse_args()
    rows = []
    adapter = None
    with tempfile.TemporaryDirectory() as tmp:
        for name, file in VOLUMES:
            volume = os.path.join(args.data, file)
            if not os.path.exists(volume):
                print(f"skipped {name}: no {volume}")
                continue
            labelled, grey = os.path.join(tmp, "labels.cgc"), os.path.join(tmp, "grey.cgc")
            info = run(args.exe, ["extract", volume, "--labels", "all", "--json", "-o", labelled])
            count = len(info.get("labels", []))
            cells = info["active_cells"]
            grey_cells = run(args.exe, ["extract", volume, "--iso", "0.5", "--json", "-o", grey])["active_cells"]
            modes = [
                ("cgc", [labelled], [grey], []),
                ("cgc, hardware raster", [labelled], [grey], ["--cell-raster", "hardware"]),
                ("cgc-noewa", [labelled], [grey], ["--mode", "cgc-noewa"]),
                ("mc", [volume, "--labels", "all"], [volume, "--iso", "0.5"], ["--mode", "mc"]),
            ]
            for mode, label_input, grey_input, extra in modes:
                for view in ["1", "2"]:
                    times = {}
                    for which, source in [("labels", label_input), ("grey", grey_input)]:
                        adapter, times[which] = render_gpu_ms(args, source, extra, view)
                    rows.append((f"{name} ({count:,} labels), view {view}", mode, cells, grey_cells, times["labels"], times["grey"]))
                    print(rows[-1], flush=True)
    lines = [
        f"Adapter: **{adapter}**; {args.size}, {args.frames} frames per render, timestamp-query medians "
        "over frames after the first (ms); every label shown; `scripts/bench_gpu_labels.py`.",
        "",
        "| scene | mode | cells, all labels | frame, all labels | raster | shade | cells, grey isosurface 0.5 | frame, grey isosurface |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for scene, mode, cells, grey_cells, t, g in rows:
        lines.append(
            f"| {scene} | {mode} | {cells:,} | {fmt(t.get('frame_ms'))} | {fmt(t.get('raster_ms'))} | "
            f"{fmt(t.get('shade_ms'))} | {grey_cells:,} | {fmt(g.get('frame_ms'))} |"
        )
    emit(lines, args.out)


if __name__ == "__main__":
    main()

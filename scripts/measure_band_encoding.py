#!/usr/bin/env python3
"""Bytes of a candidate wire encoding of a grid's cells, against the `.cgc` itself: the distinct
samples that are corners of active cells (their codes, in raster order) and a bitmask of where they
lie in the volume (x fastest), which together give back every active cell and its corner codes.
Compressed with zlib 9 (what browsers' DecompressionStream decodes) and xz 9. Positions are sample
indices (index space). Prints a markdown row per volume for docs/benchmarks-web.md.

    python scripts/measure_band_encoding.py data/mni152_t1.nii.gz   # isogrid, numpy in the Python
"""

import lzma
import sys
import zlib

import numpy as np

import isogrid

CORNERS = np.array([[c & 1, c >> 1 & 1, c >> 2 & 1] for c in range(8)])


def main():
    print("| volume | active cells | `.cgc` bytes | band samples (per cell) | mask zlib 9 | codes zlib 9 | total zlib 9 | total xz 9 |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for path in sys.argv[1:]:
        grid = isogrid.extract(path, iso_normalized=0.5)
        nx, ny, nz = grid.info["dims"]
        corners = (grid.cell_positions().astype(np.int64)[:, None, :] + CORNERS[None]).reshape(-1, 3)
        at = corners[:, 0] + nx * (corners[:, 1] + ny * corners[:, 2])
        codes = grid.corners().reshape(-1)
        order = np.argsort(at, kind="stable")
        at, codes = at[order], codes[order]
        first = np.r_[True, at[1:] != at[:-1]]
        # A sample shared by several cells has one code in all of them, or the encoding loses it.
        assert np.array_equal(codes[first][np.cumsum(first) - 1], codes)
        band, band_codes = at[first], codes[first].astype(np.uint8).tobytes()
        mask = np.zeros(nx * ny * nz, np.uint8)
        mask[band] = 1
        mask = np.packbits(mask).tobytes()
        z = [len(zlib.compress(b, 9)) for b in (mask, band_codes)]
        x = sum(len(lzma.compress(b, preset=9)) for b in (mask, band_codes))
        cells = grid.active_cells
        print(f"| {path} | {cells:,} | {len(grid.to_bytes()):,} | {len(band):,} ({len(band) / cells:.2f}) | "
              f"{z[0]:,} | {z[1]:,} | {sum(z):,} | {x:,} |", flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Writes the small Zarr and OME-Zarr fixtures that crates/isogrid-io/tests and the CLI tests read.

Every array holds the same 20x13x35 volume (nx=20, ny=13, nz=35; numpy shape (z, y, x) = (35, 13,
20)) whose sample (i, j, k) is an integer formula the Rust tests recompute:

    f(i, j, k) = (i - 9)^2 + (j - 6)^2 + (k - 17)^2 + (i + 2 j + 3 k) % 4        (u16)
    float32 arrays hold 0.25 * f - 3.5

Chunks (9, 10, 11) do not divide 16 and the shape does not divide the chunks. Fixtures:

    v2_blosc.zarr          Zarr v2, blosc (zstd, byte shuffle)
    v3_zstd.zarr           Zarr v3, zstd
    v3_sharded_gzip.zarr   Zarr v3, shards (18, 20, 22) of (9, 10, 11) chunks, gzip
    v2_f32_gzip.zarr       Zarr v2, float32, gzip
    ome_v04.zarr           OME-Zarr 0.4 (Zarr v2): axes t, c, z, y, x; two levels; channel c, time
                           t hold f + 1000 * (2 t + c); scale and translation per dataset
    ome_v05.zarr           OME-Zarr 0.5 (Zarr v3): axes z, y, x; two levels; a multiscale-level
                           scale on top of the datasets' own
    v3_missing_chunk.zarr  Zarr v3 with fill value 9 and chunk (0, 0, 0) deleted
    v2_corrupt_chunk.zarr  Zarr v2, blosc, chunk 1.0.1 overwritten with garbage
    v2_lzma.zarr           Zarr v2 with the lzma compressor (not supported by this build)
    v2_4d_unnamed.zarr     Zarr v2, shape (2, 35, 13, 20) without axis names, entry c holding f + 100 c

Written with zarr-python (pip install zarr numcodecs); the OME metadata is written as the OME-NGFF
0.4 and 0.5 specs lay it out. Run from the repository root: python3 scripts/make_zarr_fixtures.py
"""
import json
import os
import shutil

import numcodecs
import numpy as np
import zarr
from zarr.codecs import BloscCodec, GzipCodec, ZstdCodec

OUT = os.path.join("crates", "isogrid-io", "tests", "fixtures", "zarr")
NX, NY, NZ = 20, 13, 35
CHUNKS = (9, 10, 11)

k, j, i = np.meshgrid(np.arange(NZ), np.arange(NY), np.arange(NX), indexing="ij")
BASE = ((i - 9) ** 2 + (j - 6) ** 2 + (k - 17) ** 2 + (i + 2 * j + 3 * k) % 4).astype(np.uint16)


def path(name):
    p = os.path.join(OUT, name)
    shutil.rmtree(p, ignore_errors=True)
    return p


def write(name, data, **kwargs):
    kwargs.setdefault("chunks", CHUNKS)
    a = zarr.create_array(store=path(name), shape=data.shape, dtype=data.dtype, **kwargs)
    a[...] = data
    return a


def main():
    os.makedirs(OUT, exist_ok=True)
    write("v2_blosc.zarr", BASE, zarr_format=2,
          compressors=numcodecs.Blosc(cname="zstd", clevel=3, shuffle=numcodecs.Blosc.SHUFFLE))
    write("v3_zstd.zarr", BASE, zarr_format=3, compressors=ZstdCodec(level=3))
    write("v3_sharded_gzip.zarr", BASE, zarr_format=3, shards=(18, 20, 22),
          compressors=GzipCodec(level=5))
    write("v2_f32_gzip.zarr", (0.25 * BASE - 3.5).astype(np.float32), zarr_format=2,
          compressors=numcodecs.GZip(level=5))

    # OME-Zarr 0.4: 5-D, two levels (level 1 takes every second sample along z, y and x).
    tc = np.stack([np.stack([BASE + 1000 * (2 * t + c) for c in range(2)]) for t in range(2)])
    root = zarr.open_group(path("ome_v04.zarr"), mode="w", zarr_format=2)
    for level, step in enumerate([1, 2]):
        data = tc[:, :, ::step, ::step, ::step]
        a = root.create_array(str(level), shape=data.shape, dtype=data.dtype,
                              chunks=(1, 2) + CHUNKS,
                              compressors=numcodecs.Blosc(cname="lz4", clevel=5))
        a[...] = data
    root.attrs["multiscales"] = [{
        "version": "0.4",
        "name": "fixture",
        "axes": [
            {"name": "t", "type": "time"},
            {"name": "c", "type": "channel"},
            {"name": "z", "type": "space", "unit": "micrometer"},
            {"name": "y", "type": "space", "unit": "micrometer"},
            {"name": "x", "type": "space", "unit": "micrometer"},
        ],
        "datasets": [
            {"path": "0", "coordinateTransformations": [
                {"type": "scale", "scale": [1.0, 1.0, 2.0, 0.5, 0.25]},
                {"type": "translation", "translation": [0.0, 0.0, 10.0, -5.0, 3.0]}]},
            {"path": "1", "coordinateTransformations": [
                {"type": "scale", "scale": [1.0, 1.0, 4.0, 1.0, 0.5]},
                {"type": "translation", "translation": [0.0, 0.0, 11.0, -4.75, 3.125]}]},
        ],
    }]

    # OME-Zarr 0.5: 3-D, Zarr v3, with a multiscale-level scale applied after the datasets'.
    root = zarr.open_group(path("ome_v05.zarr"), mode="w", zarr_format=3)
    for level, step in enumerate([1, 2]):
        data = BASE[::step, ::step, ::step]
        a = root.create_array(str(level), shape=data.shape, dtype=data.dtype, chunks=CHUNKS,
                              compressors=ZstdCodec(level=3), dimension_names=["z", "y", "x"])
        a[...] = data
    root.attrs["ome"] = {
        "version": "0.5",
        "multiscales": [{
            "name": "fixture",
            "axes": [{"name": n, "type": "space", "unit": "nanometer"} for n in "zyx"],
            "datasets": [
                {"path": "0", "coordinateTransformations": [
                    {"type": "scale", "scale": [3.0, 2.0, 1.0]}]},
                {"path": "1", "coordinateTransformations": [
                    {"type": "scale", "scale": [6.0, 4.0, 2.0]},
                    {"type": "translation", "translation": [1.5, 1.0, 0.5]}]},
            ],
            "coordinateTransformations": [{"type": "scale", "scale": [0.5, 0.5, 0.5]}],
        }],
    }

    a = write("v3_missing_chunk.zarr", BASE, zarr_format=3, fill_value=9,
              compressors=ZstdCodec(level=3))
    os.remove(os.path.join(OUT, "v3_missing_chunk.zarr", "c", "0", "0", "0"))

    write("v2_corrupt_chunk.zarr", BASE, zarr_format=2,
          compressors=numcodecs.Blosc(cname="zstd", clevel=3))
    with open(os.path.join(OUT, "v2_corrupt_chunk.zarr", "1.0.1"), "wb") as f:
        f.write(b"this is not a blosc frame" * 3)

    write("v2_lzma.zarr", BASE[:3, :3, :3], zarr_format=2, chunks=(3, 3, 3),
          compressors=numcodecs.LZMA())

    write("v2_4d_unnamed.zarr", np.stack([BASE + 100 * c for c in range(2)]), zarr_format=2,
          chunks=(1,) + CHUNKS, compressors=numcodecs.GZip(level=5))

    total = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(OUT) for f in fs)
    print(f"wrote {OUT} ({total} bytes)")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Packs the Zarr test fixtures into inputs of the `zarr` fuzz target (standard library only):
entries `KEY\\nVALUE` joined by the separator of fuzz/src/lib.rs (`zarr_store::SEPARATOR`).

    python3 fuzz/zarr_seeds.py crates/isogrid-io/tests/fixtures/zarr fuzz/corpus/zarr

Per store: its metadata documents alone (every chunk then reads as the fill value), the metadata
with the first chunk (or shard) of each array, and the whole store when it is small.
"""

import sys
from pathlib import Path

SEPARATOR = b"\n%%zarr%%\n"
METADATA = {"zarr.json", ".zarray", ".zattrs", ".zgroup"}
WHOLE_STORE_MAX = 16 << 10


def pack(entries):
    for key, value in entries:
        if SEPARATOR in value:
            sys.exit(f"{key} holds the separator; pick another in fuzz/src/lib.rs and here")
    return SEPARATOR.join(key.encode() + b"\n" + value for key, value in entries)


def main(fixtures, out):
    out.mkdir(parents=True, exist_ok=True)
    for store in sorted(Path(fixtures).iterdir()):
        files = sorted(p for p in store.rglob("*") if p.is_file())
        entries = [(p.relative_to(store).as_posix(), p.read_bytes()) for p in files]
        metadata = [(k, v) for k, v in entries if k.rsplit("/", 1)[-1] in METADATA]
        arrays = {k.rsplit("/", 1)[0] if "/" in k else "" for k, _ in metadata}
        first_chunks, arrays_seen = [], set()
        for key, value in entries:
            if key.rsplit("/", 1)[-1] in METADATA:
                continue
            array = key  # the nearest folder above the chunk that holds metadata
            while array not in arrays:
                array = array.rsplit("/", 1)[0] if "/" in array else ""
            if array not in arrays_seen:
                arrays_seen.add(array)
                first_chunks.append((key, value))
        name = store.name.removesuffix(".zarr")
        (out / f"{name}.meta").write_bytes(pack(metadata))
        (out / f"{name}.chunk").write_bytes(pack(metadata + first_chunks))
        if sum(len(v) for _, v in entries) <= WHOLE_STORE_MAX:
            (out / f"{name}.whole").write_bytes(pack(entries))


if __name__ == "__main__":
    main(sys.argv[1], Path(sys.argv[2]))

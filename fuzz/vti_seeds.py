#!/usr/bin/env python3
"""Writes the seeds of the `vti` fuzz target with VTK's own writer, through the `.vti` tests'
`write_vti` (python/tests/test_vti.py; needs vtk and isogrid's test dependencies), one small file
per data mode, compressor, header width and byte order the reader distinguishes:

    python fuzz/vti_seeds.py fuzz/corpus-seeds/vti
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python" / "tests"))
from test_vti import write_vti  # noqa: E402


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    z, y, x = np.indices((3, 4, 5))
    u8 = (x + 5 * y + 20 * z).astype(np.uint8)
    f32 = (u8 * 0.25 - 3).astype(np.float32)
    common = {"block_size": 64, "extent_lo": (1, 0, 2)}
    write_vti(out / "ascii.vti", u8, mode="ascii", compressor=None, **common)
    write_vti(out / "binary.vti", u8, mode="binary", compressor=None, **common)
    write_vti(out / "binary_zlib.vti", f32, mode="binary", compressor="zlib", **common)
    write_vti(out / "appended_raw_lz4.vti", f32, mode="appended", compressor="lz4", **common)
    write_vti(out / "appended_base64_zlib.vti", u8, mode="appended", base64=True, compressor="zlib", **common)
    write_vti(out / "appended_raw_u64_big.vti", f32, mode="appended", compressor=None, header64=True,
              big_endian=True, **common)
    for f in sorted(out.iterdir()):
        print(f, f.stat().st_size)


if __name__ == "__main__":
    main(sys.argv[1])

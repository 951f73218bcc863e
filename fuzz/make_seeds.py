#!/usr/bin/env python3
"""Writes the small hand-made seeds of the mesh and detached-NRRD fuzz targets (standard library
only), one file per format variant the readers distinguish:

    python3 fuzz/make_seeds.py fuzz/corpus-seeds

PLY ascii / binary little and big endian (uchar and int list counts, an extra property, a quad);
STL ascii and binary; OBJ with a quad, negative indices, texture/normal references and comments;
the detached NRRD target's input format (header, blank line, then the bytes of `d.raw`).
"""

import struct
import sys
from pathlib import Path

TETRA_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TETRA_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def ply_header(fmt, count_type, extra):
    lines = ["ply", f"format {fmt} 1.0", "comment fuzz seed", f"element vertex {len(TETRA_V)}",
             "property float x", "property float y", "property float z"]
    if extra:
        lines.append("property uchar red")
    lines += [f"element face {len(TETRA_F)}", f"property list {count_type} int vertex_indices",
              "end_header"]
    return ("\n".join(lines) + "\n").encode()


def ply_binary(order, count_type, extra):
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[order]
    out = bytearray(ply_header(fmt, count_type, extra))
    for v in TETRA_V:
        out += struct.pack(order + "3f", *v)
        if extra:
            out += b"\x80"
    code = {"uchar": "B", "int": "i"}[count_type]
    for f in TETRA_F:
        out += struct.pack(order + code + "3i", 3, *f)
    return bytes(out)


def ply_ascii_quad():
    head = ("ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
            "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n")
    body = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 0 1 2 3\n3 0 1 4\n"
    return (head + body).encode()


def stl_ascii():
    out = ["solid seed"]
    for f in TETRA_F:
        out.append("  facet normal 0 0 0\n    outer loop")
        out += [f"      vertex {x} {y} {z}" for x, y, z in (TETRA_V[i] for i in f)]
        out.append("    endloop\n  endfacet")
    out.append("endsolid seed")
    return ("\n".join(out) + "\n").encode()


def stl_binary():
    out = bytearray(b"binary seed".ljust(80, b" "))
    out += struct.pack("<I", len(TETRA_F))
    for f in TETRA_F:
        out += struct.pack("<3f", 0, 0, 0)
        for i in f:
            out += struct.pack("<3f", *TETRA_V[i])
        out += b"\0\0"
    return bytes(out)


def obj_text():
    return (b"# fuzz seed\nmtllib none.mtl\no seed\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
            b"vt 0 0\nvn 0 0 1\ng base\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -5//1 -4//1 -1//1\nf 2 3 5\n"
            b"s off\nf 3 4 5\nl 1 2\n")


def nrrd_detached():
    header = b"NRRD0004\ntype: int16\ndimension: 3\nsizes: 3 2 2\nspacings: 0.5 1 2\nendian: big\nencoding: raw\ndata file: d.raw\n\n"
    return header + b"".join(struct.pack(">h", v * 100 - 300) for v in range(12))


def main(out):
    files = {
        "ply/ascii_quad.ply": ply_ascii_quad(),
        "ply/binary_le_uchar.ply": ply_binary("<", "uchar", True),
        "ply/binary_be_int.ply": ply_binary(">", "int", False),
        "stl/ascii.stl": stl_ascii(),
        "stl/binary.stl": stl_binary(),
        "obj/quads_negative.obj": obj_text(),
        "nrrd_detached/i16_big.nhdr": nrrd_detached(),
    }
    for name, data in files.items():
        path = Path(out) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


if __name__ == "__main__":
    main(sys.argv[1])

#!/usr/bin/env python3
"""Writes the label fixtures that crates/isogrid-io/tests (labels.rs, metaimage.rs) read, with the
reference tools: slicerio (3D Slicer segmentations), ome-zarr (OME-Zarr label images) and
SimpleITK (a MetaImage with a wrong CompressedDataSize).

Every volume is 20x18x16 (nx=20, ny=18, nz=16), voxel (i, j, k), with these masks, which the Rust
tests recompute (index space, bounds inclusive):

    A  box    3 <= i <= 12,  3 <= j <= 12,  2 <= k <= 10
    B  ball   (i - 11)^2 + (j - 10)^2 + (k - 8)^2 <= 16       (overlaps A and C)
    C  box   14 <= i <= 17,  2 <= j <= 15,  3 <= k <= 12
    D  voxel  (1, 16, 14)

Fixtures (in crates/isogrid-io/tests/fixtures/labels):

    one_layer.seg.nrrd   slicerio: segments A, C, D (no overlap: one 3-D layer, values 1, 2, 3)
    two_layers.seg.nrrd  slicerio: segments A, C, D and B; B overlaps A, so slicerio (as Slicer)
                         puts it in a second layer with value 1 (a 4-D file, layer axis first)
    ome_v05.zarr         ome-zarr (OME-NGFF 0.5): image f = i + j + k (u8), labels/cells with
                         A = 1, C = 2, D = 7 (D without properties), colours and a `name` property
    ome_v04.zarr         the same in OME-NGFF 0.4 (Zarr v2), the name under the key `cell name`
    frog_like.mhd/.zraw  SimpleITK, zlib, u8 (A=1, B=2 written over, C=3); its CompressedDataSize
                         then rewritten 37 bytes short of the stream, as PyVista's frogtissue.mhd
                         declares 260020 for a 262087-byte stream. SimpleITK reads this file
                         without an error and returns the samples past the declared bytes as 0.

Run from the repository root: python3 scripts/make_label_fixtures.py
(pip install numpy slicerio ome-zarr zarr SimpleITK)
"""
import os
import re
import shutil

import numpy as np
import SimpleITK as sitk
import slicerio
import zarr
from ome_zarr.format import FormatV04, FormatV05
from ome_zarr.writer import write_image, write_labels

OUT = os.path.join("crates", "isogrid-io", "tests", "fixtures", "labels")
NX, NY, NZ = 20, 18, 16
I, J, K = np.meshgrid(np.arange(NX), np.arange(NY), np.arange(NZ), indexing="ij")
A = (I >= 3) & (I <= 12) & (J >= 3) & (J <= 12) & (K >= 2) & (K <= 10)
B = (I - 11) ** 2 + (J - 10) ** 2 + (K - 8) ** 2 <= 16
C = (I >= 14) & (I <= 17) & (J >= 2) & (J <= 15) & (K >= 3) & (K <= 12)
D = (I == 1) & (J == 16) & (K == 14)

# Colours Slicer would store as floats; chosen k/255 so that the bytes are exact.
SEGMENTS = [
    ("A", A, "liver", [0.2, 0.4, 0.6]),
    ("C", C, "portal vein", [1.0, 0.0, 0.2]),
    ("D", D, "lesion 3", [0.8, 0.8, 0.0]),
]
B_SEGMENT = ("B", B, "tumour", [0.0, 0.6, 1.0])
IJK_TO_LPS = [[0.5, 0, 0, -4], [0, 0.5, 0, 2], [0, 0, 1.5, 7], [0, 0, 0, 1]]


def segmentation(path, segments):
    seg = slicerio.create_segmentation((NX, NY, NZ), IJK_TO_LPS)
    for sid, mask, name, color in segments:
        slicerio.add_segment(seg, mask, {"id": sid, "name": name, "color": color})
    slicerio.write_segmentation(os.path.join(OUT, path), seg)
    return seg


def ome(path, fmt, name_key):
    store = os.path.join(OUT, path)
    shutil.rmtree(store, ignore_errors=True)
    zyx = lambda a: np.ascontiguousarray(np.transpose(a, (2, 1, 0)))
    root = zarr.open_group(store, mode="w", zarr_format=fmt.zarr_format)
    write_image(zyx((I + J + K).astype(np.uint8)), root, axes="zyx", fmt=fmt, scale_factors=[])
    cells = np.zeros((NX, NY, NZ), np.uint16)
    cells[A], cells[C], cells[D] = 1, 2, 7
    metadata = {
        "colors": [
            {"label-value": 1, "rgba": [255, 0, 0, 255]},
            {"label-value": 2, "rgba": [0, 128, 255, 200]},
            {"label-value": 7, "rgba": [10, 20, 30, 255]},
        ],
        "properties": [
            {"label-value": 1, name_key: "nucleus", "area (pixels)": int(A.sum())},
            {"label-value": 2, name_key: "cytoplasm", "area (pixels)": int(C.sum())},
        ],
    }
    write_labels(zyx(cells), root, name="cells", axes="zyx", fmt=fmt, label_metadata=metadata, scale_factors=[])


def frog_like():
    v = np.zeros((NX, NY, NZ), np.uint8)
    v[A], v[B], v[C] = 1, 2, 3
    img = sitk.GetImageFromArray(np.transpose(v, (2, 1, 0)))
    mhd = os.path.join(OUT, "frog_like.mhd")
    sitk.WriteImage(img, mhd, useCompression=True)
    head = open(mhd).read()
    zraw = os.path.join(OUT, re.search(r"ElementDataFile = (\S+)", head).group(1))
    actual = os.path.getsize(zraw)
    assert f"CompressedDataSize = {actual}" in head, head
    open(mhd, "w").write(head.replace(f"CompressedDataSize = {actual}", f"CompressedDataSize = {actual - 37}"))
    back = np.transpose(sitk.GetArrayFromImage(sitk.ReadImage(mhd)), (2, 1, 0))
    print("SimpleITK on frog_like.mhd: samples that differ from the written ones:", int((back != v).sum()))


def main():
    os.makedirs(OUT, exist_ok=True)
    one = segmentation("one_layer.seg.nrrd", SEGMENTS)
    assert one["voxels"].ndim == 3
    two = segmentation("two_layers.seg.nrrd", SEGMENTS + [B_SEGMENT])
    assert two["voxels"].ndim == 4 and two["segments"][-1]["layer"] == 1, two["segments"]
    print([(s["name"], s["layer"], s["labelValue"]) for s in two["segments"]])
    ome("ome_v05.zarr", FormatV05(), "name")
    ome("ome_v04.zarr", FormatV04(), "cell name")
    frog_like()


if __name__ == "__main__":
    main()

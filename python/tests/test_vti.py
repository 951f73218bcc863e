"""VTK XML image data (`.vti`) read by load_volume, checked against the files' writer: VTK's own
`vtkXMLImageDataWriter` writes each file here in every data format, compressor, header width and
byte order it offers, and VTK's reader's view of it (array, spacing, first sample's world position,
axis directions) is the reference, voxel for voxel."""

from pathlib import Path

import numpy as np
import pytest

import isogrid
from conftest import vtk_reads_vti

vtk = pytest.importorskip("vtk")
from vtk.util import numpy_support  # noqa: E402

SHAPE_ZYX = (5, 6, 7)


def ramp(dtype, scale=1.0, offset=0.0):
    z, y, x = np.indices(SHAPE_ZYX)
    return np.asarray((x + 7 * y + 41 * z) * scale + offset).astype(dtype)


TYPES = [
    (ramp(np.uint8), np.uint8),
    (ramp(np.int8, offset=-100), np.int16),
    (ramp(np.uint16, scale=300), np.uint16),
    (ramp(np.int16, scale=-100), np.int16),
    (ramp(np.uint32, scale=70_000), np.uint32),
    (ramp(np.int32, scale=-70_000), np.int32),
    (ramp(np.uint64, scale=3_000_000_000), np.uint64),
    (ramp(np.int64, scale=-3), np.int64),
    (ramp(np.float32, scale=0.25, offset=-3.5), np.float32),
    (ramp(np.float64, scale=0.125, offset=1e3), np.float64),
]

# (data mode, appended data encoded as base64, compressor)
MODES = [
    ("ascii", False, None),
    ("binary", False, None),
    ("binary", False, "zlib"),
    ("binary", False, "lz4"),
    ("appended", False, None),
    ("appended", False, "zlib"),
    ("appended", True, None),
    ("appended", True, "lz4"),
]


def write_vti(path, values, *, mode="appended", base64=False, compressor="zlib", header64=False,
              big_endian=False, block_size=None, extent_lo=(0, 0, 0), others=()):
    """`values` (z, y, x) as point scalars 'v' of a vtkImageData with a rotated and flipped frame,
    its extent starting at `extent_lo`; `others` are further point arrays, written first. Also
    writes the `vti` fuzz target's seeds (fuzz/vti_seeds.py)."""
    nz, ny, nx = values.shape
    image = vtk.vtkImageData()
    lo = extent_lo
    image.SetExtent(lo[0], lo[0] + nx - 1, lo[1], lo[1] + ny - 1, lo[2], lo[2] + nz - 1)
    image.SetSpacing(0.5, 1.25, 3.0)
    image.SetOrigin(-12.5, 40.0, 7.25)
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    image.SetDirectionMatrix(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, -1.0)
    for name, other in others:
        array = numpy_support.numpy_to_vtk(other.ravel(), deep=True)
        array.SetName(name)
        image.GetPointData().AddArray(array)
    array = numpy_support.numpy_to_vtk(values.ravel(), deep=True)
    array.SetName("v")
    image.GetPointData().SetScalars(array)
    writer = vtk.vtkXMLImageDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(image)
    {"ascii": writer.SetDataModeToAscii, "binary": writer.SetDataModeToBinary,
     "appended": writer.SetDataModeToAppended}[mode]()
    writer.SetEncodeAppendedData(base64)
    {None: writer.SetCompressorTypeToNone, "zlib": writer.SetCompressorTypeToZLib,
     "lz4": writer.SetCompressorTypeToLZ4, "lzma": writer.SetCompressorTypeToLZMA}[compressor]()
    if header64:
        writer.SetHeaderTypeToUInt64()
    if big_endian:
        writer.SetByteOrderToBigEndian()
    if block_size:
        writer.SetBlockSize(block_size)
    assert writer.Write() == 1
    return path


def check(path, kept):
    values, spacing, first, rows = vtk_reads_vti(path)
    vol = isogrid.load_volume(path)
    assert vol.array.dtype == kept
    np.testing.assert_array_equal(vol.array, values.astype(kept))
    np.testing.assert_allclose(vol.spacing, spacing, rtol=1e-12)
    np.testing.assert_allclose(vol.origin, first, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(vol.direction, rows, atol=1e-9)


@pytest.mark.parametrize("values,kept", TYPES, ids=[t[0].dtype.name for t in TYPES])
@pytest.mark.parametrize("mode,base64,compressor", MODES,
                         ids=[f"{m}{'-base64' if b else ''}-{c or 'none'}" for m, b, c in MODES])
def test_every_type_and_data_mode_reads_as_vtk_reads_it(tmp_path, values, kept, mode, base64, compressor):
    path = write_vti(tmp_path / "v.vti", values, mode=mode, base64=base64, compressor=compressor)
    check(path, kept)


@pytest.mark.parametrize("header64", [False, True], ids=["uint32-headers", "uint64-headers"])
@pytest.mark.parametrize("big_endian", [False, True], ids=["little", "big"])
def test_headers_byte_orders_blocks_and_extents(tmp_path, header64, big_endian):
    values = ramp(np.float32, scale=0.25, offset=-3.5)
    for mode, base64 in [("binary", False), ("appended", False), ("appended", True)]:
        path = write_vti(tmp_path / f"{mode}{base64}.vti", values, mode=mode, base64=base64,
                         header64=header64, big_endian=big_endian, block_size=256, extent_lo=(3, -2, 10))
        text = path.read_bytes()[:400]
        assert (b'header_type="UInt64"' in text) == header64
        assert (b"BigEndian" in text) == big_endian
        check(path, np.float32)


def test_the_scalars_array_is_read_among_others(tmp_path):
    values = ramp(np.int16, scale=-100)
    path = write_vti(tmp_path / "v.vti", values, others=[("first", ramp(np.float64)), ("second", ramp(np.uint8))])
    assert b'Scalars="v"' in path.read_bytes()[:1000]
    check(path, np.int16)


def test_pyvista_s_frog_is_read_as_vtk_reads_it():
    """PyVista's bundled frog tissues (zlib, binary inline): the samples VTK reads, and the label
    grid of the path is that of VTK's array, byte for byte."""
    pyvista = pytest.importorskip("pyvista")
    path = Path(pyvista.examples.__file__).parent / "frog_tissues.vti"
    check(path, np.uint8)
    values, spacing, _, _ = vtk_reads_vti(path)
    from_path = isogrid.extract_labels(path)
    assert len(from_path.labels) == 25
    assert from_path.to_bytes() == isogrid.extract_labels(np.ascontiguousarray(values), spacing=spacing).to_bytes()


def test_files_it_cannot_read_name_the_file_and_the_problem(tmp_path):
    values = ramp(np.uint16, scale=300)
    lzma = write_vti(tmp_path / "lzma.vti", values, compressor="lzma")
    with pytest.raises(Exception, match=r"lzma\.vti.*vtkLZMADataCompressor"):
        isogrid.load_volume(lzma)
    whole = write_vti(tmp_path / "whole.vti", values, mode="appended", compressor=None).read_bytes()
    cut = tmp_path / "cut.vti"
    cut.write_bytes(whole[: len(whole) - 200])
    with pytest.raises(Exception, match=r"cut\.vti.*truncated"):
        isogrid.load_volume(cut)
    zipped = write_vti(tmp_path / "zipped.vti", values, mode="appended", compressor="zlib").read_bytes()
    at = zipped.index(b"_", zipped.index(b"<AppendedData")) + 40
    damaged = tmp_path / "damaged.vti"
    damaged.write_bytes(zipped[:at] + bytes([zipped[at] ^ 0xFF]) + zipped[at + 1:])
    with pytest.raises(Exception, match=r"damaged\.vti"):
        isogrid.load_volume(damaged)
    vectors = tmp_path / "vectors.vti"
    image = vtk.vtkImageData()
    image.SetDimensions(3, 4, 5)
    array = numpy_support.numpy_to_vtk(np.zeros((60, 3), np.float32), deep=True)
    array.SetName("velocity")
    image.GetPointData().SetVectors(array)
    writer = vtk.vtkXMLImageDataWriter()
    writer.SetFileName(str(vectors))
    writer.SetInputData(image)
    writer.Write()
    with pytest.raises(Exception, match=r"vectors\.vti.*'velocity' has 3 components"):
        isogrid.load_volume(vectors)
    poly = tmp_path / "poly.vti"
    poly.write_text('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1"><PolyData/></VTKFile>\n')
    with pytest.raises(Exception, match=r"poly\.vti.*PolyData"):
        isogrid.load_volume(poly)

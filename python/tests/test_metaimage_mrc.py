"""MetaImage and MRC maps read by load_volume, checked against the files' writers: SimpleITK and
mrcfile write each file here, and their own view of it (array, spacing, origin, direction) is the
reference, voxel for voxel."""

import numpy as np
import pytest

import isogrid
from conftest import same_grid

sitk = pytest.importorskip("SimpleITK")
mrcfile = pytest.importorskip("mrcfile")

SHAPE_ZYX = (4, 5, 6)


def ramp(dtype, scale=1.0, offset=0.0):
    """Distinct values in [z, y, x] order, exact in both `dtype` and float32."""
    z, y, x = np.indices(SHAPE_ZYX)
    return np.asarray((x + 7 * y + 41 * z) * scale + offset).astype(dtype)


def direction_rows(img):
    """SimpleITK's direction matrix is row-major with one column per axis; isogrid's rows are axes."""
    return np.array(img.GetDirection()).reshape(3, 3).T


# (SimpleITK pixel type as a numpy dtype, values, the dtype load_volume keeps)
META_TYPES = [
    (np.uint8, ramp(np.uint8), np.uint8),
    (np.int8, ramp(np.int8, offset=-100), np.int16),
    (np.uint16, ramp(np.uint16, scale=300), np.uint16),
    (np.int16, ramp(np.int16, scale=-100), np.int16),
    (np.uint32, ramp(np.uint32, scale=70_000), np.uint32),
    (np.int32, ramp(np.int32, scale=-70_000), np.int32),
    (np.int64, ramp(np.int64, scale=-3), np.int64),
    (np.float32, ramp(np.float32, scale=0.25, offset=-3.5), np.float32),
    (np.float64, ramp(np.float64, scale=0.125, offset=1e3), np.float64),
]


@pytest.mark.parametrize("dtype,values,kept", META_TYPES, ids=[np.dtype(t[0]).name for t in META_TYPES])
@pytest.mark.parametrize("suffix", [".mha", ".mhd"])
@pytest.mark.parametrize("compressed", [False, True], ids=["raw", "zlib"])
def test_metaimage_matches_simpleitk(tmp_path, dtype, values, kept, suffix, compressed):
    img = sitk.GetImageFromArray(values)
    img.SetSpacing((0.5, 1.25, 3.0))
    img.SetOrigin((-12.5, 40.0, 7.25))
    # A rotation about z by 30 degrees then a flip of the third axis: not the identity, not a permutation.
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    img.SetDirection((c, -s, 0.0, s, c, 0.0, 0.0, 0.0, -1.0))
    path = tmp_path / f"v{suffix}"
    sitk.WriteImage(img, str(path), useCompression=compressed)
    header = path.read_bytes()[:600]
    assert (b"CompressedData = True" in header) == compressed
    assert (b"ElementDataFile = LOCAL" in header) == (suffix == ".mha")

    ref = sitk.ReadImage(str(path))
    vol = isogrid.load_volume(path)
    assert vol.array.dtype == kept
    np.testing.assert_array_equal(vol.array, sitk.GetArrayFromImage(ref).astype(kept))
    assert vol.dims == ref.GetSize()
    np.testing.assert_allclose(vol.spacing, ref.GetSpacing(), rtol=1e-12)
    np.testing.assert_allclose(vol.origin, ref.GetOrigin(), rtol=1e-12)
    np.testing.assert_allclose(vol.direction, direction_rows(ref), atol=1e-9)


def test_metaimage_big_endian_data_as_simpleitk_reads_it(tmp_path):
    values = ramp(np.uint16, scale=300)
    sitk.WriteImage(sitk.GetImageFromArray(values), str(tmp_path / "v.mhd"))
    # Rewrite the data big-endian and say so in the header.
    raw = tmp_path / "v.raw"
    raw.write_bytes(np.frombuffer(raw.read_bytes(), "<u2").astype(">u2").tobytes())
    head = tmp_path / "v.mhd"
    text = head.read_text().replace("BinaryDataByteOrderMSB = False", "BinaryDataByteOrderMSB = True")
    head.write_text(text)
    reference = sitk.GetArrayFromImage(sitk.ReadImage(str(head)))
    np.testing.assert_array_equal(reference, values)  # SimpleITK honours the flag too
    np.testing.assert_array_equal(isogrid.load_volume(head).array, reference)


def test_metaimage_2d_image_is_one_slice(tmp_path):
    values = ramp(np.float32)[0]
    img = sitk.GetImageFromArray(values)
    img.SetSpacing((0.5, 2.0))
    img.SetOrigin((3.0, -4.0))
    sitk.WriteImage(img, str(tmp_path / "flat.mha"))
    vol = isogrid.load_volume(tmp_path / "flat.mha")
    assert vol.array.shape == (1,) + values.shape
    np.testing.assert_array_equal(vol.array[0], values)
    assert vol.spacing == (0.5, 2.0, 1.0) and vol.origin == (3.0, -4.0, 0.0)


def test_metaimage_missing_or_short_data_file(tmp_path):
    sitk.WriteImage(sitk.GetImageFromArray(ramp(np.int16)), str(tmp_path / "v.mhd"))
    raw = tmp_path / "v.raw"
    data = raw.read_bytes()
    raw.write_bytes(data[:-10])
    with pytest.raises(isogrid.IsogridError, match=r"v\.raw: file is truncated: sample data needs 240 bytes"):
        isogrid.load_volume(tmp_path / "v.mhd")
    raw.unlink()
    with pytest.raises(FileNotFoundError) as err:
        isogrid.load_volume(tmp_path / "v.mhd")
    assert err.value.filename == str(raw)


# (numpy dtype mrcfile writes, MRC mode, the dtype load_volume keeps)
MRC_TYPES = [
    (np.int8, 0, np.int16),
    (np.int16, 1, np.int16),
    (np.float32, 2, np.float32),
    (np.uint16, 6, np.uint16),
    (np.float16, 12, np.float32),
]


@pytest.mark.parametrize("dtype,mode,kept", MRC_TYPES, ids=[f"mode{t[1]}" for t in MRC_TYPES])
@pytest.mark.parametrize("byte_order", ["<", ">"])
def test_mrc_matches_mrcfile(tmp_path, dtype, mode, kept, byte_order):
    values = ramp(dtype, offset=-60 if np.dtype(dtype).kind in "if" else 0)
    path = tmp_path / "v.mrc"
    with mrcfile.new(path) as m:
        m.set_data(values.astype(np.dtype(dtype).newbyteorder(byte_order)))
        m.voxel_size = (0.5, 1.25, 3.0)
        m.header.origin = (-12.5, 40.0, 7.25)
    with mrcfile.open(path) as m:
        assert m.header.mode == mode and m.data.dtype.byteorder in (byte_order, "=", "|")
        reference = m.data.astype(kept)
        voxel_size = m.voxel_size
        origin = m.header.origin
        vol = isogrid.load_volume(path)
    assert vol.array.dtype == kept
    np.testing.assert_array_equal(vol.array, reference)
    np.testing.assert_allclose(vol.spacing, (voxel_size.x, voxel_size.y, voxel_size.z), rtol=1e-6)
    np.testing.assert_allclose(vol.origin, (origin.x, origin.y, origin.z), rtol=1e-6)


@pytest.mark.parametrize("order", [(3, 2, 1), (2, 3, 1), (3, 1, 2), (1, 3, 2)])
def test_mrc_axis_order_and_start_indices(tmp_path, order):
    """Columns, rows and sections along other axes come back as [z, y, x]; with origin fields 0,
    the start indices (per column, row, section) times the voxel size place the map (ChimeraX)."""
    stored = np.arange(4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6)  # [section, row, column]
    path = tmp_path / "v.map"
    with mrcfile.new(path) as m:
        m.set_data(stored)
        m.header.mapc, m.header.mapr, m.header.maps = order
        xyz_size = [0, 0, 0]
        for axis, n in zip(order, (6, 5, 4)):  # column, row, section counts
            xyz_size[axis - 1] = n
        m.header.mx, m.header.my, m.header.mz = xyz_size
        m.header.cella = tuple(n * s for n, s in zip(xyz_size, (0.5, 1.25, 3.0)))
        m.header.nxstart, m.header.nystart, m.header.nzstart = 4, -2, 7  # column, row, section
    with mrcfile.open(path) as m:
        data = m.data  # [section, row, column], as stored
        voxel = np.array([m.voxel_size.x, m.voxel_size.y, m.voxel_size.z], dtype=float)
        start_crs = (int(m.header.nxstart), int(m.header.nystart), int(m.header.nzstart))
        mapping = (int(m.header.mapc), int(m.header.mapr), int(m.header.maps))
    # The stored array's axes 0, 1, 2 run along spatial axes maps, mapr, mapc (1 = x).
    spatial_of_array_axis = [mapping[2] - 1, mapping[1] - 1, mapping[0] - 1]
    expected = np.transpose(data, [spatial_of_array_axis.index(a) for a in (2, 1, 0)])
    start_xyz = [0, 0, 0]
    for f in range(3):
        start_xyz[mapping[f] - 1] = start_crs[f]

    vol = isogrid.load_volume(path)
    np.testing.assert_array_equal(vol.array, expected)
    np.testing.assert_allclose(vol.spacing, voxel, rtol=1e-6)
    np.testing.assert_allclose(vol.origin, np.array(start_xyz) * voxel, rtol=1e-6)


def test_mrc_extended_header_is_skipped(tmp_path):
    values = ramp(np.int16)
    path = tmp_path / "ext.mrc"
    with mrcfile.new(path) as m:
        m.set_data(values)
        m.set_extended_header(np.arange(64, dtype=np.uint8))
    with mrcfile.open(path) as m:
        assert m.header.nsymbt == 64
    np.testing.assert_array_equal(isogrid.load_volume(path).array, values)


def test_mrc_header_larger_than_the_file(tmp_path):
    path = tmp_path / "v.mrc"
    with mrcfile.new(path) as m:
        m.set_data(ramp(np.float32))
    path.write_bytes(path.read_bytes()[:1500])
    with pytest.raises(isogrid.IsogridError, match=r"v\.mrc: file is truncated: 6x5x4 samples need 480 bytes"):
        isogrid.load_volume(path)


def test_extract_and_marching_cubes_take_a_path(tmp_path):
    values = ramp(np.float32)
    with mrcfile.new(tmp_path / "v.mrc") as m:
        m.set_data(values)
    img = sitk.GetImageFromArray(values)
    img.SetSpacing((0.5, 1.0, 2.0))
    sitk.WriteImage(img, str(tmp_path / "v.mha"), useCompression=True)
    for name in ("v.mrc", "v.mha"):
        path = tmp_path / name
        by_path = isogrid.extract(path, iso_normalized=0.5)
        assert same_grid(by_path, isogrid.extract(isogrid.load_volume(path), iso_normalized=0.5))
        assert by_path.active_cells > 0
        verts, faces = isogrid.marching_cubes(str(path), iso_normalized=0.5)
        ref_verts, ref_faces = isogrid.marching_cubes(isogrid.load_volume(path), iso_normalized=0.5)
        np.testing.assert_array_equal(verts, ref_verts)
        np.testing.assert_array_equal(faces, ref_faces)
    # The file's spacing comes with the path, as with a Volume.
    assert isogrid.extract(tmp_path / "v.mha", iso=50).info["spacing"] == (0.5, 1.0, 2.0)

"""Samples wider than float32 (uint32, int32, uint64, int64, float64) keep their type and are
classified exactly in it (#42): each case is a volume of two values no float32 tells apart, split
by an isovalue between them, against numpy's brute force; and files of each type written by
numpy, nibabel, tifffile and zarr-python read back as the same array."""

import numpy as np
import pytest

import isogrid
from conftest import active_cells_xyz, sort_rows

# (dtype, the two values, an isovalue between them)
CASES = [
    (np.uint32, 16777216, 16777217, 16777216.5),
    (np.int32, -100_000_001, -99_999_998, -99_999_999.5),
    (np.float64, 0.25, 0.25 + 1e-12, 0.25 + 0.5e-12),
    (np.uint64, 2**60 + 4096, 2**60 + 4096 + 512, float(2**60 + 4096 + 256)),
    (np.int64, -(2**40), 2**40 + 1, float(2**40)),
]


def two_values(dtype, lo, hi, shape=(13, 11, 12), seed=3):
    pick = np.random.default_rng(seed).integers(0, 2, size=shape).astype(bool)
    return np.where(pick, np.array(hi, dtype=dtype), np.array(lo, dtype=dtype)).astype(dtype)


def brute_force_count(a, inside):
    """Cells whose eight corners are not all on one side, by numpy (`inside` is the exact
    per-sample side, decided without converting the samples)."""
    return len(active_cells_xyz(inside.astype(np.uint8), 1))


@pytest.mark.parametrize("dtype, lo, hi, iso", CASES, ids=lambda c: str(c))
def test_two_values_an_f32_cannot_tell_apart_are_split_exactly(dtype, lo, hi, iso):
    a = two_values(dtype, lo, hi)
    # The side of each sample, decided without a float conversion of the sample.
    inside = a == np.array(hi, dtype=dtype)
    expected = brute_force_count(a, inside)
    assert expected > 0
    for precision in (4, 8, 16, 32):
        grid = isogrid.extract(a, iso=iso, precision=precision)
        assert grid.info["scalar_type"] == np.dtype(dtype).name
        assert grid.active_cells == expected, precision
        assert grid.info["value_range"] == (float(lo), float(hi))
        np.testing.assert_array_equal(
            sort_rows(grid.cell_positions()), sort_rows(active_cells_xyz(inside.astype(np.uint8), 1))
        )
        # Every stored corner keeps its sample's side.
        x, y, z = np.asarray(grid.cell_positions()).T
        corners_inside = grid.corners() >= grid.info["iso_code"]
        for c in range(8):
            side = inside[z + (c >> 2 & 1), y + (c >> 1 & 1), x + (c & 1)]
            np.testing.assert_array_equal(corners_inside[:, c], side)
    # Marching Cubes: one vertex per crossed edge.
    vertices, _ = isogrid.marching_cubes(a, iso)
    edges = sum(int((np.diff(inside, axis=axis) != 0).sum()) for axis in range(3))
    assert len(vertices) == edges


def test_u32_volume_of_16777216_and_16777217_through_the_cli_path(tmp_path):
    # The case: a .npy of both values, read from the file.
    a = np.full((6, 6, 6), 16777216, dtype=np.uint32)
    a[3:] = 16777217
    path = tmp_path / "u32.npy"
    np.save(path, a)
    grid = isogrid.extract(path, iso=16777216.5)
    assert grid.active_cells == brute_force_count(a, a > 16777216) == 25
    assert grid.info["value_range"] == (16777216.0, 16777217.0)


@pytest.mark.parametrize("dtype", [np.uint32, np.int32, np.uint64, np.int64, np.float64])
def test_npy_of_each_wide_type_reads_back_as_numpy_wrote_it(tmp_path, dtype):
    a = two_values(dtype, *CASES[[c[0] for c in CASES].index(dtype)][1:3])
    np.save(tmp_path / "a.npy", a)
    v = isogrid.load_volume(tmp_path / "a.npy")
    assert v.array.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(v.array, a)


@pytest.mark.parametrize("dtype", [np.uint32, np.int32, np.uint64, np.int64, np.float64])
def test_nifti_of_each_wide_type_reads_back_as_nibabel_wrote_it(tmp_path, dtype):
    nib = pytest.importorskip("nibabel")
    a = two_values(dtype, *CASES[[c[0] for c in CASES].index(dtype)][1:3])
    # nibabel's arrays are (x, y, z); isogrid's are (z, y, x).
    xyz = np.ascontiguousarray(a.transpose(2, 1, 0))
    img = nib.Nifti1Image(xyz, np.eye(4), dtype=dtype)
    img.header.set_slope_inter(1.0, 0.0)
    nib.save(img, tmp_path / "a.nii")
    ref = np.asanyarray(nib.load(tmp_path / "a.nii").dataobj)
    v = isogrid.load_volume(tmp_path / "a.nii")
    assert v.array.dtype == ref.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(v.array, ref.transpose(2, 1, 0))


def test_nifti_with_an_intercept_of_2e9_is_exact(tmp_path):
    nib = pytest.importorskip("nibabel")
    bits = two_values(np.int16, 0, 1)
    img = nib.Nifti1Image(np.ascontiguousarray(bits.transpose(2, 1, 0)), np.eye(4), dtype=np.int16)
    img.header.set_slope_inter(1.0, 2e9)
    nib.save(img, tmp_path / "a.nii")
    ref = np.asarray(nib.load(tmp_path / "a.nii").dataobj).transpose(2, 1, 0)  # float64
    v = isogrid.load_volume(tmp_path / "a.nii")
    np.testing.assert_array_equal(v.array, ref)
    grid = isogrid.extract(tmp_path / "a.nii", iso=2e9 + 0.5)
    assert grid.active_cells == brute_force_count(ref, ref > 2e9 + 0.5) > 0


@pytest.mark.parametrize("dtype", [np.uint32, np.int32, np.uint64, np.int64, np.float64])
def test_tiff_of_each_wide_type_reads_back_as_tifffile_wrote_it(tmp_path, dtype):
    tifffile = pytest.importorskip("tifffile")
    a = two_values(dtype, *CASES[[c[0] for c in CASES].index(dtype)][1:3])
    tifffile.imwrite(tmp_path / "a.tif", a)
    ref = tifffile.imread(tmp_path / "a.tif")
    v = isogrid.load_volume(tmp_path / "a.tif")
    assert v.array.dtype == ref.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(v.array, ref)


@pytest.mark.parametrize("dtype", [np.uint32, np.int32, np.uint64, np.int64, np.float64])
def test_zarr_of_each_wide_type_reads_back_as_zarr_python_wrote_it(tmp_path, dtype):
    zarr = pytest.importorskip("zarr")
    a = two_values(dtype, *CASES[[c[0] for c in CASES].index(dtype)][1:3])
    z = zarr.create_array(store=str(tmp_path / "a.zarr"), shape=a.shape, dtype=a.dtype, chunks=(5, 6, 7))
    z[...] = a
    ref = zarr.open_array(str(tmp_path / "a.zarr"), mode="r")[...]
    v = isogrid.load_volume(tmp_path / "a.zarr")
    assert v.array.dtype == ref.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(v.array, ref)
    iso = CASES[[c[0] for c in CASES].index(dtype)][3]
    assert isogrid.extract(tmp_path / "a.zarr", iso=iso).active_cells == isogrid.extract(ref, iso=iso).active_cells


def test_dicom_series_with_an_intercept_of_2e9_is_exact(tmp_path):
    """Written by pydicom: stored 0 or 1, RescaleIntercept 2e9; pydicom's rescaled values
    (float64) are the reference, split at 2e9 + 0.5."""
    pydicom = pytest.importorskip("pydicom")
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid

    stored = two_values(np.uint16, 0, 1, shape=(4, 6, 7))  # [k, j, i]
    series = generate_uid()
    for k in range(stored.shape[0]):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID = meta.MediaStorageSOPClassUID
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.SeriesInstanceUID = series
        ds.Modality = "CT"
        ds.InstanceNumber = k + 1
        ds.ImagePositionPatient = [0.0, 0.0, 2.0 * k]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.PixelSpacing = [1.0, 1.0]
        ds.Rows, ds.Columns = stored.shape[1], stored.shape[2]
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated = ds.BitsStored = 16
        ds.HighBit = 15
        ds.PixelRepresentation = 0
        ds.RescaleSlope = 1
        ds.RescaleIntercept = 2000000000
        ds.PixelData = np.ascontiguousarray(stored[k]).astype("<u2").tobytes()
        ds.save_as(tmp_path / f"{k}.dcm", enforce_file_format=True)
    from pydicom.pixels import apply_rescale

    ref = np.stack(
        [apply_rescale(d.pixel_array, d) for d in sorted(
            (pydicom.dcmread(p) for p in tmp_path.glob("*.dcm")), key=lambda d: d.InstanceNumber
        )]
    )
    v = isogrid.load_volume(tmp_path)
    assert v.array.dtype == np.int32
    np.testing.assert_array_equal(v.array, ref)
    expected = brute_force_count(ref, ref > 2e9 + 0.5)
    assert expected > 0
    assert isogrid.extract(tmp_path, iso=2e9 + 0.5).active_cells == expected

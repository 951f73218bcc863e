"""load_volume: formats, the axis convention shared with extract, raw specs and errors."""

import gzip
import subprocess

import numpy as np
import pytest

import isogrid
from conftest import REPO, same_grid, sphere


@pytest.mark.parametrize("fortran", [False, True])
def test_npy_round_trip_follows_the_axis_rule(tmp_path, fortran):
    c = sphere(dtype=np.int16)
    a = np.asfortranarray(c.transpose()) if fortran else c
    path = tmp_path / "v.npy"
    np.save(path, a)
    vol = isogrid.load_volume(path)
    # Whatever the file order, the result is C-ordered (nz, ny, nx) with the same samples.
    assert vol.array.flags.c_contiguous and vol.array.shape == (20, 24, 28)
    assert vol.array.dtype == np.int16
    np.testing.assert_array_equal(vol.array, c)
    assert vol.spacing == (1.0, 1.0, 1.0) and vol.dims == (28, 24, 20)
    assert same_grid(isogrid.extract(vol, iso=0), isogrid.extract(a, iso=0))


def test_loaded_array_is_an_owned_writable_numpy_array(tmp_path):
    np.save(tmp_path / "v.npy", sphere())
    vol = isogrid.load_volume(tmp_path / "v.npy")
    assert vol.array.flags.writeable
    vol.array[0, 0, 0] = 42
    assert vol.array[0, 0, 0] == 42


@pytest.mark.parametrize(
    "dtype", ["uint8", "uint16", "int16", "float32", "uint32", "int32", "uint64", "int64", "float64"]
)
@pytest.mark.parametrize("big_endian", [False, True])
def test_raw(tmp_path, dtype, big_endian):
    c = np.round(sphere() * 3 + 50).astype(dtype)
    path = tmp_path / "v.raw"
    path.write_bytes(c.astype(c.dtype.newbyteorder(">" if big_endian else "<")).tobytes())
    vol = isogrid.load_volume(path, raw_shape=(28, 24, 20), raw_dtype=dtype, big_endian=big_endian)
    np.testing.assert_array_equal(vol.array, c)
    assert vol.array.dtype == np.dtype(dtype)


def test_raw_byte_order_from_dtype(tmp_path):
    c = np.arange(2 * 3 * 4, dtype=np.uint16).reshape(2, 3, 4) * 300
    (tmp_path / "v.raw").write_bytes(c.astype(">u2").tobytes())
    vol = isogrid.load_volume(tmp_path / "v.raw", raw_shape=(4, 3, 2), raw_dtype=">u2")
    np.testing.assert_array_equal(vol.array, c)


def test_raw_errors(tmp_path):
    path = tmp_path / "v.raw"
    path.write_bytes(bytes(100))
    with pytest.raises(ValueError, match="raw size mismatch: 4x4x4 u8 needs 64 bytes but the file has 100"):
        isogrid.load_volume(path, raw_shape=(4, 4, 4), raw_dtype=np.uint8)
    with pytest.raises(ValueError, match="raw files need"):
        isogrid.load_volume(path)
    with pytest.raises(ValueError, match="need both raw_shape"):
        isogrid.load_volume(path, raw_shape=(10, 10, 1))
    with pytest.raises(ValueError, match="raw_dtype must be"):
        isogrid.load_volume(path, raw_shape=(100, 1, 1), raw_dtype=np.int8)
    with pytest.raises(ValueError, match="raw_shape must be"):
        isogrid.load_volume(path, raw_shape=(100, 1))
    with pytest.raises(ValueError, match="at least 1"):
        isogrid.load_volume(path, raw_shape=(100, 1, 0), raw_dtype="uint8")


def test_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        isogrid.load_volume(tmp_path / "missing.nii")
    junk = tmp_path / "junk.dat"
    junk.write_bytes(b"hello" * 100)
    with pytest.raises(isogrid.IsogridError, match="junk.dat: unknown volume format"):
        isogrid.load_volume(junk)
    bad = tmp_path / "bad.npy"
    bad.write_bytes(b"\x93NUMPY\x01\x00" + b"\x10\x00" + b"{'descr': '<f4'" + b"x" * 20)
    with pytest.raises(isogrid.IsogridError, match="bad.npy"):
        isogrid.load_volume(bad)


def test_nifti_with_spacing(tmp_path):
    nib = pytest.importorskip("nibabel")
    f = np.asfortranarray(sphere(dtype=np.uint8).transpose())  # nibabel's [x, y, z]
    img = nib.Nifti1Image(f, np.diag([0.5, 0.75, 2.0, 1.0]))
    img.header.set_zooms((0.5, 0.75, 2.0))
    nib.save(img, tmp_path / "v.nii.gz")
    vol = isogrid.load_volume(tmp_path / "v.nii.gz")
    assert vol.spacing == (0.5, 0.75, 2.0)
    np.testing.assert_array_equal(vol.array, f.transpose())
    # nibabel's own array, Fortran (x, y, z), with its zooms, in NIfTI's RAS world, gives the grid
    # of the Rust reader.
    assert vol.frame == "RAS"
    loaded = nib.load(tmp_path / "v.nii.gz")
    direct = isogrid.extract(isogrid.Volume(np.asanyarray(loaded.dataobj), loaded.header.get_zooms(), frame="RAS"), iso=3)
    assert same_grid(direct, isogrid.extract(vol, iso=3))


def test_nifti_of_shape_x_y_z_1_as_nibabel_returns_it(tmp_path):
    nib = pytest.importorskip("nibabel")
    f = np.asfortranarray(sphere(dtype=np.float32).transpose())[..., None]  # (x, y, z, 1)
    nib.save(nib.Nifti1Image(f, np.diag([0.5, 0.75, 2.0, 1.0])), tmp_path / "t1.nii.gz")
    loaded = nib.load(tmp_path / "t1.nii.gz")
    data = loaded.get_fdata(dtype=np.float32)
    assert data.shape[3:] == (1,) and data.flags.f_contiguous
    zooms = loaded.header.get_zooms()[:3]
    # The same grid as the Rust reader's (t = 1 read as 3-D; its RAS frame left out, as the arrays
    # have none) and as nibabel's array without the t axis.
    read = isogrid.load_volume(tmp_path / "t1.nii.gz")
    assert read.frame == "RAS"
    read.frame = None
    by_reader = isogrid.extract(read, iso=0.5)
    assert same_grid(isogrid.extract(data, iso=0.5, spacing=zooms), by_reader)
    assert same_grid(isogrid.extract(data[..., 0], iso=0.5, spacing=zooms), by_reader)
    # The C-order counterpart (1, z, y, x); a length-1 axis where a volume axis is, is not dropped.
    assert same_grid(isogrid.extract(np.ascontiguousarray(data.transpose()), iso=0.5, spacing=zooms), by_reader)
    with pytest.raises(ValueError, match="expected a 3-D array"):
        isogrid.extract(np.zeros((4, 5, 6, 2), order="F"), iso=0.5)


NIFTI2_TYPES = [np.uint8, np.int8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64, np.float32,
                np.float64]


@pytest.mark.parametrize("dtype", NIFTI2_TYPES, ids=[np.dtype(t).name for t in NIFTI2_TYPES])
@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_nifti2_matches_nibabel(tmp_path, dtype, suffix):
    """NIfTI-2 (64-bit sizes and doubles; what tools write for volumes beyond NIfTI-1's 32,767
    samples per axis), written by nibabel with an oblique sform: every sample and the affine."""
    nib = pytest.importorskip("nibabel")
    x, y, z = np.indices((9, 7, 5))
    values = np.asfortranarray((x + 11 * y + 83 * z).astype(dtype))
    t = np.radians(20)
    affine = np.eye(4)
    affine[:3, :3] = np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]]) @ np.diag([0.7, 1.2, 2.5])
    affine[:3, 3] = (-12.5, 30.25, 4.0)
    path = tmp_path / f"v{suffix}"
    nib.save(nib.Nifti2Image(values, affine, dtype=dtype), path)
    reference = nib.load(path)
    assert isinstance(reference, nib.Nifti2Image) and reference.get_data_dtype() == dtype
    volume = isogrid.load_volume(path)
    kept = np.int16 if dtype == np.int8 else dtype
    assert volume.array.dtype == kept
    np.testing.assert_array_equal(volume.array, np.asarray(reference.dataobj).astype(kept).transpose())
    got = np.eye(4)
    got[:3, :3] = (np.asarray(volume.direction) * np.asarray(volume.spacing)[:, None]).T
    got[:3, 3] = volume.origin
    np.testing.assert_allclose(got, reference.affine, atol=1e-12)
    assert volume.frame == "RAS"


@pytest.mark.parametrize("image_class", ["Nifti1Image", "Nifti2Image"])
def test_a_4d_nifti_gives_the_volume_index_t_picks(cli, tmp_path, image_class):
    """A 4-D NIfTI written by nibabel (an fMRI-like time series; .nii.gz and .nii): ``index={"t": k}``
    (``--index t=k``) reads nibabel's ``data[..., k]``; without an index, with another axis or out of
    range it fails naming the volumes. The CLI reads the uncompressed file's volume by region within
    ``--max-memory`` into the same grid as the compressed file read whole."""
    nib = pytest.importorskip("nibabel")
    rng = np.random.default_rng(4)
    data = np.asfortranarray(rng.random((14, 15, 16, 5)).astype(np.float32))  # (x, y, z, t)
    affine = np.diag([2.0, 2.0, 2.5, 1.0])
    affine[:3, 3] = [-10.0, 4.0, 7.5]
    for name in ("bold.nii.gz", "bold.nii"):
        nib.save(getattr(nib, image_class)(data, affine), tmp_path / name)
        for t in range(5):
            vol = isogrid.load_volume(tmp_path / name, index={"t": t})
            np.testing.assert_array_equal(vol.array, data[..., t].transpose())
            assert vol.spacing == (2.0, 2.0, 2.5) and vol.origin == (-10.0, 4.0, 7.5)
        for index, message in [
            (None, r'4-D NIfTI file of 5 volumes \(t=0\.\.4\): pass index=\{"t": N\} to read one'),
            ({"t": 5}, r'index=\{"t": 5\} is out of range'),
            ({"c": 0}, "index= names c, which is not an axis of this NIfTI file of 5 volumes"),
        ]:
            with pytest.raises(ValueError, match=message):
                isogrid.load_volume(tmp_path / name, index=index)
    grids = []
    for name, extra in (("bold.nii.gz", []), ("bold.nii", ["--max-memory", "64M"])):
        out = tmp_path / f"{name}.cgc"
        run = subprocess.run(
            [cli, "extract", tmp_path / name, "--iso", "0.5", "--index", "t=3", "-o", out, *extra],
            capture_output=True, text=True,
        )
        assert run.returncode == 0, run.stderr
        grids.append(out.read_bytes())
    assert grids[0] == grids[1]
    expected = isogrid.extract(isogrid.load_volume(tmp_path / "bold.nii", index={"t": 3}), iso=0.5)
    assert expected.to_bytes() == grids[0]

    # Volume 3's surface coloured by volume 4: --color-index picks the --color-by file's volume
    # (here the other copy), as index= picks it for Python.
    def colored(*extra):
        out = tmp_path / "colored.cgc"
        out.unlink(missing_ok=True)
        run = subprocess.run(
            [cli, "extract", tmp_path / "bold.nii", "--iso", "0.5", "--index", "t=3",
             "--color-by", tmp_path / "bold.nii.gz", *extra, "-o", out],
            capture_output=True, text=True,
        )
        return run, out

    run, out = colored("--color-index", "t=4")
    assert run.returncode == 0, run.stderr
    grid = isogrid.load(out)
    assert grid.attribute_info["name"] == "bold.nii.gz t=4"
    reference = isogrid.extract(
        isogrid.load_volume(tmp_path / "bold.nii", index={"t": 3}), iso=0.5,
        attribute=isogrid.load_volume(tmp_path / "bold.nii.gz", index={"t": 4}),
    )
    np.testing.assert_array_equal(grid.attribute, reference.attribute)
    other_volume = isogrid.extract(
        isogrid.load_volume(tmp_path / "bold.nii", index={"t": 3}), iso=0.5,
        attribute=isogrid.load_volume(tmp_path / "bold.nii.gz", index={"t": 2}),
    )
    assert not np.array_equal(grid.attribute, other_volume.attribute)
    for extra, message in [
        ((), "bold.nii.gz: this is a 4-D NIfTI file of 5 volumes (t=0..4): pass --color-index t=N"),
        (("--color-index", "t=5"), "bold.nii.gz: --color-index t=5 is out of range"),
        (("--color-index", "c=0"), "bold.nii.gz: --color-index names c, which is not an axis"),
    ]:
        run, out = colored(*extra)
        assert run.returncode == 1 and message in run.stderr and not out.exists(), run.stderr

    # Python reads the paths as the CLI does: index= and attribute_index= give its bytes, and the
    # errors name the keyword arguments.
    run, out = colored("--color-index", "t=4")
    from_paths = isogrid.extract(
        tmp_path / "bold.nii", iso=0.5, index={"t": 3}, attribute=tmp_path / "bold.nii.gz",
        attribute_index={"t": 4},
    )
    assert from_paths.to_bytes() == out.read_bytes()
    vertices, _, values = isogrid.marching_cubes(
        tmp_path / "bold.nii", iso=0.5, index={"t": 3}, attribute=tmp_path / "bold.nii.gz", attribute_index={"t": 4}
    )
    reference_mesh = isogrid.marching_cubes(
        isogrid.load_volume(tmp_path / "bold.nii", index={"t": 3}), iso=0.5,
        attribute=isogrid.load_volume(tmp_path / "bold.nii.gz", index={"t": 4}),
    )
    np.testing.assert_array_equal(vertices, reference_mesh[0])
    np.testing.assert_array_equal(values, reference_mesh[2])
    labels = (data[..., 0] > 0.5).astype(np.uint8) + (data[..., 1] > 0.5)
    stack = np.stack([labels, 2 - labels], axis=-1)
    nib.save(nib.Nifti1Image(np.asfortranarray(stack), affine), tmp_path / "labels4d.nii.gz")
    by_path = isogrid.extract_labels(
        tmp_path / "labels4d.nii.gz", index={"t": 1}, attribute=tmp_path / "bold.nii.gz", attribute_index={"t": 4}
    )
    by_volume = isogrid.extract_labels(
        isogrid.load_volume(tmp_path / "labels4d.nii.gz", index={"t": 1}),
        attribute=isogrid.load_volume(tmp_path / "bold.nii.gz", index={"t": 4}),
    )
    assert by_path.labels == by_volume.labels and len(by_path.labels) == 2
    np.testing.assert_array_equal(by_path.attribute, by_volume.attribute)
    assert by_path.attribute_info["name"] == "bold.nii.gz t=4"
    for call, message in [
        (lambda: isogrid.extract(tmp_path / "bold.nii", iso=0.5), r'pass index=\{"t": N\} to read one'),
        (
            lambda: isogrid.extract(tmp_path / "bold.nii", iso=0.5, index={"t": 3}, attribute=tmp_path / "bold.nii.gz"),
            r'pass attribute_index=\{"t": N\} to read one',
        ),
        (
            lambda: isogrid.extract_labels(tmp_path / "labels4d.nii.gz", index={"t": 1}, attribute=tmp_path / "bold.nii.gz",
                                           attribute_index={"t": 9}),
            r'attribute_index=\{"t": 9\} is out of range',
        ),
        (lambda: isogrid.extract_labels(tmp_path / "labels4d.nii.gz"), r'pass index=\{"t": N\}'),
        (lambda: isogrid.extract(data[..., 0], iso=0.5, index={"t": 0}), "this input is an array or Volume already"),
        (lambda: isogrid.extract(tmp_path / "bold.nii", iso=0.5, index={"t": 0}, attribute_index={"t": 0}), "needs attribute"),
    ]:
        with pytest.raises(ValueError, match=message):
            call()


def test_mni_template_if_fetched():
    path = REPO / "data" / "mni152_t1.nii.gz"
    if not path.exists():
        pytest.skip("data/mni152_t1.nii.gz not fetched (bash scripts/fetch_data.sh)")
    vol = isogrid.load_volume(path)
    assert vol.dims == (197, 233, 189) and vol.array.dtype == np.uint8
    assert vol.spacing == (1.0, 1.0, 1.0)


@pytest.mark.parametrize("pair_class", ["Nifti1Pair", "Nifti2Pair"])
@pytest.mark.parametrize("gz", [False, True], ids=["raw", "gzip"])
def test_nifti_pairs_read_through_either_file(cli, tmp_path, pair_class, gz):
    """A header/image pair (SPM's and older FSL's output) written by nibabel, named by its .hdr or
    its .img: nibabel's samples and affine, one volume of a 4-D pair picked; the uncompressed pair
    streamed by region into the bytes the in-memory read gives."""
    nib = pytest.importorskip("nibabel")
    rng = np.random.default_rng(7)
    data = np.asfortranarray(rng.random((13, 11, 9, 3)).astype(np.float32))
    affine = np.diag([1.5, -2.0, 2.5, 1.0])
    affine[:3, 3] = (40.0, 12.0, -30.0)
    suffix = ".gz" if gz else ""
    header = tmp_path / f"pair.hdr{suffix}"
    nib.save(getattr(nib, pair_class)(data, affine), header)
    image = tmp_path / f"pair.img{suffix}"
    assert image.exists()
    reference = nib.load(header)
    for name in (header, image):
        for t in range(3):
            volume = isogrid.load_volume(name, index={"t": t})
            np.testing.assert_array_equal(volume.array, np.asarray(reference.dataobj)[..., t].transpose())
            got = np.eye(4)
            got[:3, :3] = (np.asarray(volume.direction) * np.asarray(volume.spacing)[:, None]).T
            got[:3, 3] = volume.origin
            np.testing.assert_allclose(got, reference.affine, atol=1e-6)
    files = []
    for extra in ([], ["--max-memory", "64M"]):
        out = tmp_path / f"out{len(files)}.cgc"
        run = subprocess.run([cli, "extract", image, "--iso", "0.5", "--index", "t=1", "-o", out, *extra],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        # The uncompressed pair is read by region; the gzip one whole, with a note.
        assert ("read whole" in run.stderr) == (gz and bool(extra)), run.stderr
        files.append(out.read_bytes())
    assert files[0] == files[1]
    header.rename(tmp_path / "moved")
    with pytest.raises(ValueError, match="the header file .*pair.hdr.* of this NIfTI pair is missing"):
        isogrid.load_volume(image, index={"t": 0})
    (tmp_path / "moved").rename(header)
    image.unlink()
    with pytest.raises(ValueError, match="the image file .*pair.img.* of this NIfTI pair is missing"):
        isogrid.load_volume(header, index={"t": 0})


def test_analyze_headers_are_refused_naming_why(tmp_path):
    """Analyze 7.5 (no NIfTI magic) leaves the orientation undefined: one line says so."""
    nib = pytest.importorskip("nibabel")
    nib.save(nib.AnalyzeImage(np.zeros((4, 5, 6), np.float32), np.eye(4)), tmp_path / "old.hdr")
    with pytest.raises(ValueError, match="Analyze 7.5 header .* is not read"):
        isogrid.load_volume(tmp_path / "old.hdr")

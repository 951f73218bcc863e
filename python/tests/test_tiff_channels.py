"""ImageJ hyperstacks and OME-TIFFs with channels (and time points), written by tifffile: the
channel and time point picked with ``index`` read as tifffile's array of them (#42)."""

import numpy as np
import pytest

import isogrid

tifffile = pytest.importorskip("tifffile")


def zcyx():
    z, y, x = np.indices((12, 20, 24))
    return np.stack([(x + y + z).astype(np.uint16), (1000 + x * y - z).astype(np.uint16)], axis=1)


@pytest.mark.parametrize("form", ["imagej", "ome"])
def test_each_channel_reads_as_tifffile_reads_it(tmp_path, form):
    path = tmp_path / f"{form}.tif"
    tifffile.imwrite(path, zcyx(), metadata={"axes": "ZCYX"}, **{form: True})
    ref = tifffile.imread(path)
    assert ref.shape == (12, 2, 20, 24)
    for c in range(2):
        v = isogrid.load_volume(path, index={"c": c})
        np.testing.assert_array_equal(v.array, ref[:, c])
    with pytest.raises(ValueError, match=r'2 channels \(c=0\.\.1\).*pass index=\{"c": N\}'):
        isogrid.load_volume(path)
    with pytest.raises(ValueError, match="out of range"):
        isogrid.load_volume(path, index={"c": 2})


def test_ome_tiff_with_time_points_in_another_order(tmp_path):
    # TCZYX written as OME: pages run z fastest, then c, then t.
    t, c, z, y, x = np.indices((3, 2, 5, 6, 7))
    a = (x + 10 * y + 100 * z + 1000 * c + 10000 * t).astype(np.int32)
    path = tmp_path / "tczyx.ome.tif"
    tifffile.imwrite(path, a, ome=True, metadata={"axes": "TCZYX"})
    ref = tifffile.imread(path)
    assert ref.shape == a.shape
    with pytest.raises(ValueError, match=r'pass index=\{"c": N, "t": N\}'):
        isogrid.load_volume(path)
    v = isogrid.load_volume(path, index={"c": 1, "t": 2})
    assert v.array.dtype == np.int32
    np.testing.assert_array_equal(v.array, ref[2, 1])


def test_plain_stack_is_unchanged_and_refuses_an_index(tmp_path):
    a = zcyx()[:, 0]
    path = tmp_path / "plain.tif"
    tifffile.imwrite(path, a)
    np.testing.assert_array_equal(isogrid.load_volume(path).array, tifffile.imread(path))
    with pytest.raises(ValueError, match="plain stack"):
        isogrid.load_volume(path, index={"c": 0})

"""Zarr and OME-Zarr read by load_volume and extract, checked against zarr-python: zarr-python
writes each array here (v2 with blosc, v3 with zstd, v3 sharded with gzip; chunks that do not
divide 16, a shape the chunks do not divide) and its own view of it is the reference, sample for
sample. The OME-Zarr fixture of the Rust tests checks levels, indices and transforms."""

from pathlib import Path

import numpy as np
import pytest

import isogrid
from conftest import same_grid

zarr = pytest.importorskip("zarr")
from zarr.codecs import BloscCodec, GzipCodec, ZstdCodec  # noqa: E402

FIXTURES = Path(__file__).resolve().parents[2] / "crates" / "isogrid-io" / "tests" / "fixtures" / "zarr"


def volume():
    z, y, x = np.indices((37, 23, 29))
    return ((x - 14) ** 2 + (y - 11) ** 2 + (z - 18) ** 2).astype(np.uint16)


ARRAYS = {
    "v2_blosc": dict(zarr_format=2, chunks=(9, 10, 11), compressors=None),
    "v3_zstd": dict(chunks=(9, 10, 11), compressors=ZstdCodec(level=3)),
    "v3_sharded_gzip": dict(chunks=(5, 6, 7), shards=(10, 12, 14), compressors=GzipCodec()),
    "v3_blosc_f32": dict(chunks=(9, 10, 11), compressors=BloscCodec(cname="lz4")),
}


@pytest.mark.parametrize("name", sorted(ARRAYS))
def test_load_volume_matches_zarr_python(tmp_path, name):
    kwargs = dict(ARRAYS[name])
    data = volume()
    if name.endswith("f32"):
        data = data.astype(np.float32) * 0.25 - 3.0
    if name == "v2_blosc":
        import numcodecs

        kwargs["compressors"] = numcodecs.Blosc(cname="zstd", shuffle=numcodecs.Blosc.SHUFFLE)
    path = tmp_path / f"{name}.zarr"
    a = zarr.create_array(store=str(path), shape=data.shape, dtype=data.dtype, **kwargs)
    a[...] = data
    v = isogrid.load_volume(path)
    reference = zarr.open_array(str(path), mode="r")[...]
    assert v.array.dtype == reference.dtype
    np.testing.assert_array_equal(v.array, reference)
    # A path extracts as the array zarr-python reads.
    assert same_grid(isogrid.extract(path, iso_normalized=0.4), isogrid.extract(reference, iso_normalized=0.4))


# The narrow types and the one they are kept as: bool as 0 and 1 in uint8, int8 widened to int16.
NARROW = [(np.bool_, np.uint8), (np.int8, np.int16), (np.uint8, np.uint8), (np.int16, np.int16), (np.float32, np.float32)]


@pytest.mark.parametrize("zarr_format", [2, 3])
@pytest.mark.parametrize("dtype, kept", NARROW, ids=[np.dtype(d).name for d, _ in NARROW])
def test_narrow_types_read_as_zarr_python_wrote_them(tmp_path, zarr_format, dtype, kept):
    v = volume().astype(np.int64)
    data = {
        np.bool_: v < 150,
        np.int8: np.clip(v - 300, -128, 127),
        np.uint8: np.clip(v, 0, 255),
        np.int16: v - 1000,
        np.float32: v * 0.5 - 7.0,
    }[dtype].astype(dtype)
    path = tmp_path / "a.zarr"
    a = zarr.create_array(store=str(path), shape=data.shape, dtype=data.dtype, chunks=(9, 10, 11), zarr_format=zarr_format)
    a[...] = data
    reference = zarr.open_array(str(path), mode="r")[...]
    assert reference.dtype == np.dtype(dtype)
    got = isogrid.load_volume(path)
    assert got.array.dtype == np.dtype(kept)
    np.testing.assert_array_equal(got.array, reference.astype(kept))
    iso = 0.5 if dtype is np.bool_ else float(np.median(reference)) + 0.25
    assert same_grid(isogrid.extract(path, iso=iso), isogrid.extract(reference.astype(kept), iso=iso))


def test_ome_zarr_levels_and_indices_match_zarr_python():
    path = FIXTURES / "ome_v04.zarr"
    group = zarr.open_group(str(path), mode="r")
    for level in (0, 1):
        v = isogrid.load_volume(path, level=level, index={"t": 1, "c": 0})
        np.testing.assert_array_equal(v.array, group[str(level)][1, 0])
    v = isogrid.load_volume(path, index={"t": 1, "c": 0})
    assert v.spacing == pytest.approx((0.25, 0.5, 2.0))
    assert v.origin == pytest.approx((3.0, -5.0, 10.0))
    with pytest.raises(ValueError, match=r'with index=, e\.g\. index=\{"t": 0, "c": 0\}'):
        isogrid.load_volume(path)


TLS = FIXTURES.parent / "tls"


@pytest.fixture
def https_server(tmp_path):
    """A static https server on 127.0.0.1 over tmp_path, with the certificate the test CA of
    crates/isogrid-io/tests/fixtures/tls issued for 127.0.0.1 (scripts/make_tls_fixtures.sh)."""
    import functools
    import http.server
    import ssl
    import threading

    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(tmp_path))
    handler.log_message = lambda *args: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.load_cert_chain(TLS / "server.pem", TLS / "server.key")
    server.socket = context.wrap_socket(server.socket, server_side=True)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"https://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def test_zarr_over_https_trusts_the_roots_ssl_cert_file_names(tmp_path, https_server, monkeypatch):
    data = volume()
    a = zarr.create_array(store=str(tmp_path / "v.zarr"), shape=data.shape, dtype=data.dtype, chunks=(9, 10, 11))
    a[...] = data
    url = f"{https_server}/v.zarr"
    # Mozilla's roots do not include the test CA: refused, in one line naming the URL.
    monkeypatch.delenv("SSL_CERT_FILE", raising=False)
    with pytest.raises(Exception) as refused:
        isogrid.load_volume(url)
    message = str(refused.value)
    assert url in message and "certificate" in message.lower() and "\n" not in message
    # With the test CA trusted, the samples are zarr-python's.
    monkeypatch.setenv("SSL_CERT_FILE", str(TLS / "ca.pem"))
    np.testing.assert_array_equal(isogrid.load_volume(url).array, zarr.open_array(str(tmp_path / "v.zarr"), mode="r")[...])

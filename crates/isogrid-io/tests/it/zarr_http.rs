//! Zarr and OME-Zarr over HTTP, served from the fixture folder by a small static file server on
//! 127.0.0.1 that logs what is asked of it: the same volumes as from the folder, byte ranges
//! honoured or ignored by the server, only the chunks a slab needs fetched, errors that name the
//! URL, and `https://` checked against the trusted certificates (the test CA of
//! `fixtures/tls`, written by `scripts/make_tls_fixtures.sh`).

use crate::region::streams_like_memory;
use crate::zarr::options;
use isogrid::extract::stream::SlabMut;
use isogrid::{ExtractOptions, Iso};
use isogrid_io::{open_region, read_volume, ReadOptions};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// A static file server over a folder, answering GET and HEAD, with `Range` requests honoured
/// (206) or, like the simplest servers, ignored (200 and the whole file).
struct Server {
    url: String,
    /// "METHOD /path" of every request, in arrival order.
    log: Arc<Mutex<Vec<String>>>,
}

impl Server {
    fn start(root: PathBuf, honour_ranges: bool) -> Server {
        Server::start_with(root, honour_ranges, None)
    }

    /// A server speaking TLS with the certificate of `fixtures/tls/server.pem` (for 127.0.0.1,
    /// issued by the test CA `fixtures/tls/ca.pem`).
    fn start_tls(root: PathBuf) -> Server {
        Server::start_with(root, true, Some(tls_config()))
    }

    fn start_with(
        root: PathBuf,
        honour_ranges: bool,
        tls: Option<Arc<rustls::ServerConfig>>,
    ) -> Server {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let scheme = if tls.is_some() { "https" } else { "http" };
        let url = format!("{scheme}://{}", listener.local_addr().unwrap());
        let log = Arc::new(Mutex::new(Vec::new()));
        let requests = log.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                let (root, requests, tls) = (root.clone(), requests.clone(), tls.clone());
                std::thread::spawn(move || match tls {
                    None => answer(stream, &root, honour_ranges, &requests),
                    Some(config) => {
                        let Ok(connection) = rustls::ServerConnection::new(config) else {
                            return;
                        };
                        let mut tls = rustls::StreamOwned::new(connection, stream);
                        answer(&mut tls, &root, honour_ranges, &requests);
                        tls.conn.send_close_notify();
                        let _ = tls.flush();
                    }
                });
            }
        });
        Server { url, log }
    }

    fn url_of(&self, name: &str) -> PathBuf {
        PathBuf::from(format!("{}/{name}", self.url))
    }

    fn requests(&self) -> Vec<String> {
        self.log.lock().unwrap().clone()
    }
}

fn answer(stream: impl Read + Write, root: &Path, honour_ranges: bool, log: &Mutex<Vec<String>>) {
    // A GET has no body, so nothing the reader buffers beyond the headers is lost.
    let mut reader = BufReader::new(stream);
    let mut request = String::new();
    if reader.read_line(&mut request).is_err() {
        return;
    }
    let mut words = request.split_whitespace();
    let method = words.next().unwrap_or_default().to_string();
    let target = words.next().unwrap_or("/").to_string();
    let mut range = None;
    loop {
        let mut header = String::new();
        if reader.read_line(&mut header).unwrap_or(0) == 0 || header.trim().is_empty() {
            break;
        }
        if let Some((name, value)) = header.split_once(':') {
            if name.eq_ignore_ascii_case("range") {
                range = Some(value.trim().to_string());
            }
        }
    }
    log.lock().unwrap().push(format!("{method} {target}"));
    let stream = reader.get_mut();
    let path = root.join(target.trim_start_matches('/'));
    let body = match std::fs::read(&path) {
        Ok(body) if path.is_file() => body,
        _ => {
            let _ = stream.write_all(
                b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
            );
            return;
        }
    };
    let asked = range
        .filter(|_| honour_ranges)
        .and_then(|r| byte_range(&r, body.len()));
    let (status, part) = match asked {
        Some((start, end)) => ("206 Partial Content", &body[start..end]),
        None => ("200 OK", &body[..]),
    };
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        part.len()
    );
    let _ = stream.write_all(head.as_bytes());
    if method != "HEAD" {
        let _ = stream.write_all(part);
    }
}

/// `bytes=a-b`, `bytes=a-` or `bytes=-n` as a half-open range of a `size`-byte file.
fn byte_range(header: &str, size: usize) -> Option<(usize, usize)> {
    let (start, end) = header.strip_prefix("bytes=")?.split_once('-')?;
    if start.is_empty() {
        return Some((size.saturating_sub(end.parse().ok()?), size));
    }
    let start: usize = start.parse().ok()?;
    let end = match end {
        "" => size,
        end => end.parse::<usize>().ok()? + 1,
    };
    (start <= end && end <= size).then_some((start, end))
}

fn fixtures() -> PathBuf {
    crate::common::fixture("zarr")
}

#[test]
fn zarr_over_http_reads_as_from_the_folder() {
    for honour_ranges in [true, false] {
        let server = Server::start(fixtures(), honour_ranges);
        let cases = [
            ("v2_blosc.zarr", ReadOptions::default()),
            ("v3_zstd.zarr", ReadOptions::default()),
            ("v3_sharded_gzip.zarr", ReadOptions::default()),
            ("v3_missing_chunk.zarr", ReadOptions::default()),
            ("ome_v04.zarr", options(1, &[("t", 1), ("c", 1)])),
            ("ome_v05.zarr", options(1, &[])),
        ];
        for (name, opts) in cases {
            let local = read_volume(&fixtures().join(name), &opts).unwrap();
            let remote = read_volume(&server.url_of(name), &opts).unwrap();
            assert_eq!(remote.dims(), local.dims(), "{name}");
            assert_eq!(remote.spacing(), local.spacing(), "{name}");
            assert_eq!(remote.origin(), local.origin(), "{name}");
            assert!(remote.data() == local.data(), "{name}: samples differ");
        }
        // The sharded array's inner chunks come as ranges of its shard files.
        let ranged = server
            .requests()
            .iter()
            .filter(|r| r.starts_with("GET /v3_sharded_gzip.zarr/c/"))
            .count();
        assert!(ranged > 0);
    }
}

#[test]
fn a_slab_over_http_fetches_only_its_chunks() {
    let server = Server::start(fixtures(), true);
    let mut source = open_region(&server.url_of("v3_zstd.zarr"), &ReadOptions::default())
        .unwrap()
        .unwrap();
    // Chunks are 9 planes deep: planes 0..5 lie in the first layer of 2 × 2 chunks (y, x).
    let mut planes = vec![0u16; 20 * 13 * 5];
    source.read_planes(0..5, SlabMut::U16(&mut planes)).unwrap();
    let mut chunks: Vec<String> = server
        .requests()
        .into_iter()
        .filter(|r| r.contains("/c/"))
        .collect();
    chunks.sort();
    assert_eq!(
        chunks,
        [
            "GET /v3_zstd.zarr/c/0/0/0",
            "GET /v3_zstd.zarr/c/0/0/1",
            "GET /v3_zstd.zarr/c/0/1/0",
            "GET /v3_zstd.zarr/c/0/1/1"
        ]
    );

    // Only block (1, 0) wanted: it reads x 16..=19, all in the chunks of x index 1 (x 11..22).
    let mut wanted = isogrid::extract::stream::BlockMask::new([2, 1]);
    wanted.want(1, 0);
    let before = server.requests().len();
    let mut source = open_region(&server.url_of("v3_zstd.zarr"), &ReadOptions::default())
        .unwrap()
        .unwrap();
    let mut within = vec![0u16; 20 * 13 * 5];
    source
        .read_planes_within(0..5, SlabMut::U16(&mut within), &wanted)
        .unwrap();
    let mut chunks: Vec<String> = server.requests()[before..]
        .iter()
        .filter(|r| r.contains("/c/"))
        .cloned()
        .collect();
    chunks.sort();
    assert_eq!(
        chunks,
        ["GET /v3_zstd.zarr/c/0/0/1", "GET /v3_zstd.zarr/c/0/1/1"]
    );
    for (i, (&got, &all)) in within.iter().zip(&planes).enumerate() {
        if i % 20 >= 16 {
            assert_eq!(got, all, "sample {i}");
        }
    }
}

#[test]
fn zarr_over_http_streams_byte_identically() {
    let server = Server::start(fixtures(), true);
    streams_like_memory(
        &server.url_of("v3_sharded_gzip.zarr"),
        &ReadOptions::default(),
        &[ExtractOptions::new(Iso::Normalized(0.5))],
    );
}

#[test]
fn http_errors_name_the_url() {
    let server = Server::start(fixtures(), true);
    let missing = server.url_of("nothing.zarr");
    let err = read_volume(&missing, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains(&*missing.to_string_lossy()), "{err}");
    assert!(err.contains("not a Zarr store"), "{err}");
    assert!(!err.contains('\n'), "{err}");

    // Nothing listens on the port of a server that was bound and dropped.
    let closed = TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}/x.zarr", closed.local_addr().unwrap());
    drop(closed);
    let err = read_volume(Path::new(&url), &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains(&url), "{err}");
    assert!(!err.contains('\n'), "{err}");
}

fn tls_fixture(name: &str) -> PathBuf {
    crate::common::fixture("tls").join(name)
}

fn tls_config() -> Arc<rustls::ServerConfig> {
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::{CertificateDer, PrivateKeyDer};
    let certs = CertificateDer::pem_file_iter(tls_fixture("server.pem"))
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap();
    let key = PrivateKeyDer::from_pem_file(tls_fixture("server.key")).unwrap();
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ServerConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .unwrap()
        .with_no_client_auth()
        .with_single_cert(certs, key)
        .unwrap();
    Arc::new(config)
}

fn trusting(certificates: Option<PathBuf>) -> ReadOptions {
    let mut opts = ReadOptions::default();
    opts.zarr.trusted_certificates = certificates;
    opts
}

#[test]
fn zarr_over_https_reads_as_from_the_folder_when_the_server_is_trusted() {
    let server = Server::start_tls(fixtures());
    let trusted = trusting(Some(tls_fixture("ca.pem")));
    for name in ["v3_sharded_gzip.zarr", "ome_v05.zarr"] {
        let local = read_volume(&fixtures().join(name), &ReadOptions::default()).unwrap();
        let remote = read_volume(&server.url_of(name), &trusted).unwrap();
        assert_eq!(remote.dims(), local.dims(), "{name}");
        assert_eq!(remote.origin(), local.origin(), "{name}");
        assert!(remote.data() == local.data(), "{name}: samples differ");
    }
    assert!(server
        .requests()
        .iter()
        .any(|r| r.starts_with("GET /ome_v05.zarr/")));
}

#[test]
fn https_refuses_an_untrusted_server_and_a_bad_certificate_file_in_one_line() {
    let server = Server::start_tls(fixtures());
    let url = server.url_of("v3_zstd.zarr");
    let error_with = |opts: &ReadOptions| {
        let err = read_volume(&url, opts).unwrap_err().to_string();
        assert!(!err.contains('\n'), "{err}");
        err
    };
    // Mozilla's roots do not include the test CA; nor does the server's own certificate vouch
    // for itself (it is not a CA).
    for opts in [trusting(None), trusting(Some(tls_fixture("server.pem")))] {
        let err = error_with(&opts);
        assert!(err.contains(&*url.to_string_lossy()), "{err}");
        assert!(err.to_lowercase().contains("certificate"), "{err}");
    }
    assert!(server.requests().is_empty(), "{:?}", server.requests());

    let missing = tls_fixture("no-such.pem");
    let err = error_with(&trusting(Some(missing.clone())));
    assert!(err.contains(&*missing.to_string_lossy()), "{err}");
    assert!(err.contains("SSL_CERT_FILE"), "{err}");
    let key_only = tls_fixture("server.key");
    let err = error_with(&trusting(Some(key_only)));
    assert!(err.contains("holds no certificate"), "{err}");

    // Plain http:// does not read the certificates, so a bad file does not stop it.
    let plain = Server::start(fixtures(), true);
    read_volume(&plain.url_of("v3_zstd.zarr"), &trusting(Some(missing))).unwrap();
}

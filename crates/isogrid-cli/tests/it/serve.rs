//! `isogrid serve` end to end: the viewer's files, the .cgc with Range requests (206, 416 for
//! malformed ranges), its packed form (what `isogrid pack` writes, never compressed again), and
//! 404 for everything else (no listing, no paths outside).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use crate::common::{isogrid_ok as isogrid, temp_dir, TempDir};

/// A small sphere .cgc in a fresh directory.
fn sphere(dir: &Path) -> PathBuf {
    let volume = dir.join("sphere.nrrd");
    let cgc = dir.join("sphere.cgc");
    isogrid(&[
        "generate",
        "sphere",
        "--size",
        "24",
        "-o",
        volume.to_str().unwrap(),
    ]);
    isogrid(&[
        "extract",
        volume.to_str().unwrap(),
        "--iso-normalized",
        "0.5",
        "-o",
        cgc.to_str().unwrap(),
    ]);
    cgc
}

struct Server {
    child: Child,
    /// The file served, as the "serving" line names it.
    file: PathBuf,
    /// Held open so that the server's later output does not meet a closed pipe.
    _stdout: BufReader<std::process::ChildStdout>,
    addr: String,
    url: String,
}

impl Drop for Server {
    /// Stops the server as a user would, with SIGTERM, so that it removes its scratch folder (the
    /// `.cgc` of a volume it extracted); SIGKILL only if it has not ended within 10 s.
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while std::time::Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A sphere .cgc in a fresh directory named after `test`, its bytes, and a server for it.
fn sphere_server(test: &str) -> (TempDir, Vec<u8>, Server) {
    let dir = temp_dir(&format!("serve-{test}"));
    let file = sphere(&dir);
    let bytes = std::fs::read(&file).unwrap();
    let server = serve(&file);
    (dir, bytes, server)
}

fn serve(file: &Path) -> Server {
    serve_args(&[file.to_str().unwrap()])
}

fn serve_args(input: &[&str]) -> Server {
    let mut child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .arg("serve")
        .args(input)
        .args(["--port", "0"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("starts the server");
    // Extraction prints its statistics first; the URL is on the "serving" line.
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let (file, url) = loop {
        let mut line = String::new();
        assert!(
            stdout.read_line(&mut line).unwrap() > 0,
            "the server printed no URL"
        );
        if let Some(url) = line.split_whitespace().find(|w| w.starts_with("http://")) {
            let file = line.split_whitespace().nth(1).unwrap();
            break (PathBuf::from(file), url.to_string());
        }
    };
    let addr = url["http://".len()..]
        .split('/')
        .next()
        .unwrap()
        .to_string();
    Server {
        child,
        file,
        _stdout: stdout,
        addr,
        url,
    }
}

/// The body of a `Transfer-Encoding: chunked` response (hex size line, data, CRLF; 0 ends it).
fn dechunk(mut raw: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line = raw.windows(2).position(|w| w == b"\r\n").unwrap();
        let size_text = String::from_utf8_lossy(&raw[..line]);
        let size = usize::from_str_radix(size_text.split(';').next().unwrap().trim(), 16).unwrap();
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&raw[line + 2..line + 2 + size]);
        raw = &raw[line + 2 + size + 2..];
    }
}

/// The body of a response with the `content-encoding` in `head` (lower case) decoded by an
/// independent decoder (flate2, brotli-decompressor, zstd), or as it came without one.
fn decode(head: &str, body: &[u8]) -> Vec<u8> {
    let encoding = head
        .lines()
        .find_map(|l| l.strip_prefix("content-encoding:"))
        .map(str::trim);
    let mut out = Vec::new();
    match encoding {
        None => out = body.to_vec(),
        Some("gzip") => {
            flate2::read::GzDecoder::new(body)
                .read_to_end(&mut out)
                .unwrap();
        }
        Some("br") => {
            brotli_decompressor::Decompressor::new(body, 4096)
                .read_to_end(&mut out)
                .unwrap();
        }
        Some("zstd") => out = zstd::decode_all(body).unwrap(),
        Some(other) => panic!("unexpected content-encoding {other}"),
    }
    out
}

/// One HTTP/1.1 GET: (status, headers in lower case, body as sent, chunked framing removed).
fn get(addr: &str, path: &str, extra: &str) -> (u16, String, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n{extra}\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&raw[..split]).to_lowercase();
    let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    let body = &raw[split + 4..];
    let body = if head.contains("transfer-encoding: chunked") {
        dechunk(body)
    } else {
        body.to_vec()
    };
    (status, head, body)
}

#[test]
fn serves_the_viewer_and_the_file_with_ranges_and_nothing_else() {
    let (dir, bytes, server) = sphere_server("test");
    // The printed URL opens the packed form.
    assert!(server.url.ends_with("/?src=/sphere.cgcz"), "{}", server.url);
    assert!(
        server.addr.starts_with("127.0.0.1:"),
        "default bind is local: {}",
        server.addr
    );
    let a = server.addr.as_str();

    let (status, head, body) = get(a, "/", "");
    assert_eq!(status, 200);
    assert!(head.contains("text/html") && String::from_utf8_lossy(&body).contains("viewer.js"));
    let (status, head, _) = get(a, "/viewer.js", "");
    assert_eq!(status, 200);
    assert!(head.contains("javascript"));

    // The whole file, and ranges of it that add up to it.
    let (status, _, body) = get(a, "/sphere.cgc", "");
    assert_eq!((status, body.as_slice()), (200, bytes.as_slice()));
    let (status, head, body) = get(a, "/sphere.cgc", "Range: bytes=0-319\r\n");
    assert_eq!(status, 206);
    assert!(
        head.contains(&format!("content-range: bytes 0-319/{}", bytes.len())),
        "{head}"
    );
    let (_, _, rest) = get(a, "/sphere.cgc", "Range: bytes=320-\r\n");
    assert_eq!([body, rest].concat(), bytes);

    // The packed form: what `isogrid pack` writes.
    let packed = dir.join("sphere.cgcz");
    isogrid(&[
        "pack",
        dir.join("sphere.cgc").to_str().unwrap(),
        "-o",
        packed.to_str().unwrap(),
    ]);
    let (status, head, body) = get(a, "/sphere.cgcz", "Accept-Encoding: gzip, br\r\n");
    assert_eq!(status, 200);
    assert!(
        head.contains("content-type: application/x-isogrid-cgcz"),
        "{head}"
    );
    assert!(!head.contains("content-encoding"), "deflated twice: {head}");
    assert!(body == std::fs::read(&packed).unwrap());

    // Malformed and unsatisfiable ranges.
    for range in [
        "bytes=abc",
        "bytes=5-2",
        "items=0-1",
        &format!("bytes={}-", bytes.len() + 10),
    ] {
        let (status, _, _) = get(a, "/sphere.cgc", &format!("Range: {range}\r\n"));
        assert_eq!(status, 416, "Range: {range}");
    }

    // Nothing but the three paths: no listing, no other files, no way out.
    for path in [
        "/sphere.nrrd",
        "/index.html/..",
        "/../sphere.nrrd",
        "/%2e%2e/%2e%2e/etc/passwd",
        "/..%2fsphere.nrrd",
        "/dist/",
        "//etc/passwd",
    ] {
        let (status, _, body) = get(a, path, "");
        assert_eq!(status, 404, "{path}: {}", String::from_utf8_lossy(&body));
    }
    drop(server);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn compresses_whole_responses_and_never_ranges() {
    let (dir, bytes, server) = sphere_server("gzip");
    let a = server.addr.as_str();
    let web = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../web");
    let page = std::fs::read(web.join("src/index.html")).unwrap();
    let bundle = std::fs::read(web.join("dist/viewer.js")).unwrap();

    for encoding in ["gzip", "br", "zstd"] {
        let accept = format!("Accept-Encoding: {encoding}\r\n");
        for (path, expected) in [
            ("/", &page),
            ("/viewer.js", &bundle),
            ("/sphere.cgc", &bytes),
        ] {
            let (status, head, body) = get(a, path, &accept);
            assert_eq!(status, 200, "{path}");
            assert!(
                head.contains(&format!("content-encoding: {encoding}")),
                "{path} {encoding}: {head}"
            );
            assert!(
                body.len() < expected.len(),
                "{path} {encoding} did not shrink"
            );
            assert!(&decode(&head, &body) == expected, "{path} {encoding}");
            // An encoded whole file offers no ranges: they would count the encoded bytes.
            assert!(!head.contains("accept-ranges"), "{path}: {head}");
        }
        // Ranges come as the file's bytes, never encoded, and add up to the file.
        let mut joined = Vec::new();
        for range in ["0-319", "320-999", "1000-"] {
            let (status, head, body) = get(
                a,
                "/sphere.cgc",
                &format!("{accept}Range: bytes={range}\r\n"),
            );
            assert_eq!(status, 206, "{range}");
            assert!(!head.contains("content-encoding"), "{range}: {head}");
            joined.extend(body);
        }
        assert!(joined == bytes, "ranges under Accept-Encoding: {encoding}");
    }
    // Without Accept-Encoding the file comes as it is.
    let (status, head, body) = get(a, "/sphere.cgc", "");
    assert_eq!(status, 200);
    assert!(!head.contains("content-encoding") && body == bytes);
    drop(server);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn extracts_a_volume_input_first() {
    let dir = temp_dir("serve-volume");
    let cgc = sphere(&dir);
    let volume = dir.join("sphere.nrrd");
    let server = serve_args(&[volume.to_str().unwrap(), "--iso-normalized", "0.5"]);
    assert!(server.url.ends_with("/?src=/sphere.cgcz"), "{}", server.url);
    let (status, _, body) = get(&server.addr, "/sphere.cgc", "");
    assert_eq!(status, 200);
    // The same extraction as `isogrid extract` of the same volume and isovalue.
    assert_eq!(body, std::fs::read(&cgc).unwrap());
    // Ctrl-C and SIGTERM end the server, and the extracted file goes with it.
    let mut first = Some(server);
    for signal in ["-INT", "-TERM"] {
        let mut server = first
            .take()
            .unwrap_or_else(|| serve_args(&[volume.to_str().unwrap(), "--iso-normalized", "0.5"]));
        let scratch = server.file.parent().unwrap().to_path_buf();
        assert!(
            scratch.starts_with(std::env::temp_dir()) && server.file.ends_with("sphere.cgc"),
            "{}",
            server.file.display()
        );
        assert!(server.file.is_file(), "{}", server.file.display());
        let sent = Command::new("kill")
            .args([signal, &server.child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        server.child.wait().unwrap();
        assert!(
            !scratch.exists(),
            "{signal}: {} is left behind",
            scratch.display()
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A label volume with `--labels all`: the page gets the file `extract --labels all` writes.
#[test]
fn serves_a_label_volume_as_extract_labels_writes_it() {
    let dir = temp_dir("serve-labels");
    let volume = dir.join("cubes.nrrd");
    isogrid_io::write_nrrd(&volume, &isogrid::generate::labelled_cubes(12)).unwrap();
    let cgc = dir.join("cubes.cgc");
    isogrid(&[
        "extract",
        volume.to_str().unwrap(),
        "--labels",
        "all",
        "-o",
        cgc.to_str().unwrap(),
    ]);
    let server = serve_args(&[volume.to_str().unwrap(), "--labels", "all"]);
    assert!(server.url.ends_with("/?src=/cubes.cgcz"), "{}", server.url);
    let (status, _, body) = get(&server.addr, "/cubes.cgc", "");
    assert_eq!(status, 200);
    assert_eq!(body, std::fs::read(&cgc).unwrap());
    // Its packed form is that of the file `extract --labels all` writes.
    let packed = dir.join("cubes.cgcz");
    isogrid(&[
        "pack",
        cgc.to_str().unwrap(),
        "-o",
        packed.to_str().unwrap(),
    ]);
    let (status, _, body) = get(&server.addr, "/cubes.cgcz", "");
    assert!(status == 200 && body == std::fs::read(&packed).unwrap());
    drop(server);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn no_pack_serves_the_file_alone() {
    let dir = temp_dir("serve-no-pack");
    let file = sphere(&dir);
    let server = serve_args(&[file.to_str().unwrap(), "--no-pack"]);
    assert!(server.url.ends_with("/?src=/sphere.cgc"), "{}", server.url);
    assert_eq!(get(&server.addr, "/sphere.cgc", "").0, 200);
    assert_eq!(get(&server.addr, "/sphere.cgcz", "").0, 404);
    drop(server);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn refuses_a_damaged_file_with_one_line() {
    let dir = temp_dir("serve-bad");
    let file = dir.join("bad.cgc");
    std::fs::write(&file, b"not a cgc file at all").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(["serve", file.to_str().unwrap(), "--port", "0"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("bad.cgc") && stderr.lines().count() == 1,
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

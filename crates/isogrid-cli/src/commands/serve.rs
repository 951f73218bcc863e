//! `isogrid serve`: an HTTP server for the web viewer (web/, its built bundle embedded in the
//! binary) and one `.cgc` file (a volume input is extracted into a temporary one first). The
//! viewer reads the `.cgc` with Range requests, or downloads its packed form (`.cgcz`,
//! `isogrid::cgc::pack`, written into a temporary folder at start), about a sixth of its bytes,
//! and rebuilds it; the printed URL opens the packed form. It serves exactly
//! `/` (the page), `/viewer.js`, `/NAME` (the file, by its own name) and `/NAMEz` (its packed
//! form), and answers everything else with 404: no directory listing, nothing outside them.
//! Ranges, 206 and 416 come from tower-http's `ServeFile`; gzip, brotli or zstd (as the client
//! accepts) from its `CompressionLayer`, which encodes whole responses only (a 206's
//! Content-Range counts the file's bytes, so range requests get them as they are) and leaves the
//! packed form, compressed already, as it is (docs/benchmarks-web.md has the ratios).

use crate::grid_source::{is_cgc, GridSource};
use anyhow::{Context, Result};
use axum::http::{header, StatusCode};
use axum::routing::get;
use axum::Router;
use isogrid::fs::ScratchDir;
use isogrid::CellGrid;
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use tower_http::compression::predicate::{DefaultPredicate, NotForContentType, Predicate};
use tower_http::compression::CompressionLayer;
use tower_http::services::ServeFile;

/// The viewer: its page, and its bundle as `npm run build` writes it (web/dist/viewer.js, committed
/// so that a fresh clone builds without node; a web test fails when it is stale).
const INDEX_HTML: &str = include_str!("../../../../web/src/index.html");
const VIEWER_JS: &str = include_str!("../../../../web/dist/viewer.js");

#[derive(clap::Args)]
pub struct Args {
    /// The .cgc file to serve, or a volume to extract first (with --iso or --iso-normalized).
    #[command(flatten)]
    pub source: GridSource,
    /// TCP port; 0 picks a free one.
    #[arg(long, default_value_t = 8000)]
    pub port: u16,
    /// Address to listen on: 127.0.0.1 keeps it on this machine; 0.0.0.0 shares it on the network.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Open the printed URL in the default browser.
    #[arg(long)]
    pub open: bool,
    /// Serve the .cgc alone, read by ranges, without its packed form (packing takes about 50 ms
    /// per MB of .cgc at start).
    #[arg(long)]
    pub no_pack: bool,
}

/// The media type of the packed form, which the compression layer leaves alone.
const PACKED_TYPE: &str = "application/x-isogrid-cgcz";

/// `name` with every byte outside the URL-safe set percent-encoded, for the file's URL path.
fn url_name(name: &str) -> String {
    name.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The .cgc to serve: the input itself, or the volume extracted into a temporary folder (named
/// after the volume, so the page shows that name).
fn cgc_file(source: &GridSource) -> Result<(PathBuf, Option<ScratchDir>, CellGrid)> {
    if is_cgc(&source.input) {
        // Refuse a bad file here, with the reader's one-line message, rather than in the page.
        let grid = isogrid::cgc::open(&source.input)?;
        return Ok((source.input.clone(), None, grid));
    }
    let grid = source.load()?;
    // Removed when the server ends, Ctrl-C and SIGTERM included.
    let temp = ScratchDir::create_in(&std::env::temp_dir(), "isogrid-serve")?;
    let stem = source
        .input
        .file_stem()
        .and_then(|s| s.to_str())
        .map(|s| s.trim_end_matches(".nii"))
        .unwrap_or("volume");
    let path = temp.path().join(format!("{stem}.cgc"));
    isogrid::cgc::write(&path, &grid)?;
    Ok((path, Some(temp), grid))
}

/// The packed form of `grid`, the grid of `file`, written into `temp` (created when there is
/// none) as `NAMEz`, or why there is none.
fn packed_file(
    grid: &CellGrid,
    file: &std::path::Path,
    name: &str,
    temp: &mut Option<ScratchDir>,
) -> Result<std::result::Result<(PathBuf, isogrid::cgc::PackedSizes), String>> {
    if temp.is_none() {
        *temp = Some(ScratchDir::create_in(
            &std::env::temp_dir(),
            "isogrid-serve",
        )?);
    }
    let path = temp.as_ref().unwrap().path().join(format!("{name}z"));
    let mut out = std::fs::File::create(&path)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    // A bar on a terminal (packing takes about 50 ms per MB), and Ctrl-C stops it.
    let progress = std::sync::Arc::new(isogrid::Progress::new());
    let packed = crate::progress::watched(&format!("packing {name}"), &progress, || {
        isogrid::cgc::pack_into_with_progress(grid, &mut out, &progress)
    });
    match packed {
        Ok(sizes) => Ok(Ok((path, sizes))),
        Err(e) if e.kind() == isogrid::ErrorKind::Unsupported => {
            drop(out);
            let _ = std::fs::remove_file(&path);
            Ok(Err(e.to_string()))
        }
        Err(e) if e.kind() == isogrid::ErrorKind::Cancelled => {
            Err(anyhow::Error::from(e).context("packing stopped by Ctrl-C, nothing served"))
        }
        Err(e) if e.kind() == isogrid::ErrorKind::Io => {
            Err(e).with_context(|| format!("{}: cannot write", path.display()))
        }
        Err(e) => Err(e).with_context(|| format!("{}: cannot pack", file.display())),
    }
}

pub fn run(args: Args) -> Result<()> {
    let (file, mut temp, grid) = cgc_file(&args.source)?;
    let name = file
        .file_name()
        .and_then(|n| n.to_str())
        .with_context(|| format!("{}: not a file name", file.display()))?
        .to_string();
    let url_path = format!("/{}", url_name(&name));
    let packed = if args.no_pack {
        None
    } else {
        Some(packed_file(&grid, &file, &name, &mut temp)?)
    };
    // The server reads the files; an extracted volume's grid is not held while it serves.
    drop(grid);
    let app = Router::new()
        .route(
            "/",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
                    INDEX_HTML,
                )
            }),
        )
        .route(
            "/viewer.js",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
                    VIEWER_JS,
                )
            }),
        )
        .route_service(&url_path, ServeFile::new(&file));
    let app = match &packed {
        Some(Ok((path, _))) => app.route_service(
            &format!("{url_path}z"),
            ServeFile::new_with_mime(path, &PACKED_TYPE.parse().unwrap()),
        ),
        _ => app,
    };
    let app =
        app.fallback(|| async { (StatusCode::NOT_FOUND, "not found\n") })
            // The bundle shrinks 5× (gzip) to 7× (brotli); a whole-file download of the .cgc about
            // 1.5–1.7× (docs/benchmarks-web.md). tower-http never encodes a response that carries
            // Content-Range.
            .layer(CompressionLayer::new().compress_when(
                DefaultPredicate::new().and(NotForContentType::const_new(PACKED_TYPE)),
            ));
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_io()
        .build()?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(SocketAddr::new(args.bind, args.port))
            .await
            .with_context(|| format!("cannot listen on {}:{}", args.bind, args.port))?;
        let addr = listener.local_addr()?;
        let host = if addr.ip().is_unspecified() {
            "127.0.0.1".to_string()
        } else {
            match addr.ip() {
                IpAddr::V6(ip) => format!("[{ip}]"),
                ip => ip.to_string(),
            }
        };
        let base = format!("http://{host}:{}/?src=", addr.port());
        let url = match &packed {
            Some(Ok(_)) => format!("{base}{url_path}z"),
            _ => format!("{base}{url_path}"),
        };
        // Written as every command writes stdout: a closed pipe ends the server quietly, a full
        // disk in one line (crate::stdout).
        outln!("serving     {} at {url}", file.display());
        match &packed {
            Some(Ok((_, sizes))) => outln!(
                "            packed: {} of {} bytes ({:.2}×), rebuilt in the page; ?src={url_path} reads the .cgc by ranges",
                sizes.packed,
                sizes.cgc,
                sizes.cgc as f64 / sizes.packed as f64
            ),
            Some(Err(why)) => outln!("            not packed: {why}"),
            None => {}
        }
        outln!(
            "            add &view=1|2 and &size=WxH for the camera of `isogrid render`, &clip=x|y|z[:F] for a clip plane; Ctrl-C stops"
        );
        if args.open {
            open_browser(&url);
        }
        axum::serve(listener, app)
            .with_graceful_shutdown(async {
                let _ = tokio::signal::ctrl_c().await;
            })
            .await
            .context("HTTP server")
    })
}

/// Opens `url` with the platform's opener; a failure is reported, not fatal (the URL is printed).
fn open_browser(url: &str) {
    let (program, args): (&str, Vec<&str>) = if cfg!(target_os = "macos") {
        ("open", vec![url])
    } else if cfg!(windows) {
        ("cmd", vec!["/C", "start", "", url])
    } else {
        ("xdg-open", vec![url])
    };
    if let Err(e) = std::process::Command::new(program).args(&args).spawn() {
        eprintln!("isogrid: could not open a browser ({program}: {e}); open the URL above");
    }
}

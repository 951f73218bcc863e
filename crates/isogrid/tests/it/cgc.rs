//! `.cgc` files: round trips, golden bytes, and rejection of damaged files.

use crate::common::{blobs_u8, Rng};
use isogrid::{
    cgc, extract, CellGrid, ErrorKind, ExtractOptions, Iso, Precision, Volume, VolumeData,
};
use std::path::PathBuf;

fn tiny_grid() -> CellGrid {
    let mut data = vec![0u8; 18];
    data[1 + 3] = 200; // sample (1,1,0)
    data[2 + 3 * 2 + 9] = 90; // sample (2,2,1)
    let volume = Volume::new([3, 3, 2], VolumeData::U8(data))
        .unwrap()
        .with_spacing([0.5, 1.0, 2.0])
        .unwrap();
    extract(&volume.view(), &ExtractOptions::new(Iso::Value(100.0))).unwrap()
}

fn same(a: &CellGrid, b: &CellGrid) {
    assert_eq!(a.info(), b.info());
    assert_eq!(a.blocks(), b.blocks());
    assert_eq!(a.metacells(), b.metacells());
    assert_eq!(a.cells(), b.cells());
}

fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isogrid-it-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn golden_bytes_of_a_tiny_file() {
    let bytes = cgc::to_bytes(&tiny_grid());
    // Fields checked by hand against the format table, independent of the writer.
    assert_eq!(
        bytes.len(),
        560,
        "320 header + 16 block + 16×12 slots + 4×8 cells"
    );
    assert_eq!(&bytes[..8], b"\x89CGC\r\n\x1a\n");
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
    let f64_at = |o: usize| f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
    assert_eq!((u32_at(8), u32_at(12)), (1, 320));
    assert_eq!(
        [u32_at(16), u32_at(20), u32_at(24), u32_at(28)],
        [3, 3, 2, 0]
    );
    assert_eq!([f64_at(32), f64_at(40), f64_at(48)], [0.5, 1.0, 2.0]);
    assert_eq!([f64_at(80), f64_at(88), f64_at(96)], [0.0, 200.0, 100.0]);
    assert_eq!(u32_at(104), 8);
    assert_eq!(
        [u64_at(128), u64_at(136), u64_at(144), u64_at(152)],
        [1, 16, 4, 1]
    );
    assert_eq!(
        [
            u64_at(160),
            u64_at(168),
            u64_at(176),
            u64_at(184),
            u64_at(192),
            u64_at(200)
        ],
        [320, 16, 336, 192, 528, 32]
    );
    // Block: 16 slots from slot 0, min 0, max 200.
    assert_eq!(
        &bytes[320..336],
        &[16, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x48, 0x43]
    );
    // Metacell (0,0,0) with cells 0..3 active, first cell 0; then 14 zero slots; then the bound (0,0,0)-(0,0,0).
    assert_eq!(&bytes[336..348], &[0, 0, 0, 0, 0, 0, 0x0f, 0, 0, 0, 0, 0]);
    assert!(bytes[348..528].iter().all(|&b| b == 0));
    // Cell (0,0,0): only corner 3 = sample (1,1,0) = 200. Cell (1,1,0): corner 2 = (1,1,0), corner 7 = (2,2,1) = 90.
    assert_eq!(&bytes[528..536], &[0, 0, 0, 200, 0, 0, 0, 0]);
    assert_eq!(&bytes[552..560], &[200, 0, 0, 0, 0, 0, 0, 90]);

    let golden_path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/tiny.cgc");
    if std::env::var_os("ISOGRID_BLESS").is_some() {
        std::fs::write(golden_path, &bytes).unwrap();
    }
    let golden = std::fs::read(golden_path).unwrap();
    assert_eq!(
        bytes, golden,
        "the writer no longer produces the committed format"
    );
    same(&cgc::read_bytes(&golden).unwrap(), &tiny_grid());
}

#[test]
fn round_trip_through_files_and_memory_maps() {
    let volume = blobs_u8([50, 41, 37]);
    for precision in Precision::ALL {
        let grid = extract(
            &volume.view(),
            &ExtractOptions::new(Iso::Normalized(0.5)).with_precision(precision),
        )
        .unwrap();
        let path = temp_path(&format!("round-{}.cgc", precision.bits()));
        cgc::write(&path, &grid).unwrap();
        let read = cgc::read(&path).unwrap();
        same(&grid, &read);
        let mapped = cgc::open(&path).unwrap();
        assert!(mapped.is_mapped());
        same(&grid, &mapped);
        // Counted: every section byte checksummed, then every block checked.
        let progress = isogrid::Progress::new();
        same(&grid, &cgc::open_with_progress(&path, &progress).unwrap());
        let counted = (grid.blocks().len() * 16 + grid.metacells().len() * 12 + grid.cells().len())
            as u64
            + grid.blocks().len() as u64;
        assert_eq!(progress.counts(), (counted, counted));
        assert_eq!(std::fs::read(&path).unwrap(), cgc::to_bytes(&grid));
    }
}

#[test]
fn every_truncation_is_rejected() {
    let bytes = cgc::to_bytes(&tiny_grid());
    for len in 0..bytes.len() {
        let err = cgc::read_bytes(&bytes[..len]).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "len {len}: {err}");
    }
    let path = temp_path("truncated.cgc");
    std::fs::write(&path, &bytes[..400]).unwrap();
    for err in [cgc::read(&path).unwrap_err(), cgc::open(&path).unwrap_err()] {
        assert!(
            err.to_string().starts_with(&path.display().to_string()),
            "{err}"
        );
        assert!(err.to_string().contains("truncated"), "{err}");
    }
}

#[test]
fn damaged_bytes_are_rejected_without_panicking() {
    let volume = blobs_u8([30, 30, 30]);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(127.5))).unwrap();
    let bytes = cgc::to_bytes(&grid);
    let mut rng = Rng::new(11);
    for _ in 0..400 {
        let mut damaged = bytes.clone();
        let at = rng.below(bytes.len() as u64) as usize;
        damaged[at] ^= 1 << rng.below(8);
        match cgc::read_bytes(&damaged) {
            Err(e) => assert_eq!(e.kind(), ErrorKind::Corrupt, "byte {at}: {e}"),
            // Only the zero padding between sections is unchecked.
            Ok(_) => assert!(
                bytes[at] == 0 && is_padding(&bytes, at),
                "flip at byte {at} went unnoticed"
            ),
        }
    }
    // A header claiming absurd counts must fail on sizes, before allocating.
    let mut absurd = bytes.clone();
    absurd[136..144].copy_from_slice(&(u64::MAX / 2).to_le_bytes());
    let crc = crc32fast_hash(&absurd[..316]);
    absurd[316..320].copy_from_slice(&crc.to_le_bytes());
    let err = cgc::read_bytes(&absurd).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
}

/// Whether `at` lies between sections (alignment padding).
fn is_padding(bytes: &[u8], at: usize) -> bool {
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap()) as usize;
    let sections = [
        (u64_at(160), u64_at(168)),
        (u64_at(176), u64_at(184)),
        (u64_at(192), u64_at(200)),
    ];
    at >= 320 && !sections.iter().any(|&(o, l)| at >= o && at < o + l)
}

/// CRC-32 (IEEE), written out so the test does not trust the library's checksum code path.
fn crc32fast_hash(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                crc >> 1 ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn rewritten_headers_with_valid_checksums_are_still_validated() {
    let bytes = cgc::to_bytes(&tiny_grid());
    let with = |offset: usize, value: &[u8]| {
        let mut b = bytes.clone();
        b[offset..offset + value.len()].copy_from_slice(value);
        let crc = crc32fast_hash(&b[..316]);
        b[316..320].copy_from_slice(&crc.to_le_bytes());
        cgc::read_bytes(&b).unwrap_err()
    };
    assert_eq!(
        with(16, &200_000u32.to_le_bytes()).kind(),
        ErrorKind::Corrupt
    ); // dim beyond 128K
    assert_eq!(with(8, &9u32.to_le_bytes()).kind(), ErrorKind::Unsupported); // future version
    assert_eq!(with(104, &12u32.to_le_bytes()).kind(), ErrorKind::Corrupt); // precision
    assert_eq!(
        with(32, &(-1.0f64).to_le_bytes()).kind(),
        ErrorKind::Corrupt
    ); // spacing
    assert_eq!(with(176, &330u64.to_le_bytes()).kind(), ErrorKind::Corrupt); // overlapping sections
    assert_eq!(with(144, &5u64.to_le_bytes()).kind(), ErrorKind::Corrupt); // cell count vs section length
}

#[test]
fn a_section_length_mismatch_is_told_in_words() {
    let mut b = cgc::to_bytes(&tiny_grid());
    b[144..152].copy_from_slice(&5u64.to_le_bytes()); // cell count
    let crc = crc32fast_hash(&b[..316]);
    b[316..320].copy_from_slice(&crc.to_le_bytes());
    let err = cgc::read_bytes(&b).unwrap_err().to_string();
    assert!(
        err.contains("cells section is") && err.contains("holds 5 records of"),
        "{err}"
    );
    assert!(!err.contains("Some("), "Rust debug text in {err}");
}

#[test]
fn directories_and_fifos_are_refused_not_waited_on() {
    let dir = temp_path("a-directory.cgc");
    std::fs::create_dir_all(&dir).unwrap();
    for result in [cgc::open(&dir), cgc::read(&dir)] {
        let err = result.unwrap_err().to_string();
        assert!(err.contains("is a directory, not a regular file"), "{err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
    #[cfg(unix)]
    {
        let fifo = temp_path("fifo.cgc");
        let _ = std::fs::remove_file(&fifo);
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        // On another thread, so that a regression hangs that thread, not the test.
        let (send, recv) = std::sync::mpsc::channel();
        let path = fifo.clone();
        std::thread::spawn(move || {
            let _ = send.send(cgc::open(&path).map(|_| ()).unwrap_err().to_string());
        });
        let err = recv
            .recv_timeout(std::time::Duration::from_secs(20))
            .expect("opening a FIFO blocked");
        assert!(err.contains("FIFO"), "{err}");
        std::fs::remove_file(&fifo).unwrap();
    }
}

#[test]
fn writes_are_atomic_and_errors_name_the_file() {
    let path = temp_path("does/not/exist/out.cgc");
    let err = cgc::write(&path, &tiny_grid()).unwrap_err();
    assert!(err.to_string().contains("out.cgc"), "{err}");
    let err = cgc::read(&temp_path("missing.cgc")).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Io);
    assert!(err.to_string().contains("missing.cgc"));
}

/// Anonymous resident memory of this process (`RssAnon` in /proc/self/status), in bytes: heap
/// and other private memory, not pages of mapped files.
#[cfg(target_os = "linux")]
fn anonymous_resident_bytes() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status
        .lines()
        .find(|l| l.starts_with("RssAnon:"))
        .expect("RssAnon in /proc/self/status");
    let kib: u64 = line
        .trim_start_matches("RssAnon:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .unwrap();
    kib * 1024
}

/// `cgc::open` (what `isogrid render`, `view`, `bench rays` and Python's `load` use) maps the
/// file: opening and validating a grid of about 20 MB adds less than a tenth of its payload to
/// the process's anonymous memory, while `cgc::read`, which copies, adds at least 90 % of it
/// (the check that the measurement sees copies). Measured in a child process running only this
/// test, so that other tests' allocations do not blur the figures.
#[cfg(target_os = "linux")]
#[test]
fn opening_a_cgc_file_maps_its_payload_instead_of_copying_it() {
    const CHILD: &str = "ISOGRID_TEST_RSS_CHILD";
    let name = "cgc::opening_a_cgc_file_maps_its_payload_instead_of_copying_it";
    if std::env::var_os(CHILD).is_none() {
        let output = std::process::Command::new(std::env::current_exe().unwrap())
            .args(["--exact", name, "--test-threads=1", "--nocapture"])
            .env(CHILD, "1")
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&output.stdout).to_string()
            + &String::from_utf8_lossy(&output.stderr);
        eprintln!("{text}");
        assert!(output.status.success(), "child failed");
        assert!(text.contains("1 passed"), "the child ran no test");
        return;
    }
    let path = temp_path("mapped.cgc");
    let payload = {
        let volume = isogrid::generate::generate(isogrid::generate::Field::Hairball, 256, 1);
        let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Normalized(0.5))).unwrap();
        cgc::write(&path, &grid).unwrap();
        (std::mem::size_of_val(grid.blocks())
            + std::mem::size_of_val(grid.metacells())
            + grid.cells().len()) as u64
    };
    assert!(payload > 10 << 20, "payload of {payload} bytes");

    let before = anonymous_resident_bytes();
    let mapped = cgc::open(&path).unwrap();
    // Touch every payload byte, as a renderer's upload does.
    let sum = mapped.cells().iter().map(|&b| b as u64).sum::<u64>()
        + bytemuck::cast_slice::<_, u8>(mapped.metacells())
            .iter()
            .map(|&b| b as u64)
            .sum::<u64>();
    let opened = anonymous_resident_bytes().saturating_sub(before);

    let before = anonymous_resident_bytes();
    let copied = cgc::read(&path).unwrap();
    let read = anonymous_resident_bytes().saturating_sub(before);
    same(&mapped, &copied);
    eprintln!(
        "payload {payload} bytes (checksum {sum}): RssAnon +{opened} bytes after cgc::open, \
         +{read} after cgc::read"
    );
    assert!(opened < payload / 10, "open added {opened} bytes");
    assert!(read >= payload / 10 * 9, "read added only {read} bytes");
    std::fs::remove_file(&path).unwrap();
}

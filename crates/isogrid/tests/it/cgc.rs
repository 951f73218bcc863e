//! `.cgc` files: round trips, golden bytes, and rejection of damaged files.

use crate::common::{blobs_u8, Rng};
use crate::labels::tiny_labelled_grid;
use isogrid::{
    cgc, extract, CellGrid, ErrorKind, ExtractOptions, Iso, Precision, Volume, VolumeData,
    WorldFrame,
};
use std::path::PathBuf;

fn tiny_grid() -> CellGrid {
    tiny_grid_in(WorldFrame::Unknown)
}

/// A tiny grid of a volume whose world coordinates are `frame`'s.
fn tiny_grid_in(frame: WorldFrame) -> CellGrid {
    let mut data = vec![0u8; 18];
    data[1 + 3] = 200; // sample (1,1,0)
    data[2 + 3 * 2 + 9] = 90; // sample (2,2,1)
    let geometry = isogrid::Geometry {
        spacing: [0.5, 1.0, 2.0],
        frame,
        ..isogrid::Geometry::new([3, 3, 2])
    };
    let volume = Volume::with_geometry(geometry, VolumeData::U8(data)).unwrap();
    extract(&volume.view(), &ExtractOptions::new(Iso::Value(100.0))).unwrap()
}

fn same(a: &CellGrid, b: &CellGrid) {
    assert_eq!(a.info(), b.info());
    assert_eq!(a.blocks(), b.blocks());
    assert_eq!(a.metacells(), b.metacells());
    assert_eq!(a.cells(), b.cells());
}

/// A path in the system's temporary folder for the file `name` of this process (no folder of
/// its own, so that nothing is left behind once the tests remove their files).
fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("isogrid-it-{}-{name}", std::process::id()))
}

#[test]
fn golden_bytes_of_a_tiny_file() {
    let bytes = cgc::to_bytes(&tiny_grid());
    // Fields checked by hand against the format table, independent of the writer.
    assert_eq!(
        bytes.len(),
        656,
        "320 header + 3×32 table + 16 block + 16×12 slots + 4×8 cells"
    );
    assert_eq!(&bytes[..8], b"\x89CGC\r\n\x1a\n");
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
    let f64_at = |o: usize| f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
    assert_eq!((u32_at(8), u32_at(12)), (2, 320));
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
    // The section table: at 320, 3 entries, its CRC; reserved bytes zero.
    assert_eq!((u64_at(160), u32_at(168)), (320, 3));
    assert_eq!(u32_at(172), crc32_by_hand(&bytes[320..416]));
    assert!(bytes[176..208]
        .iter()
        .chain(&bytes[280..316])
        .all(|&b| b == 0));
    assert_eq!(u32_at(316), crc32_by_hand(&bytes[..316]));
    // Entries: kind, flags (required), offset, length, CRC of the section, reserved.
    for (e, (kind, offset, len)) in [(1, 416, 16), (2, 432, 192), (3, 624, 32)]
        .into_iter()
        .enumerate()
    {
        let at = 320 + 32 * e;
        assert_eq!((u32_at(at), u32_at(at + 4)), (kind, 1), "entry {e}");
        assert_eq!(
            (u64_at(at + 8), u64_at(at + 16)),
            (offset, len),
            "entry {e}"
        );
        let section = &bytes[offset as usize..(offset + len) as usize];
        assert_eq!(u32_at(at + 24), crc32_by_hand(section), "entry {e}");
        assert_eq!(u32_at(at + 28), 0);
    }
    // Block: 16 slots from slot 0, min 0, max 200.
    assert_eq!(
        &bytes[416..432],
        &[16, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x48, 0x43]
    );
    // Metacell (0,0,0) with cells 0..3 active, first cell 0; then 14 zero slots; then the bound (0,0,0)-(0,0,0).
    assert_eq!(&bytes[432..444], &[0, 0, 0, 0, 0, 0, 0x0f, 0, 0, 0, 0, 0]);
    assert!(bytes[444..624].iter().all(|&b| b == 0));
    // Cell (0,0,0): only corner 3 = sample (1,1,0) = 200. Cell (1,1,0): corner 2 = (1,1,0), corner 7 = (2,2,1) = 90.
    assert_eq!(&bytes[624..632], &[0, 0, 0, 200, 0, 0, 0, 0]);
    assert_eq!(&bytes[648..656], &[200, 0, 0, 0, 0, 0, 0, 90]);

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

/// A version 1 file, as the first writer made it (committed, never rewritten), still reads: from
/// memory, into memory and memory-mapped, to the same grid the current writer writes.
#[test]
fn version_1_files_still_read() {
    let path = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/tiny-v1.cgc"
    ));
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 1);
    same(&cgc::read_bytes(&bytes).unwrap(), &tiny_grid());
    same(&cgc::read(&path).unwrap(), &tiny_grid());
    same(&cgc::open(&path).unwrap(), &tiny_grid());
    for len in 0..bytes.len() {
        assert!(cgc::read_bytes(&bytes[..len]).is_err(), "len {len}");
    }
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
        drop(mapped);
        std::fs::remove_file(&path).unwrap();
    }
}

#[test]
fn every_truncation_is_rejected() {
    for grid in [
        tiny_grid(),
        tiny_labelled_grid(),
        tiny_grid_in(WorldFrame::Ras),
    ] {
        let bytes = cgc::to_bytes(&grid);
        for len in 0..bytes.len() {
            let err = cgc::read_bytes(&bytes[..len]).unwrap_err();
            assert_eq!(err.kind(), ErrorKind::Corrupt, "len {len}: {err}");
        }
    }
    let bytes = cgc::to_bytes(&tiny_grid());
    let path = temp_path("truncated.cgc");
    std::fs::write(&path, &bytes[..400]).unwrap();
    for err in [cgc::read(&path).unwrap_err(), cgc::open(&path).unwrap_err()] {
        assert!(
            err.to_string().starts_with(&path.display().to_string()),
            "{err}"
        );
        assert!(err.to_string().contains("truncated"), "{err}");
    }
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn damaged_bytes_are_rejected_without_panicking() {
    // Every bit of a small file: the header, the table, the padding between sections and every
    // section are covered by a checksum or a zero check, so no flip goes unnoticed.
    for grid in [
        tiny_grid(),
        tiny_labelled_grid(),
        tiny_grid_in(WorldFrame::Lps),
    ] {
        let bytes = cgc::to_bytes(&grid);
        for at in 0..bytes.len() {
            for bit in 0..8 {
                let mut damaged = bytes.clone();
                damaged[at] ^= 1 << bit;
                let err = cgc::read_bytes(&damaged).unwrap_err();
                assert_eq!(err.kind(), ErrorKind::Corrupt, "byte {at} bit {bit}: {err}");
            }
        }
    }
    let volume = blobs_u8([30, 30, 30]);
    let grid = extract(&volume.view(), &ExtractOptions::new(Iso::Value(127.5))).unwrap();
    let bytes = cgc::to_bytes(&grid);
    let mut rng = Rng::new(11);
    for _ in 0..400 {
        let mut damaged = bytes.clone();
        let at = rng.below(bytes.len() as u64) as usize;
        damaged[at] ^= 1 << rng.below(8);
        let err = cgc::read_bytes(&damaged).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "byte {at}: {err}");
    }
    // A header claiming absurd counts must fail on sizes, before allocating.
    let mut absurd = bytes.clone();
    absurd[136..144].copy_from_slice(&(u64::MAX / 2).to_le_bytes());
    let crc = crc32_by_hand(&absurd[..316]);
    absurd[316..320].copy_from_slice(&crc.to_le_bytes());
    let err = cgc::read_bytes(&absurd).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
}

/// CRC-32 (IEEE), written out so the test does not trust the library's checksum code path.
fn crc32_by_hand(data: &[u8]) -> u32 {
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

/// A version 2 file assembled by this test, independently of the library's writer: the header
/// fields 16..160 and the direction of `model` (a file the library wrote), then a table of
/// `sections` (kind, flags, bytes) in this order.
pub(crate) fn assemble(model: &[u8], sections: &[(u32, u32, &[u8])]) -> Vec<u8> {
    let table_end = 320 + 32 * sections.len();
    let mut offsets = Vec::new();
    let mut end = table_end;
    for (_, _, bytes) in sections {
        let offset = end.div_ceil(16) * 16;
        offsets.push(offset);
        end = offset + bytes.len();
    }
    let mut file = vec![0u8; end];
    file[..160].copy_from_slice(&model[..160]);
    file[208..280].copy_from_slice(&model[208..280]);
    for (e, ((kind, flags, bytes), offset)) in sections.iter().zip(&offsets).enumerate() {
        let at = 320 + 32 * e;
        file[at..at + 4].copy_from_slice(&kind.to_le_bytes());
        file[at + 4..at + 8].copy_from_slice(&flags.to_le_bytes());
        file[at + 8..at + 16].copy_from_slice(&(*offset as u64).to_le_bytes());
        file[at + 16..at + 24].copy_from_slice(&(bytes.len() as u64).to_le_bytes());
        file[at + 24..at + 28].copy_from_slice(&crc32_by_hand(bytes).to_le_bytes());
        file[*offset..*offset + bytes.len()].copy_from_slice(bytes);
    }
    file[160..168].copy_from_slice(&320u64.to_le_bytes());
    file[168..172].copy_from_slice(&(sections.len() as u32).to_le_bytes());
    let table_crc = crc32_by_hand(&file[320..table_end]);
    file[172..176].copy_from_slice(&table_crc.to_le_bytes());
    let crc = crc32_by_hand(&file[..316]);
    file[316..320].copy_from_slice(&crc.to_le_bytes());
    file
}

/// The bytes of section `e` of a version 2 file.
pub(crate) fn section(file: &[u8], e: usize) -> &[u8] {
    let u64_at = |o: usize| u64::from_le_bytes(file[o..o + 8].try_into().unwrap()) as usize;
    let (offset, len) = (u64_at(320 + 32 * e + 8), u64_at(320 + 32 * e + 16));
    &file[offset..offset + len]
}

#[test]
fn the_world_frame_travels_in_its_own_optional_section() {
    // The frame of the volume, in every way a file is read; a grid of no frame has no section.
    for frame in [WorldFrame::Lps, WorldFrame::Ras, WorldFrame::Unknown] {
        let grid = tiny_grid_in(frame);
        assert_eq!(grid.info().frame, frame);
        let bytes = cgc::to_bytes(&grid);
        let sections = u32::from_le_bytes(bytes[168..172].try_into().unwrap());
        assert_eq!(sections, 3 + (frame != WorldFrame::Unknown) as u32);
        let path = temp_path(&format!("frame-{}.cgc", frame.name()));
        cgc::write(&path, &grid).unwrap();
        for read in [
            cgc::read_bytes(&bytes).unwrap(),
            cgc::read(&path).unwrap(),
            cgc::open(&path).unwrap(),
        ] {
            same(&read, &grid);
        }
        std::fs::remove_file(&path).unwrap();
    }
    // Kind 8, optional, eight bytes: the code (1 LPS, 2 RAS) and four zero bytes.
    let model = cgc::to_bytes(&tiny_grid());
    let [blocks, metacells, cells] = [0, 1, 2].map(|e| section(&model, e));
    let with = |frame: &[u8]| {
        assemble(
            &model,
            &[
                (1, 1, blocks),
                (2, 1, metacells),
                (3, 1, cells),
                (8, 0, frame),
            ],
        )
    };
    assert_eq!(
        with(&[2, 0, 0, 0, 0, 0, 0, 0]),
        cgc::to_bytes(&tiny_grid_in(WorldFrame::Ras))
    );
    for bad in [
        &[3u8, 0, 0, 0, 0, 0, 0, 0][..],
        &[1, 0, 0, 0, 0, 0, 0, 1],
        &[1, 0, 0, 0],
    ] {
        let err = cgc::read_bytes(&with(bad)).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
        assert!(err.to_string().contains("world frame"), "{err}");
    }
}

#[test]
fn the_section_table_admits_unknown_optional_sections_and_refuses_unknown_required_ones() {
    let model = cgc::to_bytes(&tiny_grid());
    let [blocks, metacells, cells] = [0, 1, 2].map(|e| section(&model, e));
    // The test's own assembly of the same sections is the library's file, byte for byte.
    assert_eq!(
        assemble(&model, &[(1, 1, blocks), (2, 1, metacells), (3, 1, cells)]),
        model
    );
    // An optional section of a kind from the future, anywhere in the table, is skipped...
    let extra: &[u8] = b"a section from a later version";
    for file in [
        assemble(
            &model,
            &[
                (1, 1, blocks),
                (2, 1, metacells),
                (3, 1, cells),
                (99, 0, extra),
            ],
        ),
        assemble(
            &model,
            &[
                (99, 0, extra),
                (1, 1, blocks),
                (2, 1, metacells),
                (3, 1, cells),
            ],
        ),
    ] {
        same(&cgc::read_bytes(&file).unwrap(), &tiny_grid());
        // ...but its checksum is still checked.
        let mut damaged = file.clone();
        let at = file.windows(extra.len()).position(|w| w == extra).unwrap();
        damaged[at] ^= 4;
        let err = cgc::read_bytes(&damaged).unwrap_err().to_string();
        assert!(err.contains("kind 99") && err.contains("checksum"), "{err}");
    }
    // A required one is refused as unsupported, naming the kind.
    let file = assemble(
        &model,
        &[
            (1, 1, blocks),
            (2, 1, metacells),
            (3, 1, cells),
            (99, 1, extra),
        ],
    );
    let err = cgc::read_bytes(&file).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Unsupported);
    assert!(err.to_string().contains("kind 99"), "{err}");
    // Structure: each grid section once, with its flags; reserved flag bits zero.
    for (sections, words) in [
        (
            vec![(1, 1, blocks), (2, 1, metacells)],
            "section table of 2 entries",
        ),
        (
            vec![(1, 1, blocks), (2, 1, metacells), (99, 0, extra)],
            "no cells section",
        ),
        (
            vec![
                (1, 1, blocks),
                (2, 1, metacells),
                (3, 1, cells),
                (3, 1, cells),
            ],
            "two cells sections",
        ),
        (
            vec![(1, 0, blocks), (2, 1, metacells), (3, 1, cells)],
            "wrong flags",
        ),
        (
            vec![(1, 1, blocks), (2, 3, metacells), (3, 1, cells)],
            "reserved table bits",
        ),
    ] {
        let err = cgc::read_bytes(&assemble(&model, &sections)).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
        assert!(err.to_string().contains(words), "{words}: {err}");
    }
    // Overlapping sections, with every checksum made valid again.
    let mut overlapping = model.clone();
    overlapping[352 + 8..352 + 16].copy_from_slice(&416u64.to_le_bytes());
    let table_crc = crc32_by_hand(&overlapping[320..416]);
    overlapping[172..176].copy_from_slice(&table_crc.to_le_bytes());
    let crc = crc32_by_hand(&overlapping[..316]);
    overlapping[316..320].copy_from_slice(&crc.to_le_bytes());
    let err = cgc::read_bytes(&overlapping).unwrap_err().to_string();
    assert!(
        err.contains("metacells section at 416+192 does not fit"),
        "{err}"
    );
    // Bytes appended after the last section are refused: the file must end where it ends.
    let mut appended = model.clone();
    appended.extend_from_slice(&[0; 16]);
    let err = cgc::read_bytes(&appended).unwrap_err().to_string();
    assert!(err.contains("sections end at 656"), "{err}");
}

#[test]
fn rewritten_headers_with_valid_checksums_are_still_validated() {
    let bytes = cgc::to_bytes(&tiny_grid());
    let with = |offset: usize, value: &[u8]| {
        let mut b = bytes.clone();
        b[offset..offset + value.len()].copy_from_slice(value);
        let crc = crc32_by_hand(&b[..316]);
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
    assert_eq!(with(176, &1u64.to_le_bytes()).kind(), ErrorKind::Corrupt); // reserved bytes
    assert_eq!(with(144, &5u64.to_le_bytes()).kind(), ErrorKind::Corrupt); // cell count vs section length
}

#[test]
fn a_section_length_mismatch_is_told_in_words() {
    let mut b = cgc::to_bytes(&tiny_grid());
    b[144..152].copy_from_slice(&5u64.to_le_bytes()); // cell count
    let crc = crc32_by_hand(&b[..316]);
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
    crate::heap::run_alone("cgc::opening_maps_alone", &[]);
}

#[cfg(target_os = "linux")]
#[test]
#[ignore = "run alone by opening_a_cgc_file_maps_its_payload_instead_of_copying_it"]
fn opening_maps_alone() {
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

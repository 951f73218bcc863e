//! `isogrid pack`: the packed form of a volume's surface (or labels) is that of its `.cgc`, much
//! smaller, and bad requests fail in one line without writing anything. (The web tests rebuild the
//! `.cgc` from it byte for byte: web/test/packed.test.mjs.)

use super::{fails, s, temp_dir};
use crate::common::isogrid_ok as isogrid;

#[test]
fn a_volume_packs_as_its_extracted_file() {
    let dir = temp_dir("pack");
    let volume = dir.join("sphere.nrrd");
    let cgc = dir.join("sphere.cgc");
    isogrid(&["generate", "sphere", "--size", "40", "-o", s(&volume)]);
    super::extracted_at_half(&volume, &cgc);
    let (a, b) = (dir.join("a.cgcz"), dir.join("b.cgcz"));
    isogrid(&["pack", s(&cgc), "-o", s(&a)]);
    isogrid(&["pack", s(&volume), "--iso-normalized", "0.5", "-o", s(&b)]);
    let (a, b, file) = (
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        std::fs::read(&cgc).unwrap(),
    );
    assert!(a == b, "the volume and its .cgc pack differently");
    assert_eq!(&a[..8], b"\x89CGZ\r\n\x1a\n");
    // The .cgc's header and section table travel as they are.
    let head = 320 + 32 * u32::from_le_bytes(file[168..172].try_into().unwrap()) as usize;
    let at = isogrid::cgc::PACKED_HEAD_SIZE;
    assert_eq!(&a[at..at + head], &file[..head]);
    assert!(
        a.len() * 4 < file.len(),
        "{} bytes packed into {}",
        file.len(),
        a.len()
    );
}

#[test]
fn a_label_file_packs_as_its_volume_does() {
    let dir = temp_dir("pack-labels");
    let volume = dir.join("cubes.nrrd");
    isogrid_io::write_nrrd(&volume, &isogrid::generate::labelled_cubes(12)).unwrap();
    let labels = dir.join("cubes.cgc");
    isogrid(&["extract", s(&volume), "--labels", "all", "-o", s(&labels)]);
    let (a, b) = (dir.join("a.cgcz"), dir.join("b.cgcz"));
    isogrid(&["pack", s(&labels), "-o", s(&a)]);
    isogrid(&["pack", s(&volume), "--labels", "all", "-o", s(&b)]);
    assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap());
}

#[test]
fn bad_requests_fail_in_one_line_and_write_nothing() {
    let dir = temp_dir("pack-bad");
    let volume = dir.join("sphere.nrrd");
    isogrid(&["generate", "sphere", "--size", "16", "-o", s(&volume)]);
    let cgc = dir.join("sphere.cgc");
    isogrid(&["extract", s(&volume), "--iso", "100", "-o", s(&cgc)]);
    let original = std::fs::read(&cgc).unwrap();
    let out = dir.join("out.cgcz");
    let damaged = dir.join("damaged.cgc");
    let mut bytes = original.clone();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&damaged, &bytes).unwrap();
    fails(&["pack", s(&damaged), "-o", s(&out)], "damaged.cgc");
    fails(&["pack", s(&volume), "-o", s(&out)], "--iso");
    assert!(!out.exists());
    // The output's name and the input are checked before any work.
    fails(&["pack", s(&cgc), "-o", s(&dir.join("out.cgc"))], ".cgcz");
    fails(&["pack", s(&cgc), "-o", s(&cgc)], "overwrite");
    assert!(std::fs::read(&cgc).unwrap() == original);
}

/// Ctrl-C while packing stops between blocks: exit 130, one line, the old output kept and no
/// temporary file (or, when the signal comes before the work, the default action).
#[cfg(unix)]
#[test]
fn ctrl_c_stops_packing_and_leaves_no_output() {
    let dir = temp_dir("interrupt-pack");
    let volume = super::generated(&dir, "hairball", 256);
    let cgc = dir.join("hairball.cgc");
    super::extracted_at_half(&volume, &cgc);
    let out = dir.join("out.cgcz");
    let args = ["pack", s(&cgc), "-o", s(&out)];
    let stopped = super::hostile::interrupt_at(&args, &out, &[30, 80, 150, 300], |new| {
        std::fs::read(new)
            .unwrap()
            .starts_with(b"\x89CGZ\r\n\x1a\n")
    });
    assert!(stopped
        .iter()
        .all(|m| m.contains("packing stopped by Ctrl-C, nothing written")));
}

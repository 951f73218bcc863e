//! `isogrid pack`: the packed form of a volume's surface is that of its `.cgc`, much smaller, and
//! what cannot be packed fails in one line without writing anything. (The web tests rebuild the
//! `.cgc` from it byte for byte: web/test/packed.test.mjs.)

use super::{fails, s, temp_dir};
use crate::common::isogrid_ok as isogrid;

#[test]
fn a_volume_packs_as_its_extracted_file() {
    let dir = temp_dir("pack");
    let volume = dir.join("sphere.nrrd");
    let cgc = dir.join("sphere.cgc");
    isogrid(&["generate", "sphere", "--size", "40", "-o", s(&volume)]);
    isogrid(&[
        "extract",
        s(&volume),
        "--iso-normalized",
        "0.5",
        "-o",
        s(&cgc),
    ]);
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
    assert_eq!(&a[48..48 + head], &file[..head]);
    assert!(
        a.len() * 4 < file.len(),
        "{} bytes packed into {}",
        file.len(),
        a.len()
    );
}

#[test]
fn what_cannot_be_packed_fails_in_one_line_and_writes_nothing() {
    let dir = temp_dir("pack-bad");
    let volume = dir.join("cubes.nrrd");
    isogrid_io::write_nrrd(&volume, &isogrid::generate::labelled_cubes(12)).unwrap();
    let labels = dir.join("cubes.cgc");
    isogrid(&["extract", s(&volume), "--labels", "all", "-o", s(&labels)]);
    let out = dir.join("out.cgcz");
    fails(&["pack", s(&labels), "-o", s(&out)], "labels");
    fails(
        &["pack", s(&volume), "--labels", "all", "-o", s(&out)],
        "labels",
    );
    let damaged = dir.join("damaged.cgc");
    let original = std::fs::read(&labels).unwrap();
    let mut bytes = original.clone();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&damaged, &bytes).unwrap();
    fails(&["pack", s(&damaged), "-o", s(&out)], "damaged.cgc");
    assert!(!out.exists());
    // The output's name and the input are checked before any work.
    fails(
        &["pack", s(&labels), "-o", s(&dir.join("out.cgc"))],
        ".cgcz",
    );
    fails(&["pack", s(&labels), "-o", s(&labels)], "overwrite");
    assert!(std::fs::read(&labels).unwrap() == original);
}

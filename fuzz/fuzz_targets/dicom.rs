//! A single DICOM part-10 file given as the path (`.dcm`): the data set parser (dicom-rs), the
//! transfer syntaxes' pixel-data decoders, single- and multi-frame geometry.
//!
//! JPEG 2000 (and HTJ2K) inputs are skipped: their decoder, the pure-Rust openjp2 0.6.1, frees
//! never-allocated code-block buffers through `std::alloc::dealloc(null, ..)`, which nightly's
//! debug-assertion UB checks turn into an abort on every J2K file, valid ones included (release
//! and stable builds call `free(NULL)`, a no-op). See docs/fuzzing.md.
#![no_main]

fn is_jpeg2000(data: &[u8]) -> bool {
    [&b"1.2.840.10008.1.2.4.9"[..], b"1.2.840.10008.1.2.4.20"]
        .iter()
        .any(|uid| data.windows(uid.len()).any(|w| w == *uid))
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if is_jpeg2000(data) {
        return;
    }
    let opts = isogrid_io::ReadOptions::default();
    isogrid_fuzz::fuzz_volume("in.dcm", data, |path| {
        isogrid_io::read_dicom(path, &opts).map(|(volume, _)| volume)
    });
});

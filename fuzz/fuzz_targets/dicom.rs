//! A single DICOM part-10 file given as the path (`.dcm`): the data set parser (dicom-rs), the
//! transfer syntaxes' pixel-data decoders, single- and multi-frame geometry. OpenJPEG (JPEG 2000),
//! CharLS and libjpeg-turbo are C and C++ built without the sanitizer's instrumentation: their
//! allocations and frees go through AddressSanitizer's allocator and are checked, their memory
//! accesses and branches are not.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let opts = isogrid_io::ReadOptions::default();
    isogrid_fuzz::fuzz_volume("in.dcm", data, |path| {
        isogrid_io::read_dicom(path, &opts).map(|(volume, _)| volume)
    });
});

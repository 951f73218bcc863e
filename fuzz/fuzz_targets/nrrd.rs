//! NRRD with an attached header (`.nrrd`): raw, gzip and text encodings, both byte orders.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.nrrd", data, isogrid_io::read_nrrd);
});

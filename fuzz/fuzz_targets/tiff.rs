//! TIFF stacks (`.tif`): the tiff crate's decoder and the stack assembly around it.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.tif", data, isogrid_io::read_tiff);
});

//! MetaImage with the data in the same file (`.mha`): header, element types, zlib data.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.mha", data, isogrid_io::read_metaimage);
});

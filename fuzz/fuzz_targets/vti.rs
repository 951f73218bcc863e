//! VTK XML image data (`.vti`): the XML, ascii / base64 / raw appended data, zlib and LZ4 blocks.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.vti", data, isogrid_io::read_vti);
});

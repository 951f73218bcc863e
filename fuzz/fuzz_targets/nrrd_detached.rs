//! NRRD with a detached header (`.nhdr`): the input is the header, up to and including the first
//! blank line, then the bytes of `d.raw`, the data file seeds name (`data file: d.raw`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let split = data
        .windows(2)
        .position(|w| w == b"\n\n")
        .map_or(data.len(), |at| at + 2);
    let (header, rest) = data.split_at(split);
    isogrid_fuzz::scratch_file("d.raw", rest);
    isogrid_fuzz::fuzz_volume("in.nhdr", header, isogrid_io::read_nrrd);
});

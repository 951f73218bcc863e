//! MRC / CCP4 maps (`.mrc`): modes, axis permutation, cell geometry, extended headers.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.mrc", data, isogrid_io::read_mrc);
});

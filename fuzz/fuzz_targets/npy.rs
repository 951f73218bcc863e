//! NumPy `.npy`: the magic, the Python-literal header dictionary, C and Fortran order.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.npy", data, isogrid_io::read_npy);
});

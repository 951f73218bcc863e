//! NIfTI-1 gzip-compressed (`.nii.gz`): the inflation limits as well as the header.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.nii.gz", data, isogrid_io::read_nifti);
});

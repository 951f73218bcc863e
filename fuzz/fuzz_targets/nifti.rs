//! NIfTI-1 single file (`.nii`): header, qform/sform geometry, scaling, samples.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.nii", data, isogrid_io::read_nifti);
});

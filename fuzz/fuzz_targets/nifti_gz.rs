//! NIfTI-1 gzip-compressed (`.nii.gz`): the inflation limits as well as the header; and the same
//! file as a folder's one mask, streamed into bits, against the volume read whole.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.nii.gz", data, isogrid_io::read_nifti);
    isogrid_fuzz::fuzz_nifti_as_mask("in.nii.gz", data);
});

//! NIfTI-1 single file (`.nii`): header, qform/sform geometry, scaling, samples; and the same
//! file as a folder's one mask, streamed into bits, against the volume read whole.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.nii", data, isogrid_io::read_nifti);
    isogrid_fuzz::fuzz_nifti_as_mask("in.nii", data);
});

//! NIfTI-1 single file (`.nii`): header, qform/sform geometry, scaling, samples; the same file as
//! a folder's one mask, streamed into bits, against the volume read whole; and a volume of a 4-D
//! file read by region against the same read whole.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.nii", data, isogrid_io::read_nifti);
    isogrid_fuzz::fuzz_nifti_as_mask("in.nii", data);
    // The last byte picks the volume of a 4-D file.
    let t = u64::from(data.last().copied().unwrap_or(0) % 4);
    isogrid_fuzz::fuzz_frame_whole_and_by_region("in.nii", data, t);
});

//! NIfTI header/image pairs (`.hdr` + `.img`): the bytes up to the header's size (540 when its
//! first word says NIfTI-2, else 348) as `in.hdr`, the rest as `in.img`; each volume of a 4-D pair
//! read whole through either name and by region, which must agree.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let nifti_2 = data.len() >= 4
        && (data[..4] == 540i32.to_le_bytes() || data[..4] == 540i32.to_be_bytes());
    let split = data.len().min(if nifti_2 { 540 } else { 348 });
    isogrid_fuzz::scratch_file("in.img", &data[split..]);
    let t = u64::from(data.last().copied().unwrap_or(0) % 4);
    isogrid_fuzz::fuzz_frame_whole_and_by_region("in.hdr", &data[..split], t);
    isogrid_fuzz::fuzz_frame_whole_and_by_region("in.img", &data[split..], t);
});

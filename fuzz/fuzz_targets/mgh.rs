//! FreeSurfer MGH (`.mgh`; gzip, as `.mgz`, where the bytes start with the gzip magic): header,
//! geometry, frames and the inflation limits; a frame read by region equals the frame read whole.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.mgh", data, isogrid_io::read_mgh);
    // The last byte picks the frame, so mutations reach every frame and an out-of-range one.
    let t = u64::from(data.last().copied().unwrap_or(0) % 4);
    isogrid_fuzz::fuzz_frame_whole_and_by_region("in.mgh", data, t);
});

//! TIFF stacks (`.tif`): the tiff crate's decoder and the stack assembly around it, read whole and
//! with an index into extra axes (an ImageJ or OME hyperstack's channels and times).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_volume("in.tif", data, isogrid_io::read_tiff);
    // The last byte picks the index, so mutations reach every axis and an out-of-range entry.
    let pick = data.last().copied().unwrap_or(0);
    let axis = ["c", "t", "z"][(pick % 3) as usize];
    let index = vec![(axis.to_string(), u64::from(pick / 3 % 4))];
    isogrid_fuzz::fuzz_volume("in.tif", data, |path| {
        let pick = isogrid_io::AxisPick {
            indices: &index,
            flag: isogrid_io::IndexFlag::Cli("--index"),
        };
        isogrid_io::tiff::read_tiff_indexed(path, pick)
    });
});

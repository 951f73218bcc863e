//! 3D Slicer segmentations (`.seg.nrrd`): `SegmentN_` keys, layers along a 4th axis, the label
//! values they number, then the ordinary label extraction of each layer.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::init();
    let path = isogrid_fuzz::scratch_file("in.seg.nrrd", data);
    let options = isogrid_io::ReadOptions::default();
    if let Ok((labels, _)) = isogrid_io::labels::read_label_volume(&path, &options) {
        for layer in &labels.layers {
            isogrid_fuzz::check_volume(&layer.volume);
        }
        // The labels the file names are extracted as `isogrid extract --labels all` would; a
        // refusal is fine, a panic or a wrong grid is not.
        let options = isogrid::LabelOptions::new(isogrid::LabelSelection::All);
        if let Ok(grid) = isogrid_io::labels::extract_label_volume(&labels, &options) {
            let bytes = isogrid::cgc::to_bytes(&grid);
            isogrid::cgc::read_bytes(&bytes).expect("and reads back");
        }
    }
});

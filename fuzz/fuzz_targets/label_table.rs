//! Label colour tables (`--label-table`): FreeSurfer LUT, Slicer `.ctbl`, ITK-SNAP label
//! descriptions and CSV/TSV tables of named columns (BIDS `dseg.tsv`), told apart by content.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::init();
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(table) = isogrid_io::labels::parse_label_table(text) {
            for label in &table {
                assert!(!label.name.contains('\n'), "a name spans lines: {:?}", label.name);
            }
        }
    }
});

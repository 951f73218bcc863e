//! Showing and hiding labels (`CellGrid::showing_labels`, `GridLabels::shown`): the grid of a
//! label grid with some labels hidden is the grid the extraction makes of the shown labels alone,
//! slot for slot and record for record.

use isogrid::generate::labelled_ball;
use isogrid::{extract_labels, LabelOptions, LabelSelection};

fn extracted(selection: &str) -> isogrid::CellGrid {
    let volume = labelled_ball(40);
    extract_labels(
        &volume.view(),
        &LabelOptions::new(LabelSelection::parse(selection).unwrap()),
    )
    .unwrap()
}

#[test]
fn hiding_labels_gives_the_grid_of_the_others_extracted_alone() {
    let all = extracted("1-3");
    let labels = all.labels().unwrap();
    for (hide, rest) in [("2", "1,3"), ("1,3", "2"), ("3", "1-2")] {
        let shown = labels
            .shown(None, Some(&LabelSelection::parse(hide).unwrap()), false)
            .unwrap();
        let view = all.showing_labels(&shown).unwrap();
        let alone = extracted(rest);
        assert_eq!(view.metacells(), alone.metacells(), "hide {hide}");
        assert_eq!(view.cells(), alone.cells(), "hide {hide}");
        let slots = |g: &isogrid::CellGrid| -> Vec<(u32, u32)> {
            g.blocks()
                .iter()
                .map(|b| (b.metacell_count, b.metacell_pointer))
                .collect()
        };
        assert_eq!(slots(&view), slots(&alone), "hide {hide}");
        // Cluster by cluster the same label value; the hidden labels keep their entries, empty.
        let values = |g: &isogrid::CellGrid| -> Vec<u64> {
            let l = g.labels().unwrap();
            l.cluster_labels()
                .iter()
                .map(|&i| l.table()[i as usize].value)
                .collect()
        };
        assert_eq!(values(&view), values(&alone), "hide {hide}");
        let vl = view.labels().unwrap();
        for (i, label) in vl.table().iter().enumerate() {
            match alone.labels().unwrap().find(label.value) {
                Some(j) => assert_eq!(
                    vl.index()[i].cell_count,
                    alone.labels().unwrap().index()[j].cell_count
                ),
                None => assert_eq!(vl.index()[i].cell_count, 0),
            }
        }
        // The reader's checks of the label sections against the slots pass on the view.
        let again = isogrid::cgc::read_bytes(&isogrid::cgc::to_bytes(&view));
        assert!(again.is_ok(), "hide {hide}: {:?}", again.err());
    }
}

/// With an attribute, each shown cell keeps its value: the view's values are those of the grid
/// of the shown labels alone, sampled the same way, and the range stays the whole grid's.
#[test]
fn hiding_labels_keeps_each_shown_cells_attribute_value() {
    // A value per cell that names it: its position and the label of its cluster.
    let with_values = |grid: isogrid::CellGrid| {
        let labels = grid.labels().unwrap().clone();
        let mut values = Vec::new();
        for (c, cluster) in grid.metacells().chunks(16).enumerate() {
            let label = labels.table()[labels.cluster_labels()[c] as usize].value as f32;
            for m in &cluster[..15] {
                for b in 0..m.active_cells() {
                    values.push(
                        1000.0 * label
                            + (m.position[0] * 7 + m.position[1] * 3 + m.position[2]) as f32
                            + b as f32 / 8.0,
                    );
                }
            }
        }
        let attribute =
            isogrid::CellAttribute::from_values("id", isogrid::AttributePrecision::F32, &values);
        grid.with_attribute(attribute).unwrap()
    };
    let all = with_values(extracted("1-3"));
    let labels = all.labels().unwrap();
    let shown = labels
        .shown(None, Some(&LabelSelection::parse("2").unwrap()), false)
        .unwrap();
    let view = all.showing_labels(&shown).unwrap();
    let alone = with_values(extracted("1,3"));
    let (got, want) = (view.attribute().unwrap(), alone.attribute().unwrap());
    assert_eq!(got.value_bytes(), want.value_bytes());
    assert_eq!(got.info().range, all.attribute().unwrap().info().range);
    let again = isogrid::cgc::read_bytes(&isogrid::cgc::to_bytes(&view)).unwrap();
    assert_eq!(again.attribute().unwrap().value_bytes(), want.value_bytes());
}

#[test]
fn show_and_hide_name_labels_that_exist() {
    let all = extracted("1-3");
    let labels = all.labels().unwrap();
    let sel = |s: &str| LabelSelection::parse(s).unwrap();
    assert_eq!(
        labels.shown(Some(&sel("1,3")), None, false).unwrap(),
        [true, false, true]
    );
    assert_eq!(
        labels
            .shown(Some(&sel("1-3")), Some(&sel("2")), false)
            .unwrap(),
        [true, false, true]
    );
    assert_eq!(labels.shown(None, None, false).unwrap(), [true; 3]);
    // A range holding some label is accepted; a value or range holding none is refused.
    assert!(labels.shown(Some(&sel("3-9")), None, false).is_ok());
    for bad in ["7", "4-9", "0"] {
        let err = labels
            .shown(None, Some(&sel(bad)), false)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("no such label") && !err.contains('\n'),
            "{bad}: {err}"
        );
        assert!(labels.shown(Some(&sel(bad)), None, false).is_err());
    }
}

/// Labels are shown and hidden by name too (`--show liver,5-9`): a name picks every label of the
/// table that has it, in any case, as its value would; a name no label has is refused naming
/// some that exist; names are refused where labels are extracted (by value).
#[test]
fn show_and_hide_take_labels_names() {
    let all = extracted("1-3");
    let mut labels = all.labels().unwrap().clone();
    let names = ["Left-Hippocampus", "liver", "Liver"];
    let table = labels
        .table()
        .iter()
        .zip(names)
        .map(|(l, name)| isogrid::Label {
            name: name.to_string(),
            ..l.clone()
        })
        .collect();
    labels.set_table(table).unwrap();
    let named = |s: &str| LabelSelection::parse_with_names(s).unwrap();
    let shown = |show: &str, hide: Option<&str>| {
        let hide = hide.map(named);
        labels.shown(Some(&named(show)), hide.as_ref(), false)
    };
    assert_eq!(
        shown("left-hippocampus", None).unwrap(),
        [true, false, false]
    );
    assert_eq!(shown("LIVER", None).unwrap(), [false, true, true]);
    assert_eq!(shown("1, liver", Some("3")).unwrap(), [true, true, false]);
    assert_eq!(shown("all", Some("liver")).unwrap(), [true, false, false]);
    assert_eq!(
        shown("1-3", Some("Left-Hippocampus,2")).unwrap(),
        [false, false, true]
    );
    // By name as by value.
    assert_eq!(
        shown("Left-Hippocampus", None).unwrap(),
        shown("1", None).unwrap()
    );
    let err = shown("livr", None).unwrap_err().to_string();
    assert!(
        err.contains("\"livr\": no label has this name")
            && err.contains("the labels are Left-Hippocampus, liver, Liver")
            && !err.contains('\n'),
        "{err}"
    );
    assert!(shown("1", Some("spleen")).is_err());
    assert!(matches!(named("1,5-9"), LabelSelection::Values(_)));
    let err = LabelSelection::parse("liver").unwrap_err().to_string();
    assert!(err.contains("is not a whole number"), "{err}");
    assert!(LabelSelection::parse_with_names("1,,2").is_err());
    assert!(LabelSelection::parse_with_names("9-5").is_err());
}

/// Signed labels: a range across zero (`-5-5`) selects the negative and the positive labels in
/// it, when extracting, showing and hiding, and names no label when it holds none.
#[test]
fn a_signed_range_across_zero_selects_both_sides() {
    let ball = labelled_ball(24);
    let isogrid::VolumeData::U8(samples) = ball.data() else {
        panic!("labelled_ball is u8")
    };
    let signed: Vec<i16> = samples.iter().map(|&v| [0, -4, 3, 9][v as usize]).collect();
    let volume =
        isogrid::Volume::with_geometry(*ball.geometry(), isogrid::VolumeData::I16(signed)).unwrap();
    let sel = |s: &str| LabelSelection::parse(s).unwrap();
    let extract = |s: &str| extract_labels(&volume.view(), &LabelOptions::new(sel(s))).unwrap();
    let values = |g: &isogrid::CellGrid| -> Vec<i64> {
        let table = g.labels().unwrap().table();
        table.iter().map(|l| l.value as i64).collect()
    };
    // The table is in key order: positives, then negatives; a range holding 0 selects the
    // background too, as `0` does.
    assert_eq!(values(&extract("all")), [3, 9, -4]);
    assert_eq!(values(&extract("-5-5")), [0, 3, -4]);
    assert_eq!(values(&extract("-4--1,1-3")), [3, -4]);
    let all = extract("all");
    let labels = all.labels().unwrap();
    assert_eq!(
        labels.shown(Some(&sel("-5-5")), None, true).unwrap(),
        [true, false, true]
    );
    assert_eq!(
        labels.shown(None, Some(&sel("-10-100")), true).unwrap(),
        [false; 3]
    );
    let err = labels
        .shown(Some(&sel("-2-2")), None, true)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("labels -2-2: no such label"), "{err}");
}

/// A label's box for a camera (`LabelEntry::world_box`, which the viewers frame a label by): the
/// smallest box, in index × spacing, holding every cell of the label, each cell spanning its
/// samples `p` to `p + 1`.
#[test]
fn a_labels_world_box_holds_exactly_its_cells() {
    let spacing = [0.5, 1.0, 2.5];
    let ball = labelled_ball(24);
    let geometry = isogrid::Geometry {
        spacing,
        ..*ball.geometry()
    };
    let volume = isogrid::Volume::with_geometry(geometry, ball.into_data()).unwrap();
    let grid = extract_labels(&volume.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    let labels = grid.labels().unwrap();
    let mut boxes = vec![([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]); labels.table().len()];
    for (c, cluster) in grid.metacells().chunks(16).enumerate() {
        let (lo, hi) = &mut boxes[labels.cluster_labels()[c] as usize];
        for m in cluster[..15].iter().filter(|m| !m.is_empty()) {
            for bit in (0..8).filter(|b| m.cell_mask >> b & 1 != 0) {
                let p = m.cell_position(bit);
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a] as f64 * spacing[a]);
                    hi[a] = hi[a].max((p[a] + 1) as f64 * spacing[a]);
                }
            }
        }
    }
    assert!(labels.table().len() >= 3);
    for (entry, expected) in labels.index().iter().zip(&boxes) {
        assert_eq!(entry.world_box(spacing), *expected);
    }
}

/// With labels hidden, the surface box (what surface views frame) is the shown labels': it holds
/// each shown label's box (`LabelEntry::world_box`, checked against its cells above) and reaches
/// past their union by at most one cell a side.
#[test]
fn the_surface_box_of_shown_labels_holds_theirs_alone() {
    let grid = extracted("1-3");
    let labels = grid.labels().unwrap();
    let n = labels.table().len();
    let mut boxes = Vec::new();
    for shown_label in 0..n {
        let shown: Vec<bool> = (0..n).map(|l| l == shown_label).collect();
        let entry = &labels.index()[shown_label];
        let (lo, hi) = entry.world_box([1.0; 3]);
        let (blo, bhi) = grid
            .showing_labels(&shown)
            .unwrap()
            .surface_bounds()
            .unwrap();
        boxes.push((blo, bhi));
        for a in 0..3 {
            assert!(
                blo[a] <= lo[a] && blo[a] >= lo[a] - 1.0,
                "label {shown_label} axis {a}"
            );
            assert!(
                bhi[a] >= hi[a] && bhi[a] <= hi[a] + 1.0,
                "label {shown_label} axis {a}"
            );
        }
    }
    boxes.dedup();
    assert!(boxes.len() > 1, "the labels' boxes differ: {boxes:?}");
    let none = grid.showing_labels(&vec![false; n]).unwrap();
    assert_eq!(none.surface_bounds(), None);
}

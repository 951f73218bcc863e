//! Label volumes with names and colours from files written by other tools
//! (scripts/make_label_fixtures.py: slicerio, ome-zarr, SimpleITK) and from colour tables, each
//! label's cells checked against a brute-force count over the masks the script wrote.

use crate::common::{fixture, TempDir};
use isogrid::{ErrorKind, Label, LabelOptions, LabelSelection};
use isogrid_io::labels::{
    apply_label_names, extract_label_volume, label_image_path, parse_label_table, read_label_table,
    read_label_volume,
};
use isogrid_io::ReadOptions;

const DIMS: [usize; 3] = [20, 18, 16];

/// The masks of scripts/make_label_fixtures.py, in index space.
fn mask(name: char, i: usize, j: usize, k: usize) -> bool {
    let (x, y, z) = (i as i64, j as i64, k as i64);
    match name {
        'A' => (3..=12).contains(&i) && (3..=12).contains(&j) && (2..=10).contains(&k),
        'B' => (x - 11).pow(2) + (y - 10).pow(2) + (z - 8).pow(2) <= 16,
        'C' => (14..=17).contains(&i) && (2..=15).contains(&j) && (3..=12).contains(&k),
        'D' => (i, j, k) == (1, 16, 14),
        _ => unreachable!(),
    }
}

/// Cells whose eight corners are neither all in the mask nor all out: a label's active cells.
fn brute_force_cells(name: char) -> u64 {
    let mut count = 0;
    for k in 0..DIMS[2] - 1 {
        for j in 0..DIMS[1] - 1 {
            for i in 0..DIMS[0] - 1 {
                let inside = (0..8)
                    .filter(|c| mask(name, i + (c & 1), j + (c >> 1 & 1), k + (c >> 2)))
                    .count();
                count += (inside != 0 && inside != 8) as u64;
            }
        }
    }
    count
}

fn label(value: u64, name: &str, rgba: [u8; 4]) -> Label {
    Label {
        value,
        name: name.into(),
        rgba,
    }
}

/// (value, name, colour, active cells) of every label of a grid.
fn summary(grid: &isogrid::CellGrid) -> Vec<(u64, String, [u8; 4], u64)> {
    let labels = grid.labels().expect("a label grid");
    labels
        .table()
        .iter()
        .zip(labels.index())
        .map(|(l, e)| (l.value, l.name.clone(), l.rgba, e.cell_count))
        .collect()
}

fn extract(path: &std::path::Path, selection: &str) -> isogrid::CellGrid {
    let (source, _) = read_label_volume(path, &ReadOptions::default()).unwrap();
    extract_label_volume(
        &source,
        &LabelOptions::new(LabelSelection::parse(selection).unwrap()),
    )
    .unwrap()
}

// Slicer's colours are floats 0..1: 0.2 0.4 0.6 is (51, 102, 153).
const LIVER: [u8; 4] = [51, 102, 153, 255];
const VEIN: [u8; 4] = [255, 0, 51, 255];
const LESION: [u8; 4] = [204, 204, 0, 255];
const TUMOUR: [u8; 4] = [0, 153, 255, 255];

#[test]
fn slicer_segmentation_names_and_colours_its_segments() {
    let path = fixture("labels/one_layer.seg.nrrd");
    let (source, _) = read_label_volume(&path, &ReadOptions::default()).unwrap();
    assert_eq!(source.layers.len(), 1);
    assert_eq!(
        source.names,
        [
            label(1, "liver", LIVER),
            label(2, "portal vein", VEIN),
            label(3, "lesion 3", LESION)
        ]
    );
    let grid = extract(&path, "all");
    assert_eq!(
        summary(&grid),
        [
            (1, "liver".into(), LIVER, brute_force_cells('A')),
            (2, "portal vein".into(), VEIN, brute_force_cells('C')),
            (3, "lesion 3".into(), LESION, brute_force_cells('D')),
        ]
    );
}

#[test]
fn layered_slicer_segmentation_keeps_overlapping_segments_whole() {
    // slicerio put the tumour (B), which overlaps the liver (A), in layer 1 with value 1; layer
    // 0's largest value is 3, so it is label 4.
    let path = fixture("labels/two_layers.seg.nrrd");
    let (source, _) = read_label_volume(&path, &ReadOptions::default()).unwrap();
    assert_eq!(source.layers.len(), 2);
    assert_eq!(
        source.layers.iter().map(|l| l.offset).collect::<Vec<_>>(),
        [0, 3]
    );
    assert_eq!(source.names[3], label(4, "tumour", TUMOUR));
    let grid = extract(&path, "all");
    assert_eq!(
        summary(&grid),
        [
            (1, "liver".into(), LIVER, brute_force_cells('A')),
            (2, "portal vein".into(), VEIN, brute_force_cells('C')),
            (3, "lesion 3".into(), LESION, brute_force_cells('D')),
            (4, "tumour".into(), TUMOUR, brute_force_cells('B')),
        ]
    );
    // Selections are of the file's labels, across layers.
    let some = extract(&path, "2,4");
    let values: Vec<u64> = summary(&some).iter().map(|s| s.0).collect();
    assert_eq!(values, [2, 4]);
    assert_eq!(summary(&some)[1].3, brute_force_cells('B'));
    // The joined grid is a valid label grid: written and read back, its sections check out.
    let dir = TempDir::new("seg-layers");
    let out = dir.path("seg.cgc");
    isogrid::cgc::write(&out, &grid).unwrap();
    let back = isogrid::cgc::read(&out).unwrap();
    assert_eq!(summary(&back), summary(&grid));
    assert_eq!(back.active_cells(), grid.active_cells());
    // As one volume, a layered file is refused in one line rather than read as its first layer.
    let err = isogrid_io::read_volume(&path, &ReadOptions::default()).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Unsupported, "{err}");
    assert!(
        err.to_string().contains("2 volumes along its first axis"),
        "{err}"
    );
}

#[test]
fn ome_zarr_label_images_give_colours_and_names() {
    for (image, version) in [("ome_v05.zarr", "0.5"), ("ome_v04.zarr", "0.4")] {
        let image = fixture(&format!("labels/{image}"));
        let path = label_image_path(&image, "cells").unwrap();
        let (source, _) = read_label_volume(&path, &ReadOptions::default()).unwrap();
        // 0.5 names labels by a `name` property, the 0.4 file by `cell name`.
        assert_eq!(
            source.names,
            [
                label(1, "nucleus", [255, 0, 0, 255]),
                label(2, "cytoplasm", [0, 128, 255, 200]),
                label(7, "label 7", [10, 20, 30, 255]),
            ],
            "OME-Zarr {version}"
        );
        let grid = extract(&path, "all");
        assert_eq!(
            summary(&grid),
            [
                (
                    1,
                    "nucleus".into(),
                    [255, 0, 0, 255],
                    brute_force_cells('A')
                ),
                (
                    2,
                    "cytoplasm".into(),
                    [0, 128, 255, 200],
                    brute_force_cells('C')
                ),
                (
                    7,
                    "label 7".into(),
                    [10, 20, 30, 255],
                    brute_force_cells('D')
                ),
            ],
            "OME-Zarr {version}"
        );
        // A name the image does not have: the error lists those it has.
        let err = label_image_path(&image, "nuclei").unwrap_err();
        assert_eq!(err.kind(), ErrorKind::InvalidInput);
        assert!(err.to_string().contains("\"cells\""), "{err}");
        // The image itself has no label images below it.
        let err = label_image_path(&path, "cells").unwrap_err();
        assert!(
            err.to_string().contains("no OME-Zarr label images"),
            "{err}"
        );
    }
}

/// An excerpt of FreeSurferColorLUT.txt as FreeSurfer ships it (fourth column 0: opaque).
const FREESURFER: &str = "\
#$Id: FreeSurferColorLUT.txt,v 1.105 2015/07/29 18:24:59 zkaufman Exp $

#No. Label Name:                            R   G   B   A

0   Unknown                                 0   0   0   0
1   Left-Cerebral-Exterior                  70  130 180 0
2   Left-Cerebral-White-Matter              245 245 245 0
3   Left-Cerebral-Cortex                    205 62  78  0
";

/// A 3D Slicer colour table (`.ctbl`): the fourth column is alpha.
const SLICER: &str = "\
# Color table file /tmp/GenericAnatomyColors.ctbl
# 4 values
0 Background 0 0 0 0
1 tissue 128 174 128 255
2 bone 241 214 145 255
3 skin 177 122 101 128
";

/// An ITK-SNAP label description, as ITK-SNAP saves it.
const ITK_SNAP: &str = "\
################################################
# ITK-SnAP Label Description File
# File format:
# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL
# Fields:
#    IDX:   Zero-based index
#    -R-:   Red color component (0..255)
#    -G-:   Green color component (0..255)
#    -B-:   Blue color component (0..255)
#    -A-:   Label transparency (0.00 .. 1.00)
#    VIS:   Label visibility (0 or 1)
#    IDX:   Label mesh visibility (0 or 1)
#  LABEL:   Label description
################################################
    0     0    0    0        0  0  0    \"Clear Label\"
    1   255    0    0        1  1  1    \"Left hippocampus\"
    2     0  255    0      0.5  1  1    \"Right hippocampus\"
";

#[test]
fn colour_tables_in_three_formats_are_told_apart_by_content() {
    assert_eq!(
        parse_label_table(FREESURFER).unwrap(),
        [
            label(0, "Unknown", [0, 0, 0, 255]),
            label(1, "Left-Cerebral-Exterior", [70, 130, 180, 255]),
            label(2, "Left-Cerebral-White-Matter", [245, 245, 245, 255]),
            label(3, "Left-Cerebral-Cortex", [205, 62, 78, 255]),
        ]
    );
    assert_eq!(
        parse_label_table(SLICER).unwrap(),
        [
            label(0, "Background", [0, 0, 0, 0]),
            label(1, "tissue", [128, 174, 128, 255]),
            label(2, "bone", [241, 214, 145, 255]),
            label(3, "skin", [177, 122, 101, 128]),
        ]
    );
    assert_eq!(
        parse_label_table(ITK_SNAP).unwrap(),
        [
            label(0, "Clear Label", [0, 0, 0, 0]),
            label(1, "Left hippocampus", [255, 0, 0, 255]),
            label(2, "Right hippocampus", [0, 255, 0, 128]),
        ]
    );
}

/// A BIDS `dseg.tsv` as the BIDS specification shows it (derivatives, "Common data types"):
/// `index`, `name`, `abbreviation`, `color`, with `n/a` where a value is missing.
const BIDS_DSEG: &str = "index\tname\tabbreviation\tcolor\tmapping\n\
    0\tBackground\tBG\t#000000\t0\n\
    1\tGray Matter\tGM\t#ff53bb\t1\n\
    2\tWhite Matter\tWM\t#2f8bbe\t2\n\
    3\tCerebrospinal Fluid\tCSF\tn/a\t3\n";

#[test]
fn column_tables_name_their_columns_in_a_header() {
    // BIDS: tab-separated, hex colours; a missing colour is the label's default.
    assert_eq!(
        parse_label_table(BIDS_DSEG).unwrap(),
        [
            label(0, "Background", [0, 0, 0, 255]),
            label(1, "Gray Matter", [0xff, 0x53, 0xbb, 255]),
            label(2, "White Matter", [0x2f, 0x8b, 0xbe, 255]),
            label(3, "Cerebrospinal Fluid", isogrid::labels::palette(3)),
        ]
    );
    // An atlas's CSV (abagen's columns): `id` and `label` name it, no colour, other columns
    // ignored; a UTF-8 byte order mark and out-of-order rows.
    assert_eq!(
        parse_label_table(
            "\u{feff}id,label,hemisphere,structure\n35,insula,L,cortex\n1,bankssts,L,cortex\n"
        )
        .unwrap(),
        [
            label(1, "bankssts", isogrid::labels::palette(1)),
            label(35, "insula", isogrid::labels::palette(35)),
        ]
    );
    // r, g, b and alpha columns in any case; a quoted name holding the delimiter; `label` as the
    // value column beside `name`; an empty name keeps the default, with the value as written.
    assert_eq!(
        parse_label_table(
            "# exported\nLabel,Name,R,G,B,Alpha\n-2,\"Left, inferior\",1,2,3,128\n7,,4,5,6,\n"
        )
        .unwrap(),
        [
            label(7, "label 7", [4, 5, 6, 255]),
            label(-2i64 as u64, "Left, inferior", [1, 2, 3, 128]),
        ]
    );
}

#[test]
fn a_table_names_the_labels_it_lists_and_reports_the_others() {
    let mut grid = extract(&fixture("labels/one_layer.seg.nrrd"), "all");
    // The table names 1 and 3 and lists 9, which the volume does not hold, and 0.
    let table =
        parse_label_table("0 bg 0 0 0 0\n1 one 1 2 3 255\n3 three 4 5 6 7\n9 nine 9 9 9 255\n")
            .unwrap();
    let absent = apply_label_names(&mut grid, &table);
    assert_eq!(absent, [9]);
    let s = summary(&grid);
    assert_eq!((s[0].1.as_str(), s[0].2), ("one", [1, 2, 3, 255]));
    assert_eq!(
        (s[1].1.as_str(), s[1].2),
        ("portal vein", VEIN),
        "unlisted: the file's"
    );
    assert_eq!((s[2].1.as_str(), s[2].2), ("three", [4, 5, 6, 7]));
    let notice = |selection: &LabelSelection| {
        isogrid_io::labels::absent_labels_notice(
            std::path::Path::new("t.txt"),
            &absent,
            selection,
            false,
        )
    };
    assert_eq!(
        notice(&LabelSelection::All).unwrap(),
        "t.txt: 1 label of the table is not among the labels extracted (9)"
    );
    // A label the selection leaves out is not missing.
    assert_eq!(notice(&LabelSelection::Values(vec![1..=3])), None);
    assert!(notice(&LabelSelection::Values(vec![1..=9])).is_some());
}

#[test]
fn malformed_tables_name_the_file_and_line() {
    let dir = TempDir::new("label-tables");
    for (text, line, what) in [
        (
            "0 bg 0 0 0 0\n1 one 1 2 300 0\n",
            2,
            "colour component \"300\"",
        ),
        ("# c\n\n1 one 1 2\n", 3, "4 fields"),
        ("x one 1 2 3 0\n", 1, "label value \"x\""),
        ("1 a 1 2 3 0\n1 b 1 2 3 0\n", 2, "label 1 is listed twice"),
        (
            "1 1 2 3 1 1 1 \"a\"\n2 b 1 2 3 0\n",
            2,
            "mixes ITK-SNAP lines",
        ),
        ("1 1 2 3 2 1 1 \"a\"\n", 1, "opacity \"2\""),
        ("1 1 2 3 1 1 \"a\"\n", 1, "6 fields before the name"),
        ("1 1 2 3 1 1 1 \"a\" x\n", 1, "one quoted string at the end"),
        (
            "1,bankssts\n2,cuneus\n",
            1,
            "starts with a header naming its columns",
        ),
        ("name,color\nx,#ffffff\n", 1, "no column of label values"),
        (
            "index,name,r,g\n1,x,1,2\n",
            1,
            "r, g and b but not all three",
        ),
        ("index,name,color\n1,x,#fff\n", 2, "colour \"#fff\""),
        (
            "index,name,color\n1,x,#ffffff\n2,y\n",
            3,
            "2 fields, where the header names 3",
        ),
        ("index\tname\n1\tx\n1\ty\n", 3, "label 1 is listed twice"),
        ("index,name\n1,\"two\nlines\"\n", 2, "line break"),
        ("id,name\nfirst,x\n", 2, "label value \"first\""),
    ] {
        let path = dir.file("table.txt", text.as_bytes());
        let err = read_label_table(&path).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
        let message = err.to_string();
        assert!(
            message.starts_with(&format!("{}: label table line {line}: ", path.display())),
            "{message}"
        );
        assert!(message.contains(what), "{message}");
        assert!(!message.contains('\n'), "{message}");
    }
    let err = read_label_table(&dir.path("absent.txt")).unwrap_err();
    assert!(err.to_string().contains("absent.txt"), "{err}");
}

#[test]
fn a_float_volume_is_a_label_volume_only_when_its_values_are_integers() {
    let dir = TempDir::new("float-labels");
    let data: Vec<f32> = (0..27).map(|i| if i == 13 { 2.5 } else { 1.0 }).collect();
    let volume = isogrid::Volume::new([3, 3, 3], isogrid::VolumeData::F32(data)).unwrap();
    let path = dir.path("f.nrrd");
    isogrid_io::write_nrrd(&path, &volume).unwrap();
    let (source, _) = read_label_volume(&path, &ReadOptions::default()).unwrap();
    let err = extract_label_volume(&source, &LabelOptions::new(LabelSelection::All)).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::InvalidInput);
    assert!(err.to_string().contains("2.5"), "{err}");
}

#[test]
fn a_fourth_nrrd_axis_is_read_only_as_leading_layers() {
    let dir = TempDir::new("nrrd-4d");
    let data = [0u8; 2 * 2 * 2 * 2];
    for (directions, what) in [
        // A spatial first axis (a time series, say): not layers.
        (
            "space dimension: 3\nspace directions: (1,0,0) (0,1,0) (0,0,1) (1,1,1)\n",
            "NRRD dimension 4 is not supported",
        ),
        // No space directions at all: nothing says which axis is the list.
        ("", "NRRD dimension 4 is not supported"),
    ] {
        let head = format!(
            "NRRD0004\ntype: uint8\ndimension: 4\nsizes: 2 2 2 2\n{directions}encoding: raw\n\n"
        );
        let path = dir.file("four.seg.nrrd", &[head.as_bytes(), &data].concat());
        let err = read_label_volume(&path, &ReadOptions::default())
            .err()
            .expect("refused");
        assert_eq!(err.kind(), ErrorKind::Unsupported, "{err}");
        assert!(err.to_string().contains(what), "{err}");
    }
    // A segment in a layer the file lacks, and a colour that is not three numbers 0..1.
    let head = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
    for (keys, what) in [
        (
            "Segment0_Layer:=1\n",
            "Segment0_Layer 1 is beyond the file's 1 layer",
        ),
        (
            "Segment0_Color:=0.5 2 0\n",
            "Segment0_Color \"0.5 2 0\" is not three numbers 0..1",
        ),
    ] {
        let text = format!("{head}{keys}\n");
        let path = dir.file("bad.seg.nrrd", &[text.as_bytes(), &data[..8]].concat());
        let err = read_label_volume(&path, &ReadOptions::default())
            .err()
            .expect("refused");
        assert_eq!(err.kind(), ErrorKind::Corrupt, "{err}");
        assert!(err.to_string().contains(what), "{err}");
        assert!(err.to_string().contains("bad.seg.nrrd"), "{err}");
    }
}

/// Real label volumes streamed slab by slab give the in-memory file byte for byte: the abagen
/// Desikan-Killiany atlas (83 labels) and PyVista's frog tissues (25 labels), fetched by
/// `scripts/fetch_data.sh atlas frog`, one-layer slabs with small runs and four-layer slabs, with
/// and without smoothing (a halo of 3 planes).
#[test]
fn real_label_volumes_stream_to_the_in_memory_bytes() {
    use isogrid::extract::label_stream::extract_labels_planned;
    let dir = TempDir::new("labels-real-stream");
    let out = dir.path("out.cgc");
    for (name, file, labels) in [
        ("atlas", "atlas-desikankilliany.nii.gz", 83),
        ("frog", "frog_tissues.vti", 25),
    ] {
        let path = crate::common::real_data(name, file);
        let volume = isogrid_io::read_volume(&path, &ReadOptions::default()).unwrap();
        for smooth in [0.0, 1.0] {
            let mut options = LabelOptions::new(LabelSelection::All);
            options.smooth = smooth;
            let grid = isogrid::extract_labels(&volume.view(), &options).unwrap();
            assert_eq!(grid.labels().unwrap().table().len(), labels);
            let expected = isogrid::cgc::to_bytes(&grid);
            for (layers, buffer) in [(1, 1 << 16), (4, 1 << 20)] {
                extract_labels_planned(
                    &mut volume.view(),
                    &options,
                    &crate::region::plan(layers, buffer),
                    &out,
                    &isogrid::Progress::new(),
                    &mut |_| {},
                )
                .unwrap();
                assert!(
                    std::fs::read(&out).unwrap() == expected,
                    "{}: σ {smooth}, {layers}-layer slabs",
                    path.display()
                );
            }
        }
    }
}

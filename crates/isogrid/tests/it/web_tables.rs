//! The browser viewer's colour data and rules come from this crate, not from copies typed into
//! TypeScript: this test writes `web/src/colormaps.generated.ts` (the colour maps' tables, the NaN
//! colour and the sRGB → linear decoding, which the viewer uploads as `ColorUniforms` and label
//! albedos, and the corner precisions its `.cgc` reader accepts) and `web/test/rules.generated.json` (input/output vectors of the attribute code rule,
//! the default colour range, the empty-surface note and whether directions mirror the world, which
//! the viewer's own `codes16`, `defaultClim`, `emptySurfaceNote` and `directionsMirror` must reproduce: `web/test/cgc.test.mjs`). It fails while a committed file differs from what
//! `isogrid::colormap` and `isogrid::attribute` give; `ISOGRID_BLESS=1 cargo test -p isogrid --test
//! it web_tables` rewrites them.

use isogrid::colormap::{srgb8_to_linear, ColorMap, Coloring, NAN_SRGB, TABLE_SIZE};
use isogrid::{AttributePrecision, CellAttribute, Precision};
use std::fmt::Write;
use std::path::PathBuf;

fn web() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../web"))
}

fn tables_ts() -> String {
    let mut s = String::new();
    s += "// Generated from isogrid::colormap by crates/isogrid/tests/it/web_tables.rs: do not edit.\n";
    s += "// `ISOGRID_BLESS=1 cargo test -p isogrid --test it web_tables` rewrites it; that test fails while\n";
    s += "// it is stale.\n\n";
    s += "/** Entries of a colour table (`colormap::TABLE_SIZE`). */\n";
    writeln!(s, "export const TABLE_SIZE = {TABLE_SIZE};").unwrap();
    s += "/** sRGB colour of NaN values (`colormap::NAN_SRGB`). */\n";
    writeln!(
        s,
        "export const NAN_SRGB: [number, number, number] = [{}, {}, {}];",
        NAN_SRGB[0], NAN_SRGB[1], NAN_SRGB[2]
    )
    .unwrap();
    s += "/**\n * The colour maps (`ColorMap::ALL`, the first the default): name, and entry i (the colour at\n";
    s += " * i / 255) as sRGB `rrggbb` hex, one after another.\n */\n";
    s += "export const COLOR_MAPS: [string, string][] = [\n";
    for map in ColorMap::ALL {
        let hex: String = map
            .table()
            .iter()
            .map(|[r, g, b]| format!("{r:02x}{g:02x}{b:02x}"))
            .collect();
        writeln!(s, "  ['{}', '{hex}'],", map.name()).unwrap();
    }
    s += "];\n";
    s += "/** `colormap::srgb8_to_linear` of 0..=255, as f32. */\n";
    s += "export const SRGB8_TO_LINEAR = new Float32Array([\n";
    for row in (0..=255u8).collect::<Vec<_>>().chunks(8) {
        let line: Vec<String> = row
            .iter()
            .map(|&v| format!("{:?}", srgb8_to_linear(v)))
            .collect();
        writeln!(s, "  {},", line.join(", ")).unwrap();
    }
    s += "]);\n";
    s += "/** Bits per stored corner a `.cgc` file may give (`layout::Precision::ALL`). */\n";
    let bits: Vec<String> = Precision::ALL
        .iter()
        .map(|p| p.bits().to_string())
        .collect();
    writeln!(
        s,
        "export const CORNER_PRECISION_BITS = [{}];",
        bits.join(", ")
    )
    .unwrap();
    s
}

/// A JSON number for an f32 or f64 (`null` for NaN), in the shortest form that reads back the same.
fn num<T: std::fmt::Debug + Into<f64> + Copy>(v: T) -> String {
    if v.into().is_nan() {
        "null".into()
    } else {
        format!("{v:?}")
    }
}

fn rules_json() -> String {
    // Values that exercise the rule: the ends, clamping, halves, NaN, and a single-valued range.
    let sets: [(&str, Vec<f32>); 4] = [
        (
            "ramp",
            vec![-2.5, -1.0, 0.0, 0.1, 1.0 / 3.0, 0.5, 2.0, 7.25, 10.0],
        ),
        ("with NaN", vec![3.0, f32::NAN, 4.0, 3.000_1, 3.999_9]),
        ("one value", vec![5.0, 5.0, f32::NAN]),
        ("none finite", vec![f32::NAN, f32::NAN]),
    ];
    let mut cases = Vec::new();
    for (name, values) in &sets {
        for precision in AttributePrecision::ALL {
            let a = CellAttribute::from_values(name, precision, values);
            let stored: Vec<String> = (0..a.len()).map(|i| num(a.value(i))).collect();
            let (codes, m) = a.codes16();
            let info = a.info();
            cases.push(format!(
                "    {{\"name\": \"{name}\", \"bits\": {}, \"range\": [{}, {}], \"values\": [{}], \"codes\": [{}], \"zero\": {}, \"step\": {}, \"nan_code\": {}}}",
                precision.bits(),
                num(info.range[0]),
                num(info.range[1]),
                stored.join(", "),
                codes.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(", "),
                num(m.zero),
                num(m.step),
                m.nan_code
            ));
        }
    }
    let clims: Vec<String> = [
        [0.0, 1.0],
        [-3.5, 2.0],
        [5.0, 5.0],
        [0.0, 0.0],
        [-4e7, -4e7],
    ]
    .into_iter()
    .map(|r| {
        let c = Coloring::default_clim(r);
        format!(
            "    {{\"range\": [{}, {}], \"clim\": [{}, {}]}}",
            num(r[0]),
            num(r[1]),
            num(c[0]),
            num(c[1])
        )
    })
    .collect();
    format!(
        "{{\n  \"generated_by\": \"crates/isogrid/tests/it/web_tables.rs (ISOGRID_BLESS=1 to rewrite)\",\n  \"codes16\": [\n{}\n  ],\n  \"default_clim\": [\n{}\n  ],\n  \"empty_notes\": [\n{}\n  ],\n  \"mirrored_axes\": [\n{}\n  ]\n}}\n",
        cases.join(",\n"),
        clims.join(",\n"),
        empty_notes().join(",\n"),
        mirrored_axes().join(",\n")
    )
}

/// Grids without a surface, extracted from small volumes, and the note `GridInfo::empty_surface_note`
/// gives each (for a file: the volume not at hand), which the viewer's `emptySurfaceNote` must
/// reproduce from the header and label values: isovalues above and below the samples, f32 and
/// f64 ranges whose shortest text is long or would take an exponent, a volume one sample thick,
/// and label volumes filled by one label (unsigned and signed), holding none, one plane thick, and
/// a label that smoothing erases.
fn empty_notes() -> Vec<String> {
    use isogrid::{extract, extract_labels, ExtractOptions, Iso, LabelOptions, LabelSelection};
    use isogrid::{Volume, VolumeData};
    let n = 4 * 4 * 4;
    let ramp = |lo: f64, hi: f64| (0..n).map(move |i| lo + (hi - lo) * i as f64 / (n - 1) as f64);
    let volume = |dims: [usize; 3], data: VolumeData| Volume::new(dims, data).unwrap();
    let isosurfaces = [
        (
            volume(
                [4; 3],
                VolumeData::U8(ramp(3.0, 250.0).map(|v| v as u8).collect()),
            ),
            300.0,
        ),
        (
            volume(
                [4; 3],
                VolumeData::U8(ramp(3.0, 250.0).map(|v| v as u8).collect()),
            ),
            2.5,
        ),
        (
            volume(
                [4; 3],
                VolumeData::F32(ramp(-12.976177, 8.0).map(|v| v as f32).collect()),
            ),
            9.0,
        ),
        (
            volume([4; 3], VolumeData::F64(ramp(1.5e-7, 2.5e21).collect())),
            3e21,
        ),
        (
            volume([4; 3], VolumeData::F64(ramp(-0.1, 0.2).collect())),
            -0.25,
        ),
        (volume([1, 4, 4], VolumeData::U8(vec![9; 16])), 5.0),
    ];
    let mut speck = vec![0u8; n];
    speck[21] = 4;
    let label_volumes = [
        (volume([4; 3], VolumeData::U8(vec![7; n])), 0.0),
        (volume([4; 3], VolumeData::I16(vec![-5; n])), 0.0),
        (volume([4; 3], VolumeData::U16(vec![0; n])), 0.0),
        (volume([4, 4, 1], VolumeData::U8(vec![3; 16])), 0.0),
        (volume([4; 3], VolumeData::U8(speck)), 1.5),
    ];
    let mut grids = Vec::new();
    for (v, iso) in &isosurfaces {
        grids.push(extract(&v.view(), &ExtractOptions::new(Iso::Value(*iso))).unwrap());
    }
    for (v, smooth) in &label_volumes {
        let mut options = LabelOptions::new(LabelSelection::All);
        options.smooth = *smooth;
        grids.push(extract_labels(&v.view(), &options).unwrap());
    }
    grids
        .iter()
        .map(|grid| {
            assert_eq!(grid.active_cells(), 0);
            let info = grid.info();
            let labels = grid.labels().map(|l| l.table());
            let values = labels.map_or("null".to_string(), |t| {
                let v: Vec<String> = t.iter().map(|l| format!("\"{}\"", l.value)).collect();
                format!("[{}]", v.join(", "))
            });
            format!(
                "    {{\"dims\": {:?}, \"scalar_type\": \"{}\", \"value_range\": [{}, {}], \"iso\": {}, \"precision_bits\": {}, \"labels\": {values}, \"note\": {:?}}}",
                info.dims,
                info.scalar_type.name(),
                num(info.value_range[0]),
                num(info.value_range[1]),
                num(info.iso),
                info.precision.bits(),
                info.empty_surface_note(labels, || false)
            )
        })
        .collect()
}

/// Directions and whether `isogrid::directions_mirror` says they mirror the world, which the
/// viewer's `directionsMirror` must reproduce (it mirrors the camera by it): the standard
/// radiological orientations (RAS, LAS, LIA, RAI, LPS), an oblique rotation, oblique mirrors, a
/// degenerate matrix.
fn mirrored_axes() -> Vec<String> {
    use isogrid::directions_mirror;
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let (c, s) = (0.8f64, 0.6f64);
    let directions: [[[f64; 3]; 3]; 9] = [
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
        [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]],
        [[h, h, 0.0], [h, -h, 0.0], [0.0, 0.0, 1.0]],
        [[0.0, 0.0, -1.0], [-h, h, 0.0], [h, h, 0.0]],
        [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
    ];
    directions
        .iter()
        .map(|d| {
            format!(
                "    {{\"direction\": {d:?}, \"mirrors\": {}}}",
                directions_mirror(d)
            )
        })
        .collect()
}

#[test]
fn web_tables_are_generated_from_the_colour_maps_and_attribute_rules() {
    let bless = std::env::var_os("ISOGRID_BLESS").is_some();
    for (path, fresh) in [
        (web().join("src/colormaps.generated.ts"), tables_ts()),
        (web().join("test/rules.generated.json"), rules_json()),
    ] {
        if bless {
            std::fs::write(&path, &fresh).unwrap();
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            committed == fresh,
            "{} is stale: ISOGRID_BLESS=1 cargo test -p isogrid --test it web_tables, then rebuild web/dist",
            path.display()
        );
    }
}

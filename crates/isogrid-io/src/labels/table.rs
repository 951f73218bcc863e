//! Colour tables that name and colour labels, as `isogrid extract --label-table FILE` reads them:
//! FreeSurfer's `FreeSurferColorLUT.txt`, 3D Slicer's `.ctbl` and ITK-SNAP's label description.
//!
//! The format is told from the content, not the name:
//!
//! - **ITK-SNAP** (a line's name is a quoted string): `IDX R G B A VIS MSH "LABEL"`, colours 0..255,
//!   `A` the opacity 0..1.
//! - **FreeSurfer LUT / Slicer `.ctbl`**: `ID NAME R G B [A]`, the name one word, colours 0..255. The
//!   two formats write the same columns with opposite meanings of the last one: Slicer's is the
//!   alpha, FreeSurfer's the transparency (its tables hold 0 everywhere, opaque). A table whose
//!   fourth colour column is 0 on every line (or absent) is read as FreeSurfer's, every label
//!   opaque; otherwise the column is the alpha.
//!
//! `#` starts a comment line in all three. A line that does not parse is an error naming the file
//! and the line.

use isogrid::{Error, Label, Result};
use std::path::Path;

/// Reads a colour table file into labels (value, name, sRGB colour), in increasing value.
pub fn read_label_table(path: &Path) -> Result<Vec<Label>> {
    use std::io::Read;
    const MAX_BYTES: u64 = 64 << 20;
    let mut bytes = Vec::new();
    isogrid::fs::open_regular(path)?
        .take(MAX_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(e).with_path(path))?;
    if bytes.len() as u64 > MAX_BYTES {
        return Err(Error::too_large("a label table is at most 64 MiB").with_path(path));
    }
    let text = std::str::from_utf8(&bytes).map_err(|_| {
        Error::corrupt("a label table is text, and this is not UTF-8").with_path(path)
    })?;
    parse_label_table(text).map_err(|e| e.with_path(path))
}

/// One table line before the alpha convention is settled.
struct Row {
    line: usize,
    value: u64,
    name: String,
    rgb: [u8; 3],
    /// The fourth colour column as written (`None` when absent).
    fourth: Option<f64>,
}

/// Parses a colour table's text (see the module documentation); errors name the line.
pub fn parse_label_table(text: &str) -> Result<Vec<Label>> {
    let lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let mut itk_snap = None;
    let mut rows = Vec::new();
    for (line, text) in lines {
        let quoted = text.contains('"');
        // Every line of a file is in its first line's format.
        if *itk_snap.get_or_insert(quoted) != quoted {
            return Err(bad(
                line,
                "mixes ITK-SNAP lines (a quoted name) with `ID NAME R G B A` lines",
            ));
        }
        rows.push(if quoted {
            itk_snap_row(line, text)?
        } else {
            lut_row(line, text)?
        });
    }
    let itk_snap = itk_snap.unwrap_or(false);
    // FreeSurfer's fourth column is a transparency left at 0; Slicer's is the alpha.
    let freesurfer = !itk_snap && rows.iter().all(|r| r.fourth.unwrap_or(0.0) == 0.0);
    let mut labels: Vec<Label> = Vec::with_capacity(rows.len());
    rows.sort_by_key(|r| r.value);
    for r in rows {
        if labels.last().is_some_and(|l| l.value == r.value) {
            return Err(bad(
                r.line,
                &format!("label {} is listed twice", r.value as i64),
            ));
        }
        let alpha = match (itk_snap, freesurfer, r.fourth) {
            (true, _, Some(a)) => (a * 255.0).round() as u8,
            (false, false, Some(a)) => a as u8,
            _ => 255,
        };
        labels.push(Label {
            value: r.value,
            name: r.name,
            rgba: [r.rgb[0], r.rgb[1], r.rgb[2], alpha],
        });
    }
    Ok(labels)
}

fn bad(line: usize, what: &str) -> Error {
    Error::corrupt(format!("label table line {line}: {what}"))
}

/// A label value: an integer (negative ones as their two's complement, as a signed volume's keys).
fn value(line: usize, text: &str) -> Result<u64> {
    text.parse::<i64>()
        .map(|v| v as u64)
        .or_else(|_| text.parse::<u64>())
        .map_err(|_| bad(line, &format!("label value {text:?} is not an integer")))
}

fn channel(line: usize, text: &str) -> Result<u8> {
    text.parse::<u8>().map_err(|_| {
        bad(
            line,
            &format!("colour component {text:?} is not an integer 0..255"),
        )
    })
}

/// `ID NAME R G B [A]` (FreeSurfer LUT, Slicer `.ctbl`).
fn lut_row(line: usize, text: &str) -> Result<Row> {
    let fields: Vec<&str> = text.split_whitespace().collect();
    if !(5..=6).contains(&fields.len()) {
        return Err(bad(
            line,
            &format!("{} fields, expected `ID NAME R G B A`", fields.len()),
        ));
    }
    let rgb = [
        channel(line, fields[2])?,
        channel(line, fields[3])?,
        channel(line, fields[4])?,
    ];
    let fourth = match fields.get(5) {
        Some(a) => Some(channel(line, a)? as f64),
        None => None,
    };
    Ok(Row {
        line,
        value: value(line, fields[0])?,
        name: fields[1].to_string(),
        rgb,
        fourth,
    })
}

/// `IDX R G B A VIS MSH "LABEL"` (ITK-SNAP label description).
fn itk_snap_row(line: usize, text: &str) -> Result<Row> {
    let open = text.find('"').expect("the line has a quote");
    let name = text[open + 1..]
        .strip_suffix('"')
        .filter(|n| !n.contains('"'))
        .ok_or_else(|| bad(line, "the label's name is not one quoted string at the end"))?;
    let fields: Vec<&str> = text[..open].split_whitespace().collect();
    if fields.len() != 7 {
        return Err(bad(
            line,
            &format!(
                "{} fields before the name, expected `IDX R G B A VIS MSH`",
                fields.len()
            ),
        ));
    }
    let alpha: f64 = fields[4]
        .parse()
        .ok()
        .filter(|a| (0.0..=1.0).contains(a))
        .ok_or_else(|| {
            bad(
                line,
                &format!("opacity {:?} is not a number 0..1", fields[4]),
            )
        })?;
    Ok(Row {
        line,
        value: value(line, fields[0])?,
        name: name.to_string(),
        rgb: [
            channel(line, fields[1])?,
            channel(line, fields[2])?,
            channel(line, fields[3])?,
        ],
        fourth: Some(alpha),
    })
}

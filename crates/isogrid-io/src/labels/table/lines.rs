//! Colour tables of one label per line, told apart by content:
//!
//! - **ITK-SNAP** (a line's name is a quoted string): `IDX R G B A VIS MSH "LABEL"`, colours 0..255,
//!   `A` the opacity 0..1.
//! - **FreeSurfer LUT / Slicer `.ctbl`**: `ID NAME R G B [A]`, the name one word, colours 0..255. The
//!   two formats write the same columns with opposite meanings of the last one: Slicer's is the
//!   alpha, FreeSurfer's the transparency (its tables hold 0 everywhere, opaque). A table whose
//!   fourth colour column is 0 on every line (or absent) is read as FreeSurfer's, every label
//!   opaque; otherwise the column is the alpha.
//!
//! `#` starts a comment line in all three.

use super::text::{bad, channel, value};
use isogrid::{Label, Result};

/// One table line before the alpha convention is settled.
struct Row {
    line: usize,
    value: u64,
    name: String,
    rgb: [u8; 3],
    /// The fourth colour column as written (`None` when absent).
    fourth: Option<f64>,
}

/// The labels of a table of one label per line, each with its line, in the file's order.
pub(super) fn parse_lines(text: &str) -> Result<Vec<(usize, Label)>> {
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
    Ok(rows
        .into_iter()
        .map(|r| {
            let alpha = match (itk_snap, freesurfer, r.fourth) {
                (true, _, Some(a)) => (a * 255.0).round() as u8,
                (false, false, Some(a)) => a as u8,
                _ => 255,
            };
            let label = Label {
                value: r.value,
                name: r.name,
                rgba: [r.rgb[0], r.rgb[1], r.rgb[2], alpha],
            };
            (r.line, label)
        })
        .collect())
}

/// `ID NAME R G B [A]` (FreeSurfer LUT, Slicer `.ctbl`).
fn lut_row(line: usize, text: &str) -> Result<Row> {
    let fields: Vec<&str> = text.split_whitespace().collect();
    if !(5..=6).contains(&fields.len()) {
        // `1,bankssts`: a CSV without the header that names its columns.
        let hint = match text.contains(',') {
            true => {
                "; a CSV or TSV table starts with a header naming its columns (index, name, color)"
            }
            false => "",
        };
        return Err(bad(
            line,
            &format!("{} fields, expected `ID NAME R G B A`{hint}", fields.len()),
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

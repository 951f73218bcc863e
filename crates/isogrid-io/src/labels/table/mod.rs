//! Colour tables that name and colour labels, as `isogrid extract --label-table FILE` reads them,
//! told apart by content: tables of one label per line (FreeSurfer's `FreeSurferColorLUT.txt`, 3D
//! Slicer's `.ctbl`, ITK-SNAP's label description: [`lines`]) and tables of columns under a header
//! (BIDS `dseg.tsv`, atlases' CSVs: [`columns`]). A line that does not parse is an error naming the
//! file and the line; a value listed twice is an error.

mod columns;
mod lines;
mod text;

use isogrid::{Error, Label, Result};
use std::path::Path;
use text::bad;

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

/// Parses a colour table's text (see the module documentation) into labels in increasing value;
/// errors name the line.
pub fn parse_label_table(text: &str) -> Result<Vec<Label>> {
    // A spreadsheet's UTF-8 byte order mark is not part of the first column's name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'));
    let mut labels = match first {
        Some(header) if columns::is_header(header) => columns::parse_columns(text, header)?,
        _ => lines::parse_lines(text)?,
    };
    labels.sort_by_key(|(_, label)| label.value);
    for pair in labels.windows(2) {
        if pair[0].1.value == pair[1].1.value {
            let (line, label) = &pair[1];
            return Err(bad(
                *line,
                &format!("label {} is listed twice", label.value as i64),
            ));
        }
    }
    Ok(labels.into_iter().map(|(_, label)| label).collect())
}

//! The pieces every colour table format shares: a line's error, a label value and a colour
//! component as text.

use isogrid::Error;

/// An error at line `line` of a table (1-based, as editors count).
pub(super) fn bad(line: usize, what: &str) -> Error {
    Error::corrupt(format!("label table line {line}: {what}"))
}

/// A label value: an integer (negative ones as their two's complement, as a signed volume's keys).
pub(super) fn value(line: usize, text: &str) -> Result<u64, Error> {
    text.parse::<i64>()
        .map(|v| v as u64)
        .or_else(|_| text.parse::<u64>())
        .map_err(|_| bad(line, &format!("label value {text:?} is not an integer")))
}

/// A colour component, an integer 0..255.
pub(super) fn channel(line: usize, text: &str) -> Result<u8, Error> {
    text.parse::<u8>().map_err(|_| {
        bad(
            line,
            &format!("colour component {text:?} is not an integer 0..255"),
        )
    })
}

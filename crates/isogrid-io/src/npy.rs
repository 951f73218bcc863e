//! NumPy `.npy` arrays (format versions 1.0, 2.0 and 3.0).
//!
//! Spec: <https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html>. The file is the
//! magic `\x93NUMPY`, a version, a header length, a Python dict literal
//! `{'descr': '<f4', 'fortran_order': False, 'shape': (3, 5, 7), }` and the raw array bytes.
//!
//! # Axis convention
//! A volume has i (x) fastest in memory. Both array orders are read without copying axes around:
//! - C order (numpy's default): the **last** axis is fastest, so an array of shape `(nz, ny, nx)`
//!   gives `dims = (nx, ny, nz) = (shape[2], shape[1], shape[0])`, i.e. `a[k, j, i]` is sample (i, j, k).
//! - Fortran order: the **first** axis is fastest, so an array of shape `(nx, ny, nz)` gives
//!   `dims = shape`, i.e. `a[i, j, k]` is sample (i, j, k).
//!
//! 2-D arrays are one slice (nz = 1) and 1-D arrays one row, by the same rule. Spacing is 1 and
//! origin 0 (the format has none). Types: `b1` (→ u8), `u1 i1 u2 i2 u4 i4 u8 i8 f4 f8` with `<`, `>`
//! or `|` byte order, converted as described in the crate docs (`i1` → i16; 32/64-bit → f32).

use crate::samples::{byte_count, read_samples, sample_count, ElemType};
use isogrid::{Error, Result, ResultExt, Volume};
use std::io::{BufReader, Read};
use std::path::Path;

/// Reads a `.npy` file as a volume (see the module doc for the axis convention). Errors name `path`.
pub fn read_npy(path: &Path) -> Result<Volume> {
    read(path).at_path(path)
}

/// What the header dict says.
#[derive(Debug, PartialEq)]
struct Header {
    elem: ElemType,
    big_endian: bool,
    fortran_order: bool,
    shape: Vec<usize>,
}

fn read(path: &Path) -> Result<Volume> {
    let file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata()?.len();
    let mut reader = BufReader::new(file);
    let mut preamble = [0u8; 8];
    reader
        .read_exact(&mut preamble)
        .map_err(|_| Error::corrupt("not a .npy file: shorter than its magic"))?;
    if &preamble[..6] != b"\x93NUMPY" {
        return Err(Error::corrupt("not a .npy file: bad magic"));
    }
    let header_len = match preamble[6] {
        1 => {
            let mut n = [0u8; 2];
            reader.read_exact(&mut n)?;
            u16::from_le_bytes(n) as u64
        }
        2 | 3 => {
            let mut n = [0u8; 4];
            reader.read_exact(&mut n)?;
            u32::from_le_bytes(n) as u64
        }
        v => {
            return Err(Error::unsupported(format!(
                ".npy format version {v} is not supported"
            )))
        }
    };
    let data_offset = 8 + if preamble[6] == 1 { 2 } else { 4 } + header_len;
    if data_offset > file_len {
        return Err(Error::corrupt("file is truncated inside the .npy header"));
    }
    let mut text = vec![0u8; header_len as usize];
    reader.read_exact(&mut text)?;
    // Version 3.0 allows UTF-8; all keys and values we understand are ASCII anyway.
    let text =
        std::str::from_utf8(&text).map_err(|_| Error::corrupt(".npy header is not UTF-8"))?;
    let header = parse_header(text)?;
    let dims = dims_of(&header)?;
    let count = sample_count(dims)?;
    let needed = byte_count(count, header.elem)?;
    let available = file_len - data_offset;
    if needed != available {
        return Err(Error::corrupt(format!(
            "array data needs {needed} bytes but the file has {available} after the header"
        )));
    }
    let data = read_samples(&mut reader, header.elem, header.big_endian, count)?;
    Volume::new(dims, data)
}

/// Volume dims (i fastest) for an array shape and order; see the module doc.
fn dims_of(header: &Header) -> Result<[usize; 3]> {
    let mut shape = header.shape.clone();
    if shape.is_empty() || shape.len() > 3 {
        return Err(Error::unsupported(format!(
            "a {}-dimensional array is not a volume (need 1 to 3 axes)",
            shape.len()
        )));
    }
    if !header.fortran_order {
        shape.reverse();
    }
    shape.resize(3, 1);
    Ok([shape[0], shape[1], shape[2]])
}

fn parse_header(text: &str) -> Result<Header> {
    let mut p = Parser {
        s: text.as_bytes(),
        pos: 0,
    };
    let mut descr = None;
    let mut fortran = None;
    let mut shape = None;
    p.expect(b'{')?;
    loop {
        p.skip_ws();
        if p.eat(b'}') {
            break;
        }
        let key = p.string()?;
        p.expect(b':')?;
        match key.as_str() {
            "descr" => {
                p.skip_ws();
                if p.peek() == Some(b'[') {
                    return Err(Error::unsupported(
                        "structured .npy dtypes are not supported",
                    ));
                }
                descr = Some(p.string()?);
            }
            "fortran_order" => fortran = Some(p.boolean()?),
            "shape" => shape = Some(p.tuple()?),
            other => {
                return Err(Error::corrupt(format!(
                    "unknown key '{other}' in .npy header"
                )))
            }
        }
        p.skip_ws();
        if !p.eat(b',') {
            p.expect(b'}')?;
            break;
        }
    }
    let descr = descr.ok_or_else(|| Error::corrupt(".npy header has no 'descr'"))?;
    let (elem, big_endian) = parse_descr(&descr)?;
    Ok(Header {
        elem,
        big_endian,
        fortran_order: fortran
            .ok_or_else(|| Error::corrupt(".npy header has no 'fortran_order'"))?,
        shape: shape.ok_or_else(|| Error::corrupt(".npy header has no 'shape'"))?,
    })
}

fn parse_descr(descr: &str) -> Result<(ElemType, bool)> {
    let unsupported = || Error::unsupported(format!("numpy dtype '{descr}' is not supported"));
    let (order, code) = match descr.as_bytes().first() {
        Some(b'<' | b'>' | b'|' | b'=') => descr.split_at(1),
        _ => ("|", descr),
    };
    let elem = match code {
        "b1" | "u1" | "?" | "B" => ElemType::U8,
        "i1" | "b" => ElemType::I8,
        "u2" => ElemType::U16,
        "i2" => ElemType::I16,
        "u4" => ElemType::U32,
        "i4" => ElemType::I32,
        "u8" => ElemType::U64,
        "i8" => ElemType::I64,
        "f4" => ElemType::F32,
        "f8" => ElemType::F64,
        _ => return Err(unsupported()),
    };
    // '=' is native order; numpy always writes '<' or '>' for multi-byte types, so this is rare.
    let big_endian = match order {
        ">" => true,
        "=" => cfg!(target_endian = "big"),
        _ => false,
    };
    Ok((elem, big_endian))
}

/// A tiny reader for the subset of Python literals numpy writes in headers.
struct Parser<'a> {
    s: &'a [u8],
    pos: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.pos).copied()
    }
    fn skip_ws(&mut self) {
        while self.peek().is_some_and(|c| c.is_ascii_whitespace()) {
            self.pos += 1;
        }
    }
    fn eat(&mut self, c: u8) -> bool {
        self.skip_ws();
        if self.peek() == Some(c) {
            self.pos += 1;
            true
        } else {
            false
        }
    }
    fn expect(&mut self, c: u8) -> Result<()> {
        if self.eat(c) {
            Ok(())
        } else {
            Err(Error::corrupt(format!(
                "malformed .npy header: expected '{}' at byte {}",
                c as char, self.pos
            )))
        }
    }
    fn string(&mut self) -> Result<String> {
        self.skip_ws();
        let quote = match self.peek() {
            Some(q @ (b'\'' | b'"')) => q,
            _ => {
                return Err(Error::corrupt(format!(
                    "malformed .npy header: expected a string at byte {}",
                    self.pos
                )))
            }
        };
        let start = self.pos + 1;
        let len = self.s[start..]
            .iter()
            .position(|&c| c == quote)
            .ok_or_else(|| Error::corrupt("malformed .npy header: unterminated string"))?;
        self.pos = start + len + 1;
        Ok(String::from_utf8_lossy(&self.s[start..start + len]).into_owned())
    }
    fn boolean(&mut self) -> Result<bool> {
        self.skip_ws();
        for (word, value) in [(&b"True"[..], true), (&b"False"[..], false)] {
            if self.s[self.pos..].starts_with(word) {
                self.pos += word.len();
                return Ok(value);
            }
        }
        Err(Error::corrupt(
            "malformed .npy header: fortran_order is not True or False",
        ))
    }
    fn tuple(&mut self) -> Result<Vec<usize>> {
        self.expect(b'(')?;
        let mut values = Vec::new();
        loop {
            if self.eat(b')') {
                return Ok(values);
            }
            self.skip_ws();
            let start = self.pos;
            while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                self.pos += 1;
            }
            let digits = std::str::from_utf8(&self.s[start..self.pos]).unwrap_or("");
            let value = digits.parse::<usize>().map_err(|_| {
                Error::corrupt(format!(
                    "malformed .npy header: bad shape entry at byte {start}"
                ))
            })?;
            if values.len() == 8 {
                return Err(Error::unsupported(
                    "arrays of more than 8 axes are not supported",
                ));
            }
            values.push(value);
            if !self.eat(b',') {
                self.expect(b')')?;
                return Ok(values);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_header_numpy_writes() {
        let h = parse_header("{'descr': '>u2', 'fortran_order': True, 'shape': (7, 5, 3), }    \n")
            .unwrap();
        assert_eq!(
            h,
            Header {
                elem: ElemType::U16,
                big_endian: true,
                fortran_order: true,
                shape: vec![7, 5, 3]
            }
        );
        assert_eq!(dims_of(&h).unwrap(), [7, 5, 3]);
        let c = Header {
            fortran_order: false,
            ..h
        };
        assert_eq!(dims_of(&c).unwrap(), [3, 5, 7]);
        let one =
            parse_header("{'descr': '|u1', 'fortran_order': False, 'shape': (4,), }").unwrap();
        assert_eq!(dims_of(&one).unwrap(), [4, 1, 1]);
    }

    #[test]
    fn rejects_odd_headers() {
        for bad in [
            "{'descr': '<c8', 'fortran_order': False, 'shape': (2,), }",
            "{'descr': [('a', '<f4')], 'fortran_order': False, 'shape': (2,), }",
            "{'descr': '<f4', 'fortran_order': Maybe, 'shape': (2,), }",
            "{'descr': '<f4', 'fortran_order': False, 'shape': (2, x), }",
            "{'descr': '<f4', 'shape': (2,), }",
            "{'descr': '<f4",
        ] {
            assert!(parse_header(bad).is_err(), "{bad}");
        }
    }
}

//! Parsing the text header of a NRRD file into the fields a volume needs.
//!
//! Follows the Teem NRRD format spec (versions NRRD0001..NRRD0005): a magic line, then
//! `field: value` lines, `# comments` and `key:=value` pairs, ended by a blank line (attached data)
//! or the end of the file (detached header). Field names are matched with and without their
//! spaces (`byte skip` = `byteskip`). Known fields that carry nothing for a scalar grid (kinds,
//! labels, units, …) are ignored; an unknown field is an error, as Teem does.

use crate::geometry::{norm, normalized, Vec3};
use crate::samples::ElemType;
use isogrid::{Error, Result, WorldFrame};

/// How the data bytes are encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Encoding {
    Raw,
    Gzip,
    Ascii,
}

/// Where the data lives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum DataFiles {
    /// Right after the header's blank line.
    Attached,
    /// One or more files (paths relative to the header's folder), each holding an equal share.
    Detached(Vec<String>),
}

#[derive(Debug, Clone)]
pub(crate) struct Header {
    pub elem: ElemType,
    pub dims: [usize; 3],
    pub encoding: Encoding,
    pub big_endian: bool,
    pub spacing: [f64; 3],
    pub origin: Vec3,
    pub direction: Option<[Vec3; 3]>,
    /// The `space` field's convention: LPS for `left-posterior-superior` (3D Slicer's files, ITK),
    /// RAS for `right-anterior-superior`; unknown for any other space or none.
    pub frame: WorldFrame,
    pub line_skip: u64,
    /// -1 means "the data is the last bytes of the file" (raw encoding only).
    pub byte_skip: i64,
    pub data: DataFiles,
    /// Entries of a leading non-spatial axis (a 4-D file whose first axis has no space
    /// direction, as a layered 3D Slicer segmentation); 1 for a 3-D file. Samples interleave
    /// them: entry fastest.
    pub layers: usize,
    /// The `key:=value` pairs, in file order (3D Slicer keeps segment names and colours there).
    pub key_values: Vec<(String, String)>,
}

/// Fields that are legal but carry nothing for a scalar grid.
const IGNORED: &[&str] = &[
    "content",
    "min",
    "max",
    "oldmin",
    "oldmax",
    "number",
    "sampleunits",
    "thicknesses",
    "axismins",
    "axismaxs",
    "centers",
    "centerings",
    "labels",
    "units",
    "kinds",
    "spaceunits",
    "measurementframe",
    "blocksize",
];

/// Parses header `lines` (without the magic line). Lines after a `data file: LIST` field are
/// taken as file names, as the spec says.
pub(crate) fn parse(lines: &[String]) -> Result<Header> {
    let mut elem = None;
    let mut dimension = None;
    let mut sizes: Option<Vec<usize>> = None;
    let mut encoding = None;
    let mut endian = None;
    let mut spacings: Option<Vec<f64>> = None;
    let mut directions: Option<Vec<Option<Vec<f64>>>> = None;
    let mut origin: Option<Vec<f64>> = None;
    let mut line_skip = 0u64;
    let mut byte_skip = 0i64;
    let mut data = DataFiles::Attached;
    let mut space_dim = None;
    let mut frame = WorldFrame::Unknown;
    let mut key_values = Vec::new();

    let mut index = 0;
    while index < lines.len() {
        let line = lines[index].as_str();
        index += 1;
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let Some(colon) = line.find(':') else {
            return Err(Error::corrupt(format!(
                "malformed NRRD header line '{}'",
                clip(line)
            )));
        };
        if let Some(value) = line[colon + 1..].strip_prefix('=') {
            // key:=value pairs are free-form metadata, kept for the label reader.
            key_values.push((line[..colon].to_string(), value.to_string()));
            continue;
        }
        let name = line[..colon].trim().to_ascii_lowercase().replace(' ', "");
        let value = line[colon + 1..].trim();
        match name.as_str() {
            "type" => elem = Some(parse_type(value)?),
            "dimension" => dimension = Some(parse_int::<usize>(value, "dimension")?),
            "sizes" => sizes = Some(parse_list(value, "sizes")?),
            "encoding" => encoding = Some(parse_encoding(value)?),
            "endian" => {
                endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => false,
                    "big" => true,
                    _ => return Err(Error::corrupt(format!("unknown endian '{}'", clip(value)))),
                })
            }
            "spacings" => spacings = Some(parse_floats(value, "spacings")?),
            "spacedirections" => directions = Some(parse_vectors(value)?),
            "spaceorigin" => {
                let v = parse_vector(value)?;
                origin = Some(v.ok_or_else(|| Error::corrupt("space origin cannot be 'none'"))?);
            }
            "spacedimension" => space_dim = Some(parse_int::<usize>(value, "space dimension")?),
            "space" => {
                frame = match value.to_ascii_lowercase().as_str() {
                    "left-posterior-superior" | "lps" => WorldFrame::Lps,
                    "right-anterior-superior" | "ras" => WorldFrame::Ras,
                    _ => WorldFrame::Unknown,
                }
            }
            "lineskip" => line_skip = parse_int(value, "line skip")?,
            "byteskip" => {
                byte_skip = parse_int(value, "byte skip")?;
                if byte_skip < -1 {
                    return Err(Error::corrupt(format!("byte skip {byte_skip} is below -1")));
                }
            }
            "datafile" => {
                data = DataFiles::Detached(parse_data_files(value, &lines[index..])?);
                if value.split_whitespace().next() == Some("LIST") {
                    index = lines.len();
                }
            }
            _ if IGNORED.contains(&name.as_str()) => {}
            _ => {
                return Err(Error::unsupported(format!(
                    "unknown NRRD field '{}'",
                    clip(line[..colon].trim())
                )))
            }
        }
    }

    let elem = elem.ok_or_else(|| Error::corrupt("NRRD header has no 'type' field"))?;
    let dimension =
        dimension.ok_or_else(|| Error::corrupt("NRRD header has no 'dimension' field"))?;
    let sizes = sizes.ok_or_else(|| Error::corrupt("NRRD header has no 'sizes' field"))?;
    let encoding = encoding.ok_or_else(|| Error::corrupt("NRRD header has no 'encoding' field"))?;
    if sizes.len() != dimension {
        return Err(Error::corrupt(format!(
            "'sizes' has {} entries but dimension is {dimension}",
            sizes.len()
        )));
    }
    // A 4th axis is read only as a leading list of volumes: the first axis, without a space
    // direction (`none`), as 3D Slicer writes a segmentation's layers.
    let layered = dimension == 4
        && directions
            .as_ref()
            .is_some_and(|d| d.len() == 4 && d[0].is_none());
    if !(1..=3).contains(&dimension) && !layered {
        return Err(Error::unsupported(format!(
            "NRRD dimension {dimension} is not supported (a scalar volume has 1 to 3 axes; 4 only \
             with a first, non-spatial axis of layers)"
        )));
    }
    let (layers, sizes, spacings, directions) = if layered {
        let skip = |v: Option<Vec<f64>>| v.map(|v| v.get(1..).unwrap_or_default().to_vec());
        (
            sizes[0],
            sizes[1..].to_vec(),
            skip(spacings),
            directions.map(|d| d[1..].to_vec()),
        )
    } else {
        (1, sizes, spacings, directions)
    };
    let dimension = sizes.len();
    let big_endian = match endian {
        Some(e) => e,
        None if elem.size() == 1 || encoding == Encoding::Ascii => false,
        None => {
            return Err(Error::corrupt(
                "NRRD header has no 'endian' field for a multi-byte type",
            ))
        }
    };
    if byte_skip == -1 && encoding != Encoding::Raw {
        return Err(Error::corrupt(
            "byte skip -1 is only allowed with raw encoding",
        ));
    }
    let mut dims = [1usize; 3];
    dims[..dimension].copy_from_slice(&sizes);

    let mut spacing = [f64::NAN; 3];
    let mut direction = None;
    if let Some(s) = &spacings {
        if s.len() != dimension {
            return Err(Error::corrupt(format!(
                "'spacings' has {} entries, expected {dimension}",
                s.len()
            )));
        }
        spacing[..dimension].copy_from_slice(s);
    }
    if let Some(vectors) = &directions {
        if vectors.len() != dimension {
            return Err(Error::corrupt(format!(
                "'space directions' has {} entries, expected {dimension}",
                vectors.len()
            )));
        }
        let mut rows = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for (axis, v) in vectors.iter().enumerate() {
            let Some(v) = v else { continue };
            let v = to_vec3(v, space_dim, "space directions")?;
            spacing[axis] = norm(v);
            if let Some(unit) = normalized(v) {
                rows[axis] = unit;
            }
        }
        direction = Some(rows);
    }
    let origin = match origin {
        Some(o) => to_vec3(&o, space_dim, "space origin")?,
        None => [0.0; 3],
    };
    Ok(Header {
        elem,
        dims,
        encoding,
        big_endian,
        spacing,
        origin,
        direction,
        frame,
        line_skip,
        byte_skip,
        data,
        layers,
        key_values,
    })
}

fn parse_type(value: &str) -> Result<ElemType> {
    let v = value.to_ascii_lowercase();
    Ok(
        match v.split_whitespace().collect::<Vec<_>>().join(" ").as_str() {
            "signed char" | "int8" | "int8_t" => ElemType::I8,
            "uchar" | "unsigned char" | "uint8" | "uint8_t" => ElemType::U8,
            "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
                ElemType::I16
            }
            "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
                ElemType::U16
            }
            "int" | "signed int" | "int32" | "int32_t" => ElemType::I32,
            "uint" | "unsigned int" | "uint32" | "uint32_t" => ElemType::U32,
            "longlong"
            | "long long"
            | "long long int"
            | "signed long long"
            | "signed long long int"
            | "int64"
            | "int64_t" => ElemType::I64,
            "ulonglong"
            | "unsigned long long"
            | "unsigned long long int"
            | "uint64"
            | "uint64_t" => ElemType::U64,
            "float" => ElemType::F32,
            "double" => ElemType::F64,
            "block" => return Err(Error::unsupported("NRRD type 'block' is not supported")),
            _ => {
                return Err(Error::corrupt(format!(
                    "unknown NRRD type '{}'",
                    clip(value)
                )))
            }
        },
    )
}

fn parse_encoding(value: &str) -> Result<Encoding> {
    Ok(match value.to_ascii_lowercase().as_str() {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        "ascii" | "text" | "txt" => Encoding::Ascii,
        "hex" | "bzip2" | "bz2" | "zrl" => {
            return Err(Error::unsupported(format!(
                "NRRD encoding '{value}' is not supported"
            )))
        }
        _ => {
            return Err(Error::corrupt(format!(
                "unknown NRRD encoding '{}'",
                clip(value)
            )))
        }
    })
}

/// `data file:` forms: a single name; `LIST [subdim]` (names on the following lines); or
/// `format min max step [subdim]` with a printf-style `%d` (optionally `%0Nd`) in `format`.
fn parse_data_files(value: &str, following: &[String]) -> Result<Vec<String>> {
    let parts: Vec<&str> = value.split_whitespace().collect();
    let subdim_check = |sub: Option<&&str>| -> Result<()> {
        match sub {
            None => Ok(()),
            Some(s) => Err(Error::unsupported(format!(
                "NRRD 'data file' with an explicit sub-dimension ({s}) is not supported"
            ))),
        }
    };
    if parts.first() == Some(&"LIST") {
        subdim_check(parts.get(1))?;
        let names: Vec<String> = following
            .iter()
            .map(|l| l.trim().to_string())
            .filter(|l| !l.is_empty())
            .collect();
        if names.is_empty() {
            return Err(Error::corrupt(
                "'data file: LIST' is followed by no file names",
            ));
        }
        return Ok(names);
    }
    if parts.len() >= 4 && parts[0].contains('%') {
        subdim_check(parts.get(4))?;
        let min: i64 = parse_int(parts[1], "data file min")?;
        let max: i64 = parse_int(parts[2], "data file max")?;
        let step: i64 = parse_int(parts[3], "data file step")?;
        if step == 0 || (max - min).signum() * step.signum() < 0 {
            return Err(Error::corrupt("'data file' range never reaches its end"));
        }
        let count = (max - min) / step + 1;
        if count > 1 << 20 {
            return Err(Error::too_large("'data file' range names too many files"));
        }
        return (0..count)
            .map(|n| format_index(parts[0], min + n * step))
            .collect();
    }
    if value.is_empty() {
        return Err(Error::corrupt("'data file' is empty"));
    }
    Ok(vec![value.to_string()])
}

/// Expands the single `%d` / `%Nd` / `%0Nd` in `pattern`.
fn format_index(pattern: &str, n: i64) -> Result<String> {
    let bad = || {
        Error::unsupported(format!(
            "'data file' pattern '{}' is not a %d pattern",
            clip(pattern)
        ))
    };
    let start = pattern.find('%').ok_or_else(bad)?;
    let rest = &pattern[start + 1..];
    let end = rest.find('d').ok_or_else(bad)?;
    let spec = &rest[..end];
    if !spec.chars().all(|c| c.is_ascii_digit()) || rest[end + 1..].contains('%') {
        return Err(bad());
    }
    let width: usize = if spec.is_empty() {
        0
    } else {
        spec.parse().map_err(|_| bad())?
    };
    let number = if spec.starts_with('0') {
        format!("{n:0width$}")
    } else {
        format!("{n:width$}")
    };
    Ok(format!(
        "{}{}{}",
        &pattern[..start],
        number,
        &rest[end + 1..]
    ))
}

fn parse_int<T: std::str::FromStr>(value: &str, what: &str) -> Result<T> {
    value.trim().parse().map_err(|_| {
        Error::corrupt(format!(
            "'{what}' value '{}' is not a valid integer",
            clip(value)
        ))
    })
}

fn parse_list(value: &str, what: &str) -> Result<Vec<usize>> {
    value
        .split_whitespace()
        .map(|v| parse_int(v, what))
        .collect()
}

fn parse_float(v: &str, what: &str) -> Result<f64> {
    match v.to_ascii_lowercase().as_str() {
        "nan" => Ok(f64::NAN),
        _ => v
            .parse()
            .map_err(|_| Error::corrupt(format!("'{what}' value '{}' is not a number", clip(v)))),
    }
}

fn parse_floats(value: &str, what: &str) -> Result<Vec<f64>> {
    value
        .split_whitespace()
        .map(|v| parse_float(v, what))
        .collect()
}

/// `(x,y,z)` or `none`.
fn parse_vector(text: &str) -> Result<Option<Vec<f64>>> {
    let text = text.trim();
    if text == "none" {
        return Ok(None);
    }
    let inner = text
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or_else(|| Error::corrupt(format!("malformed NRRD vector '{}'", clip(text))))?;
    inner
        .split(',')
        .map(|v| parse_float(v.trim(), "vector"))
        .collect::<Result<_>>()
        .map(Some)
}

/// Space-separated vectors; spaces inside parentheses are allowed.
fn parse_vectors(value: &str) -> Result<Vec<Option<Vec<f64>>>> {
    let mut out = Vec::new();
    let mut rest = value.trim();
    while !rest.is_empty() {
        let end = if rest.starts_with('(') {
            rest.find(')')
                .map(|p| p + 1)
                .ok_or_else(|| Error::corrupt("unclosed '(' in space directions"))?
        } else {
            rest.find(char::is_whitespace).unwrap_or(rest.len())
        };
        out.push(parse_vector(&rest[..end])?);
        rest = rest[end..].trim_start();
    }
    Ok(out)
}

fn to_vec3(v: &[f64], space_dim: Option<usize>, what: &str) -> Result<Vec3> {
    if v.is_empty() || v.len() > 3 || space_dim.is_some_and(|d| d != v.len()) {
        return Err(Error::unsupported(format!(
            "'{what}' vectors of {} components are not supported",
            v.len()
        )));
    }
    let mut out = [0.0; 3];
    out[..v.len()].copy_from_slice(v);
    Ok(out)
}

/// Shortens untrusted text quoted in an error so the message stays one readable line.
pub(crate) fn clip(s: &str) -> String {
    let s: String = s.chars().filter(|c| !c.is_control()).take(60).collect();
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &str) -> Vec<String> {
        text.lines().map(str::to_string).collect()
    }

    #[test]
    fn reads_space_directions_as_spacing_and_direction() {
        let h = parse(&lines(
            "type: unsigned short\ndimension: 3\nsizes: 4 5 6\nencoding: gz\nendian: big\n\
             space: left-posterior-superior\nspace directions: (0,-2,0) (1.5, 0, 0) (0,0,3)\n\
             space origin: (1,2,3)\nkinds: domain domain domain\n# comment\nmy key:=value",
        ))
        .unwrap();
        assert_eq!(h.elem, ElemType::U16);
        assert_eq!(h.dims, [4, 5, 6]);
        assert_eq!(h.encoding, Encoding::Gzip);
        assert!(h.big_endian);
        assert_eq!(h.spacing, [2.0, 1.5, 3.0]);
        assert_eq!(h.direction.unwrap()[0], [0.0, -1.0, 0.0]);
        assert_eq!(h.origin, [1.0, 2.0, 3.0]);
    }

    #[test]
    fn expands_data_file_patterns() {
        let h = parse(&lines(
            "type: uint8\ndimension: 3\nsizes: 2 2 3\nencoding: raw\ndata file: slice%03d.raw 1 5 2",
        ))
        .unwrap();
        assert_eq!(
            h.data,
            DataFiles::Detached(vec![
                "slice001.raw".into(),
                "slice003.raw".into(),
                "slice005.raw".into()
            ])
        );
        let h = parse(&lines(
            "type: uint8\ndimension: 2\nsizes: 2 2\nencoding: raw\ndata file: LIST\na.raw\nb.raw",
        ))
        .unwrap();
        assert_eq!(
            h.data,
            DataFiles::Detached(vec!["a.raw".into(), "b.raw".into()])
        );
        assert_eq!(h.dims, [2, 2, 1]);
    }

    #[test]
    fn rejects_bad_headers_with_a_reason() {
        let cases = [
            (
                "type: uint8\ndimension: 3\nsizes: 2 2\nencoding: raw",
                "sizes",
            ),
            (
                "type: quux\ndimension: 3\nsizes: 2 2 2\nencoding: raw",
                "unknown NRRD type",
            ),
            (
                "type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: bzip2",
                "not supported",
            ),
            (
                "type: short\ndimension: 3\nsizes: 2 2 2\nencoding: raw",
                "endian",
            ),
            (
                "type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nfrobnicate: 1",
                "unknown NRRD field",
            ),
            (
                "type: uint8\ndimension: 4\nsizes: 2 2 2 2\nencoding: raw",
                "dimension 4",
            ),
            (
                "type: uint8\ndimension: 3\nsizes: 2 -2 2\nencoding: raw",
                "integer",
            ),
            ("dimension: 3\nsizes: 2 2 2\nencoding: raw", "type"),
        ];
        for (text, needle) in cases {
            let err = parse(&lines(text)).unwrap_err();
            assert!(err.message().contains(needle), "{text}: {err}");
        }
    }
}

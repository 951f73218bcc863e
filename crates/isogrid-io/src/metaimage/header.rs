//! Parsing the text header of a MetaImage (`.mha`, `.mhd`) into the fields a volume needs.
//!
//! Follows ITK's MetaIO reader: `Key = Value` lines, in any order, ended by `ElementDataFile`
//! (always the last field). Keys are matched without regard to case; fields that carry nothing
//! for a scalar grid (`CenterOfRotation`, `AnatomicalOrientation`, `Comment`, `ElementMin`, …) are
//! ignored. Synonyms are those MetaIO accepts: `Offset` = `Origin` = `Position`,
//! `TransformMatrix` = `Rotation` = `Orientation`, `ElementByteOrderMSB` = `BinaryDataByteOrderMSB`,
//! and `ElementSize` stands in for a missing `ElementSpacing`.

use crate::geometry::{normalized, Vec3};
use crate::nrrd::clip;
use crate::samples::ElemType;
use isogrid::{Error, Result};

/// Where the data starts in its file (`HeaderSize`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DataStart {
    /// No `HeaderSize`: right after the header (`LOCAL`) or at the start of the data file.
    Default,
    /// `HeaderSize = N`: at byte N of the file holding the data (MetaIO seeks from the file's
    /// start, also for `LOCAL` data).
    At(u64),
    /// `HeaderSize = -1`: the data is the last bytes of the file (uncompressed data only).
    End,
}

/// Where the samples live (`ElementDataFile`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum DataFile {
    /// `LOCAL`: in the same file, right after the `ElementDataFile` line.
    Local,
    /// One file, relative to the header's folder unless absolute.
    Single(String),
    /// `LIST [ND]`: file names follow, one per line; each holds an `ND`-dimensional piece
    /// (default: one slice, i.e. NDims − 1).
    List { piece_dims: usize },
    /// `name%03d.raw [first [last [step]]]`: one file per slice, numbered by the printf pattern.
    Pattern {
        pattern: String,
        first: i64,
        last: Option<i64>,
        step: i64,
    },
}

#[derive(Debug, Clone)]
pub(crate) struct Header {
    /// Dimensions the file declares (1 to 3; a 2-D image has one slice).
    pub ndims: usize,
    pub dims: [usize; 3],
    pub elem: ElemType,
    pub big_endian: bool,
    /// `BinaryData = False` means whitespace-separated decimal values.
    pub binary: bool,
    pub compressed: bool,
    pub compressed_size: Option<u64>,
    pub start: DataStart,
    pub spacing: [f64; 3],
    pub origin: Vec3,
    pub direction: Option<[Vec3; 3]>,
    pub data: DataFile,
}

/// Parses header `lines`, the last of which is the `ElementDataFile` line.
pub(crate) fn parse(lines: &[String]) -> Result<Header> {
    let mut ndims = None;
    let mut sizes: Option<Vec<u64>> = None;
    let mut elem = None;
    let mut big_endian = false;
    let mut binary = true;
    let mut compressed = false;
    let mut compressed_size = None;
    let mut start = DataStart::Default;
    let mut spacing: Option<Vec<f64>> = None;
    let mut element_size: Option<Vec<f64>> = None;
    let mut origin: Option<Vec<f64>> = None;
    let mut matrix: Option<Vec<f64>> = None;
    let mut channels = 1u64;
    let mut data = None;
    for line in lines {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let Some((key, value)) = line.split_once('=').or_else(|| line.split_once(':')) else {
            return Err(Error::corrupt(format!(
                "MetaImage header line '{}' is not 'Key = Value'",
                clip(line)
            )));
        };
        let (key, value) = (key.trim(), value.trim());
        let field = |what: &str| format!("{key} value '{}' {what}", clip(value));
        match key.to_ascii_lowercase().as_str() {
            "objecttype" if !value.eq_ignore_ascii_case("image") => {
                return Err(Error::unsupported(format!(
                    "MetaImage ObjectType '{}' is not an image",
                    clip(value)
                )));
            }
            "ndims" => {
                ndims = Some(integer(value).ok_or_else(|| Error::corrupt(field("is not a count")))?)
            }
            "dimsize" => {
                sizes =
                    Some(integers(value).ok_or_else(|| {
                        Error::corrupt(field("is not a list of positive integers"))
                    })?)
            }
            "elementtype" => elem = Some(element_type(value)?),
            "elementbyteordermsb" | "binarydatabyteordermsb" => big_endian = boolean(value, key)?,
            "binarydata" => binary = boolean(value, key)?,
            "compresseddata" => compressed = boolean(value, key)?,
            "compresseddatasize" => {
                compressed_size = Some(
                    integer(value).ok_or_else(|| Error::corrupt(field("is not a byte count")))?,
                )
            }
            "headersize" => {
                start = match value.parse::<i64>() {
                    Ok(-1) => DataStart::End,
                    Ok(0) => DataStart::Default,
                    Ok(n) if n > 0 => DataStart::At(n as u64),
                    _ => return Err(Error::corrupt(field("is not a byte count or -1"))),
                }
            }
            "elementnumberofchannels" => {
                channels = integer(value).ok_or_else(|| Error::corrupt(field("is not a count")))?
            }
            "elementspacing" => spacing = Some(reals(value, key)?),
            "elementsize" => element_size = Some(reals(value, key)?),
            "offset" | "origin" | "position" => origin = Some(reals(value, key)?),
            "transformmatrix" | "rotation" | "orientation" => matrix = Some(reals(value, key)?),
            "elementdatafile" => data = Some(data_file(value)?),
            // Everything else (CenterOfRotation, AnatomicalOrientation, Comment, Name, ElementMin,
            // Modality, …) carries nothing a scalar grid keeps.
            _ => {}
        }
    }
    let data =
        data.ok_or_else(|| Error::corrupt("MetaImage header has no ElementDataFile field"))?;
    let ndims =
        ndims.ok_or_else(|| Error::corrupt("MetaImage header has no NDims field"))? as usize;
    if ndims == 0 {
        return Err(Error::corrupt("MetaImage NDims is 0"));
    }
    let sizes = sizes.ok_or_else(|| Error::corrupt("MetaImage header has no DimSize field"))?;
    if sizes.len() != ndims {
        return Err(Error::corrupt(format!(
            "DimSize has {} values but NDims is {ndims}",
            sizes.len()
        )));
    }
    let mut dims = [1usize; 3];
    for (axis, &n) in sizes.iter().enumerate() {
        if n == 0 {
            return Err(Error::corrupt(format!("DimSize along axis {axis} is 0")));
        }
        match axis {
            0..=2 => {
                dims[axis] = usize::try_from(n).map_err(|_| {
                    Error::too_large(format!(
                        "DimSize {n} along axis {axis} does not fit in memory"
                    ))
                })?
            }
            _ if n > 1 => {
                return Err(Error::unsupported(format!(
                    "MetaImage has {ndims} dimensions (DimSize {}); only one 3-D volume is read",
                    sizes
                        .iter()
                        .map(u64::to_string)
                        .collect::<Vec<_>>()
                        .join(" ")
                )))
            }
            _ => {}
        }
    }
    if channels != 1 {
        return Err(Error::unsupported(format!(
            "ElementNumberOfChannels is {channels}; only scalar (1-channel) images are read"
        )));
    }
    let elem = elem.ok_or_else(|| Error::corrupt("MetaImage header has no ElementType field"))?;
    if compressed && !binary {
        return Err(Error::corrupt(
            "CompressedData = True needs BinaryData = True",
        ));
    }
    if (compressed || !binary) && start == DataStart::End {
        return Err(Error::unsupported(
            "HeaderSize = -1 (data at the end of the file) only locates uncompressed binary data",
        ));
    }
    if let DataFile::List { piece_dims } = &data {
        if *piece_dims > ndims {
            return Err(Error::corrupt(format!(
                "LIST {piece_dims}D pieces do not fit an image of NDims {ndims}"
            )));
        }
    }
    let spacing = per_axis(spacing.or(element_size), ndims, "ElementSpacing", 1.0)?;
    let origin = per_axis(origin, ndims, "Offset", 0.0)?;
    let direction = match matrix {
        None => None,
        Some(m) => directions(&m, ndims)?,
    };
    Ok(Header {
        ndims,
        dims,
        elem,
        big_endian,
        binary,
        compressed,
        compressed_size,
        start,
        spacing,
        origin,
        direction,
        data,
    })
}

fn element_type(value: &str) -> Result<ElemType> {
    Ok(match value.to_ascii_uppercase().as_str() {
        "MET_UCHAR" => ElemType::U8,
        "MET_CHAR" => ElemType::I8,
        "MET_USHORT" => ElemType::U16,
        "MET_SHORT" => ElemType::I16,
        // MetaIO's LONG and ULONG are 32-bit on every platform.
        "MET_UINT" | "MET_ULONG" => ElemType::U32,
        "MET_INT" | "MET_LONG" => ElemType::I32,
        "MET_ULONG_LONG" => ElemType::U64,
        "MET_LONG_LONG" => ElemType::I64,
        "MET_FLOAT" => ElemType::F32,
        "MET_DOUBLE" => ElemType::F64,
        _ => {
            return Err(Error::unsupported(format!(
                "MetaImage ElementType '{}' is not supported (scalar MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT, MET_ULONG, MET_LONG, MET_ULONG_LONG, MET_LONG_LONG, MET_FLOAT, MET_DOUBLE are)",
                clip(value)
            )))
        }
    })
}

fn data_file(value: &str) -> Result<DataFile> {
    if value.is_empty() {
        return Err(Error::corrupt("ElementDataFile is empty"));
    }
    if value.eq_ignore_ascii_case("local") {
        return Ok(DataFile::Local);
    }
    let words: Vec<&str> = value.split_whitespace().collect();
    if words[0] == "LIST" {
        // "LIST", "LIST 2D" or "LIST 2": the dimension of each file's piece.
        let piece_dims = match words.get(1) {
            None => 0,
            Some(w) => w
                .trim_end_matches(['D', 'd'])
                .parse::<usize>()
                .map_err(|_| {
                    Error::corrupt(format!(
                        "ElementDataFile '{}' is not 'LIST [ND]'",
                        clip(value)
                    ))
                })?,
        };
        return Ok(DataFile::List { piece_dims });
    }
    if value.contains('%') {
        // The last up to three words are numbers; the rest (which may hold spaces) is the pattern.
        let numbers = words
            .iter()
            .rev()
            .take(3)
            .take_while(|w| w.parse::<i64>().is_ok())
            .count();
        let (name, nums) = words.split_at(words.len() - numbers);
        let nums: Vec<i64> = nums.iter().map(|w| w.parse().unwrap_or(0)).collect();
        let step = nums.get(2).copied().unwrap_or(1);
        if step <= 0 {
            return Err(Error::corrupt(format!(
                "ElementDataFile pattern step {step} is not positive"
            )));
        }
        return Ok(DataFile::Pattern {
            pattern: name.join(" "),
            first: nums.first().copied().unwrap_or(1),
            last: nums.get(1).copied(),
            step,
        });
    }
    Ok(DataFile::Single(value.to_string()))
}

/// `n` values for the first `ndims` axes, padded to three with `fill`.
fn per_axis(values: Option<Vec<f64>>, ndims: usize, name: &str, fill: f64) -> Result<[f64; 3]> {
    let mut out = [fill; 3];
    if let Some(v) = values {
        if v.len() < ndims {
            return Err(Error::corrupt(format!(
                "{name} has {} values but NDims is {ndims}",
                v.len()
            )));
        }
        let n = ndims.min(3);
        out[..n].copy_from_slice(&v[..n]);
    }
    Ok(out)
}

/// Axis directions from a row-major `TransformMatrix`: row `a` (values `a·n .. a·n + n`) is the
/// world direction of axis `a`, as ITK's MetaImageIO reads it. Axes the file lacks keep their own
/// direction. A degenerate or non-finite row gives `None` (identity), as other readers do.
fn directions(m: &[f64], ndims: usize) -> Result<Option<[Vec3; 3]>> {
    if m.len() != ndims * ndims {
        return Err(Error::corrupt(format!(
            "TransformMatrix has {} values; NDims {ndims} needs {}",
            m.len(),
            ndims * ndims
        )));
    }
    let mut rows = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for (axis, row) in rows.iter_mut().enumerate().take(ndims.min(3)) {
        let mut r = [0.0; 3];
        for (c, value) in r.iter_mut().enumerate().take(ndims.min(3)) {
            *value = m[axis * ndims + c];
        }
        match normalized(r) {
            Some(unit) => *row = unit,
            None => return Ok(None),
        }
    }
    Ok(Some(rows))
}

fn boolean(value: &str, key: &str) -> Result<bool> {
    match value.chars().next() {
        Some('T' | 't' | '1') => Ok(true),
        Some('F' | 'f' | '0') => Ok(false),
        _ => Err(Error::corrupt(format!(
            "{key} value '{}' is not True or False",
            clip(value)
        ))),
    }
}

fn integer(value: &str) -> Option<u64> {
    value.parse::<u64>().ok()
}

fn integers(value: &str) -> Option<Vec<u64>> {
    value.split_whitespace().map(integer).collect()
}

fn reals(value: &str, key: &str) -> Result<Vec<f64>> {
    value
        .split_whitespace()
        .map(|w| {
            w.parse::<f64>()
                .map_err(|_| Error::corrupt(format!("{key} value '{}' is not a number", clip(w))))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &str) -> Vec<String> {
        text.lines().map(str::to_string).collect()
    }

    #[test]
    fn a_simpleitk_header_parses() {
        let h = parse(&lines(
            "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n\
             CompressedData = True\nCompressedDataSize = 44\n\
             TransformMatrix = 0 -1 0 1 0 0 0 0 1\nOffset = 1 2 3\nCenterOfRotation = 0 0 0\n\
             AnatomicalOrientation = PRI\nElementSpacing = 0.5 0.75 2\nDimSize = 4 3 2\n\
             ElementType = MET_SHORT\nElementDataFile = b.zraw",
        ))
        .unwrap();
        assert_eq!(h.dims, [4, 3, 2]);
        assert_eq!(h.elem, ElemType::I16);
        assert!(h.compressed && h.binary && !h.big_endian);
        assert_eq!(h.compressed_size, Some(44));
        assert_eq!(h.spacing, [0.5, 0.75, 2.0]);
        assert_eq!(h.origin, [1.0, 2.0, 3.0]);
        let d = h.direction.unwrap();
        assert_eq!(d[0], [0.0, -1.0, 0.0]);
        assert_eq!(d[1], [1.0, 0.0, 0.0]);
        assert_eq!(h.data, DataFile::Single("b.zraw".into()));
    }

    #[test]
    fn a_2d_image_is_one_slice() {
        let h = parse(&lines(
            "NDims = 2\nDimSize = 4 3\nElementSpacing = 2 3\nPosition = 5 6\n\
             Orientation = 0 1 1 0\nElementType = MET_FLOAT\nElementDataFile = LOCAL",
        ))
        .unwrap();
        assert_eq!(h.dims, [4, 3, 1]);
        assert_eq!(h.spacing, [2.0, 3.0, 1.0]);
        assert_eq!(h.origin, [5.0, 6.0, 0.0]);
        assert_eq!(h.direction.unwrap()[0], [0.0, 1.0, 0.0]);
        assert_eq!(h.direction.unwrap()[2], [0.0, 0.0, 1.0]);
        assert_eq!(h.data, DataFile::Local);
    }

    #[test]
    fn list_and_pattern_data_files() {
        assert_eq!(
            data_file("LIST 2D").unwrap(),
            DataFile::List { piece_dims: 2 }
        );
        assert_eq!(
            data_file("my slice %03d.raw 5 9 2").unwrap(),
            DataFile::Pattern {
                pattern: "my slice %03d.raw".into(),
                first: 5,
                last: Some(9),
                step: 2
            }
        );
        assert!(data_file("s%d.raw 1 4 0").is_err());
    }

    #[test]
    fn refusals_say_why() {
        let base = "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n";
        let err = |extra: &str| {
            parse(&lines(&format!("{base}{extra}ElementDataFile = LOCAL")))
                .unwrap_err()
                .to_string()
        };
        assert!(err("ElementNumberOfChannels = 3\n").contains("ElementNumberOfChannels is 3"));
        assert!(err("ElementType = MET_FLOAT_MATRIX\n").contains("not supported"));
        assert!(err("ObjectType = Tube\n").contains("not an image"));
        let four = parse(&lines(
            "NDims = 4\nDimSize = 2 2 2 5\nElementType = MET_UCHAR\nElementDataFile = LOCAL",
        ))
        .unwrap_err();
        assert_eq!(four.kind(), isogrid::ErrorKind::Unsupported);
        assert!(four.to_string().contains("4 dimensions"), "{four}");
        let huge = parse(&lines(
            "NDims = 3\nDimSize = 2 2 99999999999999999999999\nElementType = MET_UCHAR\nElementDataFile = LOCAL",
        ))
        .unwrap_err();
        assert!(huge.to_string().contains("DimSize value"), "{huge}");
    }
}

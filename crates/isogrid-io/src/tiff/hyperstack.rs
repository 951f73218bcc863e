//! Channels and time points of a multi-page TIFF (ImageJ hyperstacks and OME-TIFF): which pages
//! hold the z slices of one channel `c` and time point `t`.
//!
//! A plain stack's page n is slice n. ImageJ writes `channels=`, `slices=`, `frames=` (and
//! `hyperstack=true`) in page 0's ImageDescription and orders pages c fastest, then z, then t;
//! OME-TIFF writes `SizeC`, `SizeZ`, `SizeT` and the `DimensionOrder` (e.g. `XYCZT`: after x
//! and y, fastest first) on its first `Pixels` element. tifffile writes both forms. A stack with
//! one channel and one time point is a plain stack. The entries are picked with the same
//! `--index c=N,t=N` as a Zarr array's extra axes.

use crate::read_options::AxisPick;
use isogrid::{Error, Result};

/// The page layout of a hyperstack.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Hyperstack {
    /// Entries along c, z, t.
    pub sizes: [usize; 3],
    /// The axes (0 = c, 1 = z, 2 = t) from fastest to slowest across pages.
    pub order: [usize; 3],
    /// Which metadata described it, for messages.
    pub source: &'static str,
}

const NAMES: [&str; 3] = ["c", "z", "t"];

impl Hyperstack {
    /// The layout page 0's ImageDescription declares; `None` for a plain stack (one channel, one
    /// time point, or no description isogrid knows).
    pub fn parse(description: &str) -> Option<Hyperstack> {
        let stack = if description.starts_with("ImageJ=") {
            let value = |key: &str| {
                description.lines().find_map(|line| {
                    let (k, v) = line.split_once('=')?;
                    (k.trim() == key).then(|| v.trim().parse::<usize>().ok())?
                })
            };
            let [c, t] = [value("channels"), value("frames")].map(|v| v.unwrap_or(1));
            let z = value("slices")
                .unwrap_or_else(|| value("images").map_or(1, |n| n / (c * t).max(1)));
            Hyperstack {
                sizes: [c, z, t],
                order: [0, 1, 2],
                source: "ImageJ hyperstack",
            }
        } else {
            let pixels = ome_pixels(description)?;
            let attribute = |name: &str| {
                let at = pixels.find(&format!(" {name}=\""))? + name.len() + 3;
                Some(&pixels[at..at + pixels[at..].find('"')?])
            };
            let size = |name: &str| attribute(name).and_then(|v| v.parse::<usize>().ok());
            let order = attribute("DimensionOrder")?;
            let axis = |ch: u8| match ch {
                b'C' => Some(0),
                b'Z' => Some(1),
                b'T' => Some(2),
                _ => None,
            };
            let rest = order.as_bytes().get(2..5)?;
            if !order.starts_with("XY") {
                return None;
            }
            let order = [axis(rest[0])?, axis(rest[1])?, axis(rest[2])?];
            Hyperstack {
                sizes: [size("SizeC")?, size("SizeZ")?, size("SizeT")?],
                order,
                source: "OME-TIFF",
            }
        };
        (stack.sizes.iter().all(|&n| n >= 1) && (stack.sizes[0] > 1 || stack.sizes[2] > 1))
            .then_some(stack)
    }

    /// Pages the layout takes.
    pub fn pages(&self) -> usize {
        self.sizes.iter().product()
    }

    /// The page of slice `z` of channel `c` at time `t`.
    pub fn page(&self, coords: [usize; 3]) -> usize {
        let mut page = 0;
        for &axis in self.order.iter().rev() {
            page = page * self.sizes[axis] + coords[axis];
        }
        page
    }

    /// The (c, t) that `pick` (`--index`) chooses; an axis with one entry needs none. An index
    /// of another axis, out of range, or given twice, or a missing one, is an error.
    pub fn pick(&self, pick: AxisPick) -> Result<(usize, usize)> {
        crate::read_options::refuse_repeated_axes(pick)?;
        let (indices, flag) = (pick.indices, pick.flag);
        let [c, z, t] = self.sizes;
        let mut parts = Vec::new();
        if c > 1 {
            parts.push(format!("{c} channels (c=0..{})", c - 1));
        }
        parts.push(format!("{z} slices"));
        if t > 1 {
            parts.push(format!("{t} time points (t=0..{})", t - 1));
        }
        let described = format!("{} of {}", self.source, parts.join(", "));
        for (name, index) in indices {
            let axis = match name.to_ascii_lowercase().as_str() {
                "c" => 0,
                "t" => 2,
                _ => {
                    return Err(Error::invalid(format!(
                        "{flag} names {name}, which is not an axis of this {described}: use c or t"
                    )))
                }
            };
            if *index >= self.sizes[axis] as u64 {
                return Err(Error::invalid(format!(
                    "{} is out of range: this is an {described}",
                    flag.with(&[(name, &index.to_string())])
                )));
            }
        }
        let given = |axis: usize| {
            indices
                .iter()
                .find(|(n, _)| n.eq_ignore_ascii_case(NAMES[axis]))
                .map(|&(_, i)| i as usize)
                .or((self.sizes[axis] == 1).then_some(0))
        };
        match (given(0), given(2)) {
            (Some(c), Some(t)) => Ok((c, t)),
            (c, t) => {
                let missing: Vec<(&str, &str)> = [(0, c), (2, t)]
                    .iter()
                    .filter(|(_, v)| v.is_none())
                    .map(|&(axis, _)| (NAMES[axis], "N"))
                    .collect();
                Err(Error::invalid(format!(
                    "this is an {described}: pass {}",
                    flag.with(&missing)
                )))
            }
        }
    }
}

/// The opening tag of the first `Pixels` element of an OME-XML description.
fn ome_pixels(description: &str) -> Option<&str> {
    if !description.contains("<OME") {
        return None;
    }
    let start = description.find("<Pixels ")?;
    let end = start + description[start..].find('>')?;
    Some(&description[start..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imagej_and_ome_layouts() {
        let ij =
            "ImageJ=1.11a\nimages=24\nchannels=2\nslices=12\nhyperstack=true\nmode=grayscale\n";
        let h = Hyperstack::parse(ij).unwrap();
        assert_eq!((h.sizes, h.order), ([2, 12, 1], [0, 1, 2]));
        assert_eq!(h.page([1, 3, 0]), 7);
        assert!(Hyperstack::parse("ImageJ=1.11a\nimages=12\nslices=12\n").is_none());
        let ome = r#"<?xml version="1.0"?><OME xmlns="x"><Image ID="Image:0"><Pixels ID="P" DimensionOrder="XYZCT" Type="uint16" SizeX="24" SizeY="20" SizeC="2" SizeZ="12" SizeT="1">"#;
        let h = Hyperstack::parse(ome).unwrap();
        assert_eq!((h.sizes, h.order), ([2, 12, 1], [1, 0, 2]));
        assert_eq!(h.page([1, 3, 0]), 15);
        fn pick(indices: &[(String, u64)]) -> AxisPick<'_> {
            AxisPick {
                indices,
                flag: crate::IndexFlag::Cli("--index"),
            }
        }
        let err = h.pick(AxisPick::NONE).unwrap_err();
        assert!(err.message().contains("2 channels (c=0..1)"), "{err}");
        assert!(err.message().ends_with("pass --index c=N"), "{err}");
        assert_eq!(h.pick(pick(&[("c".into(), 1)])).unwrap(), (1, 0));
        assert!(h.pick(pick(&[("c".into(), 2)])).is_err());
        assert!(h.pick(pick(&[("z".into(), 0)])).is_err());
        assert!(h.pick(pick(&[("c".into(), 0), ("C".into(), 1)])).is_err());
    }
}

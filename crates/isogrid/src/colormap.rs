//! Colour maps for attribute values: the named maps of `colorous` (d3-scale-chromatic's published
//! tables), sampled into a 256-entry table that every renderer indexes the same way.
//!
//! The rule, written once here and mirrored by the shaders: a value `v` with colour range
//! `[lo, hi]` takes entry `round(clamp((v − lo)/(hi − lo), 0, 1) · 255)` of the table; NaN takes
//! [`NAN_SRGB`]. Entries are sRGB 8-bit as the tables give them; renderers that shade turn them
//! into linear albedo ([`Coloring::albedo`]).

use crate::error::{Error, Result};

/// Entries of a colour table.
pub const TABLE_SIZE: usize = 256;
/// sRGB colour of NaN values ("no value"): magenta, in none of the maps.
pub const NAN_SRGB: [u8; 3] = [255, 0, 255];

/// A named colour map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ColorMap {
    #[default]
    Viridis,
    Magma,
    Inferno,
    Plasma,
    Cividis,
    Turbo,
    /// Black to white (ColorBrewer's Greys, reversed).
    Gray,
    /// Diverging red (low) – white – blue (high), ColorBrewer's RdBu.
    RdBu,
}

impl ColorMap {
    pub const ALL: [ColorMap; 8] = [
        ColorMap::Viridis,
        ColorMap::Magma,
        ColorMap::Inferno,
        ColorMap::Plasma,
        ColorMap::Cividis,
        ColorMap::Turbo,
        ColorMap::Gray,
        ColorMap::RdBu,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ColorMap::Viridis => "viridis",
            ColorMap::Magma => "magma",
            ColorMap::Inferno => "inferno",
            ColorMap::Plasma => "plasma",
            ColorMap::Cividis => "cividis",
            ColorMap::Turbo => "turbo",
            ColorMap::Gray => "gray",
            ColorMap::RdBu => "rdbu",
        }
    }

    /// The map called `name` (case-insensitive); the error lists the known names.
    pub fn from_name(name: &str) -> Result<ColorMap> {
        ColorMap::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(name.trim()))
            .ok_or_else(|| {
                Error::invalid(format!(
                    "unknown colour map {name:?}; known: {}",
                    ColorMap::ALL.map(|m| m.name()).join(", ")
                ))
            })
    }

    /// sRGB colour at `t` in `[0, 1]`.
    fn at(self, t: f64) -> [u8; 3] {
        let (gradient, t) = match self {
            ColorMap::Viridis => (colorous::VIRIDIS, t),
            ColorMap::Magma => (colorous::MAGMA, t),
            ColorMap::Inferno => (colorous::INFERNO, t),
            ColorMap::Plasma => (colorous::PLASMA, t),
            ColorMap::Cividis => (colorous::CIVIDIS, t),
            ColorMap::Turbo => (colorous::TURBO, t),
            ColorMap::Gray => (colorous::GREYS, 1.0 - t),
            ColorMap::RdBu => (colorous::RED_BLUE, t),
        };
        gradient.eval_continuous(t).as_array()
    }

    /// The map's table: entry `i` is the colour at `i / 255`.
    pub fn table(self) -> [[u8; 3]; TABLE_SIZE] {
        std::array::from_fn(|i| self.at(i as f64 / (TABLE_SIZE - 1) as f64))
    }
}

/// How values become colours: a map and the value range it spans.
#[derive(Debug, Clone, PartialEq)]
pub struct Coloring {
    pub map: ColorMap,
    /// Values at or below `clim[0]` take the first entry, at or above `clim[1]` the last.
    pub clim: [f64; 2],
    table: [[u8; 3]; TABLE_SIZE],
}

impl Coloring {
    /// Fails unless `clim` is finite with `lo < hi`.
    pub fn new(map: ColorMap, clim: [f64; 2]) -> Result<Coloring> {
        check_clim(clim)?;
        Ok(Coloring {
            map,
            clim,
            table: map.table(),
        })
    }

    /// `clim` for values spanning `range` (an attribute's range on the surface): the range
    /// itself, widened around its value when it is a single value.
    pub fn default_clim(range: [f64; 2]) -> [f64; 2] {
        if range[0] < range[1] {
            range
        } else {
            let half = (range[0].abs() * 1e-6).max(0.5);
            [range[0] - half, range[0] + half]
        }
    }

    /// Table entry of `value` (`None` for NaN).
    pub fn index(&self, value: f32) -> Option<usize> {
        if value.is_nan() {
            return None;
        }
        let [lo, hi] = self.clim;
        let t = ((value as f64 - lo) / (hi - lo)).clamp(0.0, 1.0);
        Some((t * (TABLE_SIZE - 1) as f64).round() as usize)
    }

    /// sRGB colour of `value`.
    pub fn srgb(&self, value: f32) -> [u8; 3] {
        self.index(value).map_or(NAN_SRGB, |i| self.table[i])
    }

    /// Linear diffuse albedo of `value`: its sRGB colour decoded.
    pub fn albedo(&self, value: f32) -> [f32; 3] {
        self.srgb(value).map(srgb8_to_linear)
    }

    /// The table, sRGB.
    pub fn table(&self) -> &[[u8; 3]; TABLE_SIZE] {
        &self.table
    }

    /// The colour bar's labels of `clim`'s low end, middle and high end, all with the same
    /// decimals: enough to give the span three significant digits (`27`, `120`, `212` for 27.28
    /// to 212.48; `0.00`, `0.50`, `1.00` for 0 to 1), in scientific notation (three significant
    /// digits) where an end is 10⁶ or more, or under 10⁻³ but not 0, in magnitude.
    pub fn bar_labels(&self) -> [String; 3] {
        let [lo, hi] = self.clim;
        let values = [lo, lo + (hi - lo) / 2.0, hi];
        let magnitude = lo.abs().max(hi.abs());
        let tiny = |v: f64| v != 0.0 && v.abs() < 1e-3;
        if magnitude >= 1e6 || tiny(lo) || tiny(hi) {
            return values.map(|v| format!("{v:.2e}"));
        }
        let decimals = (2 - (hi - lo).log10().floor() as i32).clamp(0, 6) as usize;
        values.map(|v| {
            let text = format!("{v:.decimals$}");
            // A value that rounds to zero from below: `-0.00` reads as a different value.
            match text.strip_prefix('-') {
                Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
                _ => text,
            }
        })
    }
}

/// Fails unless `clim` is finite with `lo < hi`.
pub fn check_clim(clim: [f64; 2]) -> Result<()> {
    if !(clim[0].is_finite() && clim[1].is_finite() && clim[0] < clim[1]) {
        return Err(Error::invalid(format!(
            "colour range {},{} must be two finite values with lo < hi",
            clim[0], clim[1]
        )));
    }
    Ok(())
}

/// sRGB 8-bit → linear.
pub fn srgb8_to_linear(v: u8) -> f32 {
    let s = v as f32 / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_the_published_ones_at_their_ends_and_the_rule_rounds_to_the_nearest_entry() {
        // viridis runs from #440154 to #fde725 (matplotlib's and d3's table).
        let viridis = ColorMap::Viridis.table();
        assert_eq!(viridis[0], [0x44, 0x01, 0x54]);
        assert_eq!(viridis[255], [0xfd, 0xe7, 0x25]);
        let gray = ColorMap::Gray.table();
        assert!(
            gray[0][0] < 10 && gray[255][0] > 245,
            "{:?} {:?}",
            gray[0],
            gray[255]
        );
        let c = Coloring::new(ColorMap::Viridis, [10.0, 20.0]).unwrap();
        assert_eq!(c.index(10.0), Some(0));
        assert_eq!(c.index(5.0), Some(0));
        assert_eq!(c.index(25.0), Some(255));
        assert_eq!(c.index(15.0), Some(128)); // 127.5 rounds up
        assert_eq!(c.index(f32::NAN), None);
        assert_eq!(c.srgb(f32::NAN), NAN_SRGB);
        assert!(Coloring::new(ColorMap::Viridis, [1.0, 1.0]).is_err());
        assert!(Coloring::new(ColorMap::Viridis, [f64::NAN, 1.0]).is_err());
        let err = ColorMap::from_name("jet").unwrap_err().to_string();
        assert!(err.contains("viridis") && err.contains("rdbu"), "{err}");
        assert_eq!(ColorMap::from_name("Magma").unwrap(), ColorMap::Magma);
    }

    #[test]
    fn bar_labels_share_the_decimals_that_resolve_the_span() {
        let labels = |lo, hi| {
            Coloring::new(ColorMap::Viridis, [lo, hi])
                .unwrap()
                .bar_labels()
        };
        assert_eq!(labels(27.278301, 212.48097), ["27", "120", "212"]);
        assert_eq!(labels(0.0, 1.0), ["0.00", "0.50", "1.00"]);
        assert_eq!(labels(-1.0, 1.0), ["-1.00", "0.00", "1.00"]);
        assert_eq!(labels(0.01, 0.06), ["0.0100", "0.0350", "0.0600"]);
        assert_eq!(labels(1000.0, 1000.5), ["1000.000", "1000.250", "1000.500"]);
        assert_eq!(labels(0.0, 2e6), ["0.00e0", "1.00e6", "2.00e6"]);
        assert_eq!(labels(1e-5, 3e-5), ["1.00e-5", "2.00e-5", "3.00e-5"]);
        // A value that rounds to zero from below reads as 0, not -0.
        assert_eq!(labels(-0.001, 1.0), ["0.00", "0.50", "1.00"]);
        assert_eq!(labels(-0.4, 0.2), ["-0.400", "-0.100", "0.200"]);
    }
}

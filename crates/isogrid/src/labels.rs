//! Labels of a segmentation: which label each cluster draws, where each label's clusters are, and
//! the labels' values, names and colours, as three optional `.cgc` sections.
//!
//! A label volume's surfaces are extracted by [`crate::extract::labels`]: each label's surface is
//! the isosurface at ½ of its indicator, and every cluster holds cells of one label only, so a
//! cluster's label says which surface each of its cells belongs to. The cells themselves are
//! ordinary corner records (the indicator's codes), so a reader that skips these sections still
//! draws the union of the label surfaces.
//!
//! The sections, little-endian, in this order in the file:
//!
//! **Cluster labels** (kind [`crate::cgc::SectionKind::ClusterLabels`]): one u32 per cluster (every
//! 16 metacell slots), the index of its label in the label table.
//!
//! **Label index** (kind [`crate::cgc::SectionKind::LabelIndex`]): a 16-byte head, one 48-byte
//! entry per label in table order, then the runs:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | label count `n`, u64 (equal to the label table's) |
//! | 8 | 8 | run count `r`, u64 |
//! | 16 + 48·i | 8 | label i: active cells, u64 |
//! | 24 + 48·i | 8 | label i: its first run, u64 (the runs of label i follow those of label i − 1) |
//! | 32 + 48·i | 8 | label i: its run count, u64 |
//! | 40 + 48·i | 12 | label i: `lo`, 3×u32, the smallest cell index of its active cells (index space) |
//! | 52 + 48·i | 12 | label i: `hi`, 3×u32, one past the largest (`lo = hi = 0` without cells) |
//! | 16 + 48·n + 8·j | 8 | run j: first cluster u32, cluster count u32 |
//!
//! A run is a label's clusters inside one block (they are contiguous there: a block's clusters
//! are sorted by label); a label's runs are in cluster order, and all runs together cover every
//! cluster exactly once. A renderer shows or hides a label by its runs, without a scan.
//!
//! **Label table** (kind [`crate::cgc::SectionKind::LabelTable`]): a 16-byte head, one 16-byte
//! entry per label, then the names:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | label count `n`, u64 |
//! | 8 | 8 | name bytes `m`, u64 |
//! | 16 + 16·i | 8 | label i: value, u64 (a signed volume's value as its two's complement), strictly increasing |
//! | 24 + 16·i | 4 | label i: colour, sRGB R, G, B and alpha, 4×u8 |
//! | 28 + 16·i | 4 | label i: name length in bytes, u32 |
//! | 16 + 16·n | m | the names, UTF-8, one after another in table order |

use crate::error::{Error, Result};
use crate::layout::{Metacell, BOUND_SLOT, CLUSTER_SLOTS};
use crate::volume::Scalar;

/// Bytes of the head of the label index and of the label table.
pub const LABEL_HEAD_SIZE: usize = 16;
/// Bytes of one label's entry in the label index.
pub const LABEL_INDEX_ENTRY_SIZE: usize = 48;
/// Bytes of one run in the label index.
pub const LABEL_RUN_SIZE: usize = 8;
/// Bytes of one label's entry in the label table.
pub const LABEL_TABLE_ENTRY_SIZE: usize = 16;

/// A sample type a label volume can hold: its samples are label values, compared as `u64` keys.
pub trait LabelSample: Scalar {
    /// The label value as a key: unsigned values as they are, signed ones as their two's
    /// complement (so a key round-trips through [`LabelSample::from_key`]).
    fn key(self) -> u64;
    /// Whether the sample is a label value at all (integers always are; floats when integral).
    fn is_label(self) -> bool {
        true
    }
}

macro_rules! unsigned_label {
    ($($t:ty),*) => {$(
        impl LabelSample for $t {
            #[inline]
            fn key(self) -> u64 {
                self as u64
            }
        }
    )*};
}
macro_rules! signed_label {
    ($($t:ty),*) => {$(
        impl LabelSample for $t {
            #[inline]
            fn key(self) -> u64 {
                self as i64 as u64
            }
        }
    )*};
}
// Every integer type `ScalarType` has.
unsigned_label!(u8, u16, u32, u64);
signed_label!(i16, i32, i64);

/// Floats are labels when every sample is an integer the type holds exactly (|v| ≤ 2²⁴ for f32,
/// 2⁵³ for f64): label maps are often stored as floats, and their values are then integers.
impl LabelSample for f32 {
    #[inline]
    fn key(self) -> u64 {
        self as i64 as u64
    }
    fn is_label(self) -> bool {
        self.is_finite() && self.fract() == 0.0 && self.abs() <= (1 << 24) as f32
    }
}

impl LabelSample for f64 {
    #[inline]
    fn key(self) -> u64 {
        self as i64 as u64
    }
    fn is_label(self) -> bool {
        self.is_finite() && self.fract() == 0.0 && self.abs() <= (1u64 << 53) as f64
    }
}

/// Whether a volume of this type has signed label values (shown with their sign).
pub fn signed_labels(t: crate::ScalarType) -> bool {
    !t.name().starts_with('u')
}

/// How a label value is shown: as signed when the volume's type is signed.
pub fn display_value(key: u64, signed: bool) -> String {
    if signed {
        (key as i64).to_string()
    } else {
        key.to_string()
    }
}

/// Which labels to extract, or to show or hide.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LabelSelection {
    /// Every label in the volume except 0, the background.
    All,
    /// The values in these inclusive ranges of keys (see [`LabelSample::key`]) that the volume
    /// holds. A range whose start is above its end wraps past `u64::MAX` to 0: a signed range
    /// across zero (`-5-5`), whose negative end's key is its two's complement
    /// ([`LabelSelection::key_ranges`] gives it as two ordinary ranges).
    Values(Vec<std::ops::RangeInclusive<u64>>),
    /// Values and names (`1,5-9,liver`, [`LabelSelection::parse_with_names`]): a name picks the
    /// labels of a table that have it, in any case ([`LabelSelection::resolved`]). Extraction
    /// selects by value: front doors resolve names against the names a file gives first.
    Named {
        ranges: Vec<std::ops::RangeInclusive<u64>>,
        names: Vec<String>,
    },
}

impl LabelSelection {
    /// Whether the label of `key` is selected by value (names are resolved to values first:
    /// [`LabelSelection::resolved`]).
    pub fn selects(&self, key: u64) -> bool {
        match self {
            LabelSelection::All => key != 0,
            LabelSelection::Values(ranges) | LabelSelection::Named { ranges, .. } => ranges
                .iter()
                .any(|r| Self::key_ranges(r).any(|r| r.contains(&key))),
        }
    }

    /// The selection with its names replaced by the values of the labels of `table` that have
    /// them (matched whole, in any case): the one rule by which names select labels, for a
    /// grid's table ([`GridLabels::shown`]) and for the names a file gives before extraction. A
    /// name no label of `table` has is an error naming some that exist.
    pub fn resolved(&self, table: &[Label]) -> Result<LabelSelection> {
        let LabelSelection::Named { ranges, names } = self else {
            return Ok(self.clone());
        };
        let mut ranges = ranges.clone();
        for name in names {
            let before = ranges.len();
            ranges.extend(
                table
                    .iter()
                    .filter(|l| l.name.eq_ignore_ascii_case(name))
                    .map(|l| l.value..=l.value),
            );
            if ranges.len() == before {
                return Err(Error::invalid(format!(
                    "{name:?}: no label has this name ({})",
                    names_for_an_error(table)
                )));
            }
        }
        Ok(LabelSelection::Values(ranges))
    }

    /// `range` as ordinary ranges of keys: itself, or the two halves of a range that wraps.
    pub fn key_ranges(
        range: &std::ops::RangeInclusive<u64>,
    ) -> impl Iterator<Item = std::ops::RangeInclusive<u64>> {
        let (start, end) = (*range.start(), *range.end());
        let halves = if start <= end {
            [Some(start..=end), None]
        } else {
            [Some(start..=u64::MAX), Some(0..=end)]
        };
        halves.into_iter().flatten()
    }

    /// Parses `all` or a comma-separated list of values and ranges (`1,5-9`); negative values
    /// (for signed volumes) are written with a leading minus (`-3--1` is -3 to -1, `-5-5` is -5
    /// to 5). Each value is a key ([`LabelSample::key`]): a negative one is its two's complement,
    /// so a range across zero wraps (see [`LabelSelection::Values`]).
    pub fn parse(text: &str) -> Result<LabelSelection> {
        Self::parse_parts(text, false)
    }

    /// [`LabelSelection::parse`], where a part that is neither a value nor a range is a label's
    /// name (`1,5-9,liver,Left-Hippocampus`), for labels whose table names them. A name holds no
    /// comma and is matched whole, in any case.
    pub fn parse_with_names(text: &str) -> Result<LabelSelection> {
        Self::parse_parts(text, true)
    }

    fn parse_parts(text: &str, names_allowed: bool) -> Result<LabelSelection> {
        let text = text.trim();
        if text.eq_ignore_ascii_case("all") {
            return Ok(LabelSelection::All);
        }
        let bad = |part: &str, why: &str| {
            Error::invalid(format!(
                "label selection {text:?}: {part:?} {why} (give `all` or a list such as 1,5-9 or -3--1{})",
                if names_allowed { ", or labels' names" } else { "" }
            ))
        };
        let value = |part: &str, s: &str| -> Result<i128> {
            let v = s
                .trim()
                .parse::<i128>()
                .map_err(|_| bad(part, "is not a whole number or a range of them"))?;
            if (i64::MIN as i128..=u64::MAX as i128).contains(&v) {
                Ok(v)
            } else {
                Err(bad(part, "is beyond the 64-bit label values"))
            }
        };
        let key = |v: i128| v as i64 as u64;
        let mut ranges = Vec::new();
        let mut names = Vec::new();
        for part in text.split(',') {
            let part = part.trim();
            // A '-' that is not the first character (nor right after another '-') splits a range.
            let split = part
                .char_indices()
                .skip(1)
                .find(|&(i, c)| c == '-' && !part[..i].ends_with('-'))
                .map(|(i, _)| i);
            let bounds = match split {
                Some(i) => {
                    value(part, &part[..i]).and_then(|lo| Ok((lo, value(part, &part[i + 1..])?)))
                }
                None => value(part, part).map(|v| (v, v)),
            };
            let (lo, hi) = match bounds {
                Ok(bounds) => bounds,
                // Not a number: a name, where names are taken (not a number beyond 64 bits).
                Err(_) if names_allowed && !part.is_empty() && part.parse::<i128>().is_err() => {
                    names.push(part.to_string());
                    continue;
                }
                Err(e) => return Err(e),
            };
            if lo > hi {
                return Err(bad(part, "runs backwards"));
            }
            ranges.push(key(lo)..=key(hi));
        }
        Ok(match names.is_empty() {
            true => LabelSelection::Values(ranges),
            false => LabelSelection::Named { ranges, names },
        })
    }
}

/// Some names of `table`, for an error about a name it lacks: the first eight, and how many more
/// there are.
fn names_for_an_error(table: &[Label]) -> String {
    const NAMED: usize = 8;
    let named: Vec<&str> = table.iter().take(NAMED).map(|l| l.name.as_str()).collect();
    match table.len().saturating_sub(NAMED) {
        0 if named.is_empty() => "no label has a name here: select them by value".to_string(),
        0 => format!("the labels are {}", named.join(", ")),
        more => format!("the labels are {} and {more} more", named.join(", ")),
    }
}

/// One label of a table: its value, name and colour.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    /// The label value as a key ([`LabelSample::key`]).
    pub value: u64,
    pub name: String,
    /// sRGB red, green, blue and alpha.
    pub rgba: [u8; 4],
}

impl Label {
    /// The label's surfaces' diffuse albedo: its sRGB colour decoded, as a colour map's entry is
    /// (`colormap::Coloring::albedo`); every renderer draws a label with it.
    pub fn albedo(&self) -> [f32; 3] {
        let [r, g, b, _] = self.rgba;
        [r, g, b].map(crate::colormap::srgb8_to_linear)
    }

    /// The colour as `#rrggbbaa`, as reports show it.
    pub fn color_hex(&self) -> String {
        self.rgba
            .iter()
            .fold("#".to_string(), |s, c| s + &format!("{c:02x}"))
    }

    /// The default name and colour of label `value` (until a file names them).
    pub fn default_for(value: u64, signed: bool) -> Label {
        Label {
            value,
            name: format!("label {}", display_value(value, signed)),
            rgba: palette(value),
        }
    }
}

/// The default colour of label `value`: the one palette rule.
///
/// Hue walks the colour circle by the golden ratio, `frac(value / φ)` (computed exactly as
/// Fibonacci hashing: `value · ⌊2⁶⁴/φ⌋ mod 2⁶⁴`), through `colorous`' sinebow, whose hues are of
/// even lightness. By the three-distance theorem consecutive values, which atlases give to
/// neighbouring structures, land far apart on the circle whatever their count, and any value gets
/// its colour without knowing the others, so a label keeps its colour across files and
/// selections. Three lightness steps (`value mod 3`: as is, darker, lighter) separate values whose
/// hues fall close. Label 0 (the background) is grey.
pub fn palette(value: u64) -> [u8; 4] {
    if value == 0 {
        return [128, 128, 128, 255];
    }
    let t = value.wrapping_mul(0x9E37_79B9_7F4A_7C15) as f64 / 2f64.powi(64);
    let c = colorous::SINEBOW.eval_continuous(t);
    let shade = |v: u8| -> u8 {
        match value % 3 {
            0 => v,
            1 => (v as f64 * 0.7).round() as u8,
            _ => (v as f64 + (255.0 - v as f64) * 0.35).round() as u8,
        }
    };
    [shade(c.r), shade(c.g), shade(c.b), 255]
}

/// A label's entry in the label index: its active cells, their bounds and its runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LabelEntry {
    pub cell_count: u64,
    /// Its runs are `runs[first_run .. first_run + run_count]`.
    pub first_run: u64,
    pub run_count: u64,
    /// Smallest cell index of its active cells, and one past the largest (index space); both 0
    /// without cells.
    pub lo: [u32; 3],
    pub hi: [u32; 3],
}

impl LabelEntry {
    /// The box of its active cells in the renderers' frame (index × `spacing`): cells `[lo, hi)`
    /// span samples `lo` to `hi`. A label without cells has an empty box at 0.
    pub fn world_box(&self, spacing: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        (
            [0, 1, 2].map(|a| self.lo[a] as f64 * spacing[a]),
            [0, 1, 2].map(|a| self.hi[a] as f64 * spacing[a]),
        )
    }
}

/// Consecutive clusters of one label (inside one block).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClusterRun {
    pub first_cluster: u32,
    pub cluster_count: u32,
}

impl ClusterRun {
    pub fn clusters(&self) -> std::ops::Range<usize> {
        self.first_cluster as usize..self.first_cluster as usize + self.cluster_count as usize
    }
}

/// The labels of a grid: the table, every cluster's label and the index from label to clusters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridLabels {
    table: Vec<Label>,
    cluster_labels: Vec<u32>,
    index: Vec<LabelEntry>,
    runs: Vec<ClusterRun>,
}

impl GridLabels {
    /// Labels from their parts; [`GridLabels::check`] checks them against a grid.
    pub(crate) fn from_parts(
        table: Vec<Label>,
        cluster_labels: Vec<u32>,
        index: Vec<LabelEntry>,
        runs: Vec<ClusterRun>,
    ) -> Self {
        GridLabels {
            table,
            cluster_labels,
            index,
            runs,
        }
    }

    /// The labels, in increasing value.
    pub fn table(&self) -> &[Label] {
        &self.table
    }
    /// Label-table index of every cluster.
    pub fn cluster_labels(&self) -> &[u32] {
        &self.cluster_labels
    }
    /// Per label (table order): cells, bounds, runs.
    pub fn index(&self) -> &[LabelEntry] {
        &self.index
    }
    /// The runs of label `label` (a table index).
    pub fn runs_of(&self, label: usize) -> &[ClusterRun] {
        let e = &self.index[label];
        &self.runs[e.first_run as usize..(e.first_run + e.run_count) as usize]
    }
    /// Which labels to draw, one flag per table entry: those `show` selects (all when `None`)
    /// that `hide` does not. Each value or range either names must hold a label of the table,
    /// or it is refused in one line (`signed`: how values are written, [`display_value`]).
    pub fn shown(
        &self,
        show: Option<&LabelSelection>,
        hide: Option<&LabelSelection>,
        signed: bool,
    ) -> Result<Vec<bool>> {
        let show = show.map(|s| s.resolved(&self.table)).transpose()?;
        let hide = hide.map(|h| h.resolved(&self.table)).transpose()?;
        for selection in [&show, &hide].into_iter().flatten() {
            let LabelSelection::Values(ranges) = selection else {
                continue;
            };
            for r in ranges {
                let holds = |r: std::ops::RangeInclusive<u64>| {
                    let first = self.table.partition_point(|l| l.value < *r.start());
                    self.table.get(first).is_some_and(|l| l.value <= *r.end())
                };
                if !LabelSelection::key_ranges(r).any(holds) {
                    let (lo, hi) = (
                        display_value(*r.start(), signed),
                        display_value(*r.end(), signed),
                    );
                    let named = if lo == hi {
                        format!("label {lo}")
                    } else {
                        format!("labels {lo}-{hi}")
                    };
                    return Err(Error::invalid(format!(
                        "{named}: no such label in the grid ({} labels, {} to {})",
                        self.table.len(),
                        self.table
                            .first()
                            .map_or(String::new(), |l| display_value(l.value, signed)),
                        self.table
                            .last()
                            .map_or(String::new(), |l| display_value(l.value, signed)),
                    )));
                }
            }
        }
        Ok(self
            .table
            .iter()
            .map(|l| {
                show.as_ref().is_none_or(|s| s.selects(l.value))
                    && !hide.as_ref().is_some_and(|h| h.selects(l.value))
            })
            .collect())
    }

    /// The table index of the label with value `value`.
    pub fn find(&self, value: u64) -> Option<usize> {
        self.table.binary_search_by_key(&value, |l| l.value).ok()
    }

    /// Replaces the names and colours (the values must stay).
    pub fn set_table(&mut self, table: Vec<Label>) -> Result<()> {
        if table.len() != self.table.len()
            || table
                .iter()
                .zip(&self.table)
                .any(|(a, b)| a.value != b.value)
        {
            return Err(Error::invalid("a label table must keep the labels' values"));
        }
        self.table = table;
        Ok(())
    }

    /// The three sections' bytes: cluster labels, label index, label table.
    pub fn section_bytes(&self) -> [Vec<u8>; 3] {
        let clusters: Vec<u8> = self
            .cluster_labels
            .iter()
            .flat_map(|l| l.to_le_bytes())
            .collect();
        let mut index = Vec::with_capacity(
            LABEL_HEAD_SIZE
                + LABEL_INDEX_ENTRY_SIZE * self.index.len()
                + LABEL_RUN_SIZE * self.runs.len(),
        );
        index.extend_from_slice(&(self.index.len() as u64).to_le_bytes());
        index.extend_from_slice(&(self.runs.len() as u64).to_le_bytes());
        for e in &self.index {
            index.extend_from_slice(&e.cell_count.to_le_bytes());
            index.extend_from_slice(&e.first_run.to_le_bytes());
            index.extend_from_slice(&e.run_count.to_le_bytes());
            e.lo.iter()
                .chain(&e.hi)
                .for_each(|v| index.extend_from_slice(&v.to_le_bytes()));
        }
        for r in &self.runs {
            index.extend_from_slice(&r.first_cluster.to_le_bytes());
            index.extend_from_slice(&r.cluster_count.to_le_bytes());
        }
        let names: usize = self.table.iter().map(|l| l.name.len()).sum();
        let mut table =
            Vec::with_capacity(LABEL_HEAD_SIZE + LABEL_TABLE_ENTRY_SIZE * self.table.len() + names);
        table.extend_from_slice(&(self.table.len() as u64).to_le_bytes());
        table.extend_from_slice(&(names as u64).to_le_bytes());
        for l in &self.table {
            table.extend_from_slice(&l.value.to_le_bytes());
            table.extend_from_slice(&l.rgba);
            table.extend_from_slice(&(l.name.len() as u32).to_le_bytes());
        }
        for l in &self.table {
            table.extend_from_slice(l.name.as_bytes());
        }
        [clusters, index, table]
    }

    /// Parses the three sections (bytes as [`GridLabels::section_bytes`] writes them) and checks
    /// them against the grid's metacell slots. Every count is checked against the section's
    /// length before anything is allocated from it.
    pub fn from_sections(
        clusters: &[u8],
        index: &[u8],
        table: &[u8],
        metacells: &[Metacell],
    ) -> Result<GridLabels> {
        let u64_at = |b: &[u8], o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap());
        let u32_at = |b: &[u8], o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());

        // The table.
        if table.len() < LABEL_HEAD_SIZE {
            return Err(Error::corrupt(
                "label table section is shorter than its head",
            ));
        }
        let (n, name_bytes) = (u64_at(table, 0), u64_at(table, 8));
        let expected = n
            .checked_mul(LABEL_TABLE_ENTRY_SIZE as u64)
            .and_then(|e| e.checked_add(LABEL_HEAD_SIZE as u64))
            .and_then(|e| e.checked_add(name_bytes));
        if expected != Some(table.len() as u64) {
            return Err(Error::corrupt(format!(
                "label table section is {} bytes, not the head, {n} entries and {name_bytes} name bytes",
                table.len()
            )));
        }
        let n = n as usize;
        let mut names = &table[LABEL_HEAD_SIZE + LABEL_TABLE_ENTRY_SIZE * n..];
        let mut labels = Vec::with_capacity(n);
        for i in 0..n {
            let e =
                &table[LABEL_HEAD_SIZE + LABEL_TABLE_ENTRY_SIZE * i..][..LABEL_TABLE_ENTRY_SIZE];
            let value = u64_at(e, 0);
            let len = u32_at(e, 12) as usize;
            if labels.last().is_some_and(|l: &Label| l.value >= value) {
                return Err(Error::corrupt(format!(
                    "label table entry {i}: values are not strictly increasing"
                )));
            }
            if len > names.len() {
                return Err(Error::corrupt(format!(
                    "label table entry {i}: its name runs past the names"
                )));
            }
            let (name, rest) = names.split_at(len);
            names = rest;
            let name = std::str::from_utf8(name)
                .map_err(|_| Error::corrupt(format!("label table entry {i}: name is not UTF-8")))?;
            labels.push(Label {
                value,
                name: name.to_string(),
                rgba: e[8..12].try_into().unwrap(),
            });
        }
        if !names.is_empty() {
            return Err(Error::corrupt(
                "label table names are longer than its entries say",
            ));
        }

        // Cluster labels.
        let cluster_count = metacells.len() / CLUSTER_SLOTS;
        if clusters.len() as u64 != cluster_count as u64 * 4 {
            return Err(Error::corrupt(format!(
                "cluster label section is {} bytes for {cluster_count} clusters",
                clusters.len()
            )));
        }
        let cluster_labels: Vec<u32> = clusters
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        if let Some(c) = cluster_labels.iter().position(|&l| l as usize >= n) {
            return Err(Error::corrupt(format!(
                "cluster {c} has label {} of {n}",
                cluster_labels[c]
            )));
        }

        // The index.
        if index.len() < LABEL_HEAD_SIZE || u64_at(index, 0) != n as u64 {
            return Err(Error::corrupt(format!(
                "label index section does not start with the table's {n} labels"
            )));
        }
        let run_total = u64_at(index, 8);
        let expected = run_total
            .checked_mul(LABEL_RUN_SIZE as u64)
            .and_then(|r| r.checked_add((LABEL_HEAD_SIZE + LABEL_INDEX_ENTRY_SIZE * n) as u64));
        if expected != Some(index.len() as u64) {
            return Err(Error::corrupt(format!(
                "label index section is {} bytes, not the head, {n} entries and {run_total} runs",
                index.len()
            )));
        }
        let entries: Vec<LabelEntry> = (0..n)
            .map(|i| {
                let e = &index[LABEL_HEAD_SIZE + LABEL_INDEX_ENTRY_SIZE * i..]
                    [..LABEL_INDEX_ENTRY_SIZE];
                LabelEntry {
                    cell_count: u64_at(e, 0),
                    first_run: u64_at(e, 8),
                    run_count: u64_at(e, 16),
                    lo: [0, 1, 2].map(|a| u32_at(e, 24 + 4 * a)),
                    hi: [0, 1, 2].map(|a| u32_at(e, 36 + 4 * a)),
                }
            })
            .collect();
        let runs: Vec<ClusterRun> = index[LABEL_HEAD_SIZE + LABEL_INDEX_ENTRY_SIZE * n..]
            .chunks_exact(LABEL_RUN_SIZE)
            .map(|r| ClusterRun {
                first_cluster: u32_at(r, 0),
                cluster_count: u32_at(r, 4),
            })
            .collect();
        let labels = GridLabels {
            table: labels,
            cluster_labels,
            index: entries,
            runs,
        };
        labels.check(metacells)?;
        Ok(labels)
    }

    /// Checks the index against the cluster labels and the metacells: each label's runs follow the
    /// previous label's, lie in cluster order inside the grid and hold only its clusters; together
    /// they cover every cluster once; its cell count and bounds are those of its clusters' cells.
    pub(crate) fn check(&self, metacells: &[Metacell]) -> Result<()> {
        let cluster_count = metacells.len() / CLUSTER_SLOTS;
        let fail = |i: usize, what: &str| Error::corrupt(format!("label index entry {i}: {what}"));
        if self.table.len() != self.index.len() || self.cluster_labels.len() != cluster_count {
            return Err(Error::corrupt(
                "label sections disagree on the number of labels or clusters",
            ));
        }
        let mut next_run = 0u64;
        let mut covered = 0usize;
        for (i, e) in self.index.iter().enumerate() {
            if e.first_run != next_run || e.run_count > self.runs.len() as u64 - next_run {
                return Err(fail(i, "its runs do not follow the previous label's"));
            }
            next_run += e.run_count;
            let (mut cells, mut lo, mut hi) = (0u64, [u32::MAX; 3], [0u32; 3]);
            let mut end = 0usize;
            for run in &self.runs[e.first_run as usize..next_run as usize] {
                let clusters = run.clusters();
                if run.cluster_count == 0 || clusters.start < end || clusters.end > cluster_count {
                    return Err(fail(i, "a run is empty, out of order or outside the grid"));
                }
                end = clusters.end;
                covered += clusters.len();
                for c in clusters {
                    if self.cluster_labels[c] as usize != i {
                        return Err(fail(
                            i,
                            &format!("cluster {c} in its runs has another label"),
                        ));
                    }
                    let slots = &metacells[c * CLUSTER_SLOTS..c * CLUSTER_SLOTS + BOUND_SLOT];
                    for m in slots.iter().filter(|m| !m.is_empty()) {
                        cells += m.active_cells() as u64;
                        let (l, h) = m.cell_box();
                        for a in 0..3 {
                            lo[a] = lo[a].min(l[a]);
                            hi[a] = hi[a].max(h[a]);
                        }
                    }
                }
            }
            if cells == 0 {
                lo = [0; 3];
            }
            if e.cell_count != cells || e.lo != lo || e.hi != hi {
                return Err(fail(
                    i,
                    "its cell count or bounds do not match its clusters",
                ));
            }
        }
        if next_run != self.runs.len() as u64 || covered != cluster_count {
            return Err(Error::corrupt(
                "the label index's runs do not cover every cluster once",
            ));
        }
        Ok(())
    }
}

/// Rejects a float volume that is not a label volume, naming the first value that is not a label.
pub fn check_label_samples<T: LabelSample>(samples: &[T]) -> Result<()> {
    use rayon::prelude::*;
    match samples.par_iter().find_first(|v| !v.is_label()) {
        None => Ok(()),
        Some(v) => Err(Error::invalid(format!(
            "label values must be integers, and this {} volume holds {} (a float volume is a label volume only when every value is an integer of at most 2^24)",
            T::TYPE.name(),
            v.to_f64()
        ))),
    }
}

//! The label list of a label grid (docs/design/labels.md, "The viewer"): the labels' table and
//! cell counts as the panel lists them, the search that filters them by name or value, and which
//! labels are drawn. The panel shows at most [`MAX_ROWS`] of the matches, so that a grid of 10⁵
//! labels lists as quickly as one of ten; the search runs only when the query changes.

use isogrid::labels::{display_value, GridLabels, LabelSelection};

/// The most rows the panel lists at once; it says how many more match.
pub const MAX_ROWS: usize = 300;

/// The labels of the grid shown, and which of them are drawn.
pub struct LabelList {
    /// The grid's labels (table, cell counts, the index `GridLabels::shown` checks against).
    labels: GridLabels,
    signed: bool,
    /// Each label's name in lower case, and its value as written, for the search.
    names: Vec<String>,
    values: Vec<String>,
    /// One flag per label (table order): drawn or hidden.
    shown: Vec<bool>,
    query: String,
    /// Table indices of the labels matching `query`, in table (value) order.
    matches: Vec<usize>,
}

impl LabelList {
    /// The list of `labels` (values signed as `signed` says), all shown, no search.
    pub fn new(labels: GridLabels, signed: bool) -> LabelList {
        let names = labels
            .table()
            .iter()
            .map(|l| l.name.to_lowercase())
            .collect();
        let values = labels
            .table()
            .iter()
            .map(|l| display_value(l.value, signed))
            .collect();
        let n = labels.table().len();
        LabelList {
            labels,
            signed,
            names,
            values,
            shown: vec![true; n],
            query: String::new(),
            matches: (0..n).collect(),
        }
    }

    pub fn labels(&self) -> &GridLabels {
        &self.labels
    }
    pub fn len(&self) -> usize {
        self.shown.len()
    }
    /// The label value as written (with its sign for signed volumes).
    pub fn value_text(&self, label: usize) -> &str {
        &self.values[label]
    }
    pub fn shown(&self) -> &[bool] {
        &self.shown
    }
    pub fn shown_count(&self) -> usize {
        self.shown.iter().filter(|&&s| s).count()
    }

    /// Draws the labels `show` selects (all when `None`) that `hide` does not, as `render --show
    /// / --hide` do (`GridLabels::shown`, which refuses a value naming no label).
    pub fn choose(
        &mut self,
        show: Option<&LabelSelection>,
        hide: Option<&LabelSelection>,
    ) -> isogrid::Result<()> {
        self.shown = self.labels.shown(show, hide, self.signed)?;
        Ok(())
    }

    /// Keeps the flags of `old` for the labels of the same value (a new grid of the same input).
    pub fn keep_flags_of(&mut self, old: &LabelList) {
        for (flag, label) in self.shown.iter_mut().zip(self.labels.table()) {
            if let Some(i) = old.labels.find(label.value) {
                *flag = old.shown[i];
            }
        }
    }

    pub fn set_shown(&mut self, label: usize, shown: bool) {
        self.shown[label] = shown;
    }
    pub fn set_all(&mut self, shown: bool) {
        self.shown.fill(shown);
    }
    /// Shows the matches of the search and hides every other label.
    pub fn show_only_matches(&mut self) {
        self.shown.fill(false);
        for &i in &self.matches {
            self.shown[i] = true;
        }
    }

    /// Searches for `query`: a label matches when its name contains the query (ignoring case) or,
    /// when the query is a list of values and ranges as `--show` takes (`5`, `1,5-9`), when its
    /// value is among them. An empty query matches every label.
    pub fn search(&mut self, query: &str) {
        if query == self.query {
            return;
        }
        self.query = query.to_string();
        let q = query.trim().to_lowercase();
        let values = match LabelSelection::parse(&q) {
            Ok(LabelSelection::Values(v)) => Some(LabelSelection::Values(v)),
            _ => None,
        };
        let table = self.labels.table();
        self.matches = (0..table.len())
            .filter(|&i| {
                q.is_empty()
                    || self.names[i].contains(&q)
                    || values.as_ref().is_some_and(|v| v.selects(table[i].value))
            })
            .collect();
    }

    /// Table indices of the labels the search matches.
    pub fn matches(&self) -> &[usize] {
        &self.matches
    }

    /// The table index of the label with `value`.
    pub fn find(&self, value: u64) -> Option<usize> {
        self.labels.find(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isogrid::labels::Label;
    use isogrid::{extract_labels, LabelOptions, Volume, VolumeData};

    /// A u16 volume of `n` slabs two voxels thick, labelled 1..=n along x.
    pub(crate) fn slabs(n: usize) -> Volume {
        let dims = [2 * n + 2, 6, 6];
        let samples = (0..dims[0] * dims[1] * dims[2])
            .map(|i| ((i % dims[0]).saturating_sub(1) / 2 + 1).min(n) as u16)
            .collect();
        Volume::new(dims, VolumeData::U16(samples)).unwrap()
    }

    /// A label grid of `n` labels (values 1..=n), named `label k` but for the first two.
    fn list(n: usize) -> LabelList {
        let options = LabelOptions::new(LabelSelection::All);
        let grid = extract_labels(&slabs(n).view(), &options).unwrap();
        let mut labels = grid.labels().expect("a label grid").clone();
        let mut table = labels.table().to_vec();
        assert_eq!(table.len(), n);
        for (l, name) in table
            .iter_mut()
            .zip(["Left-Hippocampus", "Right-Hippocampus"])
        {
            l.name = name.to_string();
        }
        labels.set_table(table).unwrap();
        LabelList::new(labels, false)
    }

    /// The search against a brute-force filter of the table written out here: names by
    /// substring (any case), values by list and range.
    #[test]
    fn search_filters_by_name_and_value() {
        let mut list = list(27);
        let table: Vec<Label> = list.labels().table().to_vec();
        let brute = |pred: &dyn Fn(&Label) -> bool| -> Vec<usize> {
            (0..table.len()).filter(|&i| pred(&table[i])).collect()
        };
        assert_eq!(list.matches().len(), 27, "no query matches every label");

        list.search("hippo");
        assert_eq!(list.matches(), brute(&|l| l.name.contains("Hippocampus")));
        assert_eq!(list.matches().len(), 2);

        list.search("12");
        // Label 12 by value; no name "label 12" contains it otherwise but label 12's own.
        assert_eq!(list.matches(), brute(&|l| l.value == 12));

        list.search("1");
        let ones = brute(&|l| l.value == 1 || l.name.contains('1'));
        assert_eq!(list.matches(), ones);
        assert!(
            ones.len() > 5,
            "names with a 1 (label 1, 10-19, 21) match too"
        );

        list.search("3-5, 20");
        assert_eq!(
            list.matches(),
            brute(&|l| (3..=5).contains(&l.value) || l.value == 20)
        );

        list.search("no such label");
        assert!(list.matches().is_empty());
    }

    /// 10⁵ labels (a 48×48×44 u32 volume of one-voxel labels): building the list and searching it
    /// give the brute-force matches, in milliseconds (printed; the panel lists at most
    /// [`MAX_ROWS`] of them).
    #[test]
    fn searches_a_hundred_thousand_labels() {
        let dims = [48, 48, 44];
        let n = dims[0] * dims[1] * dims[2];
        let samples = (0..n).map(|i| (i + 1) as u32).collect();
        let volume = Volume::new(dims, VolumeData::U32(samples)).unwrap();
        let options = LabelOptions::new(LabelSelection::All);
        let labels = extract_labels(&volume.view(), &options)
            .unwrap()
            .labels()
            .unwrap()
            .clone();
        assert!(labels.table().len() >= 100_000, "{}", labels.table().len());
        let start = std::time::Instant::now();
        let mut list = LabelList::new(labels, false);
        let built = start.elapsed();
        for query in ["label 4242", "777", "100-199,5000", "LABEL 9999"] {
            let start = std::time::Instant::now();
            list.search(query);
            let took = start.elapsed();
            let q = query.to_lowercase();
            let values = LabelSelection::parse(&q).ok();
            let brute: Vec<usize> = (0..list.len())
                .filter(|&i| {
                    let l = &list.labels().table()[i];
                    l.name.to_lowercase().contains(&q)
                        || values.as_ref().is_some_and(|v| v.selects(l.value))
                })
                .collect();
            assert_eq!(list.matches(), brute, "{query}");
            assert!(!brute.is_empty(), "{query}");
            eprintln!(
                "{} labels: list built in {:.1} ms; {query:?}: {} matches in {:.2} ms",
                list.len(),
                built.as_secs_f64() * 1e3,
                brute.len(),
                took.as_secs_f64() * 1e3
            );
        }
    }

    /// Show all / hide all / only matches and `--show` / `--hide` set the flags the renderer gets.
    #[test]
    fn visibility_follows_the_buttons_and_selections() {
        let mut list = list(10);
        assert_eq!(list.shown_count(), 10);
        list.set_all(false);
        assert_eq!(list.shown_count(), 0);
        list.search("2-4");
        list.show_only_matches();
        let shown: Vec<u64> = (0..list.len())
            .filter(|&i| list.shown()[i])
            .map(|i| list.labels().table()[i].value)
            .collect();
        assert_eq!(shown, [2, 3, 4]);

        let hide = LabelSelection::parse("3,7").unwrap();
        list.choose(None, Some(&hide)).unwrap();
        assert_eq!(list.shown_count(), 8);
        assert!(!list.shown()[list.find(7).unwrap()]);
        let absent = LabelSelection::parse("99").unwrap();
        assert!(list.choose(None, Some(&absent)).is_err());

        // A new grid of the same labels keeps the flags.
        let mut again = super::tests::list(10);
        again.keep_flags_of(&list);
        assert_eq!(again.shown(), list.shown());
    }
}

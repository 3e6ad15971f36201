//! Plain-text tables with aligned columns: a title, a header, rows, optional rules between
//! groups of rows and notes under the table. The first column is left-aligned (labels), the
//! others right-aligned (numbers); widths count characters, not bytes, so `µ` and `×` align.

use std::fmt::Write as _;

/// One table, built row by row and rendered once.
#[derive(Clone, Debug, Default)]
pub struct Table {
    title: String,
    /// Left-align every column (tables of text rather than numbers).
    left: bool,
    header: Vec<String>,
    rows: Vec<Row>,
    notes: Vec<String>,
}

#[derive(Clone, Debug)]
enum Row {
    Cells(Vec<String>),
    Rule,
}

impl Table {
    /// A table with a title and column headers.
    pub fn new(title: impl Into<String>, header: &[&str]) -> Table {
        Table {
            title: title.into(),
            header: header.iter().map(|s| s.to_string()).collect(),
            ..Table::default()
        }
    }

    /// Left-aligns every column, for tables of sentences.
    pub fn left_aligned(mut self) -> Table {
        self.left = true;
        self
    }

    /// Appends a row (missing cells are blank, extra cells are kept).
    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.rows
            .push(Row::Cells(cells.into_iter().map(Into::into).collect()));
    }

    /// Appends a horizontal rule between groups of rows.
    pub fn rule(&mut self) {
        self.rows.push(Row::Rule);
    }

    /// Appends a note printed under the table.
    pub fn note(&mut self, note: impl Into<String>) {
        self.notes.push(note.into());
    }

    /// The table as text, ending with a newline.
    pub fn render(&self) -> String {
        let columns = self.rows.iter().fold(self.header.len(), |n, r| match r {
            Row::Cells(c) => n.max(c.len()),
            Row::Rule => n,
        });
        let mut width = vec![0usize; columns];
        let all = std::iter::once(&self.header).chain(self.rows.iter().filter_map(|r| match r {
            Row::Cells(c) => Some(c),
            Row::Rule => None,
        }));
        for cells in all {
            for (w, c) in width.iter_mut().zip(cells) {
                *w = (*w).max(c.chars().count());
            }
        }
        let total = width.iter().sum::<usize>() + 2 * columns.saturating_sub(1);
        let line = |cells: &[String]| -> String {
            let mut s = String::from("  ");
            for (k, w) in width.iter().enumerate() {
                let c = cells.get(k).map(String::as_str).unwrap_or("");
                let pad = w - c.chars().count().min(*w);
                if k > 0 {
                    s.push_str("  ");
                }
                if k == 0 || self.left {
                    s.push_str(c);
                    s.extend(std::iter::repeat_n(' ', pad));
                } else {
                    s.extend(std::iter::repeat_n(' ', pad));
                    s.push_str(c);
                }
            }
            s.truncate(s.trim_end().len());
            s
        };
        let rule = format!("  {}", "-".repeat(total));
        let mut out = String::new();
        if !self.title.is_empty() {
            let _ = writeln!(out, "{}", self.title);
        }
        let _ = writeln!(out, "{}", line(&self.header));
        let _ = writeln!(out, "{rule}");
        for r in &self.rows {
            match r {
                Row::Cells(c) => {
                    let _ = writeln!(out, "{}", line(c));
                }
                Row::Rule => {
                    let _ = writeln!(out, "{rule}");
                }
            }
        }
        for n in &self.notes {
            let _ = writeln!(out, "  {n}");
        }
        out
    }
}

/// `x` with `digits` decimals, or `-` when it is not finite.
pub fn num(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "-".into()
    }
}

/// An optional number, `-` when absent.
pub fn opt(x: Option<f64>, digits: usize) -> String {
    x.map_or_else(|| "-".into(), |v| num(v, digits))
}

/// A fraction as a percentage with `digits` decimals.
pub fn pct(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{:.digits$}%", 100.0 * x)
    } else {
        "-".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_align_by_characters() {
        let mut t = Table::new("T", &["name", "µs"]);
        t.row(["begin-refine", "1.5"]);
        t.rule();
        t.row(["×", "12.25"]);
        t.note("a note");
        let s = t.render();
        let lines: Vec<&str> = s.lines().collect();
        assert_eq!(lines[0], "T");
        // Every data line ends at the same character column (right-aligned numbers).
        let ends: Vec<usize> = [1, 3, 5]
            .iter()
            .map(|&i| lines[i].chars().count())
            .collect();
        assert!(ends.iter().all(|&e| e == ends[0]), "{s}");
        assert!(lines[2].starts_with("  ---") && lines[4].starts_with("  ---"));
        assert_eq!(lines[6], "  a note");
    }

    #[test]
    fn numbers() {
        assert_eq!(num(1.23456, 2), "1.23");
        assert_eq!(num(f64::NAN, 2), "-");
        assert_eq!(opt(None, 1), "-");
        assert_eq!(pct(0.4776, 1), "47.8%");
    }
}

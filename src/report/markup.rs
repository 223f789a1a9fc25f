//! The reports' shared vocabulary, as hyperfine's `export/markup.rs`: the one family of number
//! formats every report writes its numbers with, one escape per output language (HTML in
//! [`crate::report::html::escape`], XML for SVG and JUnit here), a document written a line at a
//! time ([`Doc`]), and Markdown tables written once: a table is made from its columns, and every
//! row must have one cell per column, so a header and its rows cannot drift apart.

use std::fmt::Display;

/// What a report writes where a number is absent (nothing observed, nothing to divide by).
pub const ABSENT: &str = "—";

/// A non-negative statistic compactly, two significant digits: `3.1e-7`, `0`, `NaN`, or
/// [`ABSENT`].
pub fn sci(x: Option<f64>) -> String {
    match x {
        None => ABSENT.into(),
        Some(0.0) => "0".into(),
        Some(v) if v.is_nan() => "NaN".into(),
        Some(v) => format!("{v:.1e}"),
    }
}

/// A statistic with three significant digits (`1.23e-2`); [`ABSENT`] when absent or not
/// finite. Takes an `f64` or an `Option<f64>`.
pub fn sci2(x: impl Into<Option<f64>>) -> String {
    match x.into() {
        Some(v) if v.is_finite() => format!("{v:.2e}"),
        _ => ABSENT.into(),
    }
}

/// A fraction as a percentage with one decimal and no unit (`12.5`; [`ABSENT`] for NaN), for a
/// column whose header names the unit.
pub fn percent(x: f64) -> String {
    if x.is_nan() {
        ABSENT.into()
    } else {
        format!("{:.1}", 100.0 * x)
    }
}

/// A fraction as a percentage with one decimal and its unit (`12.5 %`; [`ABSENT`] for NaN).
pub fn pct(x: f64) -> String {
    if x.is_nan() {
        ABSENT.into()
    } else {
        format!("{:.1} %", 100.0 * x)
    }
}

/// `part` as a percentage of `whole` (`12.5 %`; [`ABSENT`] when `whole` is 0).
pub fn share(part: usize, whole: usize) -> String {
    if whole == 0 {
        ABSENT.into()
    } else {
        format!("{:.1} %", 100.0 * part as f64 / whole as f64)
    }
}

/// Text for XML (an SVG image, a JUnit report), in an element or an attribute: the five
/// special characters escaped, and the control characters XML 1.0 cannot hold at all
/// replaced by `?`.
pub fn xml_escape(text: &str) -> String {
    let mut o = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            '\t' | '\n' | '\r' => o.push(c),
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => o.push('?'),
            c => o.push(c),
        }
    }
    o
}

/// A text document written a line at a time (Markdown, SVG, CSV), in place of `writeln!`
/// into a `String` with its result ignored: writing to a `String` cannot fail, so these
/// return nothing.
pub trait Doc {
    /// `text` and a newline.
    fn line(&mut self, text: impl Display);
    /// `text` without a newline.
    fn put(&mut self, text: impl Display);
    /// An empty line.
    fn blank(&mut self) {
        self.put("\n");
    }
    /// A paragraph: `text`, then an empty line.
    fn para(&mut self, text: impl Display) {
        self.line(text);
        self.blank();
    }
    /// A Markdown heading of `level` (1 is `#`), then an empty line.
    fn heading(&mut self, level: usize, text: impl Display) {
        self.put("#".repeat(level));
        self.put(" ");
        self.para(text);
    }
    /// A Markdown bullet list, one `- item` line each.
    fn bullets<I: IntoIterator>(&mut self, items: I)
    where
        I::Item: Display,
    {
        for item in items {
            self.line(format_args!("- {item}"));
        }
    }
    /// A Markdown table.
    fn table(&mut self, table: &Table) {
        self.put(table.markdown());
    }
}

impl Doc for String {
    fn line(&mut self, text: impl Display) {
        self.put(text);
        self.push('\n');
    }

    fn put(&mut self, text: impl Display) {
        use std::fmt::Write as _;
        // Writing to a String cannot fail.
        write!(self, "{text}").expect("writing to a String cannot fail");
    }
}

/// How a column's cells are aligned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    Left,
    Right,
}

/// A Markdown table: its columns, then its rows.
#[derive(Clone, Debug)]
pub struct Table {
    columns: Vec<(String, Align)>,
    rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new(columns: &[(&str, Align)]) -> Table {
        Table::with_columns(columns.iter().map(|(n, a)| (n.to_string(), *a)).collect())
    }

    /// A table whose column names are computed (one column per method, per material, ...).
    pub fn with_columns(columns: Vec<(String, Align)>) -> Table {
        Table {
            columns,
            rows: Vec::new(),
        }
    }

    /// No rows yet.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Adds a row; it must have one cell per column (a mismatch is a bug in the caller).
    pub fn row(&mut self, cells: Vec<String>) {
        assert_eq!(
            cells.len(),
            self.columns.len(),
            "a row of {} cells in a table of columns {:?}",
            cells.len(),
            self.columns.iter().map(|c| &c.0).collect::<Vec<_>>()
        );
        self.rows.push(cells);
    }

    /// The header, the alignment line and every row, each line ending in a newline.
    pub fn markdown(&self) -> String {
        // `| a | b |`; an empty cell is `| |`.
        let line = |cells: &[String]| {
            let mut l = String::from("|");
            for c in cells {
                if !c.is_empty() {
                    l.push(' ');
                    l.push_str(c);
                }
                l.push_str(" |");
            }
            l.push('\n');
            l
        };
        let names: Vec<String> = self.columns.iter().map(|c| c.0.clone()).collect();
        let mut out = line(&names);
        out.push('|');
        for (_, a) in &self.columns {
            out.push_str(match a {
                Align::Left => "---|",
                Align::Right => "---:|",
            });
        }
        out.push('\n');
        for r in &self.rows {
            out.push_str(&line(r));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_writes_its_header_alignment_and_rows() {
        let mut t = Table::new(&[("method", Align::Left), ("n", Align::Right)]);
        t.row(vec!["`a`".into(), "3".into()]);
        assert_eq!(t.markdown(), "| method | n |\n|---|---:|\n| `a` | 3 |\n");
        let mut t = Table::with_columns(vec![("x".into(), Align::Right), (String::new(), Align::Left)]);
        assert!(t.is_empty());
        t.row(vec!["1".into(), String::new()]);
        assert_eq!(t.markdown(), "| x | |\n|---:|---|\n| 1 | |\n");
    }

    #[test]
    fn numbers_are_written_one_way() {
        assert_eq!(sci(None), "—");
        assert_eq!(sci(Some(0.0)), "0");
        assert_eq!(sci(Some(3.14e-7)), "3.1e-7");
        assert_eq!(sci2(0.0123456), "1.23e-2");
        assert_eq!(sci2(None), "—");
        assert_eq!(sci2(f64::NAN), "—");
        assert_eq!(percent(0.125), "12.5");
        assert_eq!(pct(0.1), "10.0 %");
        assert_eq!(share(1, 8), "12.5 %");
        assert_eq!(share(1, 0), "—");
    }

    #[test]
    fn xml_text_is_escaped_and_control_characters_replaced() {
        assert_eq!(
            xml_escape("a<b> & \"c\" 'd'\u{1}\n"),
            "a&lt;b&gt; &amp; &quot;c&quot; &apos;d&apos;?\n"
        );
    }

    #[test]
    fn a_document_is_written_a_line_at_a_time() {
        let mut d = String::new();
        d.heading(2, "Findings");
        d.bullets(["a", "b"]);
        d.blank();
        d.para(format_args!("n = {}", 3));
        d.put("x");
        d.line("y");
        assert_eq!(d, "## Findings\n\n- a\n- b\n\nn = 3\n\nxy\n");
    }

    #[test]
    #[should_panic(expected = "a row of 1 cells")]
    fn a_row_that_does_not_fit_the_header_is_refused() {
        let mut t = Table::new(&[("method", Align::Left), ("n", Align::Right)]);
        t.row(vec!["`a`".into()]);
    }
}

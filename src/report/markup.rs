//! Markdown tables written once: a table is made from its columns, and every row must have one
//! cell per column, so a header and its rows cannot drift apart.

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
    #[should_panic(expected = "a row of 1 cells")]
    fn a_row_that_does_not_fit_the_header_is_refused() {
        let mut t = Table::new(&[("method", Align::Left), ("n", Align::Right)]);
        t.row(vec!["`a`".into()]);
    }
}

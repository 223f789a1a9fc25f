//! "Where the bits go": per method, the kernel source lines whose f32 operations lose the
//! most bits (local error, src/eval/interp), as a short Markdown table. Kept apart from
//! `markdown/`, which only calls [`render`].

use crate::analyse::summary::Attribution;
use crate::report::markup::{Align, Doc as _, Table};

/// Lines shown per method.
const TOP: usize = 5;

pub fn render(methods: &[Attribution]) -> String {
    let mut o = String::new();
    if methods.is_empty() {
        return o;
    }
    o.heading(2, "Where the bits go");
    o.para(format_args!(
        "Local f32 rounding error per kernel source line (the CPU evaluator in f32 with an f64 shadow; each \
         operation in f32 on the shadow's arguments rounded to f32, against the exact operation; bits = \
         log2(1 + ULP distance)). Per configuration a line's bits are the mean and the max over its operations; \
         the table gives the mean of the means and the p99 of the maxima over the configurations the line ran \
         on. The {TOP} lines with the most bits per method, on an evenly spread subset of the configurations \
         (count per method)."
    ));
    for m in methods {
        o.para(format_args!("`{}` ({} configurations):", m.label, m.configurations));
        let mut table = Table::new(&[
            ("file:line", Align::Left),
            ("source", Align::Left),
            ("mean bits", Align::Right),
            ("p99 bits", Align::Right),
        ]);
        for l in m.lines.iter().take(TOP) {
            table.row(vec![
                format!("`{}:{}`", l.path, l.line),
                format!("`{}`", l.text.trim().replace('|', "\\|")),
                format!("{:.2}", l.mean),
                format!("{:.2}", l.p99),
            ]);
        }
        o.table(&table);
        o.blank();
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analyse::summary::BitsLine;

    #[test]
    fn a_table_per_method_top_lines_first() {
        let line = |n: usize, text: &str, mean: f64| BitsLine {
            path: "kernels/k.wgsl".into(),
            line: n,
            text: text.into(),
            mean,
            p99: 2.0 * mean,
        };
        let m = Attribution {
            label: "line.k".into(),
            configurations: 10,
            lines: (0..7).map(|i| line(i + 1, "let a = b | c;", 7.0 - i as f64)).collect(),
        };
        let text = render(&[m]);
        assert!(text.contains("## Where the bits go"));
        assert!(text.contains("`line.k` (10 configurations)"));
        assert!(text.contains("| `kernels/k.wgsl:1` | `let a = b \\| c;` | 7.00 | 14.00 |"));
        assert_eq!(text.matches("kernels/k.wgsl:").count(), TOP);
        assert_eq!(render(&[]), "");
    }
}

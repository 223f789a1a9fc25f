//! Method against method: the measured differences (findings sentences), the |a − b| tables
//! per compared pair, and the search for where compared methods disagree most.

use crate::analyse::summary::Summary;
use crate::report::markup::{sci, Align, Doc as _, Table};

/// One sentence per compared pair and material.
pub(super) fn measured_differences(w: &mut String, input: &Summary) {
    let a = &input.analysis;
    if !a.comparisons.is_empty() {
        w.heading(2, "Measured differences");
        for c in &a.comparisons {
            for mat in &c.materials {
                w.line(crate::report::findings::comparison(a, c, mat));
            }
        }
        w.blank();
    }
}

/// |a − b| / reference per compared pair, material and axis bin.
pub(super) fn comparison_tables(w: &mut String, input: &Summary) {
    let a = &input.analysis;
    for c in &a.comparisons {
        w.heading(2, format_args!("`{}` against `{}`", c.a, c.b));
        w.para("|a − b| / reference, configuration by configuration (p99 and max; f32 GPU / f64 CPU).");
        for mat in &c.materials {
            for axis in &mat.axes {
                w.para(format_args!("Material `{}`, by `{}`:", mat.material, axis.axis));
                let mut columns = vec![(axis.axis.to_string(), Align::Left)];
                columns
                    .extend(["n", "f32 p99", "f32 max", "f64 p99", "f64 max"].map(|c| (c.to_string(), Align::Right)));
                let mut table = Table::with_columns(columns);
                for b in &axis.bins {
                    let s = &b.stats;
                    table.row(vec![
                        format!("[{}, {})", b.lo, b.hi),
                        s.count.to_string(),
                        sci(s.diff_f32.map(|q| q.p99)),
                        sci(s.diff_f32.map(|q| q.max)),
                        sci(s.diff_f64.map(|q| q.p99)),
                        sci(s.diff_f64.map(|q| q.max)),
                    ]);
                }
                w.table(&table);
                w.blank();
            }
        }
    }
}

/// The disagreement search: per compared pair, both ways, the configurations where one method is
/// least accurate relative to the other, with the region they fall in.
pub(super) fn disagreements(w: &mut String, input: &Summary) {
    if input.case.compare.is_empty() {
        return;
    }
    let eps = input.case.disagreements.clone().unwrap_or_default().epsilon;
    w.heading(2, "Where the compared methods disagree");
    w.para(format_args!(
        "For every compared pair (A, B) and both ways, a search (restarts from the sample's largest ratios, \
         then a hill climb in the family's dimensionless parameters) for the configurations that maximise \
         err_A / max(err_B, ε), ε = {}, relative errors with no floor. Every configuration found is in \
         `disagreements.jsonl` (eval input format; replay with `linelight eval`); its id names the pair and \
         the direction. Region: the configuration's axes in the transformed (diffuse) configuration; \
         subtended: the angle the segment subtends at the shading point (radians, untransformed); \
         × typical: the reference over the median reference of the family's lit configurations (how \
         bright the light is against a typical one of the sample).",
        sci(Some(eps))
    ));
    for [x, y] in &input.case.compare {
        for (a, b) in [(x, y), (y, x)] {
            let mut found: Vec<_> = input.disagreements.iter().filter(|d| &d.a == a && &d.b == b).collect();
            found.sort_by(|p, q| q.ratio.total_cmp(&p.ratio));
            w.heading(3, format_args!("`{a}` less accurate than `{b}`"));
            if found.is_empty() {
                w.para(format_args!("Nowhere found: in no family does `{a}` lose to `{b}`."));
                continue;
            }
            let mut columns = vec![("family".to_string(), Align::Left)];
            columns.extend(
                [
                    "ratio",
                    "in sample",
                    "err A (f32)",
                    "err B (f32)",
                    "A f64",
                    "B f64",
                    "reference",
                    "× typical",
                    "subtended",
                    "reach_near_o",
                    "reach_o",
                    "subtended_o",
                    "height_o",
                    "tilt_o",
                ]
                .map(|c| (c.to_string(), Align::Right)),
            );
            let mut table = Table::with_columns(columns);
            for d in found.iter().take(6) {
                let f = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.6e}"));
                let x = &d.axes;
                table.row(vec![
                    format!("`{}`", d.family),
                    sci(Some(d.ratio)),
                    sci(Some(d.sample_ratio)),
                    sci(Some(d.err_a)),
                    sci(Some(d.err_b)),
                    f(d.f64_a),
                    f(d.f64_b),
                    format!("{:.6e}", d.reference.value),
                    super::brightness(input, a, &d.family, d.reference.value),
                    sci(Some(x.subtended)),
                    sci(Some(x.reach_near_o)),
                    sci(Some(x.reach_o)),
                    sci(Some(x.subtended_o)),
                    format!("{:.2}", x.height_o),
                    format!("{:.3}", x.tilt_o),
                ]);
            }
            w.table(&table);
            if found.len() > 6 {
                w.line(format_args!("\n{} more in `disagreements.jsonl`.", found.len() - 6));
            }
            w.blank();
        }
    }
}

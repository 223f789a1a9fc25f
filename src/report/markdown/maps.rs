//! The validity maps: per map, method and material, the chart and the table of where the
//! relative error stays under each threshold.

use crate::analyse::summary::Summary;
use crate::report::markup::{Align, Doc as _, Table};

/// Every validity map of the case, for the methods it shows.
pub(super) fn validity_maps(w: &mut String, input: &Summary) {
    let (case, a) = (&input.case, &input.analysis);
    for (k, map) in case.maps.iter().enumerate() {
        w.heading(2, format_args!("Validity map: `{}` × `{}`", map.x.axis, map.y.axis));
        for ms in a.methods.iter().filter(|m| map.shows(&m.label)) {
            for mat in &ms.materials {
                let stats = &mat.maps[k];
                let file = crate::report::map_file(&ms.label, &mat.material, &map.x.axis, &map.y.axis);
                w.para(format_args!(
                    "### `{}` on `{}`\n\n![{} on {}]({file})",
                    ms.label, mat.material, ms.label, mat.material
                ));
                w.para(format_args!(
                    "Where the relative error stays under each threshold, from the smallest `{}` up: for 99 % \
                     of configurations (p99), and for half of them (median):",
                    map.x.axis
                ));
                let mut columns = vec![(map.y.axis.to_string(), Align::Left), ("n".to_string(), Align::Right)];
                columns.extend(
                    ["p99 ≤ 1 %", "p99 ≤ 5 %", "p99 ≤ 10 %", "median ≤ 1 %", "median ≤ 10 %"]
                        .map(|c| (c.to_string(), Align::Left)),
                );
                let mut table = Table::with_columns(columns);
                let p99 = |q: &crate::analyse::stats::Quantiles| q.p99;
                let median = |q: &crate::analyse::stats::Quantiles| q.median;
                let limits = [
                    (0.01, p99 as fn(&_) -> f64),
                    (0.05, p99),
                    (0.1, p99),
                    (0.01, median),
                    (0.1, median),
                ]
                .map(|(t, q)| crate::report::svg::valid_up_to(stats, t, q));
                for ky in (0..map.y.edges.len() - 1).rev() {
                    let n: usize = stats.cells[ky].iter().map(|c| c.count + c.nan + c.inf).sum();
                    let cells = limits.iter().map(|l| match l[ky] {
                        Some(x) if x == *map.x.edges.last().unwrap() => format!("whole range (≤ {x})"),
                        Some(x) => format!("{} < {x}", map.x.axis),
                        None => "nowhere".into(),
                    });
                    let mut row = vec![format!("[{}, {})", map.y.edges[ky], map.y.edges[ky + 1]), n.to_string()];
                    row.extend(cells);
                    table.row(row);
                }
                w.table(&table);
                w.blank();
            }
        }
    }
}

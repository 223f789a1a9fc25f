//! "How to read this": the definitions behind every table (relative error, floors, bits,
//! quantile kinds, references) and each method's source.

use crate::analyse::summary::Summary;
use crate::report::markup::{sci, Doc as _};

/// The definitions and the methods with their sources.
pub(super) fn how_to_read(w: &mut String, input: &Summary) {
    let (case, a) = (&input.case, &input.analysis);
    let floors: Vec<String> = a
        .methods
        .iter()
        .map(|ms| ms.target)
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .map(|t| format!("`{t}` {}", sci(Some(case.floor(t)))))
        .collect();
    w.heading(2, "How to read this");
    w.line(format_args!(
        "- Relative error = |value − reference| / |reference|, with no floor, over the configurations whose \
         reference is not 0; those whose reference is exactly 0 are counted under *False light*. The floored \
         variant, labelled wherever it appears, divides by max(|reference|, floor); floor per target (units \
         where the line's distance d = 1; `line` and `line_upper` floors scale as 1/d): {}.\n\
         - Bits of error = log2(1 + ULP distance between the f32 result and the f32-rounded reference).\n\
         - Quantiles are over the configurations with a finite result; NaN and ±inf are counted \
         in their own columns and never enter a quantile; the ≤ columns count them as outside. {}\n\
         - References: CPU f64 adaptive Gauss–Kronrod quadrature of the target's definition (docs/targets.md), \
         independent of the kernels, each with its own error estimate.\n\
         - Methods and their sources:",
        floors.join(", "),
        quantile_kinds(a)
    ));
    for ms in &a.methods {
        w.line(format_args!(
            "  - `{}` ({}): {} — `{}`",
            ms.describe, ms.target, ms.source, ms.kernel
        ));
    }
    w.line("- Full tables: `stats.csv` (every method × material × bin), `comparisons.csv`, `summary.json`.");
}

/// Which kind of quantile the tables show: exact nearest-rank, or read from a sketch (bins
/// past `stats::EXACT_LIMIT` values), with how many bins are of each kind.
fn quantile_kinds(a: &crate::analyse::analysis::Analysis) -> String {
    use crate::analyse::stats::QuantileKind;
    let (mut exact, mut sketch) = (0, 0);
    for ms in &a.methods {
        for mat in &ms.materials {
            let bins = std::iter::once(&mat.all).chain(mat.axes.iter().flat_map(|ax| ax.bins.iter().map(|b| &b.stats)));
            for q in bins.filter_map(|s| s.rel) {
                match q.kind {
                    QuantileKind::Exact => exact += 1,
                    QuantileKind::Sketch => sketch += 1,
                }
            }
        }
    }
    format!(
        "A bin of at most {} values shows exact nearest-rank quantiles (every number one observed); a larger \
         bin shows median, p90 and p99 from a DDSketch of {} % relative accuracy, and its exact maximum \
         (`stats.csv` column `quantiles`, `summary.json` `kind`). In this run: {exact} bins exact, {sketch} \
         sketched (method × material × bin, relative error).",
        crate::analyse::stats::EXACT_LIMIT,
        100.0 * crate::analyse::stats::SKETCH_ALPHA
    )
}

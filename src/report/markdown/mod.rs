//! The Markdown report (`report.md`): what to ship first, then the verdict and findings, then
//! the tables they come from. [`render`] is the report's table of contents; each section is written by one function
//! in a sibling file, grouped by what the sections are about, and the cell formatters they
//! share are here.

mod accuracy;
mod baseline;
mod comparisons;
mod configurations;
mod cost;
mod maps;
mod reading;
mod ship;
mod verdict;

use crate::analyse::stats::BinStats;
use crate::analyse::summary::Summary;
use crate::report::markup::{sci, Doc as _, ABSENT};

/// The report, section by section, in reading order.
pub fn render(input: &Summary) -> String {
    let mut o = String::new();
    let w = &mut o;
    // The title and the run, then the answer a reader came for, then what the run concludes.
    verdict::header(w, input);
    ship::what_to_ship(w, input);
    verdict::stale_claims(w, input);
    verdict::verdict(w, input);
    baseline::against_baseline(w, input);
    verdict::findings(w, input);
    verdict::at_a_glance(w, input);
    comparisons::measured_differences(w, input);
    // The tables the conclusions come from.
    accuracy::error_tables(w, input);
    accuracy::convergence(w, input);
    maps::validity_maps(w, input);
    comparisons::comparison_tables(w, input);
    accuracy::false_light(w, input);
    accuracy::missed_light(w, input);
    configurations::sampling(w, input);
    comparisons::disagreements(w, input);
    configurations::worst_cases(w, input);
    configurations::nonfinite(w, input);
    accuracy::below_horizon(w, input);
    // What it cost, where the bits go, how long the run took.
    cost::speed_against_accuracy(w, input);
    w.put(super::attribution::render(&input.attribution));
    if let Some(a) = &input.any_driver {
        w.put(super::envelope::render(a));
    }
    cost::timing(w, input);
    cost::throughput(w, input);
    // Definitions.
    reading::how_to_read(w, input);
    o
}

/// Median, p90, p99 and max of the quantiles `f` picks from `s`, formatted (`—` when absent).
fn q3(s: &BinStats, f: impl Fn(&BinStats) -> Option<crate::analyse::stats::Quantiles>) -> [String; 4] {
    let q = f(s);
    [
        q.map(|q| q.median),
        q.map(|q| q.p90),
        q.map(|q| q.p99),
        q.map(|q| q.max),
    ]
    .map(sci)
}

/// How bright a light of reference `reference` is against the family's typical light: over
/// the median |reference| of the family's lit configurations (natural sample, `method`'s
/// target). A worst case on a light 1e-9 of the typical one is a dim light's.
fn brightness(input: &Summary, method: &str, family: &str, reference: f64) -> String {
    let median = input
        .analysis
        .methods
        .iter()
        .find(|m| m.label == method)
        .and_then(|m| m.materials.iter().find(|x| x.material == family))
        .and_then(|x| x.all.reference)
        .map(|q| q.median);
    match median {
        Some(m) if m > 0.0 => sci(Some(reference.abs() / m)),
        _ => ABSENT.into(),
    }
}

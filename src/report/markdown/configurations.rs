//! The configurations themselves: how the sample was drawn, and the ones singled out for
//! replay (the worst found by the search, those giving NaN or inf).

use crate::analyse::summary::Summary;
use crate::report::markup::{sci, share, Align, Doc as _, Table};

/// The axes with their own `min_per_bin`, as a clause (empty when none has).
fn own_minimum(case: &crate::input::case::Case) -> String {
    let own: Vec<String> = case
        .bins
        .iter()
        .filter_map(|b| b.min_per_bin.map(|n| format!("`{}` {n}", b.axis)))
        .collect();
    if own.is_empty() {
        String::new()
    } else {
        format!(" (axes with their own minimum: {})", own.join(", "))
    }
}

/// How the sample was drawn: the natural sample, the top-ups of thin bins, the bins still thin.
pub(super) fn sampling(w: &mut String, input: &Summary) {
    let case = &input.case;
    w.heading(2, "Sampling");
    w.para(format_args!(
        "Every family is first drawn from the case's distributions (the natural sample: the *all* rows, \
         the maps and the verdict use only it). Then every bin of every axis that holds fewer than {} \
         configurations{} is topped up: more configurations are drawn from the same distributions and kept \
         only for the thin bins they fall in (rejection sampling), so within a bin they follow the natural \
         distribution and need no weights; they are counted only in the bins they were kept for.",
        case.min_per_bin,
        own_minimum(case)
    ));
    let mut table = Table::new(&[
        ("family", Align::Left),
        ("natural", Align::Right),
        ("top-up draws", Align::Right),
        ("kept", Align::Right),
        ("acceptance", Align::Right),
        ("bins still thin", Align::Left),
    ]);
    for (k, family) in case.materials.iter().enumerate() {
        let natural = input.natural[k];
        let t = input.topups.iter().find(|t| t.family == family.name);
        let (draws, kept) = t.map_or((0, 0), |t| (t.draws, t.kept));
        let thin: Vec<String> = t.map_or(Vec::new(), |t| {
            t.thin
                .iter()
                .map(|(axis, lo, hi, n)| format!("`{axis}` [{lo}, {hi}): {n}"))
                .collect()
        });
        table.row(vec![
            format!("`{}`", family.name),
            natural.to_string(),
            draws.to_string(),
            kept.to_string(),
            share(kept, draws),
            if thin.is_empty() {
                "none".to_string()
            } else {
                thin.join(", ")
            },
        ]);
    }
    w.table(&table);
    w.blank();
}

/// The worst-case search: worst error in the sample and after refinement, per method and family.
pub(super) fn worst_cases(w: &mut String, input: &Summary) {
    if !input.found.is_empty() {
        w.heading(2, "Worst cases found");
        w.para(
            "For each method and family: the worst relative error in the random sample, and after the \
             search refined the worst starting points (∞: NaN or inf), with how bright the light found is: \
             its reference, the angle its segment subtends (radians) and the reference over the median \
             reference of the family's lit configurations (× typical). Every configuration is in \
             `worst.jsonl`; replay with `linelight eval --input worst.jsonl --output out.jsonl`.",
        );
        let mut table = Table::new(&[
            ("method", Align::Left),
            ("family", Align::Left),
            ("worst in sample", Align::Right),
            ("worst found", Align::Right),
            ("evaluations", Align::Right),
            ("value (f32)", Align::Right),
            ("reference", Align::Right),
            ("subtended", Align::Right),
            ("× typical", Align::Right),
            ("id", Align::Left),
        ]);
        for f in &input.found {
            table.row(vec![
                format!("`{}`", f.method),
                format!("`{}`", f.family),
                sci(Some(f.sample_worst)),
                sci(Some(f.worst)),
                f.evaluations.to_string(),
                format!("{:e}", f.value),
                format!("{:e} ± {:.0e}", f.reference.value, f.reference.error),
                sci(Some(crate::input::sampler::line_axes(f.config.p1, f.config.p2).2)),
                super::brightness(input, &f.method, &f.family, f.reference.value),
                format!("`{}`", f.config.id),
            ]);
        }
        w.table(&table);
        w.blank();
    }
}

/// The configurations that gave NaN or ±inf, with the methods that did.
pub(super) fn nonfinite(w: &mut String, input: &Summary) {
    let nonfinite = &input.nonfinite;
    if !nonfinite.is_empty() {
        w.heading(2, "NaN and inf");
        w.para(format_args!(
            "{} configurations gave NaN or ±inf from at least one method; {} are in `nonfinite.jsonl` \
             (replay with `linelight eval`).",
            input.nonfinite_total,
            if nonfinite.len() == input.nonfinite_total {
                "all".to_string()
            } else {
                format!("the first {}", nonfinite.len())
            }
        ));
        let mut table = Table::new(&[("configuration", Align::Left), ("methods", Align::Left)]);
        for (c, methods) in nonfinite.iter().take(40) {
            let names: Vec<String> = methods.iter().map(|m| format!("`{m}`")).collect();
            table.row(vec![format!("`{}`", c.id), names.join(", ")]);
        }
        if nonfinite.len() > 40 {
            table.row(vec![
                format!("… {} more in `nonfinite.jsonl`", nonfinite.len() - 40),
                String::new(),
            ]);
        }
        w.table(&table);
        w.blank();
    }
}

//! "What to ship", the report's first section: per material, the method to ship, what it costs,
//! where it does not meet the case's budget and what does there (src/analyse/ship.rs computes
//! it; this only writes it down).

use crate::analyse::ship::{Judgement, Meets, Price, Ship, ShipBudget, ShipMaterial};
use crate::analyse::stats::Bound;
use crate::analyse::summary::Summary;
use crate::report::markup::{sci, Align, Doc as _, Table};

/// Regions listed per material before the rest are counted (all are in summary.json `ship`).
const REGIONS_SHOWN: usize = 8;

/// The section, or a line saying why there is no answer.
pub(super) fn what_to_ship(w: &mut String, input: &Summary) {
    w.heading(2, "What to ship");
    let Some(ship) = &input.ship else {
        w.para("No method was run, so there is nothing to ship.");
        return;
    };
    w.para(budget_line(&ship.budget, &input.timing.adapter));
    for m in &ship.materials {
        material(w, ship, m);
    }
}

/// The budget in one sentence, and how "meets" and "cheapest" are decided.
fn budget_line(b: &ShipBudget, adapter: &str) -> String {
    format!(
        "Budget{}: {} of the relative error (f32, against the reference at the configuration rounded \
         to f32) ≤ {}, against `{}`, in every region with at least {} \
         configurations. A method meets it where the {:.0} % upper confidence bound of the {} is within it \
         (a reference of 0 counts as exact when the method returns 0, as an infinite error when it lights \
         it; NaN counts infinite). {} † ns per evaluation measured in this run on {adapter}{}.",
        if b.stated {
            " (the case's `[budget]`)"
        } else {
            " (the default: the case states none)"
        },
        b.quantile_name(),
        sci(Some(b.value)),
        b.target,
        b.min_count,
        100.0 * b.confidence,
        b.quantile_name(),
        if b.cost_matters {
            "Cheapest = fewest ops (one invocation's operation count from the naga IR, docs/statistics.md)."
        } else {
            "Cost does not matter in this case: the most accurate (smallest bound) that meets it is shipped."
        },
        if adapter.to_lowercase().contains("llvmpipe") || adapter.to_lowercase().contains("lavapipe") {
            ": a software driver (the CPU), whose ns rank methods differently from a GPU's, so they do not rank here"
        } else {
            ""
        }
    )
}

fn bound(j: &Judgement) -> String {
    match j.bound {
        Bound::At { value } => format!("≤ {}", sci(Some(value))),
        Bound::Infinite => "∞ (false light or NaN)".into(),
        Bound::TooFew => format!("— ({} configurations, too few)", j.n),
    }
}

fn price(p: &Price) -> String {
    let ops = p.ops.map_or("ops unknown".to_string(), |o| format!("{o} ops"));
    match p.measured_ns {
        Some(ns) => format!("{ops}, {ns:.0} ns†"),
        None => ops,
    }
}

fn material(w: &mut String, ship: &Ship, m: &ShipMaterial) {
    let q = ship.budget.quantile_name();
    let find = |label: &str| m.candidates.iter().find(|c| c.label == label);
    w.put(format_args!("**`{}`**: ", m.material));
    match (&m.meets_everywhere, &m.ship) {
        (Some(s), _) => {
            let c = find(s).expect("shipped is a candidate");
            w.put(format_args!(
                "ship `{s}` ({}): meets the budget over the whole material, {q} {}",
                price(&c.price),
                bound(&c.whole)
            ));
        }
        (None, Some(s)) => {
            let c = find(s).expect("shipped is a candidate");
            w.put(format_args!(
                "no method meets the budget over the whole material. Ship `{s}` ({}), which meets it in the \
                 most regions ({} of {}); whole material {q} {}",
                price(&c.price),
                c.regions_met,
                c.regions_met + c.regions_broken + c.regions_too_few,
                bound(&c.whole)
            ));
        }
        (None, None) if m.candidates.is_empty() => {
            w.put(format_args!(
                "no method of this run is judged against `{}`, so none can be shipped",
                ship.budget.target
            ));
        }
        (None, None) => {
            w.put("no method meets the budget over the whole material or in any region");
        }
    }
    let broken: Vec<_> = m.regions.iter().filter(|r| r.shipped.meets == Meets::Breaks).collect();
    let few = m.regions.len() - broken.len();
    if m.ship.is_some() && broken.is_empty() {
        w.put(", and in every region with enough configurations");
    }
    w.para(".");
    if !broken.is_empty() {
        let s = m.ship.as_deref().unwrap_or_default();
        let mut table = Table::with_columns(vec![
            ("except in".to_string(), Align::Left),
            (format!("`{s}` {q}"), Align::Right),
            ("meets it there instead".to_string(), Align::Left),
            (format!("its {q}"), Align::Right),
            ("its cost".to_string(), Align::Right),
            (format!("input rounding {q}"), Align::Right),
        ]);
        for r in broken.iter().take(REGIONS_SHOWN) {
            let (who, b, cost) = match &r.instead {
                Some(i) => (format!("`{}`", i.label), bound(&i.judgement), price(&i.price)),
                None => ("none".to_string(), "—".to_string(), "—".to_string()),
            };
            let rounding = match (r.input_rounding, r.unattainable_in_f32) {
                (Some(x), true) => format!("{} **unattainable in f32**", sci(Some(x))),
                (x, false) => sci(x),
                (None, true) => unreachable!("unattainable only where input rounding is measured"),
            };
            table.row(vec![
                format!("`{}` [{}, {})", r.axis, r.lo, r.hi),
                bound(&r.shipped),
                who,
                b,
                cost,
                rounding,
            ]);
        }
        w.table(&table);
        if broken.len() > REGIONS_SHOWN {
            w.line(format_args!(
                "\n{} more regions break it (summary.json `ship`).",
                broken.len() - REGIONS_SHOWN
            ));
        }
        w.blank();
    }
    let ranked: Vec<String> = m
        .candidates
        .iter()
        .map(|c| {
            let mark = match c.whole.meets {
                Meets::Meets => "meets",
                Meets::Breaks => "breaks",
                Meets::TooFew => "too few",
            };
            let b = match c.whole.bound {
                Bound::Infinite => format!(
                    "∞: lights {} with nothing to light, {} NaN/inf",
                    c.false_light, c.nonfinite
                ),
                _ => bound(&c.whole),
            };
            let ops = c.price.ops.map_or("?".into(), |o| o.to_string());
            format!("`{}` {ops} ({b}, {mark})", c.label)
        })
        .collect();
    let order = if ship.budget.cost_matters {
        "cheapest first, ops"
    } else {
        "most accurate first, ops"
    };
    let mut tail = if ranked.is_empty() {
        String::new()
    } else {
        format!(
            "Candidates, {order} ({q} over the whole material): {}.",
            ranked.join("; ")
        )
    };
    if few > 0 {
        tail.put(format_args!(
            " {few} regions have too few configurations to judge the shipped method."
        ));
    }
    if !m.not_candidates.is_empty() {
        // A long list is in summary.json; the section stays short.
        let names = if m.not_candidates.len() <= 4 {
            m.not_candidates
                .iter()
                .map(|l| format!("`{l}`"))
                .collect::<Vec<_>>()
                .join(", ")
        } else {
            format!("{} methods (summary.json `ship`)", m.not_candidates.len())
        };
        tail.put(format_args!(
            " Not judged against `{}` here (another target, or a material they do not claim): {names}.",
            ship.budget.target
        ));
    }
    w.para(tail.trim_start());
}

//! "Against the baseline": a gated run's comparison (`sweep --baseline`, docs/ci/README.md):
//! the rules, each verdict, and the share rule's tests per material and bin.

use crate::analyse::gate::Change;
use crate::analyse::summary::Summary;
use crate::report::markup::{share, Align, Doc as _, Table};

pub(super) fn against_baseline(w: &mut String, input: &Summary) {
    let Some(g) = &input.baseline else {
        return;
    };
    let o = &g.share_options;
    w.heading(2, "Against the baseline");
    w.para(format_args!("**{}**", g.summary()));
    w.para(format_args!(
        "Baseline saved on {}; this run on {}. The rules (docs/ci/README.md): `error`, the paired \
         bootstrap of the error ratios (geometric mean and p99, noise ±{} %); `share`, a \
         configuration is worse when its error ratio exceeds {} and its error grew by more \
         than {} ULPs of the reference, and a material or bin fails when more than {} % got \
         worse (one-sided binomial test, P < {}, at least {} worse); `nan` and `false_light`, \
         any new one; `ops`, op-count growth. Timings are not gated.",
        g.baseline_adapter,
        g.adapter,
        100.0 * o.noise,
        1.0 + o.noise,
        o.ulps,
        100.0 * o.share,
        o.alpha,
        o.min_worse
    ));
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("material", Align::Left),
        ("rule", Align::Left),
        ("verdict", Align::Left),
        ("numbers", Align::Left),
    ]);
    for r in &g.rules {
        let verdict = match r.change {
            Change::Regressed => "**regressed**",
            c => c.name(),
        };
        table.row(vec![
            r.method.to_string(),
            r.material.to_string(),
            r.rule.to_string(),
            verdict.to_string(),
            r.message.replace('|', "\\|"),
        ]);
    }
    w.table(&table);
    w.blank();
    w.para("Configurations worse and better than the baseline, per material and bin (the share rule):");
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("material", Align::Left),
        ("scope", Align::Left),
        ("paired", Align::Right),
        ("worse", Align::Right),
        ("share worse", Align::Right),
        ("better", Align::Right),
        ("P", Align::Right),
        ("verdict", Align::Left),
    ]);
    for s in &g.shares {
        for t in &s.tests {
            table.row(vec![
                s.method.to_string(),
                s.material.to_string(),
                t.scope.to_string(),
                t.pairs.to_string(),
                t.worse.to_string(),
                share(t.worse, t.pairs),
                t.better.to_string(),
                t.p_text(),
                (if t.regressed { "**regressed**" } else { "within" }).to_string(),
            ]);
        }
    }
    w.table(&table);
    w.blank();
    if g.replay.is_empty() {
        w.para("No configuration got worse, and none has a new NaN or false light.");
    } else {
        w.para(format_args!(
            "`regressed.jsonl` holds the {} configurations that got worse, or have a NaN or false \
             light the baseline did not, in the eval input format: replay them with `linelight eval`.",
            g.replay.len()
        ));
    }
}

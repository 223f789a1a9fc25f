//! The comparison of a run with its loaded baseline, configuration by configuration: per
//! method `ops`, per method × material `share`, `error`, `nan` and `false_light`, and the
//! configurations to replay.

use super::baseline::Loaded;
use super::{observed, GateOptions, Obs, Observations};
use crate::analyse::gate::{g, paired, share_tests, Axis, Change, GateReport, Pair, RuleResult, Shares};
use crate::measure::sweep::{Measured, Setup};

/// `= 3.1e-5`, or `< 1e-300` as it stands.
fn p_eq(p: &str) -> String {
    if p.starts_with('<') {
        p.to_string()
    } else {
        format!("= {p}")
    }
}

/// The comparison with the baseline: every rule, the timings beside them, the replay list.
pub fn compare(
    loaded: &Loaded,
    setup: &Setup,
    (measured, observations): (&Measured, &Observations),
    options: GateOptions,
) -> GateReport {
    let started = std::time::Instant::now();
    let obs = observed(setup, measured, observations);
    let share_options = options.share_options();
    let axes: Vec<Axis> = setup
        .case
        .bins
        .iter()
        .map(|b| Axis {
            name: &b.axis,
            edges: &b.edges,
        })
        .collect();
    let mut rules = Vec::new();
    let mut timings = Vec::new();
    let mut shares = Vec::new();
    // (family, index) of every configuration to replay, from any method.
    let mut replay = std::collections::BTreeSet::new();
    for (entry, base_errors) in loaded.baseline.methods.iter().zip(&loaded.errors) {
        let rule = |material: &str, rule: &'static str, change: Change, message: String| RuleResult {
            method: entry.label.clone(),
            material: material.to_string(),
            rule,
            change,
            message,
        };
        let Some(now_index) = obs.iter().position(|o| o.label == entry.label) else {
            rules.push(rule(
                "(all)",
                "present",
                Change::Regressed,
                format!("`{}` is in the baseline but not in this run", entry.label),
            ));
            continue;
        };
        let now = &obs[now_index];
        timings.push((entry.label.clone(), entry.ns_per_eval, now.ns_per_eval));
        rules.push(match (entry.ops_total, now.ops_total) {
            (Some(b), Some(a)) => {
                let ratio = a as f64 / b.max(1) as f64;
                let change = if ratio > 1.0 + options.ops_growth {
                    Change::Regressed
                } else if ratio < 1.0 / (1.0 + options.ops_growth) {
                    Change::Improved
                } else {
                    Change::Unchanged
                };
                rule(
                    "(all)",
                    "ops",
                    change,
                    format!(
                        "op count {a} against baseline {b} (×{}; growth limit ×{})",
                        g(ratio),
                        g(1.0 + options.ops_growth)
                    ),
                )
            }
            _ => rule("(all)", "ops", Change::Skipped, "no op count on one side".into()),
        });
        for (family, ((m_entry, base), (supported, values))) in
            entry.materials.iter().zip(base_errors).zip(&now.materials).enumerate()
        {
            let mat = m_entry.material.as_str();
            let Some(base) = base else {
                for r in ["error", "nan", "false_light"] {
                    rules.push(rule(mat, r, Change::Skipped, "unsupported in the baseline".into()));
                }
                continue;
            };
            if !supported {
                rules.push(rule(
                    mat,
                    "support",
                    Change::Regressed,
                    "supported in the baseline, unsupported now".into(),
                ));
                continue;
            }
            let mut pairs = Vec::new();
            // The share rule's pairs: the errors now rounded as the baseline's tokens are, so
            // an unchanged kernel pairs equal numbers.
            let (mut share_pairs, mut share_bins, mut share_index) = (Vec::new(), Vec::new(), Vec::new());
            let ulps = &observations.ulps[now_index][family];
            let (mut new_nan, mut fixed_nan, mut new_light, mut fixed_light) = (vec![], 0, vec![], 0);
            for (i, (b, a)) in base.iter().zip(values).enumerate() {
                match (b, a) {
                    (Obs::Lit(eb), Obs::Lit(ea)) => {
                        pairs.push((*eb, *ea));
                        let now = Obs::parse(&Obs::Lit(*ea).token()).map_or(*ea, |o| match o {
                            Obs::Lit(e) => e,
                            _ => *ea,
                        });
                        share_pairs.push(Pair {
                            base: *eb,
                            now,
                            ulp: ulps[i],
                        });
                        share_bins.push(observations.configs[family][i].1.clone());
                        share_index.push(i);
                    }
                    (b, Obs::NonFinite) if *b != Obs::NonFinite => new_nan.push(i),
                    (Obs::NonFinite, a) if *a != Obs::NonFinite => fixed_nan += 1,
                    (Obs::Dark, Obs::FalseLight) => new_light.push(i),
                    (Obs::FalseLight, Obs::Dark) => fixed_light += 1,
                    _ => {}
                }
            }
            // The first few, by index among the material's natural configurations.
            let first = |v: &[usize]| {
                if v.is_empty() {
                    return String::new();
                }
                let shown: Vec<String> = v.iter().take(5).map(|i| i.to_string()).collect();
                format!(
                    " (configurations {}{})",
                    shown.join(", "),
                    if v.len() > 5 { ", …" } else { "" }
                )
            };
            let tests = share_tests(&share_pairs, &share_bins, &axes, &share_options);
            for (pair, i) in share_pairs.iter().zip(&share_index) {
                if pair.worse(&share_options) {
                    replay.insert((family, *i));
                }
            }
            replay.extend(new_nan.iter().chain(&new_light).map(|i| (family, *i)));
            let failed: Vec<String> = tests
                .iter()
                .filter(|t| t.regressed)
                .map(|t| format!("{} ({} of {}, P {})", t.scope, t.worse, t.pairs, p_eq(&t.p_text())))
                .collect();
            let all = &tests[0];
            rules.push(rule(
                mat,
                "share",
                if failed.is_empty() {
                    Change::Unchanged
                } else {
                    Change::Regressed
                },
                format!(
                    "worse on {} of {} paired configurations ({:.1} %; better on {}), allowed {} %{}",
                    all.worse,
                    all.pairs,
                    100.0 * all.share(),
                    all.better,
                    100.0 * share_options.share,
                    if failed.is_empty() {
                        format!(" (no material or bin beyond it at P < {})", share_options.alpha)
                    } else {
                        format!("; beyond it: {}", failed.join(", "))
                    }
                ),
            ));
            shares.push(Shares {
                method: entry.label.clone(),
                material: mat.to_string(),
                tests,
            });
            let p = paired(&pairs, options.resamples, options.noise);
            let [gl, gm, gh] = p.geomean;
            let [pl, pm, ph] = p.p99_ratio;
            rules.push(rule(
                mat,
                "error",
                p.change(options.noise),
                format!(
                    "error ratio now/baseline over {} paired configurations: geometric mean ×{} [{}–{}], \
                     p99 ×{} [{}–{}] (95 % bootstrap, noise ±{} %); worse on {}, better on {}",
                    p.pairs,
                    g(gm),
                    g(gl),
                    g(gh),
                    g(pm),
                    g(pl),
                    g(ph),
                    options.noise * 100.0,
                    p.worse,
                    p.better
                ),
            ));
            rules.push(rule(
                mat,
                "nan",
                if !new_nan.is_empty() {
                    Change::Regressed
                } else if fixed_nan > 0 {
                    Change::Improved
                } else {
                    Change::Unchanged
                },
                format!("{} new NaN/inf{}, {fixed_nan} fixed", new_nan.len(), first(&new_nan)),
            ));
            rules.push(rule(
                mat,
                "false_light",
                if !new_light.is_empty() {
                    Change::Regressed
                } else if fixed_light > 0 {
                    Change::Improved
                } else {
                    Change::Unchanged
                },
                format!(
                    "{} new false light{}, {fixed_light} fixed",
                    new_light.len(),
                    first(&new_light)
                ),
            ));
        }
    }
    let new_methods = obs
        .iter()
        .filter(|o| !loaded.baseline.methods.iter().any(|m| m.label == o.label))
        .map(|o| o.label.clone())
        .collect();
    let change = Change::overall(&rules);
    GateReport {
        baseline_adapter: loaded.baseline.adapter.clone(),
        adapter: measured.timing.adapter.clone(),
        rules,
        timings,
        new_methods,
        change,
        share_options,
        shares,
        seconds: started.elapsed().as_secs_f64(),
        replay: replay
            .into_iter()
            .map(|(family, i)| observations.configs[family][i].0.clone())
            .collect(),
    }
}

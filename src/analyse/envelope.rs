//! The "Any conforming driver" answer (docs/envelope.md): per method and material,
//! the envelope's worst relative error against the reference the budget judges by, the share
//! of configurations whose envelope breaks the budget's value, the configurations with no
//! finite envelope (and the lines named), and where the freedom goes.

use crate::analyse::ship::{surface_target, ShipBudget};
use crate::analyse::stats::{nearest_rank, relative_error};
use crate::measure::envelope::MethodEnvelope;
use std::collections::BTreeMap;

/// One method on one material.
#[derive(Clone, Debug, PartialEq)]
pub struct DriverRow {
    pub label: String,
    pub material: String,
    /// The target the worst relative error is measured against.
    pub target: String,
    /// Configurations in the subsample.
    pub n: usize,
    /// Nearest-rank p50, p90, p99 and max of the worst relative error, over the configurations
    /// with a finite envelope and a non-zero reference (None when there is none).
    pub quantiles: Option<[f64; 4]>,
    /// Of those, how many envelopes reach past the budget's value; None when the method is not
    /// judged against the budget's target.
    pub breaks: Option<(usize, usize)>,
    /// Configurations with no finite envelope, and the named lines with their counts.
    pub undefined: usize,
    pub lines: Vec<(String, usize)>,
    /// Configurations with a finite envelope, and how many of them have a GPU value outside it
    /// (the driver left the written order, or broke the spec: a finding, docs/envelope.md).
    pub gpu_checked: usize,
    pub gpu_outside: usize,
    /// The first [`OUTSIDE_SHOWN`] of those: the configuration, the GPU value, `[lo, hi]`.
    pub outside: Vec<(crate::input::scene::Config, f32, f64, f64)>,
}

/// GPU values outside their envelope listed per method and material.
pub const OUTSIDE_SHOWN: usize = 5;

/// A method's lines whose allowance widens the envelope most.
#[derive(Clone, Debug, PartialEq)]
pub struct Freedom {
    pub label: String,
    pub configurations: usize,
    /// `file:line`, source, mean bits of width added.
    pub lines: Vec<(String, String, f64)>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnyDriver {
    /// Configurations per method asked for (`envelope = { sample = N }`).
    pub sample: usize,
    pub budget_value: f64,
    pub budget_target: String,
    pub rows: Vec<DriverRow>,
    pub freedom: Vec<Freedom>,
    pub seconds: f64,
}

pub fn any_driver(envelopes: &[MethodEnvelope], materials: &[String], budget: &ShipBudget, sample: usize) -> AnyDriver {
    let mut rows = Vec::new();
    for m in envelopes {
        // The budget's target where the method is judged against it, else the method's own.
        let judged = m.target == budget.target || surface_target(m.target) == Some(budget.target);
        let target = if judged { budget.target } else { m.target };
        for (k, name) in materials.iter().enumerate() {
            let here: Vec<_> = m.rows.iter().filter(|r| r.material == k).collect();
            if here.is_empty() {
                continue;
            }
            let mut worst = Vec::new();
            let mut undefined = 0;
            let (mut gpu_checked, mut outside) = (0, Vec::new());
            let mut lines: BTreeMap<String, usize> = BTreeMap::new();
            for r in &here {
                match &r.interval {
                    Ok((lo, hi)) => {
                        gpu_checked += 1;
                        let v = f64::from(r.gpu);
                        // NaN is outside every interval.
                        if !(*lo <= v && v <= *hi) {
                            outside.push((r.config.clone(), r.gpu, *lo, *hi));
                        }
                        if let Some(&reference) = r.references.get(&target).filter(|x| **x != 0.0) {
                            worst.push(relative_error(*lo, reference).max(relative_error(*hi, reference)));
                        }
                    }
                    Err((why, line)) => {
                        undefined += 1;
                        let at = match line {
                            Some(l) => format!("`{}:{}` `{}` ({why})", l.path, l.line, l.text.trim()),
                            None => why.clone(),
                        };
                        *lines.entry(at).or_default() += 1;
                    }
                }
            }
            worst.sort_by(f64::total_cmp);
            let quantiles = (!worst.is_empty()).then(|| [0.5, 0.9, 0.99, 1.0].map(|p| nearest_rank(&worst, p)));
            let breaks = judged.then(|| (worst.iter().filter(|&&w| w > budget.value).count(), worst.len()));
            let mut lines: Vec<_> = lines.into_iter().collect();
            lines.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
            rows.push(DriverRow {
                label: m.label.clone(),
                material: name.clone(),
                target: target.name().to_string(),
                n: here.len(),
                quantiles,
                breaks,
                undefined,
                lines,
                gpu_checked,
                gpu_outside: outside.len(),
                outside: outside.into_iter().take(OUTSIDE_SHOWN).collect(),
            });
        }
    }
    let freedom = envelopes
        .iter()
        .map(|m| Freedom {
            label: m.label.clone(),
            configurations: m.freedom_configurations,
            lines: m
                .freedom
                .iter()
                .map(|(l, bits, _)| (format!("{}:{}", l.path, l.line), l.text.trim().to_string(), *bits))
                .collect(),
        })
        .collect();
    AnyDriver {
        sample,
        budget_value: budget.value,
        budget_target: budget.target.name().to_string(),
        rows,
        freedom,
        seconds: envelopes.iter().map(|m| m.seconds).sum(),
    }
}

/// The envelope's opt-in gate checks (`envelope = { …, gate = true, max_past_budget = S }`,
/// docs/envelope.md "In the gate"), one per method and material: no GPU value outside its
/// envelope; at most the share S of the envelopes past the budget. They join the case's
/// tolerance checks (the verdict, exit 1, JUnit).
pub fn checks(a: &AnyDriver, spec: &crate::input::case::EnvelopeSpec) -> Vec<crate::analyse::analysis::Check> {
    use crate::analyse::analysis::Check;
    let mut out = Vec::new();
    for r in &a.rows {
        if spec.gate {
            out.push(Check {
                method: r.label.clone(),
                material: r.material.clone(),
                what: format!(
                    "GPU values outside the envelope (of {} with a finite envelope)",
                    r.gpu_checked
                ),
                limit: 0.0,
                measured: r.gpu_outside as f64,
                pass: r.gpu_outside == 0,
                too_few: None,
            });
        }
        if let (Some(limit), Some((k, n))) = (spec.max_past_budget, r.breaks) {
            if n > 0 {
                let share = k as f64 / n as f64;
                out.push(Check {
                    method: r.label.clone(),
                    material: r.material.clone(),
                    what: format!("share of envelopes past the budget {} ({k} of {n})", a.budget_value),
                    limit,
                    measured: share,
                    pass: share <= limit,
                    too_few: None,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scene::{Config, Material};
    use crate::input::target::Target;
    use crate::measure::envelope::{EnvelopeRow, MethodEnvelope};

    fn row(gpu: f32, interval: Result<(f64, f64), (String, Option<crate::eval::interp::Line>)>) -> EnvelopeRow {
        EnvelopeRow {
            material: 0,
            config: Config {
                id: "c".into(),
                p1: [0.0, 0.0, 1.0],
                p2: [1.0, 0.0, 1.0],
                radius: None,
                rect: None,
                material: Material::Diffuse,
                texture: None,
            },
            gpu,
            references: [(Target::Line, 1.0)].into_iter().collect(),
            interval,
        }
    }

    #[test]
    fn a_gpu_value_outside_its_envelope_fails_the_gate_check_and_is_named() {
        let m = MethodEnvelope {
            label: "m".into(),
            target: Target::Line,
            rows: vec![
                row(1.0, Ok((0.99, 1.01))),
                row(1.5, Ok((0.99, 1.01))),
                row(f32::NAN, Ok((0.9, 1.1))),
                row(7.0, Err(("Inf/NaN".into(), None))),
            ],
            freedom: Vec::new(),
            freedom_configurations: 0,
            seconds: 0.0,
        };
        let budget = ShipBudget {
            statistic: "relative_error".into(),
            quantile: 0.99,
            value: 0.05,
            target: Target::Line,
            min_count: 1,
            cost_matters: false,
            confidence: 0.95,
            stated: true,
        };
        let a = any_driver(&[m], &["diffuse".to_string()], &budget, 4);
        let r = &a.rows[0];
        // The row without a finite envelope is not checked; NaN is outside every interval.
        assert_eq!((r.gpu_checked, r.gpu_outside, r.outside.len()), (3, 2, 2));
        assert_eq!(r.outside[0].1, 1.5);
        let spec = |gate, max| crate::input::case::EnvelopeSpec {
            sample: 4,
            gate,
            max_past_budget: max,
        };
        let c = checks(&a, &spec(true, None));
        assert_eq!(c.len(), 1);
        assert!(!c[0].pass && c[0].measured == 2.0, "{c:?}");
        assert!(checks(&a, &spec(false, None)).is_empty());
        // Past the budget is the envelope's own width, whatever the GPU returned: only
        // [0.9, 1.1] (worst 0.1) of the three finite envelopes reaches past 0.05.
        let c = checks(&a, &spec(false, Some(0.2)));
        assert_eq!(c.len(), 1);
        assert!(!c[0].pass && (c[0].measured - 1.0 / 3.0).abs() < 1e-12, "{c:?}");
        assert!(checks(&a, &spec(false, Some(0.5)))[0].pass);
    }
}

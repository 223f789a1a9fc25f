//! The "Any conforming driver" answer (issue 22, docs/envelope.md): per method and material,
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
}

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
            let mut lines: BTreeMap<String, usize> = BTreeMap::new();
            for r in &here {
                match &r.interval {
                    Ok((lo, hi)) => {
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

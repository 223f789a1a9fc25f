//! The gate's observations: every natural configuration of every method as the gate and
//! `diff` see it (relative error, NaN/inf, dark, false light), folded in chunk by chunk like
//! the analysis's accumulators, in sample order, with the SHA-256 of the configurations they
//! were drawn as.

use crate::analyse::analysis::Fold;
use crate::analyse::stats::Accumulate;
use crate::input::scene::Config;
use crate::measure::sweep::{Measured, Setup};
use crate::reference::Estimate;

/// One natural configuration of one method, as the gate sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Obs {
    /// Relative error |value − reference| / |reference| of a finite result (reference ≠ 0).
    Lit(f64),
    /// NaN or ±inf.
    NonFinite,
    /// Reference 0 and the method returns 0.
    Dark,
    /// Reference 0 and the method returns light (false light).
    FalseLight,
    /// The method does not apply (its target needs data this configuration lacks).
    NotApplicable,
}

impl Obs {
    /// The token of the errors files: 4 significant digits are far below the noise threshold.
    pub fn token(self) -> String {
        match self {
            Obs::Lit(e) => format!("{e:.3e}"),
            Obs::NonFinite => "nan".into(),
            Obs::Dark => "dark".into(),
            Obs::FalseLight => "light".into(),
            Obs::NotApplicable => "-".into(),
        }
    }

    pub fn parse(token: &str) -> Option<Obs> {
        Some(match token {
            "nan" => Obs::NonFinite,
            "dark" => Obs::Dark,
            "light" => Obs::FalseLight,
            "-" => Obs::NotApplicable,
            t => Obs::Lit(t.parse::<f64>().ok().filter(|e| e.is_finite() && *e >= 0.0)?),
        })
    }
}

/// The observation of a GPU result against its reference.
pub fn observe(value: f32, reference: Option<Estimate>) -> Obs {
    let Some(r) = reference else {
        return Obs::NotApplicable;
    };
    if !value.is_finite() {
        Obs::NonFinite
    } else if r.value == 0.0 {
        if value == 0.0 {
            Obs::Dark
        } else {
            Obs::FalseLight
        }
    } else {
        Obs::Lit((f64::from(value) - r.value).abs() / r.value.abs())
    }
}

/// Per method: per material (case order), whether supported, and the observations of its
/// natural configurations in sample order.
pub struct Observed {
    pub label: String,
    pub kernel: String,
    pub ops_total: Option<u64>,
    pub ns_per_eval: f64,
    pub materials: Vec<(bool, Vec<Obs>)>,
}

/// Every natural configuration as the gate sees it, in sample order. O(N): kept only for the
/// gate (`--baseline`, `--save-baseline`) and `diff`, whose cases are small.
#[derive(Clone, Debug, Default)]
pub struct Observations {
    /// Per method, per family: whether supported, and each configuration's observation.
    pub methods: Vec<Vec<(bool, Vec<Obs>)>>,
    /// Per method, per family, per configuration: the f32 ULP of the method's reference over
    /// |reference| (`stats::ulp_relative`; NaN where there is none), for the share rule.
    pub ulps: Vec<Vec<Vec<f64>>>,
    /// Per family: each configuration (for `regressed.jsonl`) and its bin on each of the
    /// case's bin axes.
    pub configs: Vec<Vec<(Config, Vec<Option<usize>>)>>,
}

/// Empty observations for `methods` methods over `families` families.
pub fn observations(methods: usize, families: usize) -> Observations {
    Observations {
        methods: vec![vec![(true, Vec::new()); families]; methods],
        ulps: vec![vec![Vec::new(); families]; methods],
        configs: vec![Vec::new(); families],
    }
}

/// The gate's observations are a mergeable accumulator like the analysis's: each measured
/// chunk's natural configurations are folded in, in sample order.
impl<'a> Accumulate<Fold<'a>> for Observations {
    fn add(&mut self, fold: Fold<'a>) {
        let (case, chunk) = (fold.case, fold.chunk);
        for (i, s) in chunk.samples.iter().enumerate().filter(|(_, s)| s.natural()) {
            let c = &s.config;
            let bins = case.bins.iter().map(|a| a.index(s.axes.get(&a.axis))).collect();
            self.configs[s.material].push((c.clone(), bins));
            for ((per_method, ulps), run) in self.methods.iter_mut().zip(&mut self.ulps).zip(chunk.runs) {
                let (supported, list) = &mut per_method[s.material];
                if list.is_empty() {
                    *supported = run.method.supports(c);
                }
                // The headline's target (the surface view), the f32 result against the reference
                // at the f32-rounded inputs where it is measured and not 0 (as the analysis does).
                let target = crate::analyse::analysis::headline_target(run.method.target());
                let reference = chunk.references[i].get(&target).copied();
                let judged = crate::analyse::analysis::f32_reference(chunk, i, target);
                list.push(if run.method.applies(c) {
                    observe(run.f32[i], judged)
                } else {
                    Obs::NotApplicable
                });
                let ulp = reference.and_then(|r| crate::analyse::stats::ulp_relative(r.value));
                ulps[s.material].push(ulp.unwrap_or(f64::NAN));
            }
        }
    }

    /// Observations are kept in sample order for one whole run (`--baseline`, `--save-baseline`,
    /// `diff`); shards interleave blocks and do not keep them, so two parts never merge.
    fn merge(&mut self, _other: &Observations) -> Result<(), String> {
        Err("the gate's per-configuration observations are not kept by shards: run the gate unsharded".into())
    }
}

/// The gate's observations of a measured sweep, with each method's cost.
pub fn observed(setup: &Setup, measured: &Measured, observations: &Observations) -> Vec<Observed> {
    setup
        .methods
        .iter()
        .zip(&observations.methods)
        .map(|(method, materials)| {
            let cost = measured.costs.iter().find(|c| c.label == method.label);
            Observed {
                label: method.label.clone(),
                kernel: method.kernel.path.clone(),
                ops_total: cost.and_then(|c| c.ops.as_ref()).map(|o| o.total),
                ns_per_eval: cost.map_or(f64::NAN, |t| crate::analyse::bench::Cost::of(t).ns_per_eval_median),
                materials: materials.clone(),
            }
        })
        .collect()
}

/// SHA-256 over every natural configuration (its eval-format JSON), family by family in
/// sample order: what a baseline was saved from, checked before a comparison pairs them.
pub fn sample_digest(observations: &Observations) -> String {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    for (family, configs) in observations.configs.iter().enumerate() {
        h.update(format!("family {family}\n").as_bytes());
        for (c, _) in configs {
            h.update(serde_json::to_vec(c).unwrap_or_default());
            h.update(b"\n");
        }
    }
    format!("{:x}", h.finalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_round_trip() {
        for o in [
            Obs::Lit(1.234e-5),
            Obs::Lit(0.0),
            Obs::NonFinite,
            Obs::Dark,
            Obs::FalseLight,
            Obs::NotApplicable,
        ] {
            assert_eq!(Obs::parse(&o.token()), Some(o));
        }
        assert_eq!(Obs::parse("1e-3x"), None);
        assert_eq!(Obs::parse("-1e-3"), None);
    }
}

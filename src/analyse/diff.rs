//! `linelight diff`'s analysis: A and B paired per material on the configurations both
//! measured (the gate's paired comparison, [`super::gate::paired`], with A as the baseline),
//! the disagreement search's finds, and the outcome the exit code follows.

use super::gate::{self, Change, Paired};
use super::observations::{observed, Obs, Observations};
use crate::input::scene::Config;
use crate::measure::sweep::{Measured, Setup};

/// Bootstrap resamples of the paired comparison.
const RESAMPLES: usize = 1000;

/// What a diff found, over all materials: the exit code follows it (B regressed on any
/// material: exit 1, as the gate's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Unchanged,
    Improved,
    Regressed,
    /// B more accurate on some materials and less on others (a regression too).
    Mixed,
    /// No material had the configurations a paired verdict needs ([`crate::limits::MIN_JUDGED`]).
    NoVerdict,
}

impl Outcome {
    pub fn regressed(self) -> bool {
        matches!(self, Outcome::Regressed | Outcome::Mixed)
    }

    /// Regressed if any material regressed (mixed if another improved), else improved if any
    /// improved, else unchanged.
    fn of(changes: &[Change]) -> Outcome {
        match (
            changes.contains(&Change::Regressed),
            changes.contains(&Change::Improved),
        ) {
            (true, true) => Outcome::Mixed,
            (true, false) => Outcome::Regressed,
            (false, true) => Outcome::Improved,
            (false, false) => Outcome::Unchanged,
        }
    }
}

/// One material of the case.
#[derive(Clone, Debug)]
pub enum MaterialDiff {
    /// A or B does not support the material (`unsupported_by`: its label).
    NotCompared { material: String, unsupported_by: String },
    /// Fewer paired configurations than a verdict needs: no interval, no verdict.
    TooFew { material: String, pairs: usize },
    Compared {
        material: String,
        change: Change,
        paired: Paired,
        /// NaN/inf configurations of A and of B.
        non_finite: [usize; 2],
        /// Configurations where A and B return light the reference does not have.
        false_light: [usize; 2],
    },
}

/// One configuration where one of the two is worse than the other most (both ways).
#[derive(Clone, Debug)]
pub struct Disagreement {
    /// "A" or "B": the one worse there.
    pub worse: &'static str,
    pub family: String,
    /// The errors of the worse one and of the other.
    pub err_worse: f64,
    pub err_other: f64,
    pub ratio: f64,
    /// The largest ratio in the family's sample, where the search started.
    pub sample_ratio: f64,
    /// The sampled parameters that place it, (name, value), in the order shown.
    pub at: Vec<(&'static str, f64)>,
    /// The configuration itself (replayable with `linelight eval`).
    pub config: Config,
}

/// The typed summary `report::diff` prints.
#[derive(Clone, Debug)]
pub struct DiffSummary {
    pub case: String,
    pub a: String,
    pub b: String,
    /// The noise band of the error ratios (a fraction).
    pub noise: f64,
    pub materials: Vec<MaterialDiff>,
    pub disagreements: Vec<Disagreement>,
    pub outcome: Outcome,
}

/// The sampled parameters a disagreement is placed by (its derived axes are in the replay file).
const AXES: [&str; 5] = ["length", "center", "elevation", "tilt", "alpha"];

/// A and B (the setup's two methods, in that order) compared on what was measured.
pub fn analyse(
    setup: &Setup,
    measured: &Measured,
    observations: &Observations,
    noise: f64,
) -> anyhow::Result<DiffSummary> {
    let (a, b) = (&setup.methods[0].label, &setup.methods[1].label);
    let observed = observed(setup, measured, observations);
    let mut materials = Vec::new();
    let mut changes = Vec::new();
    for (m, family) in setup.case.materials.iter().enumerate() {
        let (sa, oa) = &observed[0].materials[m];
        let (sb, ob) = &observed[1].materials[m];
        if !(sa & sb) {
            materials.push(MaterialDiff::NotCompared {
                material: family.name.clone(),
                unsupported_by: if *sa { b.clone() } else { a.clone() },
            });
            continue;
        }
        let pairs: Vec<(f64, f64)> = oa
            .iter()
            .zip(ob)
            .filter_map(|(x, y)| match (x, y) {
                (Obs::Lit(x), Obs::Lit(y)) => Some((*x, *y)),
                _ => None,
            })
            .collect();
        if pairs.len() < crate::limits::MIN_JUDGED {
            materials.push(MaterialDiff::TooFew {
                material: family.name.clone(),
                pairs: pairs.len(),
            });
            continue;
        }
        let count = |o: &[Obs], what: Obs| o.iter().filter(|v| **v == what).count();
        let paired = gate::paired(&pairs, RESAMPLES, noise);
        let change = paired.change(noise);
        changes.push(change);
        materials.push(MaterialDiff::Compared {
            material: family.name.clone(),
            change,
            paired,
            non_finite: [count(oa, Obs::NonFinite), count(ob, Obs::NonFinite)],
            false_light: [count(oa, Obs::FalseLight), count(ob, Obs::FalseLight)],
        });
    }
    let mut disagreements = Vec::new();
    for d in &measured.disagreements {
        let axes = serde_json::to_value(&d.axes)?;
        disagreements.push(Disagreement {
            worse: if d.a == *a { "A" } else { "B" },
            family: d.family.clone(),
            err_worse: d.err_a,
            err_other: d.err_b,
            ratio: d.ratio,
            sample_ratio: d.sample_ratio,
            at: AXES
                .iter()
                .filter_map(|k| Some((*k, axes.get(*k)?.as_f64()?)))
                .collect(),
            config: d.config.clone(),
        });
    }
    let too_few = materials.iter().any(|m| matches!(m, MaterialDiff::TooFew { .. }));
    let outcome = if changes.is_empty() && too_few {
        Outcome::NoVerdict
    } else {
        Outcome::of(&changes)
    };
    Ok(DiffSummary {
        case: setup.case.name.clone(),
        a: a.clone(),
        b: b.clone(),
        noise,
        materials,
        disagreements,
        outcome,
    })
}

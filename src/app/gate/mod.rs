//! Baselines for the CI gate (docs/ci/): what `sweep --save-baseline DIR` writes, and how
//! `sweep --baseline DIR` compares a run with it. The same seed gives the same configurations,
//! so every comparison is paired, configuration by configuration. Rules per method × material:
//! `error` (bootstrap of the log error ratios, with a noise threshold), `share` (how many
//! configurations got worse, per material and bin: src/analyse/gate.rs), `nan` (new NaN/inf),
//! `false_light` (new light where the reference is 0); per method: `ops` (op-count growth).
//! Timings are reported beside, never gated. The format is in docs/ci/README.md.

use crate::measure::sweep::{Measured, Setup};
use std::path::Path;

pub use crate::analyse::gate::{paired, Change, GateReport, Paired, RuleResult, ShareOptions, Shares, ERROR_FLOOR};
pub use crate::analyse::observations::{observations, observe, observed, sample_digest, Obs, Observations, Observed};
use baseline::file_name;
pub use baseline::{load, save, Baseline, Loaded, MaterialCount, MaterialEntry, MethodEntry, Timings, FORMAT};
pub use compare::compare;

/// The baseline's files: saved, loaded and checked.
mod baseline;
/// The run against its baseline, rule by rule.
mod compare;
/// Render baselines: `render --save-baseline` and `render --baseline` (docs/render.md).
pub mod render;

/// What a sweep's gate options ask for, checked before measuring.
pub struct GateRun {
    save: Option<std::path::PathBuf>,
    baseline: Option<Loaded>,
    junit: Option<std::path::PathBuf>,
    options: GateOptions,
}

impl GateRun {
    /// Checks the thresholds and loads the baseline (bad input: exit 2 before any work).
    pub fn prepare(
        save: Option<std::path::PathBuf>,
        baseline: Option<&Path>,
        junit: Option<std::path::PathBuf>,
        options: GateOptions,
        setup: &Setup,
    ) -> anyhow::Result<GateRun> {
        use crate::app::options::{check_float, FRACTION};
        check_float("--noise", options.noise, FRACTION).map_err(anyhow::Error::msg)?;
        check_float("--ops-growth", options.ops_growth, FRACTION).map_err(anyhow::Error::msg)?;
        check_float("--worse-share", options.worse_share, FRACTION).map_err(anyhow::Error::msg)?;
        check_float("--worse-ulps", options.worse_ulps, crate::app::options::ULPS).map_err(anyhow::Error::msg)?;
        let baseline = baseline.map(|dir| load(dir, setup)).transpose()?;
        Ok(GateRun {
            save,
            baseline,
            junit,
            options,
        })
    }

    /// Whether the sweep must keep per-configuration observations (saving or comparing a
    /// baseline pairs errors configuration by configuration: O(N), small at a gate's count).
    pub fn wants_observations(&self) -> bool {
        self.save.is_some() || self.baseline.is_some()
    }

    /// After the sweep, before its report: the comparison with the loaded baseline (every
    /// rule to stderr), if there is one. The report carries it ("Against the baseline").
    pub fn compare(
        &self,
        setup: &Setup,
        (measured, observations): (&Measured, Option<&Observations>),
    ) -> anyhow::Result<Option<GateReport>> {
        let Some(b) = self.baseline.as_ref() else {
            return Ok(None);
        };
        let observations = observations.expect("the gate's sweep keeps its observations (wants_observations)");
        // Checked before any report is written: pairing other configurations is no comparison.
        let here = sample_digest(observations);
        if b.baseline.sample_sha256 != here {
            return Err(anyhow::Error::new(crate::io::InputError(format!(
                "the baseline was saved from other configurations than this run draws (sample \
                 SHA-256 {} in the baseline, {here} here; the case, seed and counts agree): the \
                 comparison is paired configuration by configuration, so save the baseline again \
                 with this linelight (`--save-baseline`, or `scripts/ci-gate --save …`)",
                b.baseline.sample_sha256
            ))));
        }
        let g = compare(b, setup, (measured, observations), self.options);
        eprint!("{}", g.details());
        Ok(Some(g))
    }

    /// After the report: saves the baseline and writes the JUnit file.
    pub fn finish(
        &self,
        setup: &Setup,
        (measured, observations): (&Measured, Option<&Observations>),
        checks: &[crate::analyse::analysis::Check],
        report: Option<&GateReport>,
        seconds: f64,
    ) -> anyhow::Result<()> {
        if let Some(dir) = &self.save {
            let observations = observations.expect("the gate's sweep keeps its observations (wants_observations)");
            for path in save(dir, setup, measured, observations)? {
                eprintln!("wrote {}", path.display());
            }
        }
        if let Some(path) = &self.junit {
            let xml = crate::report::junit::junit(&setup.case.name, checks, report, seconds);
            crate::report::format::write_file(path, &crate::report::format::Junit::new("JUnit report", xml))?;
            eprintln!("wrote {}", path.display());
        }
        Ok(())
    }
}

/// Thresholds of the comparison.
#[derive(Clone, Copy, Debug)]
pub struct GateOptions {
    /// A ratio within [1/(1+noise), 1+noise] (at the 95 % bootstrap bounds) is unchanged.
    pub noise: f64,
    /// Op-count growth beyond this fraction is a regression.
    pub ops_growth: f64,
    pub resamples: usize,
    /// The share rule: the share of configurations allowed to get worse (`--worse-share`).
    pub worse_share: f64,
    /// The share rule: an error growth up to this many ULPs of the reference is no change
    /// (`--worse-ulps`).
    pub worse_ulps: f64,
}

impl Default for GateOptions {
    fn default() -> Self {
        let share = ShareOptions::default();
        GateOptions {
            noise: 0.05,
            ops_growth: 0.10,
            resamples: 1000,
            worse_share: share.share,
            worse_ulps: share.ulps,
        }
    }
}

impl GateOptions {
    pub fn share_options(&self) -> ShareOptions {
        ShareOptions {
            noise: self.noise,
            ulps: self.worse_ulps,
            share: self.worse_share,
            ..ShareOptions::default()
        }
    }
}

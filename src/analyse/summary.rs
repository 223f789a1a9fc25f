//! The analysed summary of one sweep: everything its report formats, gathered in the analyse
//! stage from the measured sweep, its statistics and its claims. The report formats this and
//! nothing else, so it imports neither the measure stage nor the app layer (tests/layering.rs).

use crate::analyse::analysis::{Analysis, Leak};
use crate::analyse::claims::ClaimResult;
use crate::input::case::Case;
use crate::input::scene::Config;
use crate::measure::sweep::{Measured, Setup};
use serde_json::Value;

/// Wall-clock seconds of the stages after measuring, for the report's timing section.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Stages {
    /// Statistics, comparisons, verdict and claims.
    pub analysis_seconds: f64,
    /// From the start of the command to the report being written: set-up, sampling, measuring,
    /// searches, analysis (report writing itself excluded).
    pub until_report_seconds: f64,
}

/// One method on a speed-against-accuracy chart.
#[derive(Clone, Debug, PartialEq)]
pub struct ChartPoint {
    /// Method label, e.g. `line.ltc2023` or `cylinder.numeric@16x32`.
    pub label: String,
    /// Method id without parameters, e.g. `cylinder.numeric`: one colour per group, and the
    /// points of a group with more than one point are joined by a curve in order of cost.
    pub group: String,
    /// Cost in ns per evaluation (> 0).
    pub cost: f64,
    /// Median relative error (≥ 0).
    pub median: f64,
    /// p99 relative error (≥ 0).
    pub p99: f64,
}

/// One heat map to draw: the case's map `map`, for the method `method` (index into
/// `analysis.methods`) on its material `material`.
#[derive(Clone, Copy, Debug)]
pub struct HeatMap {
    pub map: usize,
    pub method: usize,
    pub material: usize,
}

/// One kernel source line of the "where the bits go" table.
#[derive(Clone, Debug, PartialEq)]
pub struct BitsLine {
    pub path: String,
    pub line: usize,
    pub text: String,
    pub mean: f64,
    pub p99: f64,
}

/// One method's attribution: the lines that lose the most f32 bits, most first.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribution {
    pub label: String,
    /// Configurations the attribution ran on.
    pub configurations: usize,
    pub lines: Vec<BitsLine>,
}

/// Rows in the eval input format (`docs/eval-format.md`), for the report's replayable JSONL
/// files; empty when there is nothing to write.
#[derive(Clone, Debug, Default)]
pub struct Replayable {
    /// The worst-case search's findings (`worst.jsonl`).
    pub worst: Vec<Value>,
    /// The disagreement search's findings (`disagreements.jsonl`).
    pub disagreements: Vec<Value>,
    /// The kept non-finite configurations (`nonfinite.jsonl`).
    pub nonfinite: Vec<Value>,
    /// A gated run's configurations that got worse than the baseline (`regressed.jsonl`).
    pub regressed: Vec<Value>,
}

/// Everything a sweep's report is made from.
pub struct Summary {
    pub case_path: String,
    /// The command line that made this run, as typed (shell-quoted).
    pub command_line: String,
    pub case: Case,
    /// `--count`, when it overrode the case's counts (such a run is not the gate).
    pub count_override: Option<usize>,
    /// Configurations measured (natural and top-ups), and natural ones per family.
    pub configurations: usize,
    pub natural: Vec<usize>,
    pub draws: Vec<crate::input::sampler::Draws>,
    pub topups: Vec<crate::input::sampler::TopUp>,
    pub timing: crate::measure::sweep::Timing,
    pub stages: Stages,
    pub analysis: Analysis,
    pub claims: Vec<ClaimResult>,
    /// How much of `line` lies below the horizon, per material (line cases).
    pub leak: Vec<Leak>,
    pub found: Vec<crate::measure::search::Found>,
    pub disagreements: Vec<crate::measure::search::Disagreement>,
    pub costs: Vec<crate::analyse::bench::Cost>,
    pub attribution: Vec<Attribution>,
    /// The first kept configurations on which some method returned NaN or ±inf, with those
    /// methods; `nonfinite_total` counts all.
    pub nonfinite: Vec<(Config, Vec<String>)>,
    pub nonfinite_total: usize,
    /// Per material: the chart's points (every supported method with a measured cost).
    pub charts: Vec<Vec<ChartPoint>>,
    pub heat_maps: Vec<HeatMap>,
    pub replayable: Replayable,
    /// A gated run's comparison with its baseline (`--baseline`).
    pub baseline: Option<crate::analyse::gate::GateReport>,
    /// The "What to ship" answer (None only for a run without methods).
    pub ship: Option<crate::analyse::ship::Ship>,
    /// The "Any conforming driver" section, when the case asks for it (docs/envelope.md).
    pub any_driver: Option<crate::analyse::envelope::AnyDriver>,
}

/// How the run was called, and the stages' times, for the summary.
pub struct RunInfo<'a> {
    pub case_path: &'a str,
    pub command_line: &'a str,
    pub stages: Stages,
}

impl Summary {
    /// Adds a gated run's comparison, and its configurations to replay.
    pub fn set_baseline(&mut self, gate: crate::analyse::gate::GateReport) -> Result<(), serde_json::Error> {
        self.replayable.regressed = gate.replay.iter().map(serde_json::to_value).collect::<Result<_, _>>()?;
        self.baseline = Some(gate);
        Ok(())
    }

    /// Gathers the summary of a measured sweep, its analysis and its claims' results.
    pub fn new(
        run: RunInfo,
        setup: &Setup,
        measured: &Measured,
        leak: Vec<Leak>,
        mut analysis: Analysis,
        claims: Vec<ClaimResult>,
    ) -> Result<Summary, serde_json::Error> {
        let case = &setup.case;
        let rows = |configs: &mut dyn Iterator<Item = &Config>| -> Result<Vec<Value>, serde_json::Error> {
            configs.map(serde_json::to_value).collect()
        };
        let replayable = Replayable {
            worst: rows(&mut measured.found.iter().map(|f| &f.config))?,
            disagreements: rows(&mut measured.disagreements.iter().map(|d| &d.config))?,
            nonfinite: rows(&mut measured.nonfinite.iter().map(|(c, _)| c))?,
            regressed: Vec::new(),
        };
        let costs = crate::analyse::bench::costs(&measured.costs);
        let budget = crate::analyse::ship::ShipBudget::resolve(&case.budget(), case.budget.is_some(), &analysis);
        let ship = budget
            .as_ref()
            .map(|b| crate::analyse::ship::choose(b, &analysis, &costs));
        let materials: Vec<String> = case.materials.iter().map(|m| m.name.clone()).collect();
        let any_driver = match (&case.envelope, &budget) {
            (Some(spec), Some(b)) => Some(crate::analyse::envelope::any_driver(
                &measured.envelope,
                &materials,
                b,
                spec.sample,
            )),
            _ => None,
        };
        // The envelope's opt-in gate checks join the case's tolerance checks and its verdict.
        if let (Some(spec), Some(a)) = (&case.envelope, &any_driver) {
            let extra = crate::analyse::envelope::checks(a, spec);
            if !extra.is_empty() {
                analysis.checks.extend(extra);
                analysis.verdict = crate::analyse::analysis::Verdict::of(&analysis.checks);
            }
        }
        let charts = (0..case.materials.len())
            .map(|k| chart_points(&analysis, &costs, k))
            .collect();
        let mut heat_maps = Vec::new();
        for (map, spec) in case.maps.iter().enumerate() {
            for (method, ms) in analysis
                .methods
                .iter()
                .enumerate()
                .filter(|(_, m)| spec.shows(&m.label))
            {
                for material in 0..ms.materials.len() {
                    heat_maps.push(HeatMap { map, method, material });
                }
            }
        }
        let attribution = measured
            .attribution
            .iter()
            .map(|a| Attribution {
                label: a.label.clone(),
                configurations: a.configurations,
                lines: a
                    .lines
                    .iter()
                    .map(|l| BitsLine {
                        path: l.line.path.clone(),
                        line: l.line.line,
                        text: l.line.text.clone(),
                        mean: l.mean,
                        p99: l.p99,
                    })
                    .collect(),
            })
            .collect();
        Ok(Summary {
            case_path: run.case_path.to_string(),
            command_line: run.command_line.to_string(),
            case: case.clone(),
            count_override: setup.count_override,
            configurations: measured.configurations,
            natural: measured.natural.clone(),
            draws: measured.draws.clone(),
            topups: measured.topups.clone(),
            timing: measured.timing.clone(),
            stages: run.stages,
            analysis,
            claims,
            leak,
            found: measured.found.clone(),
            disagreements: measured.disagreements.clone(),
            costs,
            attribution,
            nonfinite: measured.nonfinite.clone(),
            nonfinite_total: measured.nonfinite_total,
            charts,
            heat_maps,
            replayable,
            baseline: None,
            ship,
            any_driver,
        })
    }
}

/// The chart's points for one material: every supported method with a measured cost.
fn chart_points(analysis: &Analysis, costs: &[crate::analyse::bench::Cost], material: usize) -> Vec<ChartPoint> {
    analysis
        .methods
        .iter()
        .filter_map(|ms| {
            let mat = &ms.materials[material];
            let cost = costs.iter().find(|c| c.label == ms.label)?;
            let q = mat.all.rel?;
            // NaN where no light arrives is a NaN pixel too.
            let nonfinite = mat.all.nan + mat.all.inf + mat.all.false_light.nonfinite;
            mat.supported.then(|| ChartPoint {
                label: ms.label.clone(),
                group: ms.describe.split('@').next().unwrap_or(&ms.describe).to_string(),
                cost: cost.ns_per_eval_median,
                median: q.median,
                p99: if nonfinite > 0 { f64::INFINITY } else { q.p99 },
            })
        })
        .collect()
}

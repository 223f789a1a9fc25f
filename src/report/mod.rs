//! Reports: Markdown for people, CSV and JSON for tools. The set is written as one
//! (`crate::io::write_set`): a failed run never leaves half a report and never destroys
//! the previous one, and a report folder only ever holds one run's files.

mod attribution;
pub mod chart;
mod csv;
mod findings;
mod markdown;
mod svg;

use crate::analysis::Analysis;
use crate::case::Case;
use crate::sweep::{Measured, Setup};
use std::path::{Path, PathBuf};

pub use crate::io::write_atomic;
pub use crate::names::{chart_file, map_file};

/// Formats a non-negative statistic compactly: `3.1e-07`, `0`, or `—` when absent.
pub fn sci(x: Option<f64>) -> String {
    match x {
        None => "—".into(),
        Some(0.0) => "0".into(),
        Some(v) if v.is_nan() => "NaN".into(),
        Some(v) => format!("{v:.1e}"),
    }
}

/// Wall-clock seconds of the stages after measuring, for the report's timing section.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Stages {
    /// Statistics, comparisons, verdict and claims.
    pub analysis_seconds: f64,
    /// From the start of the command to the report being written: set-up, sampling, measuring,
    /// searches, analysis (report writing itself excluded).
    pub until_report_seconds: f64,
}

/// The report header's line on degenerate draws: how many were redrawn, per family.
pub fn draws_line(draws: &[crate::sampler::Draws]) -> String {
    let rejected: usize = draws.iter().map(|d| d.rejected).sum();
    if rejected == 0 {
        return "Degenerate draws: none (no configuration was redrawn).".into();
    }
    let parts: Vec<String> = draws
        .iter()
        .filter(|d| d.rejected > 0)
        .map(|d| {
            let reasons: Vec<String> = d.reasons.iter().map(|(r, n)| format!("{n} {r}")).collect();
            format!(
                "`{}` {} of {} draws ({:.2} %: {})",
                d.family,
                d.rejected,
                d.drawn,
                100.0 * d.rate(),
                reasons.join("; ")
            )
        })
        .collect();
    format!("Degenerate draws, redrawn: {}.", parts.join(", "))
}

/// Everything a report is made from.
pub struct ReportInput<'a> {
    pub case_path: &'a str,
    /// The command line that made this run, as typed (shell-quoted).
    pub command_line: &'a str,
    pub case: &'a Case,
    pub setup: &'a Setup,
    pub measured: &'a Measured,
    pub analysis: &'a Analysis,
    pub claims: &'a [crate::claims::ClaimResult],
    pub stages: Stages,
}

/// Writes `report.md`, `summary.json`, `stats.csv` and `comparisons.csv` into `dir`.
pub fn write_reports(dir: &Path, input: &ReportInput) -> anyhow::Result<Vec<PathBuf>> {
    let summary = serde_json::json!({
        "case": input.case.name,
        "case_file": input.case_path,
        "seed": input.case.seed,
        "configurations": input.measured.configurations,
        "command_line": input.command_line,
        "count_override": input.setup.count_override,
        "statistic": "relative error |value − reference| / |reference|, no floor, over configurations whose reference is not 0; reference-0 configurations in `false_light`; `rel_floored` uses `error_floor`",
        // Degenerate draws redrawn, per family (bounded: src/sampler.rs).
        "draws": input.measured.draws,
        "error_floor": input.case.error_floor,
        "topups": input.measured.topups,
        "timing": input.measured.timing,
        "stages": input.stages,
        "leak": findings::leak(input),
        "claims": input.claims,
        "disagreements": input.measured.disagreements,
        "analysis": input.analysis,
    });
    let mut extra = Vec::new();
    if !input.measured.found.is_empty() {
        let rows: Vec<_> = input
            .measured
            .found
            .iter()
            .map(|f| serde_json::to_value(&f.config))
            .collect::<Result<_, _>>()?;
        extra.push(("worst.jsonl".to_string(), crate::eval::to_jsonl(&rows)));
    }
    if !input.measured.disagreements.is_empty() {
        // The eval input format (DESIGN §3) and nothing else: replayable with `linelight eval`.
        let rows: Vec<_> = input
            .measured
            .disagreements
            .iter()
            .map(|d| serde_json::to_value(&d.config))
            .collect::<Result<_, _>>()?;
        extra.push(("disagreements.jsonl".to_string(), crate::eval::to_jsonl(&rows)));
    }
    let nonfinite = nonfinite(input);
    if !nonfinite.is_empty() {
        let rows: Vec<_> = nonfinite
            .iter()
            .map(|(c, _)| serde_json::to_value(c))
            .collect::<Result<_, _>>()?;
        extra.push(("nonfinite.jsonl".to_string(), crate::eval::to_jsonl(&rows)));
    }
    let files = [
        ("report.md", markdown::render(input).into_bytes()),
        // Compact: a machine-readable record, large for big cases; report.md is for reading.
        ("summary.json", serde_json::to_vec(&summary)?),
        ("stats.csv", csv::stats(input.analysis).into_bytes()),
        ("comparisons.csv", csv::comparisons(input.analysis).into_bytes()),
    ];
    let files: Vec<(String, Vec<u8>)> = files
        .into_iter()
        .map(|(n, b)| (n.to_string(), b))
        .chain(heat_maps(input))
        .chain(speed_charts(input))
        .chain(extra)
        .collect();
    Ok(crate::io::write_set(dir, &files)?)
}

fn heat_maps(input: &ReportInput) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for (k, map) in input.case.maps.iter().enumerate() {
        for ms in input.analysis.methods.iter().filter(|m| map.shows(&m.label)) {
            for mat in &ms.materials {
                let stats = &mat.maps[k];
                let title = format!("{} ({}) on {}", ms.label, ms.target, mat.material);
                out.push((
                    map_file(&ms.label, &mat.material, &map.x.axis, &map.y.axis),
                    svg::heat_map(stats, &title).into_bytes(),
                ));
            }
        }
    }
    out
}

/// The configurations on which some method returned NaN or ±inf, with those methods (the
/// first `sweep::NONFINITE_KEPT`; `measured.nonfinite_total` counts all): written out
/// (`nonfinite.jsonl`) so each can be replayed with `linelight eval`.
pub fn nonfinite<'a>(input: &'a ReportInput) -> Vec<(&'a crate::scene::Config, Vec<&'a str>)> {
    input
        .measured
        .nonfinite
        .iter()
        .map(|(c, methods)| (c, methods.iter().map(String::as_str).collect()))
        .collect()
}

/// The chart's points for one material: every supported method with a measured cost.
pub fn chart_points(input: &ReportInput, material: usize) -> Vec<chart::ChartPoint> {
    input
        .analysis
        .methods
        .iter()
        .filter_map(|ms| {
            let mat = &ms.materials[material];
            let cost = input.measured.costs.iter().find(|c| c.label == ms.label)?;
            let q = mat.all.rel?;
            // NaN where no light arrives is a NaN pixel too.
            let nonfinite = mat.all.nan + mat.all.inf + mat.all.false_light.nonfinite;
            mat.supported.then(|| chart::ChartPoint {
                label: ms.label.clone(),
                group: ms.describe.split('@').next().unwrap_or(&ms.describe).to_string(),
                cost: cost.ns_per_eval_median,
                median: q.median,
                p99: if nonfinite > 0 { f64::INFINITY } else { q.p99 },
            })
        })
        .collect()
}

fn speed_charts(input: &ReportInput) -> Vec<(String, Vec<u8>)> {
    let clock = input.measured.costs.first().map_or("", |c| c.clock.as_str());
    input
        .case
        .materials
        .iter()
        .enumerate()
        .map(|(k, family)| {
            let svg = chart::speed_accuracy_chart(
                &format!("Speed against accuracy: {} on {}", input.case.name, family.name),
                &format!(
                    "{} ({clock}), f32, {} configurations of {}",
                    // The adapter's name without the driver details: the subtitle must fit.
                    input.measured.timing.adapter.split(" — ").next().unwrap_or_default(),
                    family.count,
                    family.name
                ),
                "cost (GPU ns per evaluation, median of interleaved repeats)",
                &chart_points(input, k),
            );
            (chart_file(&family.name), svg.into_bytes())
        })
        .collect()
}

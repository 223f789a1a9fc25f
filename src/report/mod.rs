//! Reports: Markdown for diffs and CI logs, `report.html` (the same text, images inline) for
//! people, CSV and JSON for tools. The set is written as one
//! (`crate::io::write_set`): a failed run never leaves half a report and never destroys
//! the previous one, and a report folder only ever holds one run's files.

mod attribution;
pub mod bench;
pub mod chain;
pub mod chart;
mod csv;
pub mod diff;
mod envelope;
mod findings;
pub mod fit;
pub mod format;
pub mod html;
pub mod image;
pub mod junit;
mod markdown;
pub mod markup;
pub mod objectives;
pub mod render;
pub mod resolution;
pub mod scan;
mod svg;

use crate::analyse::summary::Summary;
use format::{Csv, Format, Json, Jsonl, Layout, Markdown, Svg};
use std::path::{Path, PathBuf};

pub use crate::analyse::summary::Stages;
pub use crate::input::names::{chart_file, map_file};

/// The report header's line on degenerate draws: how many were redrawn, per family.
pub fn draws_line(draws: &[crate::input::sampler::Draws]) -> String {
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

/// Writes `report.md`, `report.html`, `summary.json`, `stats.csv`, `comparisons.csv` and the
/// charts and maps into `dir`.
pub fn write_reports(dir: &Path, input: &Summary) -> anyhow::Result<Vec<PathBuf>> {
    let summary = serde_json::json!({
        "case": input.case.name,
        "case_file": input.case_path,
        "seed": input.case.seed,
        "configurations": input.configurations,
        "command_line": input.command_line,
        "count_override": input.count_override,
        "statistic": "relative error |value − reference| / |reference|, no floor, over configurations whose reference is not 0; reference-0 configurations in `false_light`; `rel_floored` uses `error_floor`",
        // Degenerate draws redrawn, per family (bounded: src/input/sampler.rs).
        "draws": input.draws,
        "error_floor": input.case.error_floor,
        "topups": input.topups,
        "timing": input.timing,
        "stages": input.stages,
        "leak": input.leak,
        "claims": input.claims,
        "disagreements": input.disagreements,
        "analysis": input.analysis,
        // The "What to ship" answer, as report.md's first section states it.
        "ship": input.ship,
    });
    let mut summary = summary;
    // A gated run only: an ungated run's summary.json keeps its bytes.
    if let Some(gate) = &input.baseline {
        summary["baseline"] = serde_json::to_value(gate)?;
    }
    let md = markdown::render(input);
    let mut outputs: Vec<Box<dyn Format>> = vec![
        Box::new(Markdown::new("report.md", md.clone())),
        // Compact: a machine-readable record, large for big cases; report.md is for reading.
        Box::new(Json::new("summary.json", summary, Layout::Compact)),
        Box::new(Csv::new("stats.csv", csv::stats(&input.analysis))),
        Box::new(Csv::new("comparisons.csv", csv::comparisons(&input.analysis))),
    ];
    outputs.extend(heat_maps(input));
    outputs.extend(speed_charts(input));
    // The eval input format (docs/eval-format.md) and nothing else: replayable with `linelight eval`.
    let replayable = &input.replayable;
    for (name, rows) in [
        ("worst.jsonl", &replayable.worst),
        ("disagreements.jsonl", &replayable.disagreements),
        ("nonfinite.jsonl", &replayable.nonfinite),
        ("regressed.jsonl", &replayable.regressed),
    ] {
        if !rows.is_empty() {
            outputs.push(Box::new(Jsonl::new(name, rows.clone())));
        }
    }
    // The same text as report.md, its charts and maps inline.
    let mut files = format::encode_all(&outputs)?;
    let html = html::page(&input.case.title, &[html::Part::Markdown(&md)], &files);
    files.push(("report.html".into(), html));
    Ok(crate::io::write_set(dir, crate::io::SetKind::Sweep, &files)?)
}

fn heat_maps(input: &Summary) -> Vec<Box<dyn Format>> {
    input
        .heat_maps
        .iter()
        .map(|h| {
            let (map, ms) = (&input.case.maps[h.map], &input.analysis.methods[h.method]);
            let mat = &ms.materials[h.material];
            let title = format!("{} ({}) on {}", ms.label, ms.target, mat.material);
            Box::new(Svg::new(
                map_file(&ms.label, &mat.material, &map.x.axis, &map.y.axis),
                svg::heat_map(&mat.maps[h.map], &title),
            )) as Box<dyn Format>
        })
        .collect()
}

fn speed_charts(input: &Summary) -> Vec<Box<dyn Format>> {
    let clock = input.costs.first().map_or("", |c| c.clock.as_str());
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
                    input.timing.adapter.split(" — ").next().unwrap_or_default(),
                    family.count,
                    family.name
                ),
                "cost (GPU ns per evaluation, median of interleaved repeats)",
                &input.charts[k],
            );
            Box::new(Svg::new(chart_file(&family.name), svg)) as Box<dyn Format>
        })
        .collect()
}

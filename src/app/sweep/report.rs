//! The end of a sweep (or of merged shards): the statistics finished into the analysis, the
//! claims evaluated, the gate's comparison, the report set written, the baseline and JUnit,
//! and the verdict's exit status.

use super::Swept;
use crate::analyse::analysis::Verdict;
use crate::analyse::summary::Summary;
use crate::app::Status;

/// Where a sweep's report goes and how the run was called.
pub(super) struct SweepRun<'a> {
    pub(super) case_path: &'a str,
    pub(super) command_line: &'a str,
    pub(super) dir: &'a std::path::Path,
    pub(super) started: std::time::Instant,
    pub(super) raw: Option<&'a std::path::Path>,
}

/// Analyses a measured sweep (or merged shards), writes its report set, and gives the verdict's
/// exit code.
pub(super) fn report_sweep(
    run: SweepRun,
    setup: &crate::measure::sweep::Setup,
    swept: &Swept,
    staged: Option<crate::io::Staged>,
    gate: &crate::app::gate::GateRun,
) -> anyhow::Result<Status> {
    let SweepRun {
        case_path,
        command_line,
        dir,
        started,
        raw,
    } = run;
    let t = std::time::Instant::now();
    let measured = &swept.measured;
    let analysis = swept.accumulators.finish(&setup.case, &setup.methods);
    let facts = crate::analyse::claims::Facts {
        analysis: Some(analysis.clone()),
        configurations: measured.natural.iter().sum(),
        costs: crate::analyse::bench::costs(&measured.costs),
        disagreements: measured.disagreements.clone(),
        found: measured.found.clone(),
        ..crate::analyse::claims::dry_facts(&setup.case, setup.methods.iter().map(|m| m.label.clone()).collect())
    };
    let claim_results = crate::analyse::claims::evaluate(&setup.case.claims, facts);
    let stages = crate::analyse::summary::Stages {
        analysis_seconds: measured.timing.statistics_seconds + t.elapsed().as_secs_f64(),
        until_report_seconds: started.elapsed().as_secs_f64(),
    };
    let gate_report = gate.compare(setup, (measured, swept.observations.as_ref()))?;
    let mut input = Summary::new(
        crate::analyse::summary::RunInfo {
            case_path,
            command_line,
            stages,
        },
        setup,
        measured,
        swept.leak.clone(),
        analysis,
        claim_results,
    )?;
    if let Some(g) = &gate_report {
        input.set_baseline(g.clone())?;
    }
    for path in crate::report::write_reports(dir, &input)? {
        eprintln!("wrote {}", path.display());
    }
    if let (Some(staged), Some(raw)) = (staged, &raw) {
        staged.commit()?;
        eprintln!("wrote {}", raw.display());
    }
    let (analysis, claim_results) = (&input.analysis, &input.claims);
    gate.finish(
        setup,
        (measured, swept.observations.as_ref()),
        &analysis.checks,
        gate_report.as_ref(),
        started.elapsed().as_secs_f64(),
    )?;
    let regressed = gate_report.as_ref().is_some_and(|g| g.regressed());
    let passed = analysis.checks.iter().filter(|c| c.pass).count();
    let stale: Vec<&str> = claim_results
        .iter()
        .filter(|c| !c.holds)
        .map(|c| c.id.as_str())
        .collect();
    println!(
        "verdict: {} ({} of {} checks pass); claims: {} of {} hold{}; report: {}",
        analysis.verdict.name(),
        passed,
        analysis.checks.len(),
        claim_results.len() - stale.len(),
        claim_results.len(),
        if stale.is_empty() {
            String::new()
        } else {
            format!(" (STALE: {})", stale.join(", "))
        },
        dir.join("report.md").display()
    );
    for c in analysis.checks.iter().filter(|c| c.too_few.is_some()) {
        println!(
            "no verdict: {} of {} on {} from {} configurations, fewer than the {} a quantile needs (raise the \
             material's count)",
            c.what,
            c.method,
            c.material,
            c.too_few.unwrap_or(0),
            crate::limits::MIN_JUDGED
        );
    }
    if let Some(g) = &gate_report {
        if !g.replay.is_empty() {
            eprintln!(
                "{} configurations got worse, or NaN or false light new since the baseline: {} (replay with linelight eval)",
                g.replay.len(),
                dir.join("regressed.jsonl").display()
            );
        }
        println!("{}", g.summary());
    }
    // 3: a finding no longer holds (the report says which); 1: a tolerance failed.
    Ok(if !stale.is_empty() {
        Status::StaleClaim
    } else if analysis.verdict == Verdict::Fail || regressed {
        Status::ToleranceFail
    } else {
        Status::Ok
    })
}

//! The sweep's orchestration: the measure stage yields measured chunks (`measure::sweep::measure_chunks`),
//! and each is folded here into the statistics (`analysis::Accumulators`), the leak below the
//! horizon and, for the gate, the per-configuration observations (`app::gate::Observations`, an `Accumulate`)
//! before it is dropped. Also the shard state files (`--shard`, `linelight merge`,
//! docs/scale.md), which hold both the measure stage's kept state and the statistics.

use super::shard::{read_shards, shard_path, write_shard, Partial, Recorded, SHARD_FORMAT};
use super::{kernel_inputs, open_gpu, GpuOptions, Status};
use crate::analyse::analysis::{Accumulators, Fold, Leak, LeakAccumulator, Verdict};
use crate::analyse::stats::{add_to_each, Accumulate};
use crate::analyse::summary::Summary;
use crate::app::gate::Observations;
use crate::input::case::Case;
use crate::io::{stage_output, OutputPlan, SetKind};
use crate::measure::gpu::Gpu;
use crate::measure::sweep::{self, MeasureOptions, Measured, Setup};
// Reached here by the tests and examples that set a sweep up.
pub use super::{check_memory, prepare, prepare_with};
pub use crate::measure::setup::Holds;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The CI gate (docs/ci/): baselines and JUnit.
#[derive(clap::Args)]
pub struct GateFlags {
    /// Save this run as a baseline in DIR (baseline.json + errors/), for a later --baseline.
    #[arg(long, value_name = "DIR")]
    pub save_baseline: Option<PathBuf>,
    /// Compare with the baseline in DIR: any regression exits 1.
    #[arg(long, value_name = "DIR")]
    pub baseline: Option<PathBuf>,
    /// Write JUnit XML: one testcase per method × material × rule.
    #[arg(long, value_name = "FILE")]
    pub junit: Option<PathBuf>,
    /// Error ratios within ±NOISE (at the 95 % bootstrap bounds) are unchanged (0 to 1).
    #[arg(long, default_value_t = 0.05, value_parser = super::options::fraction)]
    pub noise: f64,
    /// Op-count growth beyond this fraction is a regression (0 to 1).
    #[arg(long, default_value_t = 0.10, value_parser = super::options::fraction)]
    pub ops_growth: f64,
    /// The share rule: the share of configurations allowed to get worse, per material and bin
    /// (0 to 1; a one-sided binomial test at P < 0.01, at least 5 worse).
    #[arg(long, default_value_t = 0.05, value_parser = super::options::fraction)]
    pub worse_share: f64,
    /// The share rule: an error that grew by at most K ULPs of the reference did not get worse
    /// (a driver's last-bit change).
    #[arg(long, value_name = "K", default_value_t = 4.0, value_parser = super::options::ulps)]
    pub worse_ulps: f64,
}

/// Options of `linelight sweep`.
#[derive(clap::Args)]
pub struct SweepOptions {
    /// Case file (TOML), e.g. cases/line_fwt.toml.
    pub case: PathBuf,
    /// Reports go to OUT/<case name>/.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
    /// Also write every configuration's values (JSONL) to this file.
    #[arg(long)]
    pub raw: Option<PathBuf>,
    /// Override every material's count (quick runs; the committed reports use the case's).
    #[arg(long)]
    pub count: Option<usize>,
    /// Evaluate shard I of N (a deterministic partition of the configurations) and write its
    /// mergeable state to OUT/shard-I-of-N.cbor instead of a report (docs/scale.md).
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    #[command(flatten)]
    pub gpu: GpuOptions,
    #[command(flatten)]
    pub gate: GateFlags,
}

/// Options of `linelight merge`.
#[derive(clap::Args)]
pub struct MergeOptions {
    /// Directories holding the shard-I-of-N.cbor files (every shard exactly once).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Reports go to OUT/<case name>/.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
}

/// `linelight sweep`: the case's inputs checked, measured (or one shard of it), analysed,
/// reported, and the verdict's status.
pub fn sweep(options: SweepOptions) -> anyhow::Result<Status> {
    let SweepOptions {
        case,
        out,
        raw,
        count,
        shard,
        gpu,
        gate,
    } = options;
    let gpu = &gpu;
    let started = std::time::Instant::now();
    let case_path = case.display().to_string();
    if count == Some(0) {
        anyhow::bail!("--count must be at least 1");
    }
    let shard = shard.as_deref().map(crate::measure::sweep::parse_shard).transpose()?;
    if shard.is_some()
        && (raw.is_some() || gate.save_baseline.is_some() || gate.baseline.is_some() || gate.junit.is_some())
    {
        anyhow::bail!("--shard writes a shard state only: --raw and the gate options belong to the unsharded sweep");
    }
    // Read once, bounded: a shard records the contents it ran (app::shard).
    let case_bytes = crate::io::read_bounded(&case, "case file", crate::limits::MAX_TEXT_INPUT)?;
    let case_text = String::from_utf8(case_bytes)
        .map_err(|e| anyhow::anyhow!("cannot read case file {}: not UTF-8 text ({e})", case.display()))?;
    let loaded = Case::parse(&case_path, &case_text)?;
    let recorded = match shard {
        Some(_) => Some((
            Recorded::new(&case, case_text.as_bytes(), &out),
            gpu.kernels
                .iter()
                .map(|k| Recorded::read(k, &out))
                .collect::<anyhow::Result<Vec<_>>>()?,
        )),
        None => None,
    };
    // Every output is checked before any work, together: the report folder (or the shard
    // state), --raw, --save-baseline and --junit.
    let dir = out.join(&loaded.name);
    let mut plan = OutputPlan::new();
    plan.input("the case file", &case);
    for (what, path) in kernel_inputs(&gpu.kernels) {
        plan.input(what, path);
    }
    if let Some(base) = &gate.baseline {
        plan.input("--baseline", base);
    }
    match shard {
        Some((i, n)) => plan.file("--shard", &shard_path(&out, i, n)),
        None => plan.set("--out", &dir, SetKind::Sweep),
    };
    if let Some(raw) = &raw {
        plan.file("--raw", raw);
    }
    if let Some(save) = &gate.save_baseline {
        plan.set("--save-baseline", save, SetKind::Baseline);
    }
    if let Some(junit) = &gate.junit {
        plan.file("--junit", junit);
    }
    plan.check()?;
    let command_line = shell_words::join(std::env::args());
    let holds = Holds {
        raw: raw.is_some(),
        observations: gate.save_baseline.is_some() || gate.baseline.is_some(),
        all_samples: false,
    };
    let setup = prepare_with(loaded, &gpu.kernels, count, holds)?;
    check_budget_target(&setup)?;
    // A claim that names what the case does not have is bad input, found before measuring.
    let labels = setup.methods.iter().map(|m| m.label.clone()).collect();
    crate::analyse::claims::check(
        &setup.case.claims,
        crate::analyse::claims::dry_facts(&setup.case, labels),
    )
    .map_err(|e| anyhow::anyhow!("{case_path}: {e}"))?;
    // A baseline that does not fit this run is bad input, found before measuring.
    let gate = crate::app::gate::GateRun::prepare(
        gate.save_baseline,
        gate.baseline.as_deref(),
        gate.junit,
        crate::app::gate::GateOptions {
            noise: gate.noise,
            ops_growth: gate.ops_growth,
            worse_share: gate.worse_share,
            worse_ulps: gate.worse_ulps,
            ..Default::default()
        },
        &setup,
    )?;
    let device = open_gpu(gpu.adapter.as_deref())?;
    eprintln!(
        "case {}: {} natural configurations (and top-ups), {} methods",
        setup.case.name,
        setup.case.materials.iter().map(|m| m.count).sum::<usize>(),
        setup.methods.len()
    );
    if let Some(shard) = shard {
        let mut part = measure_part(
            &setup,
            &device,
            crate::measure::sweep::MeasureOptions {
                chunk: gpu.chunk,
                raw: None,
                shard: Some(shard),
            },
            false,
        )?;
        // Each shard climbs its own starts; shard 0 alone times the methods and attributes.
        let pipelines = sweep::pipelines(&device, &setup.methods)?;
        sweep::search_part(&setup, &device, &pipelines, &mut part.measured)?;
        if shard.0 == 0 {
            sweep::time_part(&setup, &device, &pipelines, &mut part.measured, shard)?;
        }
        let (case_record, kernel_records) = recorded.expect("recorded for a shard");
        let path = write_shard(&out, case_record, kernel_records, &setup.methods, &part)?;
        let climbs = &part.measured.climbs;
        println!(
            "shard {}/{}: {} configurations in {:.1} s (drawing its own: {:.1} s; {} search climbs); state: {}",
            shard.0,
            shard.1,
            part.measured.configurations(),
            part.measured.timing.total_seconds,
            part.measured.timing.sampling_seconds,
            climbs
                .search
                .iter()
                .chain(&climbs.disagree)
                .map(Vec::len)
                .sum::<usize>(),
            path.display()
        );
        return Ok(Status::Ok);
    }
    let observe = gate.wants_observations();
    // --raw is staged while measuring (rows streamed a chunk at a time, never all in
    // memory) and put in place after the report set: on an error neither replaces
    // anything.
    let (measured, staged) = match &raw {
        None => (
            measure(
                &setup,
                &device,
                crate::measure::sweep::MeasureOptions {
                    chunk: gpu.chunk,
                    raw: None,
                    shard: None,
                },
                observe,
            )?,
            None,
        ),
        Some(raw) => {
            let mut measured = None;
            let mut failed = None;
            let staged = stage_output(raw, &mut |w| {
                // A failed write of a row (a full disk) names the file.
                let mut named = Named { path: raw, inner: w };
                match measure(
                    &setup,
                    &device,
                    crate::measure::sweep::MeasureOptions {
                        chunk: gpu.chunk,
                        raw: Some(&mut named),
                        shard: None,
                    },
                    observe,
                ) {
                    Ok(m) => measured = Some(m),
                    Err(e) => failed = Some(e),
                }
                Ok(())
            })?;
            if let Some(e) = failed {
                return Err(e);
            }
            (measured.expect("measured or failed"), Some(staged))
        }
    };
    report_sweep(
        SweepRun {
            case_path: &case_path,
            command_line: &command_line,
            dir: &dir,
            started,
            raw: raw.as_deref(),
        },
        &setup,
        &measured,
        staged,
        &gate,
    )
}

/// A writer whose errors name the file it writes.
struct Named<'a> {
    path: &'a Path,
    inner: &'a mut dyn std::io::Write,
}

impl std::io::Write for Named<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.inner.write(buf).map_err(|e| self.named(e))
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush().map_err(|e| self.named(e))
    }
}

impl Named<'_> {
    fn named(&self, e: std::io::Error) -> std::io::Error {
        std::io::Error::new(e.kind(), format!("cannot write {}: {e}", self.path.display()))
    }
}

/// `linelight merge`: the shard states of a sharded sweep merged into the report the unsharded
/// sweep writes. No GPU: the shards climbed the searches and shard 0 timed the methods; the
/// merge adds the statistics, settles the top-ups and keeps the climbs of the whole sample's
/// best starts (`measure::sweep::assemble`).
pub fn merge(options: MergeOptions) -> anyhow::Result<Status> {
    let (dirs, out) = (&options.shards[..], options.out.as_path());
    let started = std::time::Instant::now();
    let command_line = shell_words::join(std::env::args());
    // The case and kernels are found beside the records and must be what the shards ran.
    let shards = read_shards(dirs)?;
    let loaded = Case::parse(&shards.case_path.display().to_string(), &shards.case_text)?;
    let case_path = shards.case_shown.clone();
    let dir = out.join(&loaded.name);
    let mut plan = OutputPlan::new();
    plan.input("the case file", &shards.case_path);
    for k in &shards.kernels {
        plan.input("--kernel", k);
    }
    for shard_dir in dirs {
        plan.input("the shard folder", shard_dir);
    }
    plan.set("--out", &dir, SetKind::Sweep).check()?;
    let setup = prepare_with(
        loaded,
        &shards.kernels,
        shards.records[0].1.count_override,
        Holds::default(),
    )?;
    check_budget_target(&setup)?;
    shards.check_sources(&setup.methods)?;
    let part = Partial::merge_records(&setup, &shards)?;
    let gate = crate::app::gate::GateRun::prepare(None, None, None, Default::default(), &setup)?;
    let measured = Swept {
        measured: sweep::assemble(&setup, part.measured)?,
        accumulators: part.accumulators,
        leak: part.leak.finish(&setup.case),
        observations: part.observations,
    };
    report_sweep(
        SweepRun {
            case_path: &case_path,
            command_line: &command_line,
            dir: &dir,
            started,
            raw: None,
        },
        &setup,
        &measured,
        None,
        &gate,
    )
}

/// Where a sweep's report goes and how the run was called.
struct SweepRun<'a> {
    case_path: &'a str,
    command_line: &'a str,
    dir: &'a std::path::Path,
    started: std::time::Instant,
    raw: Option<&'a std::path::Path>,
}

/// Analyses a measured sweep (or merged shards), writes its report set, and gives the verdict's
/// exit code.
fn report_sweep(
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
    let failed = analysis.checks.iter().filter(|c| !c.pass).count();
    let stale: Vec<&str> = claim_results
        .iter()
        .filter(|c| !c.holds)
        .map(|c| c.id.as_str())
        .collect();
    println!(
        "verdict: {} ({} of {} checks pass); claims: {} of {} hold{}; report: {}",
        analysis.verdict.name(),
        analysis.checks.len() - failed,
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

/// Refuses a `[budget]` whose target no method of the sweep is judged against (bench and diff
/// time or compare methods and do not read the budget).
fn check_budget_target(setup: &Setup) -> anyhow::Result<()> {
    let (case, methods) = (&setup.case, &setup.methods);
    if let Some(target) = case.budget.as_ref().and_then(|b| b.target) {
        if !methods
            .iter()
            .any(|m| crate::analyse::ship::judged_against(m.target(), target))
        {
            let targets: std::collections::BTreeSet<&str> = methods.iter().map(|m| m.target().name()).collect();
            anyhow::bail!(
                "case `{}`: `budget.target` = \"{target}\": no method of this run is judged against it (their \
                 targets: {}); name one of those, or its surface view (`line_upper` for `line`)",
                case.name,
                targets.into_iter().collect::<Vec<_>>().join(", ")
            );
        }
    }
    Ok(())
}

/// A measured sweep with its folded statistics: what the analysis, the report and the gate
/// are made from.
pub struct Swept {
    pub measured: Measured,
    pub accumulators: Accumulators,
    /// How much of `line` lies below the horizon, per family (line cases).
    pub leak: Vec<Leak>,
    /// The gate's observations (`observe`).
    pub observations: Option<Observations>,
}

/// Measures the configurations (all, or one shard's) chunk by chunk, folding each into the
/// statistics and, when `observe`, into the gate's observations.
pub fn measure_part(setup: &Setup, gpu: &Gpu, options: MeasureOptions, observe: bool) -> anyhow::Result<Partial> {
    let case = &setup.case;
    let methods = &setup.methods;
    let shard = options.shard.unwrap_or((0, 1));
    let mut accumulators = Accumulators::new(case, methods);
    let mut leak = LeakAccumulator::new(case.materials.len());
    let mut observations = observe.then(|| crate::app::gate::observations(methods.len(), case.materials.len()));
    let mut statistics_seconds = 0.0;
    let mut measured = sweep::measure_chunks(setup, gpu, options, &mut |c| {
        let t = Instant::now();
        add_to_each(&mut [&mut accumulators, &mut leak], Fold { case, chunk: c });
        statistics_seconds += t.elapsed().as_secs_f64();
        if let Some(obs) = &mut observations {
            obs.add(Fold { case, chunk: c });
        }
        Ok(())
    })?;
    measured.timing.statistics_seconds += statistics_seconds;
    Ok(Partial {
        format: SHARD_FORMAT,
        case: case.name.clone(),
        seed: case.seed,
        count_override: setup.count_override,
        shard,
        methods: methods.iter().map(|m| m.label.clone()).collect(),
        accumulators,
        leak,
        measured,
        observations,
    })
}

/// The searches, the cost pass and the attribution after measuring: a swept sweep.
pub fn finish(setup: &Setup, gpu: &Gpu, part: Partial) -> anyhow::Result<Swept> {
    Ok(Swept {
        measured: sweep::search_and_cost(setup, gpu, part.measured)?,
        accumulators: part.accumulators,
        leak: part.leak.finish(&setup.case),
        observations: part.observations,
    })
}

/// Measures a whole sweep: its configurations chunk by chunk ([`measure_part`]), then the
/// searches, the cost pass and the attribution ([`finish`]).
pub fn measure(setup: &Setup, gpu: &Gpu, options: MeasureOptions, observe: bool) -> anyhow::Result<Swept> {
    let part = measure_part(setup, gpu, options, observe)?;
    finish(setup, gpu, part)
}

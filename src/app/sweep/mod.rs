//! `linelight sweep` and `linelight merge`: the case's inputs and outputs checked before any
//! work, the run set up (`measure::setup`), measured with its folds (`app::swept`), or one
//! shard of it written as a shard state (`--shard`, docs/scale.md), or the shard states merged;
//! then the verdict (`report`: analysed, reported, gated).

use super::shard::{merge_records, read_shards, shard_path, write_shard, Recorded};
use super::{kernel_inputs, open_gpu, GpuOptions, Status};
use crate::input::case::Case;
use crate::io::{stage_output, OutputPlan, SetKind};
use crate::kernel::Includes;
use crate::measure::sweep::{self, Setup};
use std::path::{Path, PathBuf};

// Reached here by the tests and examples that set a sweep up.
use super::prepare_with;
use super::swept::{measure, measure_part, Swept};
use crate::measure::setup::Holds;

/// The verdict of a measured sweep: analysed, reported, gated.
mod report;
use report::{report_sweep, SweepRun};

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
pub fn sweep(options: SweepOptions, includes: &Includes) -> anyhow::Result<Status> {
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
    let setup = prepare_with(loaded, &gpu.kernels, includes, count, holds)?;
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
pub fn merge(options: MergeOptions, includes: &Includes) -> anyhow::Result<Status> {
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
        includes,
        shards.records[0].1.count_override,
        Holds::default(),
    )?;
    check_budget_target(&setup)?;
    shards.check_sources(&setup.methods)?;
    let part = merge_records(&setup, &shards)?;
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

//! A sweep, measured: case → configurations → GPU results, CPU evaluator columns (f64,
//! cpu_f32), references.
//! Everything that can fail on bad input (case file, kernels, adapter) fails before any
//! measuring starts and before any report is written.

use crate::analysis::{MethodRun, References};
use crate::case::Case;
use crate::gpu::Gpu;
use crate::methods::{self, Method};
use crate::reference::{self, Estimate};
use crate::sampler::{self, Sample};
use crate::scene::GpuScene;
use crate::target::Target;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::time::Instant;

pub struct Setup {
    pub case: Case,
    pub methods: Vec<Method>,
    /// The natural sample first, then the top-ups (`Sample::strata`).
    pub samples: Vec<Sample>,
    /// What topping up thin bins did, per family.
    pub topups: Vec<sampler::TopUp>,
    /// `--count`, when it overrode the case's counts (such a run is not the gate).
    pub count_override: Option<usize>,
    /// Each family's draws, rejected ones included (shown in the report).
    pub draws: Vec<sampler::Draws>,
}

/// Loads and checks everything a sweep needs, without touching the GPU.
pub fn prepare(case: Case, user_kernels: &[PathBuf], count: Option<usize>) -> anyhow::Result<Setup> {
    prepare_with(case, user_kernels, count, false)
}

/// [`prepare`], with `raw` telling whether every configuration's values are also kept for
/// `--raw` (counted in the memory estimate).
pub fn prepare_with(case: Case, user_kernels: &[PathBuf], count: Option<usize>, raw: bool) -> anyhow::Result<Setup> {
    let mut case = case;
    anyhow::ensure!(count != Some(0), "--count must be at least 1");
    if let Some(n) = count {
        // The bins' minimum shrinks with the counts, so a quick run stays quick.
        let largest = case.materials.iter().map(|m| m.count).max().unwrap_or(1).max(1);
        case.min_per_bin = (case.min_per_bin * n).div_ceil(largest).min(case.min_per_bin);
        for m in &mut case.materials {
            m.count = n;
        }
    }
    let kernels = methods::kernel_set(user_kernels)?;
    let mut methods = Vec::new();
    for spec in &case.methods {
        methods.push(methods::resolve(spec, &kernels).map_err(|e| anyhow::anyhow!("case `{}`: {e}", case.name))?);
    }
    // `--kernel FILE`: the case's methods plus every kernel given (unless the case names it).
    for path in user_kernels {
        let k = crate::kernel::KernelFile::read(path)?;
        if !methods.iter().any(|m| m.id() == k.id) {
            methods.push(methods::resolve(&k.id, &kernels)?);
        }
    }
    for [a, b] in &case.compare {
        let target = |l: &String| methods.iter().find(|m| &m.label == l).map(|m| m.target());
        if target(a) != target(b) {
            anyhow::bail!(
                "case `{}`: compare [{a}, {b}]: the two methods approximate different targets",
                case.name
            );
        }
    }
    // Memory before the sample is allocated: counts are the user's (`--count`).
    // Top-ups add at most `min_per_bin` per bin of each family.
    let bins: u64 = case.bins.iter().map(|b| b.edges.len().saturating_sub(1) as u64).sum();
    let total = case.materials.iter().fold(0u64, |t, m| {
        t.saturating_add(m.count as u64)
            .saturating_add(bins.saturating_mul(case.min_per_bin as u64))
    });
    let estimate =
        crate::limits::sweep_estimate(total, methods.len() as u64, needed_targets(&methods).len() as u64, raw);
    crate::limits::check(
        &format!("case `{}` with {total} configurations", case.name),
        estimate,
        crate::limits::max_memory(),
    )
    .map_err(anyhow::Error::msg)?;
    if let Some(search) = &case.search {
        // One step's candidates (samples, scenes, references) at a time.
        let batch = (search.restarts as u64).saturating_mul(search.population as u64);
        crate::limits::check(
            &format!(
                "case `{}`: [search] with {} × {} candidates per step",
                case.name, search.restarts, search.population
            ),
            crate::limits::search_estimate(batch),
            crate::limits::max_memory(),
        )
        .map_err(anyhow::Error::msg)?;
    }
    let (mut samples, draws) =
        sampler::sample_case_counted(&case).map_err(|e| anyhow::anyhow!("case `{}`: {e}", case.name))?;
    let (extra, topups) = sampler::top_up(&case, &samples);
    samples.extend(extra);
    Ok(Setup {
        case,
        methods,
        samples,
        topups,
        count_override: count,
        draws,
    })
}

/// Wall-clock time of each stage, measured in this run.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Timing {
    pub configurations: usize,
    pub adapter: String,
    /// (method label, GPU seconds incl. upload and readback, configurations per second).
    pub gpu: Vec<(String, f64, f64)>,
    /// (method label, seconds of the CPU evaluator's f64 column on all cores).
    pub f64_ports: Vec<(String, f64)>,
    /// (method label, seconds of the CPU evaluator's f32 column on all cores): beside the
    /// GPU seconds, the same kernel on the CPU, measured in the same run.
    pub f32_ports: Vec<(String, f64)>,
    /// Seconds of the "where the bits go" attribution (a subset, `ATTRIBUTION_CONFIGURATIONS`).
    pub attribution_seconds: f64,
    pub references_seconds: f64,
    pub references_evaluated: usize,
    pub search_seconds: f64,
    /// The disagreement search between compared pairs, and the candidates it evaluated.
    pub disagree_seconds: f64,
    pub disagree_evaluations: usize,
    pub cost_seconds: f64,
    pub total_seconds: f64,
}

pub struct Measured {
    pub runs: Vec<MethodRun>,
    pub references: References,
    pub timing: Timing,
    /// The worst-case search's findings (cases with a `[search]`).
    pub found: Vec<crate::search::Found>,
    /// Per compared pair, both ways: where one method is least accurate relative to the other.
    pub disagreements: Vec<crate::search::Disagreement>,
    /// Each method's cost: GPU timestamps, CPU f32 port, naga op count (src/bench.rs).
    pub costs: Vec<crate::bench::Cost>,
    /// Where each method's f32 rounding loses bits, on a subset (src/interp attribution).
    pub attribution: Vec<MethodAttribution>,
}

/// One method's local f32 rounding error per kernel source line.
#[derive(Clone, Debug)]
pub struct MethodAttribution {
    pub label: String,
    /// Configurations the attribution ran on (every k-th of those the method applies to).
    pub configurations: usize,
    /// Most bits first.
    pub lines: Vec<crate::interp::LineSummary>,
}

/// Configurations per method for the attribution (a shadow f64 evaluation beside the f32
/// one costs about three plain evaluations; a spread subset keeps it to a fraction of a
/// second per method).
pub const ATTRIBUTION_CONFIGURATIONS: usize = 2048;

/// Attribution of every method on an evenly spread subset of the configurations.
fn attribute(methods: &[Method], configs: &[crate::scene::Config]) -> anyhow::Result<Vec<MethodAttribution>> {
    methods
        .iter()
        .map(|m| {
            let applies: Vec<&crate::scene::Config> = configs.iter().filter(|c| m.applies(c)).collect();
            let step = applies.len().div_ceil(ATTRIBUTION_CONFIGURATIONS).max(1);
            let subset: Vec<&crate::scene::Config> = applies.into_iter().step_by(step).collect();
            let a = crate::interp::program(m)?.attribute(&subset)?;
            Ok(MethodAttribution {
                label: m.label.clone(),
                configurations: subset.len(),
                lines: a.summary(),
            })
        })
        .collect()
}

/// Configurations per method for the cost measurement: enough to fill the device, few
/// enough to keep a sweep's timing pass to seconds.
const COST_CONFIGURATIONS: usize = 16384;
const COST_WARMUP: usize = 2;
const COST_REPEATS: usize = 7;

fn bar(len: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len as u64);
    pb.set_style(
        ProgressStyle::with_template("{msg:>28} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// The targets whose references a sweep needs: every method's, plus `line_upper`
/// beside `line` (the leak below the horizon is reported from their difference).
pub fn needed_targets(methods: &[Method]) -> BTreeSet<Target> {
    let mut t: BTreeSet<Target> = methods.iter().map(Method::target).collect();
    if t.contains(&Target::Line) {
        t.insert(Target::LineUpper);
    }
    t
}

/// References for every configuration and target that applies to it, in parallel.
pub fn references(samples: &[crate::scene::Config], targets: &BTreeSet<Target>, pb: &ProgressBar) -> References {
    samples
        .par_iter()
        .map(|c| {
            let r: BTreeMap<Target, Estimate> = targets
                .iter()
                .filter_map(|&t| reference::reference(c, t).map(|e| (t, e)))
                .collect();
            pb.inc(1);
            r
        })
        .collect()
}

pub fn measure(setup: &Setup, gpu: &Gpu, chunk: usize) -> anyhow::Result<Measured> {
    let start = Instant::now();
    // Compile every pipeline first: a kernel error stops the sweep before any work.
    let mut pipelines = Vec::new();
    for m in &setup.methods {
        pipelines.push(gpu.pipeline(m)?);
    }
    let configs: Vec<_> = setup.samples.iter().map(|s| s.config.clone()).collect();
    let scenes: Vec<GpuScene> = configs.iter().map(GpuScene::from).collect();
    let n = configs.len();
    let mut timing = Timing {
        configurations: n,
        adapter: gpu.adapter.to_string(),
        ..Timing::default()
    };

    let mut runs = Vec::new();
    for (m, pipeline) in setup.methods.iter().zip(&pipelines) {
        let pb = bar(n, &format!("GPU {}", m.label));
        let out = gpu.run(pipeline, &scenes, chunk, &mut |done| pb.set_position(done as u64))?;
        pb.finish_and_clear();
        let gpu_seconds = out.wall.as_secs_f64();
        timing.gpu.push((m.label.clone(), gpu_seconds, n as f64 / gpu_seconds));

        // The kernel's f64 and cpu_f32 columns, from the CPU evaluator.
        let t = Instant::now();
        let f64 = m.cpu_column_or_none(&configs, crate::interp::Mode::F64);
        let f64_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let f32_cpu: Vec<Option<f32>> = m
            .cpu_column_or_none(&configs, crate::interp::Mode::F32)
            .into_iter()
            .map(|v| v.map(|x| x as f32))
            .collect();
        timing.f64_ports.push((m.label.clone(), f64_seconds));
        timing.f32_ports.push((m.label.clone(), t.elapsed().as_secs_f64()));
        let f32 = out
            .values
            .iter()
            .zip(&configs)
            .map(|(&v, c)| if m.applies(c) { v } else { f32::NAN })
            .collect();
        runs.push(MethodRun {
            method: m.clone(),
            f32,
            f32_cpu,
            f64,
            gpu_seconds,
            f64_seconds,
        });
    }

    let targets = needed_targets(&setup.methods);
    let pb = bar(
        n,
        &format!(
            "references ({})",
            targets.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ")
        ),
    );
    let t = Instant::now();
    let references = references(&configs, &targets, &pb);
    pb.finish_and_clear();
    timing.references_seconds = t.elapsed().as_secs_f64();
    timing.references_evaluated = references.iter().map(BTreeMap::len).sum();
    // A reference that cannot be computed is an error, never a NaN row in the report.
    crate::eval::check_references(
        std::path::Path::new(&format!("case `{}`", setup.case.name)),
        &configs,
        &references,
    )?;

    let mut found = Vec::new();
    if let Some(spec) = &setup.case.search {
        let t = Instant::now();
        // The pipelines compiled for the runs serve the search too.
        let jobs: Vec<(&MethodRun, &crate::gpu::MethodPipeline, usize)> = runs
            .iter()
            .zip(&pipelines)
            .filter(|(r, _)| spec.methods.contains(&r.method.label))
            .flat_map(|(r, p)| (0..setup.case.materials.len()).map(move |f| (r, p, f)))
            .collect();
        let pb = bar(jobs.len(), "worst-case search");
        for (run, pipeline, family) in jobs {
            let f = crate::search::search(
                &setup.case,
                spec,
                &setup.samples,
                &references,
                run,
                (gpu, pipeline),
                family,
            )?;
            found.extend(f);
            pb.inc(1);
        }
        pb.finish_and_clear();
        timing.search_seconds = t.elapsed().as_secs_f64();
    }
    // Disagreements: every compared pair, both ways, in every family.
    let mut disagreements = Vec::new();
    if !setup.case.compare.is_empty() {
        let spec = setup.case.disagreements.clone().unwrap_or_default();
        let t = Instant::now();
        let index = |l: &String| {
            setup
                .methods
                .iter()
                .position(|m| &m.label == l)
                .expect("case checked compare labels")
        };
        let jobs: Vec<(usize, usize, usize)> = setup
            .case
            .compare
            .iter()
            .flat_map(|[a, b]| [(index(a), index(b)), (index(b), index(a))])
            .flat_map(|(a, b)| (0..setup.case.materials.len()).map(move |f| (a, b, f)))
            .collect();
        let pb = bar(jobs.len(), "disagreement search");
        for (a, b, family) in jobs {
            let (found, evaluations) = crate::search::disagreements(
                &setup.case,
                &spec,
                (&setup.samples, &references),
                gpu,
                (&runs[a], &pipelines[a]),
                (&runs[b], &pipelines[b]),
                family,
            )?;
            disagreements.extend(found);
            timing.disagree_evaluations += evaluations;
            pb.inc(1);
        }
        pb.finish_and_clear();
        timing.disagree_seconds = t.elapsed().as_secs_f64();
    }
    // Cost: the first configurations of every family, each method timed in interleaved rounds.
    let t = Instant::now();
    let per_family = COST_CONFIGURATIONS.div_ceil(setup.case.materials.len());
    let cost_configs: Vec<_> = (0..setup.case.materials.len())
        .flat_map(|m| {
            setup
                .samples
                .iter()
                .filter(move |s| s.material == m && s.natural())
                .take(per_family)
        })
        .map(|s| s.config.clone())
        .collect();
    let pb = bar(
        setup.methods.len() * (COST_WARMUP + COST_REPEATS),
        "cost (GPU timestamps)",
    );
    let costs = crate::bench::bench_methods_with(
        gpu,
        &setup.methods,
        &cost_configs,
        COST_WARMUP,
        COST_REPEATS,
        &mut |done, _| pb.set_position(done as u64),
    )?;
    pb.finish_and_clear();
    timing.cost_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let attribution = attribute(&setup.methods, &configs)?;
    timing.attribution_seconds = t.elapsed().as_secs_f64();
    timing.total_seconds = start.elapsed().as_secs_f64();
    Ok(Measured {
        attribution,
        costs,
        found,
        disagreements,
        runs,
        references,
        timing,
    })
}

//! A sweep, measured: case → configurations → GPU results, CPU evaluator columns (f64,
//! cpu_f32), references.
//! Everything that can fail on bad input (case file, kernels, adapter) fails before any
//! measuring starts and before any report is written.

use crate::eval::interp::CpuColumns;
use crate::input::case::Case;
use crate::input::sampler::{self, Sample};
use crate::input::scene::GpuScene;
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::measure::gpu::{Gpu, MethodPipeline};
use crate::reference::{self, Estimate};
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

/// What was measured for one method over a chunk of configurations.
pub struct MethodRun {
    pub method: Method,
    /// GPU results, one per configuration (NaN where the method does not apply).
    pub f32: Vec<f32>,
    /// The CPU evaluator in f32 and f64, where the method applies.
    pub f32_cpu: Vec<Option<f32>>,
    pub f64: Vec<Option<f64>>,
}

/// References per configuration, by target.
pub type References = Vec<BTreeMap<Target, Estimate>>;

/// One chunk of measured configurations, handed to the caller of [`measure_chunks`] (the app
/// layer folds it into the statistics and the gate's observations), then dropped.
pub struct MeasuredChunk<'a> {
    pub samples: &'a [Sample],
    /// Each configuration's global index (natural sample first, then top-ups).
    pub global: &'a [usize],
    pub references: &'a References,
    /// The same targets at each configuration rounded to f32 (`eval_rows::references_f32_inputs`):
    /// what the f32 columns are judged against.
    pub references_f32: &'a References,
    /// One per method, in the setup's order; this chunk's values only.
    pub runs: &'a [MethodRun],
}

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

/// Wall-clock time of each stage, measured in this run.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    pub configurations: usize,
    pub adapter: String,
    /// (method label, GPU seconds incl. upload and readback, configurations per second).
    pub gpu: Vec<(String, f64, f64)>,
    /// (method label, seconds of the CPU evaluator's f64 column on all cores).
    pub cpu_f64_seconds: Vec<(String, f64)>,
    /// (method label, seconds of the CPU evaluator's f32 column on all cores): beside the
    /// GPU seconds, the same kernel on the CPU, measured in the same run.
    pub cpu_f32_seconds: Vec<(String, f64)>,
    /// (method label, which CPU evaluator ran its f32 and f64 columns: `compiled`, or
    /// `interpreter (why)`; [`crate::eval::interp::Program::engines`]).
    #[serde(default)]
    pub cpu_engines: Vec<(String, String)>,
    /// Seconds of the "where the bits go" attribution (a subset, `ATTRIBUTION_CONFIGURATIONS`).
    pub attribution_seconds: f64,
    pub references_seconds: f64,
    pub references_evaluated: usize,
    /// The references again at the configurations rounded to f32 (input rounding apart):
    /// seconds, and references computed (those of configurations already in f32 are copied).
    #[serde(default)]
    pub references_f32_seconds: f64,
    #[serde(default)]
    pub references_f32_evaluated: usize,
    pub search_seconds: f64,
    /// The disagreement search between compared pairs, and the candidates it evaluated.
    pub disagree_seconds: f64,
    pub disagree_evaluations: usize,
    pub cost_seconds: f64,
    /// The rule the cost pass stopped by, in words ([`COST_SETTLE`], its budget).
    #[serde(default)]
    pub cost_rule: String,
    /// The cost pass's budget in seconds (a share of the sweep's wall before it).
    #[serde(default)]
    pub cost_budget_seconds: f64,
    /// (method label, timed rounds, whether its timing stopped because it was settled).
    #[serde(default)]
    pub cost_rounds: Vec<(String, usize, bool)>,
    /// Folding each chunk into the statistics (`analysis::Accumulators::add`, by the app layer).
    pub statistics_seconds: f64,
    /// Drawing the configurations (natural sample and top-ups). A shard draws them all (the
    /// top-ups need the whole natural sample's bin counts) and measures its own: this is what
    /// that costs each shard.
    #[serde(default)]
    pub sampling_seconds: f64,
    /// Measuring chunks evaluated (of [`MEASURE_CHUNK`] configurations).
    pub chunks: usize,
    /// Shards merged into these times (0 or 1: one run). Merged, every time is the sum over
    /// the shards but the cost pass's, the attribution's and the envelope's: shard 0's.
    #[serde(default)]
    pub shards: usize,
    pub total_seconds: f64,
}

pub struct Measured {
    pub timing: Timing,
    /// The worst-case search's findings (cases with a `[search]`).
    pub found: Vec<crate::measure::search::Found>,
    /// Per compared pair, both ways: where one method is least accurate relative to the other.
    pub disagreements: Vec<crate::measure::search::Disagreement>,
    /// Each method's timing, raw: GPU timestamps, CPU f32 column, naga op count
    /// (src/measure/bench.rs); the analyse stage makes them costs.
    pub costs: Vec<crate::measure::bench::Times>,
    /// Where each method's f32 rounding loses bits, on a subset (src/eval/interp attribution).
    pub attribution: Vec<MethodAttribution>,
    /// The envelope on a subsample, when the case asks (`envelope = { sample = N }`).
    pub envelope: Vec<crate::measure::envelope::MethodEnvelope>,
    /// Configurations measured (natural and top-ups), and natural ones per family.
    pub configurations: usize,
    pub natural: Vec<usize>,
    /// Each family's draws, rejected ones included (shown in the report).
    pub draws: Vec<sampler::Draws>,
    /// What topping up thin bins did, per family.
    pub topups: Vec<sampler::TopUp>,
    /// The first [`NONFINITE_KEPT`] configurations on which some method returned NaN or ±inf,
    /// with those methods, and how many there were in all.
    pub nonfinite: Vec<(crate::input::scene::Config, Vec<String>)>,
    pub nonfinite_total: usize,
}

/// Configurations measured at a time: their GPU results, CPU columns and references are in
/// memory together, then folded into the statistics and dropped.
pub const MEASURE_CHUNK: usize = 1 << 16;

/// Configurations per block of the shard partition: shard i of n draws and evaluates the
/// blocks k ≡ i (mod n) of the natural sample's global order (family by family); the top-ups
/// are shared out bin by bin (`sampler::topup_plan`).
pub const SHARD_BLOCK: usize = sampler::SHARD_BLOCK;

/// Non-finite configurations kept for `nonfinite.jsonl` (the count is always complete).
pub const NONFINITE_KEPT: usize = 1000;

/// How a sweep measures: the GPU dispatch size, where `--raw` rows go, and which shard of the
/// configurations to evaluate.
pub struct MeasureOptions<'a> {
    /// Configurations per GPU dispatch (0: the runner's default).
    pub chunk: usize,
    /// `--raw`: every configuration's row (eval output format), written chunk by chunk.
    pub raw: Option<&'a mut dyn std::io::Write>,
    /// `--shard i/n`: evaluate only the configurations of global index g with
    /// ⌊g / SHARD_BLOCK⌋ mod n = i.
    pub shard: Option<(usize, usize)>,
}

/// One method's local f32 rounding error per kernel source line.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MethodAttribution {
    pub label: String,
    /// Configurations the attribution ran on (every k-th of those the method applies to).
    pub configurations: usize,
    /// Most bits first.
    pub lines: Vec<crate::eval::interp::LineSummary>,
}

impl Timing {
    /// Adds another shard's measuring and search times (the cost pass, the attribution and the
    /// envelope run in shard 0 alone: theirs stay).
    pub fn add(&mut self, o: &Timing) {
        self.configurations += o.configurations;
        for (a, b) in [(&mut self.gpu, &o.gpu)] {
            for (x, y) in a.iter_mut().zip(b) {
                x.1 += y.1;
            }
        }
        for (a, b) in [
            (&mut self.cpu_f64_seconds, &o.cpu_f64_seconds),
            (&mut self.cpu_f32_seconds, &o.cpu_f32_seconds),
        ] {
            for (x, y) in a.iter_mut().zip(b) {
                x.1 += y.1;
            }
        }
        self.references_seconds += o.references_seconds;
        self.references_evaluated += o.references_evaluated;
        self.references_f32_seconds += o.references_f32_seconds;
        self.references_f32_evaluated += o.references_f32_evaluated;
        self.statistics_seconds += o.statistics_seconds;
        self.sampling_seconds += o.sampling_seconds;
        // Each shard climbs its own starts (the timing of methods is shard 0's alone).
        self.search_seconds += o.search_seconds;
        self.disagree_seconds += o.disagree_seconds;
        self.disagree_evaluations += o.disagree_evaluations;
        self.chunks += o.chunks;
        self.total_seconds += o.total_seconds;
    }
}

/// Configurations per method for the attribution (a shadow f64 evaluation beside the f32
/// one costs about three plain evaluations; a spread subset keeps it to a fraction of a
/// second per method).
pub const ATTRIBUTION_CONFIGURATIONS: usize = 2048;

/// Attribution of every method on its spread subset of the configurations.
fn attribute(
    methods: &[Method],
    subsets: &[Vec<crate::input::scene::Config>],
) -> anyhow::Result<Vec<MethodAttribution>> {
    methods
        .iter()
        .zip(subsets)
        .map(|(m, configs)| {
            let subset: Vec<&crate::input::scene::Config> = configs.iter().collect();
            let a = crate::eval::interp::program(m)?.attribute(&subset)?;
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
/// Timed rounds the cost pass runs whatever its budget: enough for a median and a spread.
const COST_MIN_REPEATS: usize = 3;
/// The cost pass's budget as a share of the sweep's measuring wall before it.
const COST_SHARE: f64 = 0.1;
/// A method's timing is settled, and stops, when the largest of its per-round ratios CPU f32
/// ns / GPU ns is at most 1 + this times the smallest (`measure::bench::settled`).
const COST_SETTLE: f64 = 0.2;
/// Seconds one CPU-column run aims at (the interpreter is slow on the quadratures: a few
/// hundred configurations time it as well as 16384 do).
const COST_CPU_RUN_SECONDS: f64 = 0.05;

fn bar(len: usize, what: &str) -> ProgressBar {
    // A CI log gets a plain line every 10 s.
    crate::measure::progress::bar(len as u64, what)
}

/// The targets whose references a sweep needs: every method's, plus its surface view
/// (`line_upper` beside `line`, `cylinder_upper` beside `cylinder`, …): the headline judges
/// every method against what the surface receives, and the leak below the horizon is
/// reported from the two apart.
pub fn needed_targets(methods: &[Method]) -> BTreeSet<Target> {
    let mut t: BTreeSet<Target> = methods.iter().map(Method::target).collect();
    let upper: Vec<Target> = t.iter().filter_map(|t| t.upper()).collect();
    t.extend(upper);
    t
}

/// References for every configuration and target that applies to it, in parallel.
pub fn references(samples: &[crate::input::scene::Config], targets: &BTreeSet<Target>, pb: &ProgressBar) -> References {
    samples
        .par_iter()
        .map(|c| {
            let r: BTreeMap<Target, Estimate> = reference::references(c, targets);
            pb.inc(1);
            r
        })
        .collect()
}

/// What the measure stage keeps of a streamed sweep's configurations while they pass: bounded
/// state only (best starts, first non-finite ones, subsets; the gate's observations are the
/// app layer's).
/// Configurations are named by their global index (natural sample first, then top-ups), so
/// shards' states merge into what one run keeps.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Kept {
    /// Per `[search]` method (index into the methods) and family: the highest-error starts.
    search: Vec<(usize, usize, crate::measure::search::TopK)>,
    /// Per ordered compared pair (a, b) and family: the highest-ratio starts.
    disagree: Vec<(usize, usize, usize, crate::measure::search::TopK)>,
    nonfinite: Vec<(usize, crate::input::scene::Config, Vec<String>)>,
    nonfinite_total: usize,
    /// Per family: the first natural configurations (the cost measurement's).
    cost: Vec<Vec<(usize, crate::input::scene::Config)>>,
    /// Per method: its spread subset for the attribution (and the envelope's subsample), each
    /// configuration with its global index and the index of the material it was drawn for.
    attribution: Vec<Vec<Spread>>,
    natural: Vec<usize>,
    /// Configurations measured (this part's).
    seen: usize,
    /// Every `attribution_step`-th configuration (by global index) joins the attribution's
    /// subset; each family keeps its first `cost_limit` natural ones for the cost pass.
    attribution_step: usize,
    cost_limit: usize,
}

/// One configuration of a method's spread subset: its global index, the index of the material
/// (family) it was drawn for, and the configuration.
pub type Spread = (usize, usize, crate::input::scene::Config);

/// One measured chunk offered to the kept state (`Kept::add_chunk`; the analysis stage's
/// `Accumulate` for `Kept` folds it in).
#[derive(Clone, Copy)]
pub struct Keep<'a> {
    pub case: &'a Case,
    pub methods: &'a [Method],
    pub chunk: &'a MeasuredChunk<'a>,
}

impl Kept {
    /// Folds one measured chunk in (the best starts, the first non-finite configurations, the
    /// cost pass's and the attribution's subsets).
    pub fn add_chunk(&mut self, k: Keep) {
        let steps = (self.attribution_step, self.cost_limit);
        let c = k.chunk;
        keep(
            k.case,
            k.methods,
            (c.samples, c.global),
            c.references,
            c.runs,
            self,
            steps,
        );
    }

    /// Adds another part's state (other configurations of the same sweep).
    pub fn merge_from(&mut self, o: &Kept) {
        let o = o.clone();
        let per_family_cost = self.cost_limit;
        for (a, b) in self.search.iter_mut().zip(o.search) {
            crate::measure::search::TopK::merge_from(&mut a.2, &b.2);
        }
        for (a, b) in self.disagree.iter_mut().zip(o.disagree) {
            crate::measure::search::TopK::merge_from(&mut a.3, &b.3);
        }
        self.nonfinite.extend(o.nonfinite);
        self.nonfinite.sort_by_key(|x| x.0);
        self.nonfinite.truncate(NONFINITE_KEPT);
        self.nonfinite_total += o.nonfinite_total;
        let first = |a: &mut Vec<(usize, crate::input::scene::Config)>,
                     b: Vec<(usize, crate::input::scene::Config)>,
                     n: usize| {
            a.extend(b);
            a.sort_by_key(|x| x.0);
            a.truncate(n);
        };
        for (a, b) in self.cost.iter_mut().zip(o.cost) {
            first(a, b, per_family_cost);
        }
        for (a, b) in self.attribution.iter_mut().zip(o.attribution) {
            a.extend(b);
            a.sort_by_key(|x| x.0);
            a.truncate(ATTRIBUTION_CONFIGURATIONS);
        }
        for (a, b) in self.natural.iter_mut().zip(&o.natural) {
            *a += b;
        }
        self.seen += o.seen;
    }
}

/// One measured top-up configuration, kept whole until the run knows which top-ups it keeps:
/// a shard measures every top-up its own counts could call for (a superset of the unsharded
/// run's), and the merge keeps those the whole sample's counts call for (`settle_topups`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct TopUpRow {
    pub key: sampler::TopUpKey,
    /// Draws made for it (`sampler::top_up_one`).
    pub draws: usize,
    /// None when its draws ran out before one fell in its bin.
    pub measured: Option<Row>,
}

/// Everything the statistics and the kept state take from one configuration.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Row {
    pub sample: Sample,
    pub references: BTreeMap<Target, Estimate>,
    pub references_f32: BTreeMap<Target, Estimate>,
    /// Per method: GPU f32, CPU f32, CPU f64.
    pub f32: Vec<f32>,
    pub f32_cpu: Vec<Option<f32>>,
    pub f64: Vec<Option<f64>>,
}

/// What measuring a sweep's configurations, or one shard's, leaves before the searches and
/// the cost pass: the bounded kept state, the draws and times, and (until settled) the natural
/// counts and the measured top-ups; mergeable across shards.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Part {
    pub kept: Kept,
    pub draws: Vec<sampler::Draws>,
    /// Filled once the top-ups are settled.
    pub topups: Vec<sampler::TopUp>,
    pub timing: Timing,
    /// The natural sample's bin counts per family (this part's).
    pub counts: Vec<sampler::FamilyCounts>,
    /// Top-ups measured and not yet folded (a shard's superset).
    pub topup_rows: Vec<TopUpRow>,
    /// Per part merged: how many top-ups of each bin (`sampler::bin_ordinal`) it covered, its
    /// own j < cover[o] (those of its share).
    pub cover: Vec<Vec<usize>>,
    /// The searches' climbs from this part's starts ([`search_part`]).
    pub climbs: Climbs,
    /// The timing of methods, the attribution and the envelope ([`time_part`]): the
    /// unsharded run's, or shard 0's (the other shards have none).
    pub timed: Option<Timed>,
}

impl Part {
    /// Adds another part (other configurations of the same sweep); an `Err` when the two are
    /// not parts of one sweep's families.
    pub fn merge_from(&mut self, o: &Part) -> Result<(), String> {
        if self.draws.len() != o.draws.len() || self.counts.len() != o.counts.len() {
            return Err(format!(
                "parts of {} and {} families do not merge",
                self.draws.len(),
                o.draws.len()
            ));
        }
        self.kept.merge_from(&o.kept);
        self.timing.add(&o.timing);
        for (a, b) in self.draws.iter_mut().zip(&o.draws) {
            a.merge(b);
        }
        for (a, b) in self.counts.iter_mut().zip(&o.counts) {
            a.merge(b);
        }
        self.topup_rows.extend(o.topup_rows.iter().cloned());
        self.cover.extend(o.cover.iter().cloned());
        self.climbs.merge_from(&o.climbs)?;
        match (&self.timed, &o.timed) {
            (Some(a), Some(b)) => {
                return Err(format!(
                    "shards {}/{} and {}/{} both timed the methods; only shard 0 does",
                    a.shard.0, a.shard.1, b.shard.0, b.shard.1
                ))
            }
            (None, Some(b)) => self.timed = Some(b.clone()),
            _ => {}
        }
        Ok(())
    }

    /// Configurations measured.
    pub fn configurations(&self) -> usize {
        self.timing.configurations
    }
}

/// Seconds per method of each measuring column, added up over the chunks.
struct ColumnSeconds {
    gpu: Vec<f64>,
    f64: Vec<f64>,
    f32: Vec<f64>,
}

/// One chunk's configurations measured: every method on the GPU and in the CPU evaluator's
/// f64 and f32 columns, and the references (exact, and at the configuration rounded to f32).
fn measure_samples(
    setup: &Setup,
    gpu: &Gpu,
    (pipelines, chunk): (&[MethodPipeline], usize),
    samples: &[Sample],
    (timing, columns): (&mut Timing, &mut ColumnSeconds),
) -> anyhow::Result<(Vec<MethodRun>, References, References)> {
    let case = &setup.case;
    let targets = needed_targets(&setup.methods);
    let configs: Vec<_> = samples.iter().map(|s| s.config.clone()).collect();
    let (scenes, texels): (Vec<GpuScene>, _) = crate::input::scene::gpu_scenes(&configs);
    let mut runs = Vec::new();
    for (j, (m, pipeline)) in setup.methods.iter().zip(pipelines).enumerate() {
        let out = gpu.run_textured(pipeline, &scenes, &texels, chunk, &mut |_| {})?;
        columns.gpu[j] += out.wall.as_secs_f64();
        // The kernel's f64 and cpu_f32 columns, from the CPU evaluator.
        let t = Instant::now();
        let f64 = m.cpu_column_or_none(&configs, crate::eval::interp::Mode::F64);
        columns.f64[j] += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let f32_cpu: Vec<Option<f32>> = m
            .cpu_column_or_none(&configs, crate::eval::interp::Mode::F32)
            .into_iter()
            .map(|v| v.map(|x| x as f32))
            .collect();
        columns.f32[j] += t.elapsed().as_secs_f64();
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
        });
    }
    let t = Instant::now();
    let references = references(&configs, &targets, &ProgressBar::hidden());
    timing.references_seconds += t.elapsed().as_secs_f64();
    timing.references_evaluated += references.iter().map(BTreeMap::len).sum::<usize>();
    // A reference that cannot be computed is an error, never a NaN row in the report.
    crate::measure::eval_rows::check_references(
        std::path::Path::new(&format!("case `{}`", case.name)),
        &configs,
        &references,
    )?;
    let t = Instant::now();
    let references_f32: References = configs
        .par_iter()
        .zip(&references)
        .map(|(c, exact)| crate::measure::eval_rows::references_f32_inputs(c, &targets, exact))
        .collect();
    timing.references_f32_seconds += t.elapsed().as_secs_f64();
    timing.references_f32_evaluated += configs
        .iter()
        .zip(&references_f32)
        .filter(|(c, _)| c.rounded_to_f32() != **c)
        .map(|(_, r)| r.len())
        .sum::<usize>();
    timing.chunks += 1;
    timing.configurations += samples.len();
    Ok((runs, references, references_f32))
}

/// Every `k`-th configuration (by global index) joins the attribution's subset.
fn attribution_step(case: &Case) -> usize {
    let expected: usize = case.materials.iter().map(|m| m.count).sum();
    expected.div_ceil(ATTRIBUTION_CONFIGURATIONS).max(1)
}

/// Every method's GPU pipeline (with its loop-limit check), compiled once for the stages
/// that share it: measuring, the searches and the cost pass.
pub fn pipelines(gpu: &Gpu, methods: &[Method]) -> anyhow::Result<Vec<MethodPipeline>> {
    methods.iter().map(|m| Ok(gpu.pipeline(m)?)).collect()
}

/// Measures the configurations (all, or one shard's) chunk by chunk into a [`Part`], handing
/// each measured chunk to `fold` before it is dropped. A shard draws only its own blocks of
/// the natural sample, and measures the top-ups of its share that its own counts could call
/// for, kept whole in the part until the merge settles them ([`settle_topups`]); an unsharded
/// run settles them at once, through the same code.
pub fn measure_chunks(
    setup: &Setup,
    gpu: &Gpu,
    options: MeasureOptions,
    fold: &mut dyn FnMut(&MeasuredChunk) -> anyhow::Result<()>,
) -> anyhow::Result<Part> {
    let MeasureOptions { chunk, mut raw, shard } = options;
    let start = Instant::now();
    let case = &setup.case;
    let methods = &setup.methods;
    // Compile every pipeline first: a kernel error stops the sweep before any work.
    let pipelines = pipelines(gpu, methods)?;
    let families = case.materials.len();
    let mut timing = Timing {
        adapter: gpu.adapter.to_string(),
        ..Timing::default()
    };
    let index = |l: &String| methods.iter().position(|m| &m.label == l).expect("case checked labels");
    let restarts = case.search.as_ref().map_or(0, |s| s.restarts);
    let disagree_spec = case.disagreements.clone().unwrap_or_default();
    let expected: usize = case.materials.iter().map(|m| m.count).sum();
    // Shard 0 attributes its own share of the subset (docs/scale.md): every (step / N)-th of
    // its configurations by global index, about as many as the unsharded run's.
    let attribution_step = (attribution_step(case) / shard.map_or(1, |s| s.1)).max(1);
    let per_family_cost = COST_CONFIGURATIONS.div_ceil(families.max(1));
    let mut kept = Kept {
        search: case
            .search
            .iter()
            .flat_map(|s| s.methods.iter().map(&index))
            .flat_map(|m| (0..families).map(move |f| (m, f, crate::measure::search::TopK::new(restarts))))
            .collect(),
        disagree: case
            .compare
            .iter()
            .flat_map(|[a, b]| [(index(a), index(b)), (index(b), index(a))])
            .flat_map(|(a, b)| {
                (0..families).map(move |f| (a, b, f, crate::measure::search::TopK::new(disagree_spec.restarts)))
            })
            .collect(),
        nonfinite: Vec::new(),
        nonfinite_total: 0,
        cost: vec![Vec::new(); families],
        attribution: vec![Vec::new(); methods.len()],
        natural: vec![0; families],
        seen: 0,
        attribution_step,
        cost_limit: per_family_cost,
    };
    let part_of = shard.unwrap_or((0, 1));
    let mut stream = sampler::NaturalStream::sharded(case, part_of);
    let pb = bar(expected / part_of.1, "measuring (GPU, CPU, references)");
    let mut columns = ColumnSeconds {
        gpu: vec![0.0; methods.len()],
        f64: vec![0.0; methods.len()],
        f32: vec![0.0; methods.len()],
    };
    loop {
        // This shard's blocks of the natural sample, a chunk at a time.
        let t = Instant::now();
        let drawn = stream
            .next_indexed(MEASURE_CHUNK)
            .map_err(|e| anyhow::anyhow!("case `{}`: {e}", case.name))?;
        timing.sampling_seconds += t.elapsed().as_secs_f64();
        if drawn.is_empty() {
            break;
        }
        let (global, samples): (Vec<usize>, Vec<Sample>) = drawn.into_iter().unzip();
        let (runs, references, references_f32) =
            measure_samples(setup, gpu, (&pipelines, chunk), &samples, (&mut timing, &mut columns))?;
        fold(&MeasuredChunk {
            samples: &samples,
            global: &global,
            references: &references,
            references_f32: &references_f32,
            runs: &runs,
        })?;
        kept.add_chunk(Keep {
            case,
            methods,
            chunk: &MeasuredChunk {
                samples: &samples,
                global: &global,
                references: &references,
                references_f32: &references_f32,
                runs: &runs,
            },
        });
        if let Some(w) = raw.as_mut() {
            write_raw(*w, setup, &samples, (&references, &references_f32), &runs)?;
        }
        pb.inc(samples.len() as u64);
    }
    // The top-ups this part's counts could call for, of its share: exactly the unsharded
    // run's when unsharded, a superset of its share otherwise (a shard's counts are at most
    // the whole sample's).
    let t = Instant::now();
    let needs = sampler::topup_needs(case, &stream.counts);
    let drawn: Vec<(sampler::TopUpKey, (usize, Option<Sample>))> = sampler::draw_topups(case, &needs, part_of)
        .into_iter()
        .map(|(k, d, s)| (k, (d, s)))
        .collect();
    timing.sampling_seconds += t.elapsed().as_secs_f64();
    let mut topup_rows = Vec::with_capacity(drawn.len());
    let mut pending: Vec<(sampler::TopUpKey, usize, Sample)> = Vec::new();
    let mut drawn = drawn.into_iter().peekable();
    while drawn.peek().is_some() || !pending.is_empty() {
        for (key, (draws, s)) in drawn.by_ref() {
            match s {
                Some(s) => pending.push((key, draws, s)),
                None => topup_rows.push(TopUpRow {
                    key,
                    draws,
                    measured: None,
                }),
            }
            if pending.len() == MEASURE_CHUNK {
                break;
            }
        }
        if pending.is_empty() {
            break;
        }
        let samples: Vec<Sample> = pending.iter().map(|(_, _, s)| s.clone()).collect();
        let (runs, references, references_f32) =
            measure_samples(setup, gpu, (&pipelines, chunk), &samples, (&mut timing, &mut columns))?;
        for (i, ((key, draws, sample), (r, r32))) in pending
            .drain(..)
            .zip(references.into_iter().zip(references_f32))
            .enumerate()
        {
            topup_rows.push(TopUpRow {
                key,
                draws,
                measured: Some(Row {
                    sample,
                    references: r,
                    references_f32: r32,
                    f32: runs.iter().map(|m| m.f32[i]).collect(),
                    f32_cpu: runs.iter().map(|m| m.f32_cpu[i]).collect(),
                    f64: runs.iter().map(|m| m.f64[i]).collect(),
                }),
            });
        }
        pb.inc(samples.len() as u64);
    }
    pb.finish_and_clear();
    for (j, m) in methods.iter().enumerate() {
        timing.gpu.push((m.label.clone(), columns.gpu[j], 0.0));
        timing.cpu_f64_seconds.push((m.label.clone(), columns.f64[j]));
        timing.cpu_f32_seconds.push((m.label.clone(), columns.f32[j]));
        let engines = crate::eval::interp::program(m).map_or_else(|e| format!("none ({e:#})"), |p| p.engines());
        timing.cpu_engines.push((m.label.clone(), engines));
    }
    timing.total_seconds = start.elapsed().as_secs_f64();
    let mut part = Part {
        kept,
        draws: stream.draws,
        topups: Vec::new(),
        timing,
        counts: stream.counts,
        topup_rows,
        cover: vec![needs],
        climbs: Climbs::default(),
        timed: None,
    };
    if shard.is_none() {
        settle_topups(setup, &mut part, fold, raw)?;
    }
    Ok(part)
}

/// Keeps the top-ups the whole natural sample calls for, and folds them in: from the merged
/// counts c_b, bin b keeps its top-ups j < T_b = min_per_bin − c_b (each part measured its own
/// share of j < min_per_bin − c_b^part ≥ T_b) in the unsharded order (family, axis, bin, j),
/// numbered after the natural sample; the rest is dropped. Then the part holds what the
/// unsharded run's holds.
pub fn settle_topups(
    setup: &Setup,
    part: &mut Part,
    fold: &mut dyn FnMut(&MeasuredChunk) -> anyhow::Result<()>,
    mut raw: Option<&mut dyn std::io::Write>,
) -> anyhow::Result<()> {
    let case = &setup.case;
    for (d, m) in part.draws.iter().zip(&case.materials) {
        d.check(m.count)
            .map_err(|e| anyhow::anyhow!("case `{}`: {e}", case.name))?;
    }
    let needs = sampler::topup_needs(case, &part.counts);
    let parts = part.cover.len();
    for (k, cover) in part.cover.iter().enumerate() {
        if let Some(o) = (0..needs.len()).find(|&o| cover.get(o).copied().unwrap_or(0) < needs[o]) {
            anyhow::bail!(
                "case `{}`: part {k} of {parts} drew {} top-ups of bin {o}, and the whole sample's counts call for {}: \
                 its counts were not a part of these (re-run the shards with this linelight)",
                case.name,
                cover.get(o).copied().unwrap_or(0),
                needs[o]
            );
        }
    }
    let mut rows: Vec<TopUpRow> = std::mem::take(&mut part.topup_rows)
        .into_iter()
        .filter(|r| r.key.j < needs[sampler::bin_ordinal(case, r.key.family, r.key.axis, r.key.bin)])
        .collect();
    rows.sort_by_key(|r| r.key);
    let done: Vec<(sampler::TopUpKey, usize, bool)> =
        rows.iter().map(|r| (r.key, r.draws, r.measured.is_some())).collect();
    part.topups = sampler::topup_reports(case, &part.counts, &done);
    part.cover = Vec::new();
    let natural: usize = case.materials.iter().map(|m| m.count).sum();
    let mut measured = rows.into_iter().filter_map(|r| r.measured).enumerate().peekable();
    while measured.peek().is_some() {
        let chunk: Vec<(usize, Row)> = measured.by_ref().take(MEASURE_CHUNK).collect();
        let global: Vec<usize> = chunk.iter().map(|(rank, _)| natural + rank).collect();
        let mut samples = Vec::with_capacity(chunk.len());
        let (mut references, mut references_f32) = (Vec::new(), Vec::new());
        let mut runs: Vec<MethodRun> = setup
            .methods
            .iter()
            .map(|m| MethodRun {
                method: m.clone(),
                f32: Vec::new(),
                f32_cpu: Vec::new(),
                f64: Vec::new(),
            })
            .collect();
        for (_, row) in chunk {
            for (j, run) in runs.iter_mut().enumerate() {
                run.f32.push(row.f32[j]);
                run.f32_cpu.push(row.f32_cpu[j]);
                run.f64.push(row.f64[j]);
            }
            samples.push(row.sample);
            references.push(row.references);
            references_f32.push(row.references_f32);
        }
        fold(&MeasuredChunk {
            samples: &samples,
            global: &global,
            references: &references,
            references_f32: &references_f32,
            runs: &runs,
        })?;
        part.kept.add_chunk(Keep {
            case,
            methods: &setup.methods,
            chunk: &MeasuredChunk {
                samples: &samples,
                global: &global,
                references: &references,
                references_f32: &references_f32,
                runs: &runs,
            },
        });
        if let Some(w) = raw.as_mut() {
            write_raw(*w, setup, &samples, (&references, &references_f32), &runs)?;
        }
    }
    Ok(())
}

/// The searches' climbs of one part: per `[search]` method and family, and per ordered compared
/// pair and family (in `Kept`'s order), one climb per start the part climbed.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Climbs {
    pub search: Vec<Vec<crate::measure::search::Climbed>>,
    pub disagree: Vec<Vec<crate::measure::search::Climbed>>,
}

impl Climbs {
    /// Adds another part's climbs (of other starts).
    fn merge_from(&mut self, o: &Climbs) -> Result<(), String> {
        if self.search.len() != o.search.len() || self.disagree.len() != o.disagree.len() {
            return Err("parts of different searches do not merge".to_string());
        }
        for (a, b) in self.search.iter_mut().zip(&o.search) {
            a.extend(b.iter().cloned());
        }
        for (a, b) in self.disagree.iter_mut().zip(&o.disagree) {
            a.extend(b.iter().cloned());
        }
        Ok(())
    }
}

/// What timing the methods measured, with the attribution and the envelope: run once per
/// sweep, by the unsharded run or by shard 0 of a sharded one (`shard`, (0, 1) unsharded).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Timed {
    pub shard: (usize, usize),
    pub costs: Vec<crate::measure::bench::Times>,
    pub attribution: Vec<MethodAttribution>,
    pub envelope: Vec<crate::measure::envelope::MethodEnvelope>,
}

/// The starts a part climbs for one search: its own best starts and, in a shard whose top-ups
/// are not settled yet, each measured top-up that could be among the whole sample's best:
/// fewer than `k` of the starts certain to be in the whole sample beside it (the part's own
/// natural ones, and the top-ups of its bin before it, which are kept whenever it is) score at
/// least as much (ties go to the lower global index, and those have it). So the parts'
/// climbs hold the climb of every start of the whole sample's best, whichever top-ups the
/// merge keeps.
fn starts_to_climb(
    top: &crate::measure::search::TopK,
    rows: &[&TopUpRow],
    start: &dyn Fn(&Row) -> Option<crate::measure::search::Start>,
) -> Vec<crate::measure::search::Start> {
    let k = top.k();
    let mut out = top.clone().into_sorted();
    if k == 0 {
        return out;
    }
    // Rows in key order (family, axis, bin, j): a bin's earlier top-ups come first.
    let mut seen: Vec<(sampler::TopUpKey, f64)> = Vec::new();
    for r in rows {
        let Some(s) = r.measured.as_ref().and_then(start) else {
            continue;
        };
        let same_bin = |x: &sampler::TopUpKey| (x.family, x.axis, x.bin) == (r.key.family, r.key.axis, r.key.bin);
        let before = seen.iter().filter(|(x, sc)| same_bin(x) && *sc >= s.score).count();
        seen.push((r.key, s.score));
        if top.at_least(s.score) + before < k {
            out.push(s);
        }
    }
    out
}

/// The searches' climbs from the part's starts (the worst-case search and the disagreements),
/// on the GPU: each start climbs alike wherever it runs, so the merge takes the climbs of the
/// whole sample's best starts from the shards that measured them.
pub fn search_part(setup: &Setup, gpu: &Gpu, pipelines: &[MethodPipeline], part: &mut Part) -> anyhow::Result<()> {
    use crate::measure::search::{disagreement_ratio, rel_error, Start};
    let started = Instant::now();
    let case = &setup.case;
    let methods = &setup.methods;
    let mut rows: Vec<&TopUpRow> = part.topup_rows.iter().collect();
    rows.sort_by_key(|r| r.key);
    let mut climbs = Climbs::default();
    if let Some(spec) = &case.search {
        let t = Instant::now();
        let pb = bar(part.kept.search.len(), "worst-case search");
        for (m, family, top) in &part.kept.search {
            let method = &methods[*m];
            let start = |row: &Row| -> Option<Start> {
                let c = &row.sample.config;
                if row.sample.material != *family || !(method.applies(c) && method.supports(c)) {
                    return None;
                }
                let reference = *row.references.get(&method.target())?;
                let score = rel_error(row.f32[*m], &reference)?;
                Some(Start {
                    sample: row.sample.clone(),
                    values: vec![row.f32[*m]],
                    reference,
                    score,
                })
            };
            let starts = starts_to_climb(top, &rows, &start);
            climbs.search.push(crate::measure::search::search_climbs(
                case,
                spec,
                starts,
                method,
                (gpu, &pipelines[*m]),
                *family,
            )?);
            pb.inc(1);
        }
        pb.finish_and_clear();
        part.timing.search_seconds += t.elapsed().as_secs_f64();
    }
    let disagree_spec = case.disagreements.clone().unwrap_or_default();
    if !case.compare.is_empty() {
        let t = Instant::now();
        let pb = bar(part.kept.disagree.len(), "disagreement search");
        for (a, b, family, top) in &part.kept.disagree {
            let (ma, mb) = (&methods[*a], &methods[*b]);
            let start = |row: &Row| -> Option<Start> {
                let c = &row.sample.config;
                if row.sample.material != *family
                    || !(ma.applies(c) && mb.applies(c) && ma.supports(c) && mb.supports(c))
                {
                    return None;
                }
                let reference = *row.references.get(&ma.target())?;
                let (va, vb) = (row.f32[*a], row.f32[*b]);
                let score = disagreement_ratio(
                    rel_error(va, &reference)?,
                    rel_error(vb, &reference)?,
                    disagree_spec.epsilon,
                );
                Some(Start {
                    sample: row.sample.clone(),
                    values: vec![va, vb],
                    reference,
                    score,
                })
            };
            let starts = starts_to_climb(top, &rows, &start);
            let climbed = crate::measure::search::disagreement_climbs(
                case,
                &disagree_spec,
                starts,
                gpu,
                (ma, &pipelines[*a]),
                (mb, &pipelines[*b]),
                *family,
            )?;
            part.timing.disagree_evaluations += climbed.iter().map(|c| c.evaluations).sum::<usize>();
            climbs.disagree.push(climbed);
            pb.inc(1);
        }
        pb.finish_and_clear();
        part.timing.disagree_seconds += t.elapsed().as_secs_f64();
    }
    part.climbs = climbs;
    part.timing.total_seconds += started.elapsed().as_secs_f64();
    Ok(())
}

/// The cost pass (the timing of methods), the attribution and the envelope, on the GPU: run
/// once per sweep, by the unsharded run or by shard 0 (`shard`), on the part's own kept
/// configurations.
pub fn time_part(
    setup: &Setup,
    gpu: &Gpu,
    pipelines: &[MethodPipeline],
    part: &mut Part,
    shard: (usize, usize),
) -> anyhow::Result<()> {
    let start = Instant::now();
    let case = &setup.case;
    let methods = &setup.methods;
    let (kept, timing) = (&part.kept, &mut part.timing);
    // Cost: the first configurations of every family, each method timed in interleaved rounds.
    let t = Instant::now();
    let cost_configs: Vec<_> = kept.cost.iter().flatten().map(|(_, c)| c.clone()).collect();
    let pb = bar(methods.len() * (COST_WARMUP + COST_REPEATS), "cost (GPU timestamps)");
    // Timing costs what it needs: at most about a tenth of the sweep's wall so far,
    // after COST_MIN_REPEATS rounds, and the CPU column on a subset sized to a short run.
    let so_far = timing.total_seconds + start.elapsed().as_secs_f64();
    let rounds = crate::measure::bench::Rounds {
        warmup: COST_WARMUP,
        repeats: COST_REPEATS,
        min_repeats: COST_MIN_REPEATS,
        budget: Some(std::time::Duration::from_secs_f64(so_far * COST_SHARE)),
        cpu_run_seconds: Some(COST_CPU_RUN_SECONDS),
        envelope: None,
        beside_interpreter: false,
        settle: Some(COST_SETTLE),
    };
    timing.cost_budget_seconds = so_far * COST_SHARE;
    timing.cost_rule = format!(
        "each method timed in interleaved rounds after {COST_WARMUP} warm-up rounds, at least {COST_MIN_REPEATS} and at \
         most {COST_REPEATS} timed rounds; a method stops once settled: the largest of its per-round ratios CPU f32 ns \
         / GPU ns (of its GPU ns without a CPU column) at most {:.0} % above the smallest (over k rounds that range \
         covers the median with probability 1 − 2^(1−k): 75 % at 3, 97 % at 6); every method stops once the pass \
         has taken its budget, {:.0} % of the {} wall before it ({:.2} s)",
        COST_SETTLE * 100.0,
        COST_SHARE * 100.0,
        if shard.1 > 1 { "shard's" } else { "sweep's" },
        timing.cost_budget_seconds
    );
    let costs = crate::measure::bench::bench_methods_with(gpu, methods, &cost_configs, rounds, &mut |done, total| {
        pb.set_length(total as u64);
        pb.set_position(done as u64)
    })?;
    pb.finish_and_clear();
    timing.cost_seconds = t.elapsed().as_secs_f64();
    timing.cost_rounds = costs.iter().map(|c| (c.label.clone(), c.repeats, c.settled)).collect();
    let t = Instant::now();
    let subsets: Vec<Vec<crate::input::scene::Config>> = kept
        .attribution
        .iter()
        .map(|s| s.iter().map(|(_, _, c)| c.clone()).collect())
        .collect();
    let attribution = attribute(methods, &subsets)?;
    timing.attribution_seconds = t.elapsed().as_secs_f64();
    let envelope = match &case.envelope {
        Some(spec) => crate::measure::envelope::any_driver(methods, &kept.attribution, spec.sample, (gpu, pipelines))?,
        None => Vec::new(),
    };
    timing.total_seconds += start.elapsed().as_secs_f64();
    part.timed = Some(Timed {
        shard,
        costs,
        attribution,
        envelope,
    });
    Ok(())
}

/// A measured sweep from a settled part (the whole run's, or the shards' merged): the searches'
/// findings from the whole sample's best starts and their climbs, the timing of methods from
/// the part that timed them. No GPU: this is all a merge computes beyond the statistics.
pub fn assemble(setup: &Setup, part: Part) -> anyhow::Result<Measured> {
    let case = &setup.case;
    let methods = &setup.methods;
    let Part {
        kept,
        draws,
        topups: topup_reports,
        mut timing,
        climbs,
        timed,
        ..
    } = part;
    let timed = timed.ok_or_else(|| {
        anyhow::anyhow!(
            "case `{}`: no part timed the methods (shard 0 does): re-run shard 0 with this linelight",
            case.name
        )
    })?;
    for g in &mut timing.gpu {
        g.2 = timing.configurations as f64 / g.1;
    }
    anyhow::ensure!(
        climbs.search.len() == kept.search.len() && climbs.disagree.len() == kept.disagree.len(),
        "case `{}`: the parts' searches are not the case's (re-run the shards with this linelight)",
        case.name
    );
    let mut found = Vec::new();
    if let Some(spec) = &case.search {
        for ((m, family, starts), climbed) in kept.search.into_iter().zip(&climbs.search) {
            found.extend(crate::measure::search::search(
                case,
                spec,
                starts.into_sorted(),
                &methods[m].label,
                climbed,
                family,
            )?);
        }
    }
    let disagree_spec = case.disagreements.clone().unwrap_or_default();
    let mut disagreements = Vec::new();
    for ((a, b, family, starts), climbed) in kept.disagree.into_iter().zip(&climbs.disagree) {
        disagreements.extend(crate::measure::search::disagreements(
            case,
            &disagree_spec,
            starts.into_sorted(),
            (&methods[a].label, &methods[b].label),
            climbed,
            family,
        )?);
    }
    Ok(Measured {
        timing,
        found,
        disagreements,
        costs: timed.costs,
        attribution: timed.attribution,
        envelope: timed.envelope,
        configurations: kept.seen,
        natural: kept.natural,
        draws,
        topups: topup_reports,
        nonfinite: kept.nonfinite.into_iter().map(|(_, c, m)| (c, m)).collect(),
        nonfinite_total: kept.nonfinite_total,
    })
}

/// The searches from the kept starts, the cost pass and the attribution: a measured sweep.
pub fn search_and_cost(setup: &Setup, gpu: &Gpu, mut part: Part) -> anyhow::Result<Measured> {
    let pipelines = pipelines(gpu, &setup.methods)?;
    search_part(setup, gpu, &pipelines, &mut part)?;
    time_part(setup, gpu, &pipelines, &mut part, (0, 1))?;
    assemble(setup, part)
}

/// Folds one chunk into the bounded per-configuration state.
fn keep(
    case: &Case,
    methods: &[Method],
    (samples, global): (&[Sample], &[usize]),
    references: &References,
    runs: &[MethodRun],
    kept: &mut Kept,
    (attribution_step, per_family_cost): (usize, usize),
) {
    use crate::measure::search::{disagreement_ratio, rel_error, Start};
    let eps = case.disagreements.clone().unwrap_or_default().epsilon;
    for (i, s) in samples.iter().enumerate() {
        let c = &s.config;
        let f = s.material;
        let global = global[i];
        kept.seen += 1;
        for (m, family, top) in &mut kept.search {
            let method = &methods[*m];
            if *family != f || !(method.applies(c) && method.supports(c)) {
                continue;
            }
            let Some(r) = references[i].get(&method.target()) else {
                continue;
            };
            if let Some(score) = rel_error(runs[*m].f32[i], r).filter(|&x| top.wants(x)) {
                top.push(
                    global,
                    Start {
                        sample: s.clone(),
                        values: vec![runs[*m].f32[i]],
                        reference: *r,
                        score,
                    },
                );
            }
        }
        for (a, b, family, top) in &mut kept.disagree {
            let (ma, mb) = (&methods[*a], &methods[*b]);
            if *family != f || !(ma.applies(c) && mb.applies(c) && ma.supports(c) && mb.supports(c)) {
                continue;
            }
            let Some(r) = references[i].get(&ma.target()) else {
                continue;
            };
            let (va, vb) = (runs[*a].f32[i], runs[*b].f32[i]);
            let score = rel_error(va, r)
                .zip(rel_error(vb, r))
                .map(|(x, y)| disagreement_ratio(x, y, eps));
            if let Some(score) = score.filter(|&x| top.wants(x)) {
                top.push(
                    global,
                    Start {
                        sample: s.clone(),
                        values: vec![va, vb],
                        reference: *r,
                        score,
                    },
                );
            }
        }
        let bad: Vec<String> = runs
            .iter()
            .filter(|r| r.method.applies(c) && !r.f32[i].is_finite())
            .map(|r| r.method.label.clone())
            .collect();
        if !bad.is_empty() {
            kept.nonfinite_total += 1;
            if kept.nonfinite.len() < NONFINITE_KEPT {
                kept.nonfinite.push((global, c.clone(), bad));
            }
        }
        if global.is_multiple_of(attribution_step) {
            for (subset, m) in kept.attribution.iter_mut().zip(methods) {
                if m.applies(c) && subset.len() < ATTRIBUTION_CONFIGURATIONS {
                    subset.push((global, f, c.clone()));
                }
            }
        }
        if !s.natural() {
            continue;
        }
        kept.natural[f] += 1;
        if kept.cost[f].len() < per_family_cost {
            kept.cost[f].push((global, c.clone()));
        }
    }
}

/// `--raw` rows of one chunk (the eval output format plus material, axes, strata, config).
fn write_raw(
    w: &mut dyn std::io::Write,
    setup: &Setup,
    samples: &[Sample],
    (references, references_f32): (&References, &References),
    runs: &[MethodRun],
) -> anyhow::Result<()> {
    let rows: Vec<_> = samples
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let f32s: Vec<f32> = runs.iter().map(|r| r.f32[i]).collect();
            let f64s: Vec<Option<f64>> = runs.iter().map(|r| r.f64[i]).collect();
            let c32s: Vec<Option<f64>> = runs.iter().map(|r| r.f32_cpu[i].map(f64::from)).collect();
            let mut row = crate::measure::eval_rows::result_row(
                &s.config,
                &references[i],
                Some(&references_f32[i]),
                &setup.methods,
                &f32s,
                &f64s,
                &c32s,
            );
            row["material"] = setup.case.materials[s.material].name.clone().into();
            row["axes"] = serde_json::to_value(&s.axes).expect("axes serialise");
            // Empty for the natural sample; a top-up lists the (axis, bin) it fills.
            row["strata"] = serde_json::to_value(&s.strata).expect("strata serialise");
            row["config"] = serde_json::to_value(&s.config).expect("config serialises");
            row
        })
        .collect();
    w.write_all(&crate::io::to_jsonl(&rows))?;
    Ok(())
}

/// `--shard I/N`: shard I (from 0) of N.
pub fn parse_shard(text: &str) -> anyhow::Result<(usize, usize)> {
    let bad = || anyhow::anyhow!("--shard `{text}`: write I/N with 0 ≤ I < N, e.g. 0/4");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::search::{Start, TopK};

    /// A case of one family, drawn: distinct samples to stand for starts.
    fn samples(n: usize) -> Vec<Sample> {
        let case = crate::input::case::Case::parse(
            "t.toml",
            &format!(
                r#"
name = "t"
title = "t"
seed = 1
methods = ["line.ltc2017"]
[geometry]
elevation = {{ dist = "uniform", min = 10.0, max = 90.0 }}
tilt_angle = {{ dist = "uniform", min = 0.0, max = 180.0 }}
length = {{ dist = "log_uniform", min = 0.1, max = 10.0 }}
center = {{ dist = "uniform", min = -2.0, max = 2.0 }}
[[materials]]
name = "d"
kind = "diffuse"
count = {n}
"#
            ),
        )
        .unwrap();
        crate::input::sampler::sample_case(&case)
    }

    fn start(sample: &Sample, score: f64) -> Start {
        Start {
            sample: sample.clone(),
            values: vec![0.0],
            reference: crate::reference::Estimate { value: 1.0, error: 0.0 },
            score,
        }
    }

    fn row(sample: &Sample, bin: usize, j: usize, score: f64) -> TopUpRow {
        TopUpRow {
            key: sampler::TopUpKey {
                family: 0,
                axis: 0,
                bin,
                j,
            },
            draws: 1,
            measured: Some(Row {
                sample: sample.clone(),
                references: BTreeMap::new(),
                references_f32: BTreeMap::new(),
                // The score stands in the f32 column.
                f32: vec![score as f32],
                f32_cpu: vec![None],
                f64: vec![None],
            }),
        }
    }

    /// A shard climbs its own best natural starts and every measured top-up that fewer than k
    /// of the starts certain to be in the whole sample beside it (its natural ones, the earlier
    /// top-ups of its bin) outscore, ties counting against the top-up (the lower global index
    /// wins a tie).
    #[test]
    fn a_shard_climbs_every_top_up_that_could_be_among_the_best() {
        let s = samples(9);
        let mut top = TopK::new(2);
        top.push(0, start(&s[0], 5.0));
        top.push(1, start(&s[1], 3.0));
        top.push(2, start(&s[2], 1.0));
        let rows = [
            row(&s[3], 0, 0, 4.0), // one natural above: climbed
            row(&s[4], 0, 1, 3.5), // the natural 5 and the top-up 4 before it: not
            row(&s[5], 0, 2, 6.0), // none above: climbed
            row(&s[6], 1, 0, 3.0), // ties the natural 3, which wins the tie: with 5, two: not
            row(&s[7], 1, 1, 4.5), // the 5 only (bin 0's top-ups need not be kept): climbed
            row(&s[8], 1, 2, 0.5), // below two naturals: not
        ];
        let refs: Vec<&TopUpRow> = rows.iter().collect();
        let scored = |r: &Row| Some(start(&r.sample, r.f32[0] as f64));
        let climbed: Vec<f64> = starts_to_climb(&top, &refs, &scored)
            .into_iter()
            .map(|x| x.score)
            .collect();
        assert_eq!(climbed, [5.0, 3.0, 4.0, 6.0, 4.5]);
        // No start kept at all: nothing climbs.
        assert!(starts_to_climb(&TopK::new(0), &refs, &scored).is_empty());
    }
}

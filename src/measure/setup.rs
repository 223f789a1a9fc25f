//! A run's setup, before the GPU is touched: the case with `--count` applied, its methods
//! resolved (the case's and every `--kernel` file's), the compared pairs checked, and, for
//! the runs that hold every configuration (bench), the whole sample drawn. Also the sizes its
//! memory budget is made of ([`run_size`]; the bytes are `limits::run_budget`'s).

use super::sweep::Setup;
use crate::input::case::Case;
use anyhow::Context;
use std::path::PathBuf;

/// What a run holds beside one measuring chunk and the statistics, for its memory estimate.
#[derive(Clone, Copy, Debug, Default)]
pub struct Holds {
    /// `--raw` rows are written (a chunk's at a time).
    pub raw: bool,
    /// Every natural configuration's observation is kept (the gate's baseline, `diff`).
    pub observations: bool,
    /// Every configuration is drawn up front ([`draw_all`]: bench).
    pub all_samples: bool,
}

/// Loads and checks everything a sweep needs, without touching the GPU (the `--kernel` files'
/// `#include`s search `includes`). Nothing is sampled here (a streamed sweep draws chunk by
/// chunk): `samples`, `draws` and `topups` stay empty.
pub fn resolve(
    case: Case,
    user_kernels: &[PathBuf],
    includes: &crate::kernel::Includes,
    count: Option<usize>,
) -> anyhow::Result<Setup> {
    let mut case = case;
    if let Some(n) = count {
        crate::limits::check_count("--count", n as u64).map_err(anyhow::Error::msg)?;
        // The bins' minimum shrinks with the counts, so a quick run stays quick.
        let largest = case.materials.iter().map(|m| m.count).max().unwrap_or(1).max(1);
        let scale = |min: usize| min.saturating_mul(n).div_ceil(largest).min(min);
        case.min_per_bin = scale(case.min_per_bin);
        for b in case.bins.iter_mut() {
            if let Some(min) = b.min_per_bin.as_mut() {
                *min = scale(*min);
            }
        }
        for m in &mut case.materials {
            m.count = n;
        }
    }
    let kernels = crate::kernel::methods::kernel_set(user_kernels, includes)?;
    let mut methods = Vec::new();
    for spec in &case.methods {
        methods.push(crate::kernel::methods::resolve(spec, &kernels).with_context(|| format!("case `{}`", case.name))?);
    }
    // `--kernel FILE`: the case's methods plus every kernel given (unless the case names it).
    for path in user_kernels {
        let k = crate::kernel::KernelFile::read(path, includes)?;
        if !methods.iter().any(|m| m.id() == k.id) {
            methods.push(crate::kernel::methods::resolve(&k.id, &kernels)?);
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
    Ok(Setup {
        case,
        methods,
        samples: Vec::new(),
        topups: Vec::new(),
        count_override: count,
        draws: Vec::new(),
    })
}

/// Draws the whole sample, natural configurations and top-ups, into `setup.samples` (bench
/// and others that hold every configuration).
pub fn draw_all(setup: &mut Setup) -> anyhow::Result<()> {
    let (mut samples, draws) = crate::input::sampler::sample_case_counted(&setup.case)
        .map_err(|e| anyhow::anyhow!("case `{}`: {e}", setup.case.name))?;
    let (extra, topups) = crate::input::sampler::top_up(&setup.case, &samples);
    samples.extend(extra);
    setup.samples = samples;
    setup.draws = draws;
    setup.topups = topups;
    Ok(())
}

/// (natural, natural and top-up) configurations a run of the case may measure: a family's
/// top-ups fill its bins to `min_per_bin`, within `topup_draws` times its count.
pub fn configurations(case: &Case) -> (u64, u64) {
    let wanted: u64 = case
        .bins
        .iter()
        .map(|b| (b.edges.len().saturating_sub(1) as u64).saturating_mul(b.min_per_bin(case.min_per_bin) as u64))
        .sum();
    case.materials.iter().fold((0u64, 0u64), |(n, t), m| {
        let count = m.count as u64;
        let topups = wanted.min(count.saturating_mul(case.topup_draws as u64));
        (n.saturating_add(count), t.saturating_add(count).saturating_add(topups))
    })
}

/// The sizes of a sweep's memory (and of merge, diff and bench, which run its stages): its
/// configurations, methods, light textures, searches and what it `holds`, with the size of
/// the statistics it folds into (the analysis's own count).
pub fn run_size(setup: &Setup, holds: Holds, statistics: crate::limits::StatisticsSize) -> crate::limits::RunSize {
    let case = &setup.case;
    let (naturals, total) = configurations(case);
    let texels = case
        .materials
        .iter()
        .filter_map(|m| m.texture.as_ref().map(|t| t.texel_count()))
        .max()
        .unwrap_or(0);
    let disagreement_batch = (!case.compare.is_empty()).then(|| {
        let d = case.disagreements.clone().unwrap_or_default();
        (d.restarts as u64).saturating_mul(d.population as u64)
    });
    crate::limits::RunSize {
        naturals,
        total,
        methods: setup.methods.len() as u64,
        targets: super::sweep::needed_targets(&setup.methods).len() as u64,
        chunk: super::sweep::MEASURE_CHUNK as u64,
        texels,
        statistics,
        bins: case.bins.iter().map(|b| b.edges.len().saturating_sub(1)).sum(),
        cells: case
            .maps
            .iter()
            .map(|m| (m.x.edges.len() - 1).saturating_mul(m.y.edges.len() - 1))
            .fold(0, usize::saturating_add),
        search: case.search.as_ref().map(|s| (s.restarts, s.population)),
        disagreement_batch,
        raw: holds.raw,
        observations: holds.observations,
        all_samples: holds.all_samples,
    }
}

/// Refuses a run whose memory budget exceeds `--max-memory`, before anything is allocated.
pub fn check_memory(setup: &Setup, holds: Holds, statistics: crate::limits::StatisticsSize) -> anyhow::Result<()> {
    let case = &setup.case;
    let size = run_size(setup, holds, statistics);
    crate::limits::run_budget(&size)
        .check(&format!("case `{}` with {} configurations", case.name, size.total))
        .map_err(anyhow::Error::msg)
}

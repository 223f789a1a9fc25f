//! Analysis: measured values and references → per-method, per-material, per-bin
//! statistics, method-against-method comparisons and the verdict. No I/O here.

use crate::case::{BinAxis, Case, Tolerance};
use crate::methods::Method;
use crate::reference::Estimate;
use crate::sampler::Sample;
use crate::stats::{bin_index, relative_error, BinAccumulator, BinStats, Outcome, Quantiles};
use crate::target::Target;
use serde::Serialize;
use std::collections::BTreeMap;

/// What was measured for one method over all configurations of a sweep.
pub struct MethodRun {
    pub method: Method,
    /// GPU results, one per configuration (NaN where the method does not apply).
    pub f32: Vec<f32>,
    /// The CPU ports in f32 and f64, where one exists and applies.
    pub f32_cpu: Vec<Option<f32>>,
    pub f64: Vec<Option<f64>>,
    pub gpu_seconds: f64,
    pub f64_seconds: f64,
}

/// References per configuration, by target.
pub type References = Vec<BTreeMap<Target, Estimate>>;

#[derive(Clone, Debug, Serialize)]
pub struct Bin {
    pub lo: f64,
    pub hi: f64,
    pub stats: BinStats,
}

#[derive(Clone, Debug, Serialize)]
pub struct AxisStats {
    pub axis: String,
    pub bins: Vec<Bin>,
}

/// Statistics over a two-dimensional grid of bins; `cells[y][x]`.
#[derive(Clone, Debug, Serialize)]
pub struct MapStats {
    pub x: BinAxis,
    pub y: BinAxis,
    pub cells: Vec<Vec<BinStats>>,
}

#[derive(Clone, Debug, Serialize)]
pub struct MaterialStats {
    pub material: String,
    /// False when the method does not claim to handle this material's M⁻¹ (shown, not gated).
    pub supported: bool,
    pub all: BinStats,
    pub axes: Vec<AxisStats>,
    pub maps: Vec<MapStats>,
    /// For `line` methods: the same results judged against `line_upper`, what a real
    /// surface receives (the difference is the leak below the horizon).
    pub against_line_upper: Option<BinStats>,
}

#[derive(Clone, Debug, Serialize)]
pub struct MethodStats {
    pub label: String,
    /// The label with a composite's inner method spelled out (`cylinder.line[line.ltc2023_full]`).
    pub describe: String,
    pub id: String,
    pub target: Target,
    pub source: String,
    pub kernel: String,
    pub has_f64: bool,
    pub materials: Vec<MaterialStats>,
}

/// Configuration-by-configuration difference of two methods, relative to the reference.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PairStats {
    pub count: usize,
    pub diff_f32: Option<Quantiles>,
    pub diff_f64: Option<Quantiles>,
}

#[derive(Clone, Debug, Serialize)]
pub struct PairBin {
    pub lo: f64,
    pub hi: f64,
    pub stats: PairStats,
}

#[derive(Clone, Debug, Serialize)]
pub struct PairAxis {
    pub axis: String,
    pub bins: Vec<PairBin>,
}

#[derive(Clone, Debug, Serialize)]
pub struct PairMaterial {
    pub material: String,
    pub all: PairStats,
    pub axes: Vec<PairAxis>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub a: String,
    pub b: String,
    pub materials: Vec<PairMaterial>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Check {
    pub method: String,
    pub material: String,
    pub what: String,
    pub limit: f64,
    pub measured: f64,
    pub pass: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct Analysis {
    pub methods: Vec<MethodStats>,
    pub comparisons: Vec<Comparison>,
    pub checks: Vec<Check>,
    pub pass: bool,
}

/// Selects, for one material, the configurations a statistic is taken over.
fn members<'a>(samples: &'a [Sample], material: usize) -> impl Iterator<Item = usize> + 'a {
    samples
        .iter()
        .enumerate()
        .filter(move |(_, s)| s.material == material)
        .map(|(i, _)| i)
}

/// The reference a method is judged against on configuration `i`, if it has one.
fn reference_for(references: &References, i: usize, target: Target) -> Option<Estimate> {
    references[i].get(&target).copied()
}

fn method_stats(case: &Case, samples: &[Sample], references: &References, run: &MethodRun) -> MethodStats {
    let target = run.method.target();
    // One configuration judged against `judged` (the method's target, or `line_upper`).
    let outcome = |i: usize, judged: Target| -> Option<(Outcome, Option<Outcome>, Option<Outcome>, f64)> {
        let r = reference_for(references, i, judged)?;
        if !run.method.applies(&samples[i].config) {
            return None;
        }
        let floor = case.floor_for(judged, &samples[i].config);
        Some((
            Outcome::of_f32(run.f32[i], r.value, floor),
            run.f32_cpu[i].map(|v| Outcome::of_f32(v, r.value, floor)),
            run.f64[i].map(|v| Outcome::of_f64(v, r.value, floor)),
            r.error / r.value.abs().max(floor),
        ))
    };
    let materials = case
        .materials
        .iter()
        .enumerate()
        .map(|(m, family)| {
            let idx: Vec<usize> = members(samples, m).collect();
            let collect_against = |judged: Target, filter: &dyn Fn(usize) -> bool| {
                let mut acc = BinAccumulator::default();
                for &i in idx.iter().filter(|&&i| filter(i)) {
                    if let Some((gpu, cpu, f64, r)) = outcome(i, judged) {
                        acc.push(gpu, cpu, f64, r);
                    }
                }
                acc.finish()
            };
            let collect = |filter: &dyn Fn(usize) -> bool| collect_against(target, filter);
            let in_bin =
                |axis: &str, edges: &[f64], k: usize, i: usize| bin_index(edges, samples[i].axes.get(axis)) == Some(k);
            let supported = idx.first().is_none_or(|&i| run.method.supports(&samples[i].config));
            MaterialStats {
                material: family.name.clone(),
                supported,
                all: collect(&|_| true),
                axes: case
                    .bins
                    .iter()
                    .map(|b| AxisStats {
                        axis: b.axis.clone(),
                        bins: (0..b.edges.len() - 1)
                            .map(|k| Bin {
                                lo: b.edges[k],
                                hi: b.edges[k + 1],
                                stats: collect(&|i| in_bin(&b.axis, &b.edges, k, i)),
                            })
                            .collect(),
                    })
                    .collect(),
                maps: case
                    .maps
                    .iter()
                    .map(|map| MapStats {
                        x: map.x.clone(),
                        y: map.y.clone(),
                        // Only the methods a map draws: the others' grids would be read by no one.
                        cells: (0..map.y.edges.len() - 1)
                            .filter(|_| map.shows(&run.method.label))
                            .map(|ky| {
                                (0..map.x.edges.len() - 1)
                                    .map(|kx| {
                                        collect(&|i| {
                                            in_bin(&map.x.axis, &map.x.edges, kx, i)
                                                && in_bin(&map.y.axis, &map.y.edges, ky, i)
                                        })
                                    })
                                    .collect()
                            })
                            .collect(),
                    })
                    .collect(),
                against_line_upper: (target == Target::Line).then(|| collect_against(Target::LineUpper, &|_| true)),
            }
        })
        .collect();
    MethodStats {
        label: run.method.label.clone(),
        describe: run.method.describe(),
        id: run.method.id().to_string(),
        target,
        source: run.method.kernel.source.clone(),
        kernel: run.method.kernel.path.clone(),
        has_f64: run.f64.iter().any(Option::is_some),
        materials,
    }
}

fn pair_stats(idx: impl Iterator<Item = usize>, diff: &dyn Fn(usize) -> Option<(f64, Option<f64>)>) -> PairStats {
    let (mut d32, mut d64) = (Vec::new(), Vec::new());
    for i in idx {
        if let Some((a, b)) = diff(i) {
            d32.push(a);
            if let Some(b) = b {
                d64.push(b);
            }
        }
    }
    PairStats {
        count: d32.len(),
        diff_f32: Quantiles::of(&mut d32),
        diff_f64: Quantiles::of(&mut d64),
    }
}

fn compare(case: &Case, samples: &[Sample], references: &References, a: &MethodRun, b: &MethodRun) -> Comparison {
    let target = a.method.target();
    // Differences normalised by the reference, so they read as relative errors; NaN/inf
    // results are left out here (they are counted in each method's own table).
    let diff = |i: usize| -> Option<(f64, Option<f64>)> {
        let c = &samples[i].config;
        if !(a.method.supports(c) && b.method.supports(c) && a.method.applies(c) && b.method.applies(c)) {
            return None;
        }
        let r = reference_for(references, i, target)?.value;
        let floor = case.floor_for(target, c);
        let (x, y) = (a.f32[i] as f64, b.f32[i] as f64);
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let d64 = match (a.f64[i], b.f64[i]) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some(relative_error(x, y, r.abs().max(floor))),
            _ => None,
        };
        Some((relative_error(x, y, r.abs().max(floor)), d64))
    };
    let materials = case
        .materials
        .iter()
        .enumerate()
        .map(|(m, family)| PairMaterial {
            material: family.name.clone(),
            all: pair_stats(members(samples, m), &diff),
            axes: case
                .bins
                .iter()
                .map(|bin| PairAxis {
                    axis: bin.axis.clone(),
                    bins: (0..bin.edges.len() - 1)
                        .map(|k| PairBin {
                            lo: bin.edges[k],
                            hi: bin.edges[k + 1],
                            stats: pair_stats(
                                members(samples, m)
                                    .filter(|&i| bin_index(&bin.edges, samples[i].axes.get(&bin.axis)) == Some(k)),
                                &diff,
                            ),
                        })
                        .collect(),
                })
                .collect(),
        })
        .collect();
    Comparison {
        a: a.method.label.clone(),
        b: b.method.label.clone(),
        materials,
    }
}

fn checks(case: &Case, methods: &[MethodStats]) -> Vec<Check> {
    let mut out = Vec::new();
    for m in methods {
        let Some(tol) = case.tolerances.get(&m.label) else {
            continue;
        };
        for mat in m.materials.iter().filter(|mat| mat.supported) {
            let Tolerance { median, p99, max, nan } = tol;
            let q = mat.all.rel.unwrap_or_default();
            let mut check = |what: &str, limit: Option<f64>, measured: f64| {
                if let Some(limit) = limit {
                    out.push(Check {
                        method: m.label.clone(),
                        material: mat.material.clone(),
                        what: what.to_string(),
                        limit,
                        measured,
                        pass: measured <= limit,
                    });
                }
            };
            check("median rel. error", *median, q.median);
            check("p99 rel. error", *p99, q.p99);
            check("max rel. error", *max, q.max);
            check(
                "NaN/inf count",
                nan.map(|n| n as f64),
                (mat.all.nan + mat.all.inf) as f64,
            );
        }
    }
    out
}

pub fn analyse(case: &Case, samples: &[Sample], references: &References, runs: &[MethodRun]) -> Analysis {
    let methods: Vec<MethodStats> = runs
        .iter()
        .map(|r| method_stats(case, samples, references, r))
        .collect();
    let by_label = |l: &str| {
        runs.iter()
            .find(|r| r.method.label == l)
            .expect("case checked compare labels")
    };
    let comparisons = case
        .compare
        .iter()
        .map(|[a, b]| compare(case, samples, references, by_label(a), by_label(b)))
        .collect();
    let checks = checks(case, &methods);
    let pass = checks.iter().all(|c| c.pass);
    Analysis {
        methods,
        comparisons,
        checks,
        pass,
    }
}

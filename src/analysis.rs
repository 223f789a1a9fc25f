//! Analysis: measured values and references → per-method, per-material, per-bin
//! statistics, method-against-method comparisons and the verdict. No I/O here.

use crate::case::{BinAxis, Case, Tolerance};
use crate::methods::Method;
use crate::reference::Estimate;
use crate::sampler::Sample;
use crate::stats::{BinAccumulator, BinStats, Outcome, Quantiles};
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

/// Which statistics of a method on a material a claim reads.
#[derive(Clone, Debug)]
pub enum BinStatsRef {
    All,
    /// The `line` method judged against `line_upper`.
    LineUpper,
    /// The bin of `axis` whose lower edge is `lo`.
    Bin {
        axis: String,
        lo: f64,
    },
}

impl std::fmt::Display for BinStatsRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BinStatsRef::All => f.write_str("(all)"),
            BinStatsRef::LineUpper => f.write_str("against line_upper (only line methods have it)"),
            BinStatsRef::Bin { axis, lo } => write!(f, "of `{axis}` with lower edge {lo}"),
        }
    }
}

impl MaterialStats {
    pub fn select(&self, which: &BinStatsRef) -> Option<&BinStats> {
        match which {
            BinStatsRef::All => Some(&self.all),
            BinStatsRef::LineUpper => self.against_line_upper.as_ref(),
            BinStatsRef::Bin { axis, lo } => self
                .axes
                .iter()
                .find(|a| &a.axis == axis)?
                .bins
                .iter()
                .find(|b| b.lo == *lo)
                .map(|b| &b.stats),
        }
    }
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

/// The verdict of a case's tolerance checks; a case that sets none has no verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Pass,
    Fail,
    NoVerdict,
}

impl Verdict {
    pub fn of(checks: &[Check]) -> Verdict {
        if checks.is_empty() {
            Verdict::NoVerdict
        } else if checks.iter().all(|c| c.pass) {
            Verdict::Pass
        } else {
            Verdict::Fail
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Verdict::Pass => "PASS",
            Verdict::Fail => "FAIL",
            Verdict::NoVerdict => "no verdict",
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct Analysis {
    pub methods: Vec<MethodStats>,
    pub comparisons: Vec<Comparison>,
    pub checks: Vec<Check>,
    pub verdict: Verdict,
}

/// The reference a method is judged against on configuration `i`, if it has one.
fn reference_for(references: &References, i: usize, target: Target) -> Option<Estimate> {
    references[i].get(&target).copied()
}

/// For one material: which bin of every axis each configuration falls in (computed once), and
/// whether it counts there (natural samples everywhere, top-ups only in their own strata).
struct Binning {
    /// Indices of the material's configurations.
    members: Vec<usize>,
    /// `bin[a][j]`: the bin of axis `a` that counts configuration `members[j]`, if any.
    bin: Vec<Vec<Option<usize>>>,
}

fn binning(case: &Case, samples: &[Sample], material: usize) -> Binning {
    let members: Vec<usize> = (0..samples.len())
        .filter(|&i| samples[i].material == material)
        .collect();
    let bin = case
        .bins
        .iter()
        .enumerate()
        .map(|(a, axis)| {
            members
                .iter()
                .map(|&i| {
                    let s = &samples[i];
                    let k = axis.index(s.axes.get(&axis.axis))?;
                    (s.natural() || s.strata.contains(&(a, k))).then_some(k)
                })
                .collect()
        })
        .collect();
    Binning { members, bin }
}

/// One configuration's contribution to a bin.
#[derive(Clone, Copy)]
enum Judged {
    Lit {
        gpu: Outcome,
        cpu: Option<Outcome>,
        f64: Option<Outcome>,
        reference_rel: f64,
        below_floor: bool,
    },
    /// The reference is exactly 0.
    Zero { gpu: f32, f64: Option<f64> },
}

fn push(acc: &mut BinAccumulator, j: Judged) {
    match j {
        Judged::Lit {
            gpu,
            cpu,
            f64,
            reference_rel,
            below_floor,
        } => acc.push(gpu, cpu, f64, reference_rel, below_floor),
        Judged::Zero { gpu, f64 } => acc.push_zero(gpu, f64),
    }
}

/// Configuration `i` judged against target `judged`, or None when it has no such reference or
/// the method does not apply.
fn judge(
    case: &Case,
    samples: &[Sample],
    references: &References,
    run: &MethodRun,
    i: usize,
    judged: Target,
) -> Option<Judged> {
    let r = reference_for(references, i, judged)?;
    if !run.method.applies(&samples[i].config) {
        return None;
    }
    if r.value == 0.0 {
        return Some(Judged::Zero {
            gpu: run.f32[i],
            f64: run.f64[i],
        });
    }
    let floor = case.floor_for(judged, &samples[i].config);
    Some(Judged::Lit {
        gpu: Outcome::of_f32(run.f32[i], r.value, floor),
        cpu: run.f32_cpu[i].map(|v| Outcome::of_f32(v, r.value, floor)),
        f64: run.f64[i].map(|v| Outcome::of_f64(v, r.value, floor)),
        reference_rel: r.error / r.value.abs(),
        below_floor: r.value.abs() < floor,
    })
}

fn method_stats(case: &Case, samples: &[Sample], references: &References, run: &MethodRun) -> MethodStats {
    let target = run.method.target();
    let materials = case
        .materials
        .iter()
        .enumerate()
        .map(|(m, family)| {
            let binning = binning(case, samples, m);
            let mut all = BinAccumulator::default();
            let mut upper = BinAccumulator::default();
            let mut axes: Vec<Vec<BinAccumulator>> = case
                .bins
                .iter()
                .map(|b| vec![BinAccumulator::default(); b.edges.len() - 1])
                .collect();
            // Only the methods a map draws: the others' grids would be read by no one.
            let mut maps: Vec<Vec<Vec<BinAccumulator>>> = case
                .maps
                .iter()
                .map(|map| {
                    let rows = if map.shows(&run.method.label) {
                        map.y.edges.len() - 1
                    } else {
                        0
                    };
                    vec![vec![BinAccumulator::default(); map.x.edges.len() - 1]; rows]
                })
                .collect();
            for (j, &i) in binning.members.iter().enumerate() {
                let natural = samples[i].natural();
                if natural && target == Target::Line {
                    if let Some(u) = judge(case, samples, references, run, i, Target::LineUpper) {
                        push(&mut upper, u);
                    }
                }
                let Some(judged) = judge(case, samples, references, run, i, target) else {
                    continue;
                };
                if natural {
                    push(&mut all, judged);
                    let axes_of = &samples[i].axes;
                    for (map, cells) in case.maps.iter().zip(&mut maps) {
                        if cells.is_empty() {
                            continue;
                        }
                        if let (Some(kx), Some(ky)) = (
                            map.x.index(axes_of.get(&map.x.axis)),
                            map.y.index(axes_of.get(&map.y.axis)),
                        ) {
                            push(&mut cells[ky][kx], judged);
                        }
                    }
                }
                for (a, acc) in axes.iter_mut().enumerate() {
                    if let Some(k) = binning.bin[a][j] {
                        push(&mut acc[k], judged);
                    }
                }
            }
            let supported = binning
                .members
                .first()
                .is_none_or(|&i| run.method.supports(&samples[i].config));
            MaterialStats {
                material: family.name.clone(),
                supported,
                all: all.finish(),
                axes: case
                    .bins
                    .iter()
                    .zip(axes)
                    .map(|(b, accs)| AxisStats {
                        axis: b.axis.clone(),
                        bins: accs
                            .into_iter()
                            .enumerate()
                            .map(|(k, acc)| Bin {
                                lo: b.edges[k],
                                hi: b.edges[k + 1],
                                stats: acc.finish(),
                            })
                            .collect(),
                    })
                    .collect(),
                maps: case
                    .maps
                    .iter()
                    .zip(maps)
                    .map(|(map, cells)| MapStats {
                        x: map.x.clone(),
                        y: map.y.clone(),
                        cells: cells
                            .into_iter()
                            .map(|row| row.into_iter().map(BinAccumulator::finish).collect())
                            .collect(),
                    })
                    .collect(),
                against_line_upper: (target == Target::Line).then(|| upper.finish()),
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

/// The configurations of one material.
fn members(samples: &[Sample], material: usize) -> impl Iterator<Item = usize> + '_ {
    (0..samples.len()).filter(move |&i| samples[i].material == material)
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
    // Differences normalised by the reference (no floor), so they read as relative errors;
    // zero references and NaN/inf results are left out here (they have their own rows in each
    // method's table).
    let diff = |i: usize| -> Option<(f64, Option<f64>)> {
        let c = &samples[i].config;
        if !(a.method.supports(c) && b.method.supports(c) && a.method.applies(c) && b.method.applies(c)) {
            return None;
        }
        let r = reference_for(references, i, target)?.value;
        if r == 0.0 {
            return None;
        }
        let (x, y) = (a.f32[i] as f64, b.f32[i] as f64);
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let d64 = match (a.f64[i], b.f64[i]) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some((x - y).abs() / r.abs()),
            _ => None,
        };
        Some(((x - y).abs() / r.abs(), d64))
    };
    let materials = case
        .materials
        .iter()
        .enumerate()
        .map(|(m, family)| PairMaterial {
            material: family.name.clone(),
            all: pair_stats(members(samples, m).filter(|&i| samples[i].natural()), &diff),
            axes: case
                .bins
                .iter()
                .enumerate()
                .map(|(a, bin)| PairAxis {
                    axis: bin.axis.clone(),
                    bins: (0..bin.edges.len() - 1)
                        .map(|k| PairBin {
                            lo: bin.edges[k],
                            hi: bin.edges[k + 1],
                            stats: pair_stats(
                                members(samples, m).filter(|&i| {
                                    let s = &samples[i];
                                    bin.index(s.axes.get(&bin.axis)) == Some(k)
                                        && (s.natural() || s.strata.contains(&(a, k)))
                                }),
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
            let Tolerance {
                median,
                p99,
                max,
                nan,
                false_light,
            } = tol;
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
            // NaN where no light arrives is a NaN pixel all the same.
            check(
                "NaN/inf count",
                nan.map(|n| n as f64),
                (mat.all.nan + mat.all.inf + mat.all.false_light.nonfinite) as f64,
            );
            check(
                "false light (configurations with reference 0 lit)",
                false_light.map(|n| n as f64),
                mat.all.false_light.lit as f64,
            );
        }
    }
    out
}

pub fn analyse(case: &Case, samples: &[Sample], references: &References, runs: &[MethodRun]) -> Analysis {
    use rayon::prelude::*;
    let methods: Vec<MethodStats> = runs
        .par_iter()
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
    let verdict = Verdict::of(&checks);
    Analysis {
        methods,
        comparisons,
        checks,
        verdict,
    }
}

//! Analysis: measured values and references → per-method, per-material, per-bin
//! statistics, method-against-method comparisons and the verdict. No I/O here.

use crate::analyse::stats::{merge_each, Accumulate, BinAccumulator, BinStats, Distribution, Outcome, Quantiles};
use crate::input::case::{BinAxis, Case, Tolerance};
use crate::input::sampler::Sample;
use crate::input::target::Target;
use crate::kernel::methods::Method;
use serde::{Deserialize, Serialize};

/// One chunk of measured configurations, as the measure stage hands it over: what the analysis
/// folds in, then forgets (one type, not a copy).
pub use crate::measure::sweep::MeasuredChunk as Chunk;
pub use crate::measure::sweep::MethodRun;

/// What the sweep's fold hands every chunk-level accumulator ([`Accumulators`],
/// [`LeakAccumulator`], the gate's observations): the case and one measured chunk.
#[derive(Clone, Copy)]
pub struct Fold<'a> {
    pub case: &'a Case,
    pub chunk: &'a Chunk<'a>,
}

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
    /// The headline: judged against `MethodStats::judged`, what the surface receives where the
    /// method's target has a surface view (`line` → `line_upper`, `cylinder` →
    /// `cylinder_upper`, …). There a quit test's zero for a light wholly below the surface is
    /// right and a lobe's leak below the horizon is an error.
    pub all: BinStats,
    pub axes: Vec<AxisStats>,
    pub maps: Vec<MapStats>,
    /// For methods with a surface view: the same results judged against the method's own
    /// target (the lobe as the LTC defines it, leak included): the formula's own error.
    pub own_target: Option<BinStats>,
    /// The same view per bin of every axis (empty for other methods).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub own_axes: Vec<AxisStats>,
    /// For methods with a surface view: the configurations whose light is wholly below the
    /// surface (both end points, and for a tube or rectangle the whole shape, at z <= 0),
    /// judged against the surface view (0 for every one of them). A subset of the headline's
    /// zero references ("surface receives nothing"), which also holds lights above the
    /// surface only outside the lobe.
    pub wholly_below: Option<BinStats>,
}

/// Which statistics of a method on a material a claim reads.
#[derive(Clone, Debug)]
pub enum BinStatsRef {
    All,
    /// The headline of a method with a surface view (`upper_*` claims): `All`, refused for a
    /// method that has no own-target view beside it.
    Upper,
    /// A method with a surface view judged against its own target (the formula's own error).
    Own,
    /// The same, in the bin of `axis` whose lower edge is `lo`.
    OwnBin {
        axis: String,
        lo: f64,
    },
    /// The lights wholly below the surface, against the surface view.
    WhollyBelow,
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
            BinStatsRef::Upper => f.write_str("against the surface view (only methods with one have it)"),
            BinStatsRef::Own => f.write_str("against its own target (only methods with a surface view have it)"),
            BinStatsRef::OwnBin { axis, lo } => {
                write!(f, "against its own target, of `{axis}` with lower edge {lo}")
            }
            BinStatsRef::WhollyBelow => {
                f.write_str("wholly below the surface (only methods with a surface view have it)")
            }
            BinStatsRef::Bin { axis, lo } => write!(f, "of `{axis}` with lower edge {lo}"),
        }
    }
}

impl MaterialStats {
    pub fn select(&self, which: &BinStatsRef) -> Option<&BinStats> {
        match which {
            BinStatsRef::All => Some(&self.all),
            BinStatsRef::Upper => self.own_target.as_ref().map(|_| &self.all),
            BinStatsRef::Own => self.own_target.as_ref(),
            BinStatsRef::WhollyBelow => self.wholly_below.as_ref(),
            BinStatsRef::Bin { axis, lo } => find_bin(&self.axes, axis, *lo),
            BinStatsRef::OwnBin { axis, lo } => find_bin(&self.own_axes, axis, *lo),
        }
    }
}

fn find_bin<'a>(axes: &'a [AxisStats], axis: &str, lo: f64) -> Option<&'a BinStats> {
    axes.iter()
        .find(|a| a.axis == axis)?
        .bins
        .iter()
        .find(|b| b.lo == lo)
        .map(|b| &b.stats)
}

#[derive(Clone, Debug, Serialize)]
pub struct MethodStats {
    pub label: String,
    /// The label with a composite's inner method spelled out (`cylinder.line[line.ltc2023_full]`).
    pub describe: String,
    pub id: String,
    /// The method's own target (what its formula models).
    pub target: Target,
    /// What the headline judges it against: the surface view of `target` where there is one
    /// ([`headline_target`]), else `target`.
    pub judged: Target,
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
    /// A quantile judged from fewer than [`crate::limits::MIN_JUDGED`] configurations: how many
    /// it had. Neither a pass nor a failure: the case then has no verdict.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub too_few: Option<usize>,
}

impl Check {
    /// Measured past its limit (a check with too few configurations has not failed).
    pub fn failed(&self) -> bool {
        !self.pass && self.too_few.is_none()
    }
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
        if checks.iter().any(Check::failed) {
            Verdict::Fail
        } else if checks.is_empty() || checks.iter().any(|c| c.too_few.is_some()) {
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

/// How much of `line` lies below the horizon (`line − line_upper`, the LTC leak), per material.
#[derive(Clone, Debug, Serialize)]
pub struct Leak {
    pub material: String,
    pub configurations: usize,
    /// Configurations where more than 1e-6 of `line` comes from below the horizon.
    pub leaking: usize,
    /// Median and max of the leaking configurations' fraction (median: sketched past
    /// `stats::EXACT_LIMIT` leaking configurations).
    pub median_fraction: f64,
    pub max_fraction: f64,
}

/// Where one configuration counts, computed once per configuration and shared by every
/// method and pair.
struct Placement {
    material: usize,
    natural: bool,
    /// Per bin axis: the bin that counts it (natural samples everywhere, top-ups only in their
    /// own strata).
    bins: Vec<Option<usize>>,
    /// Per map: the cell (x, y) a natural configuration falls in.
    cells: Vec<Option<(usize, usize)>>,
}

fn place(case: &Case, s: &Sample) -> Placement {
    let natural = s.natural();
    Placement {
        material: s.material,
        natural,
        bins: case
            .bins
            .iter()
            .enumerate()
            .map(|(a, axis)| {
                let k = axis.index(s.axes.get(&axis.axis))?;
                (natural || s.strata.contains(&(a, k))).then_some(k)
            })
            .collect(),
        cells: case
            .maps
            .iter()
            .map(|map| {
                if !natural {
                    return None;
                }
                Some((
                    map.x.index(s.axes.get(&map.x.axis))?,
                    map.y.index(s.axes.get(&map.y.axis))?,
                ))
            })
            .collect(),
    }
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
        /// The GPU value, and the f64 one, are exactly 0 (missed light).
        dark: (bool, bool),
        reference: f64,
        /// |reference at f32 inputs − reference| / |reference|, where measured.
        input_rounding: Option<f64>,
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
            dark,
            reference,
            input_rounding,
        } => {
            acc.push(gpu, cpu, f64, reference_rel, below_floor, dark, reference);
            if let Some(x) = input_rounding {
                acc.push_input_rounding(x);
            }
        }
        Judged::Zero { gpu, f64 } => acc.push_zero(gpu, f64),
    }
}

impl Accumulate<Judged> for BinAccumulator {
    fn add(&mut self, j: Judged) {
        push(self, j);
    }

    fn merge(&mut self, o: &BinAccumulator) -> Result<(), String> {
        BinAccumulator::merge(self, o);
        Ok(())
    }
}

/// The reference an f32 column is judged against at configuration `i` of a chunk: the one at
/// the f32-rounded inputs where it is measured and not 0 (and the exact one is not 0), else the
/// exact one (docs/statistics.md). None without an exact reference. The analysis and the gate
/// both judge through it.
pub fn f32_reference(chunk: &Chunk, i: usize, target: Target) -> Option<crate::reference::Estimate> {
    let exact = *chunk.references[i].get(&target)?;
    let rounded = chunk.references_f32.get(i).and_then(|r| r.get(&target));
    Some(match rounded {
        Some(r32) if r32.value != 0.0 && exact.value != 0.0 => *r32,
        _ => exact,
    })
}

/// Configuration `i` of a chunk judged against target `judged`, or None when it has no such
/// reference or the method does not apply.
fn judge(case: &Case, chunk: &Chunk, run: &MethodRun, i: usize, judged: Target) -> Option<Judged> {
    let r = chunk.references[i].get(&judged).copied()?;
    let config = &chunk.samples[i].config;
    if !run.method.applies(config) {
        return None;
    }
    if r.value == 0.0 {
        return Some(Judged::Zero {
            gpu: run.f32[i],
            f64: run.f64[i],
        });
    }
    let floor = case.floor_for(judged, config);
    // The f32 columns against the reference at the f32-rounded inputs (what an f32 kernel could
    // at best return; the exact one where that is missing or 0), the f64 column against the
    // exact reference (docs/statistics.md).
    let rounded = chunk.references_f32.get(i).and_then(|refs| refs.get(&judged));
    let r32 = f32_reference(chunk, i, judged).map_or(r.value, |e| e.value);
    Some(Judged::Lit {
        gpu: Outcome::of_f32(run.f32[i], r32, floor),
        cpu: run.f32_cpu[i].map(|v| Outcome::of_f32(v, r32, floor)),
        f64: run.f64[i].map(|v| Outcome::of_f64(v, r.value, floor)),
        reference_rel: r.error / r.value.abs(),
        below_floor: r.value.abs() < floor,
        dark: (run.f32[i] == 0.0, run.f64[i] == Some(0.0)),
        reference: r.value,
        input_rounding: rounded.map(|e| (e.value - r.value).abs() / r.value.abs()),
    })
}

/// One method on one material: every bin's accumulator.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct MaterialAcc {
    /// Whether the method supports the material, from its first configuration seen.
    supported: Option<bool>,
    /// Against the headline target (the surface view where there is one).
    all: BinAccumulator,
    /// Against the method's own target, for methods with a surface view.
    own: BinAccumulator,
    /// Against the surface view, the lights wholly below the surface only.
    below: BinAccumulator,
    axes: Vec<Vec<BinAccumulator>>,
    /// `own` per bin of every axis; only methods with a surface view have them (empty otherwise).
    own_axes: Vec<Vec<BinAccumulator>>,
    /// Only the methods a map draws have cells (the others' grids would be read by no one).
    maps: Vec<Vec<Vec<BinAccumulator>>>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct MethodAcc {
    label: String,
    has_f64: bool,
    materials: Vec<MaterialAcc>,
}

impl MethodAcc {
    fn new(case: &Case, method: &Method) -> MethodAcc {
        let label = method.label.as_str();
        let axes: Vec<Vec<BinAccumulator>> = case
            .bins
            .iter()
            .map(|b| vec![BinAccumulator::default(); b.edges.len() - 1])
            .collect();
        let material = MaterialAcc {
            supported: None,
            all: BinAccumulator::default(),
            own: BinAccumulator::default(),
            below: BinAccumulator::default(),
            own_axes: if headline_target(method.target()) != method.target() {
                axes.clone()
            } else {
                Vec::new()
            },
            axes,
            maps: case
                .maps
                .iter()
                .map(|map| {
                    let rows = if map.shows(label) { map.y.edges.len() - 1 } else { 0 };
                    vec![vec![BinAccumulator::default(); map.x.edges.len() - 1]; rows]
                })
                .collect(),
        };
        MethodAcc {
            label: label.to_string(),
            has_f64: false,
            materials: vec![material; case.materials.len()],
        }
    }

    fn add(&mut self, case: &Case, chunk: &Chunk, placed: &[Placement], run: &MethodRun) {
        let own = run.method.target();
        let target = headline_target(own);
        self.has_f64 |= run.f64.iter().any(Option::is_some);
        for (i, p) in placed.iter().enumerate() {
            let acc = &mut self.materials[p.material];
            acc.supported
                .get_or_insert_with(|| run.method.supports(&chunk.samples[i].config));
            if target != own {
                if let Some(o) = judge(case, chunk, run, i, own) {
                    if p.natural {
                        push(&mut acc.own, o);
                    }
                    for (bins, k) in acc.own_axes.iter_mut().zip(&p.bins) {
                        if let Some(k) = k {
                            push(&mut bins[*k], o);
                        }
                    }
                }
            }
            let Some(judged) = judge(case, chunk, run, i, target) else {
                continue;
            };
            if target != own && p.natural && chunk.samples[i].config.shape_wholly_below(own) {
                push(&mut acc.below, judged);
            }
            if p.natural {
                push(&mut acc.all, judged);
                for (cells, cell) in acc.maps.iter_mut().zip(&p.cells) {
                    if let (false, Some((kx, ky))) = (cells.is_empty(), cell) {
                        push(&mut cells[*ky][*kx], judged);
                    }
                }
            }
            for (bins, k) in acc.axes.iter_mut().zip(&p.bins) {
                if let Some(k) = k {
                    push(&mut bins[*k], judged);
                }
            }
        }
    }

    fn merge(&mut self, o: &MethodAcc) {
        self.has_f64 |= o.has_f64;
        for (a, b) in self.materials.iter_mut().zip(&o.materials) {
            a.supported = a.supported.or(b.supported);
            a.all.merge(&b.all);
            a.own.merge(&b.own);
            a.below.merge(&b.below);
            for (x, y) in a.axes.iter_mut().flatten().zip(b.axes.iter().flatten()) {
                x.merge(y);
            }
            for (x, y) in a.own_axes.iter_mut().flatten().zip(b.own_axes.iter().flatten()) {
                x.merge(y);
            }
            for (x, y) in a
                .maps
                .iter_mut()
                .flatten()
                .flatten()
                .zip(b.maps.iter().flatten().flatten())
            {
                x.merge(y);
            }
        }
    }

    fn finish(&self, case: &Case, method: &Method) -> MethodStats {
        let target = method.target();
        let judged = headline_target(target);
        let viewed = judged != target;
        // Every bin carries the budget's bound of its quantile (docs/statistics.md).
        let q = case.budget().quantile;
        let axes = |accs: &[Vec<BinAccumulator>]| -> Vec<AxisStats> {
            case.bins
                .iter()
                .zip(accs)
                .map(|(b, accs)| AxisStats {
                    axis: b.axis.clone(),
                    bins: accs
                        .iter()
                        .enumerate()
                        .map(|(k, acc)| Bin {
                            lo: b.edges[k],
                            hi: b.edges[k + 1],
                            stats: acc.finish_bounded(q),
                        })
                        .collect(),
                })
                .collect()
        };
        let materials = case
            .materials
            .iter()
            .zip(&self.materials)
            .map(|(family, acc)| MaterialStats {
                material: family.name.clone(),
                supported: acc.supported.unwrap_or(true),
                all: acc.all.finish_bounded(q),
                axes: axes(&acc.axes),
                maps: case
                    .maps
                    .iter()
                    .zip(&acc.maps)
                    .map(|(map, cells)| MapStats {
                        x: map.x.clone(),
                        y: map.y.clone(),
                        cells: cells
                            .iter()
                            .map(|row| row.iter().map(BinAccumulator::finish).collect())
                            .collect(),
                    })
                    .collect(),
                own_target: viewed.then(|| acc.own.finish_bounded(q)),
                own_axes: axes(&acc.own_axes),
                wholly_below: viewed.then(|| acc.below.finish()),
            })
            .collect();
        MethodStats {
            label: method.label.clone(),
            describe: method.describe(),
            id: method.id().to_string(),
            target,
            judged,
            source: method.kernel.source.clone(),
            kernel: method.kernel.path.clone(),
            has_f64: self.has_f64,
            materials,
        }
    }
}

impl<'a> Accumulate<(&'a Case, &'a Chunk<'a>, &'a [Placement], &'a MethodRun)> for MethodAcc {
    fn add(&mut self, (case, chunk, placed, run): (&'a Case, &'a Chunk<'a>, &'a [Placement], &'a MethodRun)) {
        MethodAcc::add(self, case, chunk, placed, run);
    }

    fn merge(&mut self, o: &MethodAcc) -> Result<(), String> {
        if self.label != o.label {
            return Err(format!("the parts measured `{}` and `{}`", self.label, o.label));
        }
        MethodAcc::merge(self, o);
        Ok(())
    }
}

/// Configuration-by-configuration differences of two methods in one bin; mergeable.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct PairAccumulator {
    d32: Distribution,
    d64: Distribution,
}

impl PairAccumulator {
    fn push(&mut self, (d32, d64): (f64, Option<f64>)) {
        self.d32.push(d32);
        if let Some(d) = d64 {
            self.d64.push(d);
        }
    }

    fn merge(&mut self, o: &PairAccumulator) {
        self.d32.merge(&o.d32);
        self.d64.merge(&o.d64);
    }

    fn finish(&self) -> PairStats {
        PairStats {
            count: self.d32.len(),
            diff_f32: self.d32.quantiles(),
            diff_f64: self.d64.quantiles(),
        }
    }
}

impl Accumulate<(f64, Option<f64>)> for PairAccumulator {
    fn add(&mut self, d: (f64, Option<f64>)) {
        self.push(d);
    }

    fn merge(&mut self, o: &PairAccumulator) -> Result<(), String> {
        PairAccumulator::merge(self, o);
        Ok(())
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct PairMaterialAcc {
    all: PairAccumulator,
    axes: Vec<Vec<PairAccumulator>>,
}

/// A compared pair: the indices of its two methods and every bin's accumulator.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct PairAcc {
    a: usize,
    b: usize,
    materials: Vec<PairMaterialAcc>,
}

impl PairAcc {
    fn add(&mut self, chunk: &Chunk, placed: &[Placement]) {
        let (a, b) = (&chunk.runs[self.a], &chunk.runs[self.b]);
        let target = a.method.target();
        for (i, p) in placed.iter().enumerate() {
            let Some(d) = pair_diff(chunk, a, b, i, target) else {
                continue;
            };
            let acc = &mut self.materials[p.material];
            if p.natural {
                acc.all.push(d);
            }
            for (bins, k) in acc.axes.iter_mut().zip(&p.bins) {
                if let Some(k) = k {
                    bins[*k].push(d);
                }
            }
        }
    }

    fn merge(&mut self, o: &PairAcc) {
        for (x, y) in self.materials.iter_mut().zip(&o.materials) {
            x.all.merge(&y.all);
            for (p, q) in x.axes.iter_mut().flatten().zip(y.axes.iter().flatten()) {
                p.merge(q);
            }
        }
    }

    fn finish(&self, case: &Case, methods: &[Method]) -> Comparison {
        Comparison {
            a: methods[self.a].label.clone(),
            b: methods[self.b].label.clone(),
            materials: case
                .materials
                .iter()
                .zip(&self.materials)
                .map(|(family, acc)| PairMaterial {
                    material: family.name.clone(),
                    all: acc.all.finish(),
                    axes: case
                        .bins
                        .iter()
                        .zip(&acc.axes)
                        .map(|(bin, accs)| PairAxis {
                            axis: bin.axis.clone(),
                            bins: accs
                                .iter()
                                .enumerate()
                                .map(|(k, acc)| PairBin {
                                    lo: bin.edges[k],
                                    hi: bin.edges[k + 1],
                                    stats: acc.finish(),
                                })
                                .collect(),
                        })
                        .collect(),
                })
                .collect(),
        }
    }
}

impl<'a> Accumulate<(&'a Chunk<'a>, &'a [Placement])> for PairAcc {
    fn add(&mut self, (chunk, placed): (&'a Chunk<'a>, &'a [Placement])) {
        PairAcc::add(self, chunk, placed);
    }

    fn merge(&mut self, o: &PairAcc) -> Result<(), String> {
        if (self.a, self.b) != (o.a, o.b) {
            return Err("the parts compared different pairs".to_string());
        }
        PairAcc::merge(self, o);
        Ok(())
    }
}

/// Differences normalised by the reference (no floor), so they read as relative errors; zero
/// references and NaN/inf results are left out here (they have their own rows in each method's
/// table).
fn pair_diff(chunk: &Chunk, a: &MethodRun, b: &MethodRun, i: usize, target: Target) -> Option<(f64, Option<f64>)> {
    let c = &chunk.samples[i].config;
    if !(a.method.supports(c) && b.method.supports(c) && a.method.applies(c) && b.method.applies(c)) {
        return None;
    }
    let r = chunk.references[i].get(&target)?.value;
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
}

/// The sizes the accumulators of [`Accumulators::new`] grow with, for the memory budget
/// (`limits::statistics_estimate`): every bin (with each material's whole-material rows) per
/// method, per compared pair and once for itself; every map cell of the methods a map draws;
/// and how many accumulators one configuration is folded into.
pub fn statistics_size(case: &Case, methods: &[Method]) -> crate::limits::StatisticsSize {
    let m = methods.len() as u64;
    let pairs = case.compare.len() as u64;
    let materials = case.materials.len() as u64;
    let axes = case.bins.len() as u64;
    let bins: u64 = case
        .bins
        .iter()
        .fold(0u64, |t, b| t.saturating_add(b.edges.len().saturating_sub(1) as u64));
    let (mut map_cells, mut map_placements) = (0u64, 0u64);
    for map in &case.maps {
        let cells =
            (map.x.edges.len().saturating_sub(1) as u64).saturating_mul(map.y.edges.len().saturating_sub(1) as u64);
        let shown = methods.iter().filter(|x| map.shows(&x.label)).count() as u64;
        map_cells = map_cells.saturating_add(cells.saturating_mul(shown));
        map_placements = map_placements.saturating_add(shown);
    }
    // A method with a surface view has its bins twice: against it and against its own target.
    let lines = methods
        .iter()
        .filter(|x| headline_target(x.target()) != x.target())
        .count() as u64;
    let per_material = m
        .saturating_mul(bins.saturating_add(2))
        .saturating_add(lines.saturating_mul(bins))
        .saturating_add(pairs.saturating_mul(bins.saturating_add(1)))
        .saturating_add(bins);
    crate::limits::StatisticsSize {
        bins: per_material.saturating_mul(materials),
        map_cells: map_cells.saturating_mul(materials),
        per_configuration: m
            .saturating_mul(axes.saturating_add(2))
            .saturating_add(lines.saturating_mul(axes))
            .saturating_add(pairs.saturating_mul(axes.saturating_add(1)))
            .saturating_add(map_placements),
    }
}

/// The statistics of a sweep while it runs: every method × material × bin and every compared
/// pair, folded in chunk by chunk and mergeable across shards. Memory per bin is bounded
/// (`stats::Distribution`), so it does not grow with the configurations.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Accumulators {
    methods: Vec<MethodAcc>,
    pairs: Vec<PairAcc>,
    /// Configurations folded in (natural and top-ups).
    pub configurations: usize,
}

impl Accumulators {
    /// Empty accumulators for `methods` (in the order every chunk's runs come in).
    pub fn new(case: &Case, methods: &[Method]) -> Accumulators {
        let index = |l: &String| {
            methods
                .iter()
                .position(|m| &m.label == l)
                .expect("case checked compare labels")
        };
        let pairs = case
            .compare
            .iter()
            .map(|[a, b]| PairAcc {
                a: index(a),
                b: index(b),
                materials: vec![
                    PairMaterialAcc {
                        all: PairAccumulator::default(),
                        axes: case
                            .bins
                            .iter()
                            .map(|b| vec![PairAccumulator::default(); b.edges.len() - 1])
                            .collect(),
                    };
                    case.materials.len()
                ],
            })
            .collect();
        Accumulators {
            methods: methods.iter().map(|m| MethodAcc::new(case, m)).collect(),
            pairs,
            configurations: 0,
        }
    }

    /// Folds in one chunk: each configuration's bins are found once, then every method and
    /// every pair is accumulated in parallel.
    pub fn add(&mut self, case: &Case, chunk: &Chunk) {
        use rayon::prelude::*;
        assert_eq!(chunk.runs.len(), self.methods.len(), "one run per method");
        let placed: Vec<Placement> = chunk.samples.par_iter().map(|s| place(case, s)).collect();
        let (methods, pairs) = (&mut self.methods, &mut self.pairs);
        rayon::join(
            || {
                methods
                    .par_iter_mut()
                    .zip(chunk.runs)
                    .for_each(|(m, run)| m.add(case, chunk, &placed, run))
            },
            || pairs.par_iter_mut().for_each(|p| p.add(chunk, &placed)),
        );
        self.configurations += chunk.samples.len();
    }

    /// Adds another part (another chunk range or shard of the same case and methods).
    pub fn merge(&mut self, o: &Accumulators) -> Result<(), String> {
        let labels = |a: &Accumulators| a.methods.iter().map(|m| m.label.clone()).collect::<Vec<_>>();
        if labels(self) != labels(o) || self.pairs.len() != o.pairs.len() {
            return Err(format!(
                "the parts measured different methods: {:?} against {:?}",
                labels(self),
                labels(o)
            ));
        }
        merge_each(&mut self.methods, &o.methods)?;
        merge_each(&mut self.pairs, &o.pairs)?;
        self.configurations += o.configurations;
        Ok(())
    }

    /// The analysed summary: statistics, comparisons, checks and verdict.
    pub fn finish(&self, case: &Case, methods: &[Method]) -> Analysis {
        use rayon::prelude::*;
        let stats: Vec<MethodStats> = self
            .methods
            .par_iter()
            .zip(methods)
            .map(|(acc, m)| acc.finish(case, m))
            .collect();
        let comparisons = self.pairs.iter().map(|p| p.finish(case, methods)).collect();
        let checks = checks(case, &stats);
        let verdict = Verdict::of(&checks);
        Analysis {
            methods: stats,
            comparisons,
            checks,
            verdict,
        }
    }
}

impl<'a> Accumulate<Fold<'a>> for Accumulators {
    fn add(&mut self, f: Fold<'a>) {
        Accumulators::add(self, f.case, f.chunk);
    }

    fn merge(&mut self, o: &Accumulators) -> Result<(), String> {
        Accumulators::merge(self, o)
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
            // A tolerance with nothing to judge fails rather than passing on zeros: a family
            // that received no configuration (or, for the error quantiles, none with a
            // non-zero reference) is reported as NaN, which no limit admits.
            let measured_any = mat.all.count > 0;
            let q = mat.all.rel;
            let quantile = |f: fn(&Quantiles) -> f64| q.as_ref().map_or(f64::NAN, f);
            // A quantile from fewer than MIN_JUDGED configurations is no evidence either way; a
            // maximum or a count is what was seen, judged from any number.
            let n = mat.all.count;
            let mut check = |what: &str, limit: Option<f64>, measured: f64, quantile: bool| {
                if let Some(limit) = limit {
                    let measured = if measured_any { measured } else { f64::NAN };
                    let too_few = (quantile && measured_any && n < crate::limits::MIN_JUDGED).then_some(n);
                    out.push(Check {
                        method: m.label.clone(),
                        material: mat.material.clone(),
                        what: what.to_string(),
                        limit,
                        measured,
                        pass: too_few.is_none() && measured <= limit,
                        too_few,
                    });
                }
            };
            check("median rel. error", *median, quantile(|q| q.median), true);
            check("p99 rel. error", *p99, quantile(|q| q.p99), true);
            check("max rel. error", *max, quantile(|q| q.max), false);
            // NaN where no light arrives is a NaN pixel all the same.
            check(
                "NaN/inf count",
                nan.map(|n| n as f64),
                (mat.all.nan + mat.all.inf + mat.all.false_light.nonfinite) as f64,
                false,
            );
            check(
                "false light (configurations with reference 0 lit)",
                false_light.map(|n| n as f64),
                mat.all.false_light.lit as f64,
                false,
            );
        }
    }
    out
}

/// What the headline judges a method of target `own` against: what the surface receives
/// (`Target::upper`: `line` → `line_upper`, `cylinder` → `cylinder_upper`, …) where the target
/// has such a view, else `own` (docs/statistics.md).
pub fn headline_target(own: Target) -> Target {
    own.upper().unwrap_or(own)
}

/// How much of `line` lies below the horizon, per family, while a sweep runs: configurations
/// with both `line` and `line_upper` references, and the fractions of those that leak.
/// Mergeable across shards; [`LeakAccumulator::finish`] gives the report's [`Leak`] rows.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LeakAccumulator {
    families: Vec<(usize, Distribution)>,
}

impl LeakAccumulator {
    pub fn new(families: usize) -> LeakAccumulator {
        LeakAccumulator {
            families: vec![(0, Distribution::default()); families],
        }
    }

    /// Folds in one chunk's references.
    pub fn add(&mut self, chunk: &Chunk) {
        for (s, r) in chunk.samples.iter().zip(chunk.references) {
            if let (Some(line), Some(upper)) = (r.get(&Target::Line), r.get(&Target::LineUpper)) {
                let fraction = ((line.value - upper.value) / line.value.abs().max(f64::MIN_POSITIVE)).max(0.0);
                let (n, d) = &mut self.families[s.material];
                *n += 1;
                if fraction > 1e-6 {
                    d.push(fraction);
                }
            }
        }
    }

    pub fn merge(&mut self, o: &LeakAccumulator) {
        for (a, b) in self.families.iter_mut().zip(&o.families) {
            a.0 += b.0;
            a.1.merge(&b.1);
        }
    }

    /// One row per family with `line` configurations.
    pub fn finish(&self, case: &Case) -> Vec<Leak> {
        case.materials
            .iter()
            .zip(&self.families)
            .filter(|(_, (n, _))| *n > 0)
            .map(|(family, (n, d))| {
                let q = d.quantiles();
                Leak {
                    material: family.name.clone(),
                    configurations: *n,
                    leaking: d.len(),
                    median_fraction: q.map_or(0.0, |q| q.median),
                    max_fraction: q.map_or(0.0, |q| q.max),
                }
            })
            .collect()
    }
}

impl<'a> Accumulate<Fold<'a>> for LeakAccumulator {
    fn add(&mut self, f: Fold<'a>) {
        LeakAccumulator::add(self, f.chunk);
    }

    fn merge(&mut self, o: &LeakAccumulator) -> Result<(), String> {
        if self.families.len() != o.families.len() {
            return Err(format!("{} families against {}", self.families.len(), o.families.len()));
        }
        LeakAccumulator::merge(self, o);
        Ok(())
    }
}

/// Small chunks built by hand, every expected number worked out on paper from the rules of
/// docs/statistics.md (the values are chosen exact in f32, so a relative error is a fraction).
/// Written for the mutation pass (docs/mutation.md).
#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::sampler::Axes;
    use crate::input::scene::{Config, Material};
    use crate::reference::Estimate;
    use std::collections::BTreeMap;

    /// A case of two diffuse families, `length` and `elevation` axes of two bins each, and
    /// whatever `extra` adds (methods, compare, maps, tolerances).
    fn case(methods: &[&str], extra: &str) -> Case {
        let methods: Vec<String> = methods.iter().map(|m| format!("\"{m}\"")).collect();
        let text = format!(
            r#"
name = "t"
title = "t"
seed = 1
methods = [{}]
{extra}
[geometry]
elevation = {{ dist = "uniform", min = 0.0, max = 90.0 }}
tilt_angle = {{ dist = "uniform", min = 0.0, max = 180.0 }}
length = {{ dist = "log_uniform", min = 0.1, max = 10.0 }}
center = {{ dist = "fixed", value = 0.0 }}
[[materials]]
name = "a"
kind = "diffuse"
count = 10
[[materials]]
name = "b"
kind = "diffuse"
count = 10
[[bins]]
axis = "length"
edges = [0.1, 1.0, 10.0]
[[bins]]
axis = "elevation"
edges = [0.0, 45.0, 90.0]
"#,
            methods.join(", ")
        );
        Case::parse("t.toml", &text).unwrap()
    }

    fn methods(case: &Case) -> Vec<Method> {
        let kernels = crate::kernel::builtin_kernels();
        case.methods
            .iter()
            .map(|l| crate::kernel::methods::resolve(l, &kernels).unwrap())
            .collect()
    }

    /// One configuration: a segment at distance 1 from the shading point, above the surface
    /// (z = 1) or wholly below it (z = −1).
    struct Row {
        sample: Sample,
        refs: BTreeMap<Target, Estimate>,
        refs32: BTreeMap<Target, Estimate>,
        /// Per method: GPU f32, CPU f32, f64.
        values: Vec<(f32, Option<f32>, Option<f64>)>,
    }

    fn sample(material: usize, length: f64, elevation: f64, strata: Vec<(usize, usize)>, below: bool) -> Sample {
        let z = if below { -1.0 } else { 1.0 };
        Sample {
            config: Config {
                id: String::new(),
                p1: [-0.5, 0.0, z],
                p2: [0.5, 0.0, z],
                radius: None,
                rect: None,
                material: Material::Diffuse,
                texture: None,
            },
            material,
            axes: Axes {
                length,
                elevation,
                ..Axes::default()
            },
            units: Vec::new(),
            strata,
        }
    }

    fn refs(list: &[(Target, f64)]) -> BTreeMap<Target, Estimate> {
        list.iter()
            .map(|&(t, value)| (t, Estimate { value, error: 0.0 }))
            .collect()
    }

    /// A natural configuration of family 0 in the first bin of both axes.
    fn row(refs_: &[(Target, f64)], values: Vec<(f32, Option<f32>, Option<f64>)>) -> Row {
        Row {
            sample: sample(0, 0.5, 10.0, Vec::new(), false),
            refs: refs(refs_),
            refs32: BTreeMap::new(),
            values,
        }
    }

    /// Folds `rows` in as one chunk.
    fn fold(case: &Case, methods: &[Method], rows: &[Row], accs: &mut Accumulators, leak: &mut LeakAccumulator) {
        fold_by(case, methods, rows, accs, leak, false)
    }

    /// The same; `through_parts`: each method's and pair's accumulator fed through its own
    /// `Accumulate` impl, as a caller holding them one by one would, not through
    /// `Accumulators`' parallel fold.
    fn fold_by(
        case: &Case,
        methods: &[Method],
        rows: &[Row],
        accs: &mut Accumulators,
        leak: &mut LeakAccumulator,
        through_parts: bool,
    ) {
        let samples: Vec<Sample> = rows.iter().map(|r| r.sample.clone()).collect();
        let global: Vec<usize> = (0..rows.len()).collect();
        let references: Vec<_> = rows.iter().map(|r| r.refs.clone()).collect();
        let references_f32: Vec<_> = rows.iter().map(|r| r.refs32.clone()).collect();
        let runs: Vec<MethodRun> = methods
            .iter()
            .enumerate()
            .map(|(m, method)| MethodRun {
                method: method.clone(),
                f32: rows.iter().map(|r| r.values[m].0).collect(),
                f32_cpu: rows.iter().map(|r| r.values[m].1).collect(),
                f64: rows.iter().map(|r| r.values[m].2).collect(),
            })
            .collect();
        let chunk = Chunk {
            samples: &samples,
            global: &global,
            references: &references,
            references_f32: &references_f32,
            runs: &runs,
        };
        if through_parts {
            let placed: Vec<Placement> = samples.iter().map(|s| place(case, s)).collect();
            for (m, run) in accs.methods.iter_mut().zip(&runs) {
                Accumulate::add(m, (case, &chunk, &placed[..], run));
            }
            for p in accs.pairs.iter_mut() {
                Accumulate::add(p, (&chunk, &placed[..]));
            }
            accs.configurations += rows.len();
            Accumulate::<Fold>::add(leak, Fold { case, chunk: &chunk });
            return;
        }
        add_to_each(
            &mut [accs as &mut dyn Accumulate<Fold>, leak],
            Fold { case, chunk: &chunk },
        );
    }

    fn analyse(case: &Case, methods: &[Method], rows: &[Row]) -> (Analysis, Vec<Leak>) {
        analyse_by(case, methods, rows, false)
    }

    fn analyse_by(case: &Case, methods: &[Method], rows: &[Row], through_parts: bool) -> (Analysis, Vec<Leak>) {
        let mut accs = Accumulators::new(case, methods);
        let mut leak = LeakAccumulator::new(case.materials.len());
        fold_by(case, methods, rows, &mut accs, &mut leak, through_parts);
        (accs.finish(case, methods), leak.finish(case))
    }

    use crate::analyse::stats::add_to_each;

    const ISO: Target = Target::LineIsotropic;

    /// Every kind of configuration of one method without a surface view
    /// (`line_isotropic.closest_point`), beside a method that applies to none of them
    /// (`cylinder.line`: no radius).
    fn judged_rows() -> Vec<Row> {
        let v = |gpu: f32, cpu: Option<f32>, f64_: Option<f64>| vec![(gpu, cpu, f64_), (1.0, None, None)];
        let mut rows = vec![
            // 0: rel 2⁻¹⁰ (within 1e-3); the CPU f32 exact; the reference's estimate 1e-9.
            row(
                &[(ISO, 1.0)],
                v(1.0 + 1.0 / 1024.0, Some(1.0), Some(1.0 + 1.0 / 1024.0)),
            ),
            // 1: rel 0.25.
            row(&[(ISO, 2.0)], v(1.5, None, Some(1.5))),
            // 2: missed light in f32 and f64: rel 1 in both.
            row(&[(ISO, 0.5)], v(0.0, None, Some(0.0))),
            // 3: missed in f32 only: f64 rel 0.5.
            row(&[(ISO, 0.5)], v(0.0, None, Some(0.25))),
            // 4: NaN in both.
            row(&[(ISO, 1.0)], v(f32::NAN, None, Some(f64::NAN))),
            // 5: a reference of 1e-9, below the floor 1e-6: rel 0.5, floored 0.5e-9 / 1e-6.
            row(&[(ISO, 1e-9)], v(1.5e-9, None, None)),
            // 6–8: references of exactly 0: lit; dark in f32 but lit in f64; infinite.
            row(&[(ISO, 0.0)], v(0.125, None, Some(0.0))),
            row(&[(ISO, 0.0)], v(0.0, None, Some(1e-3))),
            row(&[(ISO, 0.0)], v(f32::INFINITY, None, None)),
            // 9: the reference at f32 inputs is 2.5: the f32 columns are exact against it, the
            // f64 column is 0.5/2 off the exact reference 2, and the input rounding is 0.25.
            row(&[(ISO, 2.0)], v(2.5, Some(2.5), Some(2.5))),
            // 10: no reference of the method's target: not judged.
            row(&[(Target::Line, 1.0)], v(7.0, None, None)),
            // 11, 12: rel 3/64 (within 1e-1) and 2⁻⁸ (within 1e-2).
            row(&[(ISO, 1.0)], v(1.0 + 3.0 / 64.0, None, None)),
            row(&[(ISO, 1.0)], v(1.0 + 1.0 / 256.0, None, None)),
        ];
        rows[0].refs.insert(
            ISO,
            Estimate {
                value: 1.0,
                error: 1e-9,
            },
        );
        // The reference 2 of configuration 1 carries an estimate of 4e-9: 2e-9 relative, the
        // largest (a value other than 1 tells a division from a product or a remainder).
        rows[1].refs.insert(
            ISO,
            Estimate {
                value: 2.0,
                error: 4e-9,
            },
        );
        rows[9].refs32 = refs(&[(ISO, 2.5)]);
        rows
    }

    const JUDGED_EXTRA: &str = r#"
[tolerances."line_isotropic.closest_point"]
median = 0.1
max = 0.5
nan = 0
false_light = 1
"#;

    #[test]
    fn each_configuration_is_judged_by_hand() {
        let case = case(&["line_isotropic.closest_point", "cylinder.line"], JUDGED_EXTRA);
        let methods = methods(&case);
        for through_parts in [false, true] {
            let (a, _) = analyse_by(&case, &methods, &judged_rows(), through_parts);
            let m = &a.methods[0];
            assert_eq!((m.target, m.judged, m.has_f64), (ISO, ISO, true));
            let s = &m.materials[0].all;
            // Finite with a non-zero reference: 0, 1, 2, 3, 5, 9, 11, 12; NaN: 4.
            assert_eq!((s.count, s.nan, s.inf), (8, 1, 0));
            assert_eq!((s.dark, s.dark_f64, s.below_floor, s.nan_f64), (2, 1, 1, 1));
            // Sorted: 0, 2⁻¹⁰, 2⁻⁸, 3/64, 0.25, 0.5(f32 of 1.5e-9), 1, 1; median at rank 4.
            let rel = s.rel.unwrap();
            assert_eq!((rel.median, rel.max), (3.0 / 64.0, 1.0));
            // Within 1e-3: 0 and 9; 1e-2: and 12; 1e-1: and 11; of 9 (the NaN counts as outside).
            assert_eq!(s.within, [2.0 / 9.0, 3.0 / 9.0, 4.0 / 9.0]);
            // Apart from the missed ones (2, 3), the worst is configuration 5.
            let lit = s.rel_lit.unwrap();
            assert!((lit.max - 0.5).abs() < 1e-7 && lit.median == 1.0 / 256.0, "{lit:?}");
            // Floored: configuration 5's 0.5e-9 over the floor 1e-6 instead of over 1e-9.
            let floored = s.rel_floored.unwrap();
            assert_eq!(floored.max, 1.0);
            let five = {
                let mut v: Vec<f64> = vec![0.0, 1.0 / 1024.0, 1.0 / 256.0, 3.0 / 64.0, 0.25, 1.0, 1.0];
                v.push(((1.5e-9f32 as f64) - 1e-9).abs() / 1e-6);
                v.sort_by(f64::total_cmp);
                v
            };
            assert_eq!(floored.median, five[3]);
            // f64: 0, 1, 2, 3, 9 (the NaN counted apart): 2⁻¹⁰, 0.25, 1, 0.5, 0.25; lit without 2.
            let f = s.rel_f64.unwrap();
            assert_eq!((f.median, f.max), (0.25, 1.0));
            assert_eq!(s.rel_f64_lit.unwrap().max, 0.5);
            assert_eq!(s.rel_cpu_f32.unwrap().max, 0.0);
            assert_eq!(s.abs.unwrap().max, 0.5);
            assert_eq!(s.reference.unwrap().max, 2.0);
            assert_eq!(s.reference_rel.unwrap().max, 2e-9);
            assert!(!s.reference_flag, "2e-9·100 is far below the median 3/64");
            assert_eq!(s.input_rounding.unwrap().max, 0.25);
            assert_eq!(s.input_rounding.unwrap().median, 0.25);
            let fl = &s.false_light;
            assert_eq!((fl.configurations, fl.lit, fl.nonfinite, fl.lit_f64), (3, 1, 1, 1));
            assert_eq!(fl.value.unwrap().max, 0.125);
            // No surface view: no own-target rows.
            let mat = &m.materials[0];
            assert!(mat.own_target.is_none() && mat.wholly_below.is_none() && mat.own_axes.is_empty());
            // Family b saw nothing.
            assert_eq!(m.materials[1].all.configurations(), 0);
            // The method that applies to none of them (no radius) judged nothing.
            let c = &a.methods[1].materials[0];
            assert_eq!(c.all.configurations(), 0);
            assert_eq!(c.own_target.as_ref().unwrap().configurations(), 0);
            // The checks: the median is a quantile of too few configurations (no verdict, not a
            // pass), false light passes, max and NaN/inf (4 and 8) fail.
            let checks: Vec<_> = a
                .checks
                .iter()
                .filter(|c| c.material == "a")
                .map(|c| (c.what.as_str(), c.limit, c.measured, c.pass, c.too_few))
                .collect();
            assert_eq!(
                checks,
                [
                    ("median rel. error", 0.1, 3.0 / 64.0, false, Some(s.count)),
                    ("max rel. error", 0.5, 1.0, false, None),
                    ("NaN/inf count", 0.0, 2.0, false, None),
                    (
                        "false light (configurations with reference 0 lit)",
                        1.0,
                        1.0,
                        true,
                        None
                    ),
                ]
            );
            // Family b is checked too, and fails: it received no configuration, so there is
            // nothing to judge (NaN), not a pass on zeros.
            assert_eq!(a.checks.len(), 8);
            assert!(a
                .checks
                .iter()
                .filter(|c| c.material == "b")
                .all(|c| !c.pass && c.measured.is_nan()));
            assert_eq!(a.verdict, Verdict::Fail);
        }
    }

    #[test]
    fn the_f32_columns_are_judged_against_the_reference_at_f32_inputs_where_it_is_not_0() {
        let references = vec![refs(&[(ISO, 1.0)]), refs(&[(ISO, 1.0)]), refs(&[(ISO, 0.0)]), refs(&[])];
        let references_f32 = vec![refs(&[(ISO, 1.25)]), refs(&[(ISO, 0.0)]), refs(&[(ISO, 0.5)])];
        let chunk = Chunk {
            samples: &[],
            global: &[],
            references: &references,
            references_f32: &references_f32,
            runs: &[],
        };
        let at = |i| f32_reference(&chunk, i, ISO).map(|e| e.value);
        assert_eq!((at(0), at(1), at(2), at(3)), (Some(1.25), Some(1.0), Some(0.0), None));
        assert_eq!(f32_reference(&chunk, 0, Target::Line), None);
    }

    #[test]
    fn a_surface_view_judges_the_headline_and_the_formula_apart() {
        let case = case(&["line.ltc2023"], "");
        let methods = methods(&case);
        let (l, u) = (Target::Line, Target::LineUpper);
        let rows = vec![
            // Above: the surface receives 1, the lobe gives 1.25: headline 0.25, own exact (f64
            // the other way round: 0 and 0.25/1.25).
            row(&[(l, 1.25), (u, 1.0)], vec![(1.25, None, Some(1.0))]),
            // Wholly below: the surface receives nothing; a lit one and a dark one.
            Row {
                sample: sample(0, 0.5, 10.0, Vec::new(), true),
                ..row(&[(l, 0.375), (u, 0.0)], vec![(0.375, None, None)])
            },
            Row {
                sample: sample(0, 0.5, 10.0, Vec::new(), true),
                ..row(&[(l, 0.5), (u, 0.0)], vec![(0.0, None, None)])
            },
            // A top-up of the second length bin: rel 1 both ways, in that bin only.
            Row {
                sample: sample(0, 5.0, 10.0, vec![(0, 1)], false),
                ..row(&[(l, 1.0), (u, 1.0)], vec![(2.0, None, None)])
            },
        ];
        let (a, _) = analyse(&case, &methods, &rows);
        let m = &a.methods[0];
        assert_eq!((m.target, m.judged), (l, u));
        let mat = &m.materials[0];
        assert_eq!((mat.all.count, mat.all.rel.unwrap().max), (1, 0.25));
        assert_eq!(mat.all.rel_f64.unwrap().max, 0.0);
        assert_eq!((mat.all.false_light.configurations, mat.all.false_light.lit), (2, 1));
        let own = mat.own_target.as_ref().unwrap();
        assert_eq!((own.count, own.dark, own.false_light.configurations), (3, 1, 0));
        assert_eq!((own.rel.unwrap().median, own.rel.unwrap().max), (0.0, 1.0));
        assert_eq!(own.rel_f64.unwrap().max, 0.2);
        let below = mat.wholly_below.as_ref().unwrap();
        assert_eq!(
            (below.count, below.false_light.configurations, below.false_light.lit),
            (0, 2, 1)
        );
        // Per bin: the length axis (the top-up counts in bin 1 only), both views.
        let bins = &mat.axes[0].bins;
        assert_eq!((bins[0].lo, bins[0].hi, bins[1].lo, bins[1].hi), (0.1, 1.0, 1.0, 10.0));
        assert_eq!((bins[0].stats.configurations(), bins[1].stats.count), (3, 1));
        assert_eq!(bins[1].stats.rel.unwrap().max, 1.0);
        let own_bins = &mat.own_axes[0].bins;
        assert_eq!((own_bins[0].stats.count, own_bins[1].stats.count), (3, 1));
        assert_eq!(own_bins[1].stats.rel.unwrap().max, 1.0);
        // Elevation: the top-up was drawn for a length bin only.
        assert_eq!(mat.axes[1].bins[0].stats.configurations(), 3);
        // Every bin carries the bound of the budget's quantile (p99: too few here).
        assert_eq!(mat.all.bound.unwrap().quantile, 0.99);
        assert_eq!(mat.all.bound.unwrap().n, 3);
        assert_eq!(bins[0].stats.bound.unwrap().n, 3);
        assert_eq!(own.bound.unwrap().n, 3);
        // select: every view, and the bins by axis and lower edge.
        let count = |w: BinStatsRef| mat.select(&w).map(|s| s.configurations());
        assert_eq!(count(BinStatsRef::All), Some(3));
        assert_eq!(count(BinStatsRef::Upper), Some(3));
        assert_eq!(count(BinStatsRef::Own), Some(3));
        assert_eq!(count(BinStatsRef::WhollyBelow), Some(2));
        let bin = |axis: &str, lo| BinStatsRef::Bin { axis: axis.into(), lo };
        let own_bin = |axis: &str, lo| BinStatsRef::OwnBin { axis: axis.into(), lo };
        assert_eq!(count(bin("length", 1.0)), Some(1));
        assert_eq!(count(bin("elevation", 0.0)), Some(3));
        assert_eq!(count(bin("length", 0.5)), None);
        assert_eq!(count(bin("alpha", 0.1)), None);
        assert_eq!(count(own_bin("length", 1.0)), Some(1));
        assert_eq!(count(own_bin("length", 0.1)), Some(3));
        // Without a surface view there is no `Upper`, `Own` or `WhollyBelow`.
        let iso = case_iso();
        let mat = &iso.methods[0].materials[0];
        assert!(mat.select(&BinStatsRef::Upper).is_none());
        assert!(mat.select(&BinStatsRef::Own).is_none());
        assert!(mat.select(&BinStatsRef::WhollyBelow).is_none());
        assert!(mat
            .select(&BinStatsRef::OwnBin {
                axis: "length".into(),
                lo: 0.1
            })
            .is_none());
        assert_eq!(mat.select(&BinStatsRef::All).map(|s| s.count), Some(1));
    }

    fn case_iso() -> Analysis {
        let case = case(&["line_isotropic.closest_point"], "");
        let methods = methods(&case);
        analyse(&case, &methods, &[row(&[(ISO, 1.0)], vec![(1.0, None, None)])]).0
    }

    #[test]
    fn configurations_are_placed_in_their_family_bins_and_cells() {
        let extra = r#"
[[maps]]
x = { axis = "length", edges = [0.1, 1.0, 10.0] }
y = { axis = "elevation", edges = [0.0, 45.0, 90.0] }
methods = ["line_isotropic.closest_point"]
"#;
        let case = case(&["line_isotropic.closest_point", "line.ltc2017"], extra);
        let methods = methods(&case);
        // Configuration k has relative error k/8 for both methods (every reference 1).
        let r = |k: u8, material, length, elevation, strata| Row {
            sample: sample(material, length, elevation, strata, false),
            refs: refs(&[(ISO, 1.0), (Target::Line, 1.0), (Target::LineUpper, 1.0)]),
            refs32: BTreeMap::new(),
            values: vec![(1.0 + f32::from(k) / 8.0, None, None); 2],
        };
        let rows = vec![
            r(1, 0, 0.5, 10.0, vec![]),
            r(2, 0, 5.0, 60.0, vec![]),
            r(3, 0, 10.0, 90.0, vec![]), // upper edges: the last bins
            r(4, 0, 20.0, 10.0, vec![]), // outside the length axis
            r(5, 0, 5.0, 10.0, vec![(0, 1)]),
            r(6, 0, 5.0, 10.0, vec![(0, 0)]), // drawn for bin 0 but lies in bin 1: nowhere
            r(7, 1, 0.5, 10.0, vec![]),
            r(8, 0, 5.0, 60.0, vec![(1, 1)]),
        ];
        let (a, _) = analyse(&case, &methods, &rows);
        let worst = |s: &BinStats| (s.count, s.rel.map(|q| q.max));
        for m in &a.methods {
            let (a0, a1) = (&m.materials[0], &m.materials[1]);
            assert_eq!(worst(&a0.all), (4, Some(0.5)), "{}", m.label);
            assert_eq!(worst(&a1.all), (1, Some(7.0 / 8.0)), "{}", m.label);
            let length = &a0.axes[0].bins;
            assert_eq!(worst(&length[0].stats), (1, Some(1.0 / 8.0)));
            assert_eq!(worst(&length[1].stats), (3, Some(5.0 / 8.0)));
            let elevation = &a0.axes[1].bins;
            assert_eq!(worst(&elevation[0].stats), (2, Some(0.5)));
            assert_eq!(worst(&elevation[1].stats), (3, Some(1.0)));
            assert_eq!(worst(&a1.axes[0].bins[0].stats), (1, Some(7.0 / 8.0)));
            assert_eq!(worst(&a1.axes[0].bins[1].stats), (0, None));
        }
        // The map draws only the first method; natural configurations only; cells[y][x].
        let map = &a.methods[0].materials[0].maps[0];
        assert_eq!(worst(&map.cells[0][0]), (1, Some(1.0 / 8.0)));
        assert_eq!(worst(&map.cells[1][1]), (2, Some(3.0 / 8.0)));
        assert_eq!((map.cells[0][1].count, map.cells[1][0].count), (0, 0));
        assert_eq!(
            worst(&a.methods[0].materials[1].maps[0].cells[0][0]),
            (1, Some(7.0 / 8.0))
        );
        assert!(a.methods[1].materials[0].maps[0].cells.is_empty());
        // The surface view's own rows follow the same placement.
        let own = &a.methods[1].materials[0];
        assert_eq!(worst(own.own_target.as_ref().unwrap()), (4, Some(0.5)));
        assert_eq!(worst(&own.own_axes[0].bins[1].stats), (3, Some(5.0 / 8.0)));
        assert_eq!(worst(&own.own_axes[1].bins[1].stats), (3, Some(1.0)));
    }

    #[test]
    fn pair_differences_by_hand() {
        let case = case(
            &["line.ltc2023", "line.ltc2017"],
            r#"compare = [["line.ltc2023", "line.ltc2017"]]"#,
        );
        let methods = methods(&case);
        let (l, u) = (Target::Line, Target::LineUpper);
        let pair = |refs_: &[(Target, f64)], a: (f32, Option<f64>), b: (f32, Option<f64>)| {
            row(refs_, vec![(a.0, None, a.1), (b.0, None, b.1)])
        };
        let rows = vec![
            // Against the own target `line` (2), not the surface view (1): 0.25 and 0.125.
            pair(&[(l, 2.0), (u, 1.0)], (1.5, Some(1.25)), (1.0, Some(1.0))),
            pair(&[(l, 1.0)], (0.5, None), (0.5, None)),
            // Zero reference, a NaN, no `line` reference: left out.
            pair(&[(l, 0.0)], (0.5, None), (0.0, None)),
            pair(&[(l, 1.0)], (f32::NAN, None), (1.0, None)),
            pair(&[(u, 1.0)], (1.0, None), (0.0, None)),
            // A non-finite f64 leaves the f64 difference out only: 0.75.
            pair(&[(l, 1.0)], (1.0, Some(f64::NAN)), (0.25, Some(0.0))),
            // A top-up of the second length bin: 0.5 there only.
            Row {
                sample: sample(0, 5.0, 10.0, vec![(0, 1)], false),
                ..pair(&[(l, 1.0)], (1.0, None), (0.5, None))
            },
            // A full M⁻¹, which `line.ltc2023` does not claim (both apply): left out.
            {
                let mut r = pair(&[(l, 1.0)], (4.0, Some(4.0)), (1.0, Some(1.0)));
                r.sample.config.material = Material::Ltc {
                    minv: [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                };
                r
            },
        ];
        for through_parts in [false, true] {
            let (a, _) = analyse_by(&case, &methods, &rows, through_parts);
            let c = &a.comparisons[0];
            assert_eq!((c.a.as_str(), c.b.as_str()), ("line.ltc2023", "line.ltc2017"));
            let all = &c.materials[0].all;
            let d32 = all.diff_f32.unwrap();
            assert_eq!((all.count, d32.median, d32.max), (3, 0.25, 0.75));
            let d64 = all.diff_f64.unwrap();
            assert_eq!((d64.median, d64.max), (0.125, 0.125));
            let length = &c.materials[0].axes[0];
            assert_eq!(length.axis, "length");
            assert_eq!((length.bins[0].lo, length.bins[0].hi), (0.1, 1.0));
            assert_eq!((length.bins[0].stats.count, length.bins[1].stats.count), (3, 1));
            assert_eq!(length.bins[1].stats.diff_f32.unwrap().max, 0.5);
            assert_eq!(c.materials[0].axes[1].bins[0].stats.count, 3);
            assert_eq!(c.materials[1].all.count, 0);
            assert_eq!(c.materials[1].material, "b");
        }
    }

    #[test]
    fn leaks_by_hand() {
        let case = case(&["line.ltc2023"], "");
        let methods = methods(&case);
        let (l, u) = (Target::Line, Target::LineUpper);
        let one = |refs_: &[(Target, f64)]| row(refs_, vec![(1.0, None, None)]);
        let mut rows = vec![
            one(&[(l, 1.0), (u, 0.75)]),      // 0.25
            one(&[(l, 2.0), (u, 1.0)]),       // 0.5
            one(&[(l, 1.0), (u, 1.0)]),       // 0
            one(&[(l, 1e6), (u, 999_999.0)]), // 1/1e6, exactly the double 1e-6: not past it
            one(&[(l, 1.0), (u, 1.25)]),      // more above than in all: 0
            one(&[(l, 4.0), (u, 3.0)]),       // 0.25
            one(&[(l, 1.0)]),                 // no surface view: not counted
        ];
        // Family b: only configurations without both references.
        rows.push(Row {
            sample: sample(1, 0.5, 10.0, Vec::new(), false),
            ..one(&[(u, 1.0)])
        });
        let (_, leak) = analyse(&case, &methods, &rows);
        assert_eq!(leak.len(), 1, "family b has no `line` configuration");
        let a = &leak[0];
        assert_eq!(a.material, "a");
        assert_eq!((a.configurations, a.leaking), (6, 3));
        assert_eq!((a.median_fraction, a.max_fraction), (0.25, 0.5));
        // No leaking configuration: 0 for both.
        let (_, leak) = analyse(&case, &methods, &rows[2..5]);
        assert_eq!(
            (
                leak[0].configurations,
                leak[0].leaking,
                leak[0].median_fraction,
                leak[0].max_fraction
            ),
            (3, 0, 0.0, 0.0)
        );
    }

    #[test]
    fn merging_parts_is_one_pass() {
        let extra = format!(
            "compare = [[\"line_isotropic.closest_point\", \"line_isotropic.closest_point_r2\"]]\n{JUDGED_EXTRA}\n{}",
            "[[maps]]\nx = { axis = \"length\", edges = [0.1, 1.0, 10.0] }\n\
             y = { axis = \"elevation\", edges = [0.0, 45.0, 90.0] }\n"
        );
        let case = case(
            &["line_isotropic.closest_point", "line_isotropic.closest_point_r2"],
            &extra,
        );
        let methods = methods(&case);
        let mut rows = judged_rows();
        for (k, r) in rows.iter_mut().enumerate() {
            // Spread over both families, both bins of each axis and a top-up; `line` and
            // `line_upper` references for the leak.
            r.sample.material = k % 2;
            r.sample.axes.length = if k % 3 == 0 { 5.0 } else { 0.5 };
            r.sample.axes.elevation = if k % 4 == 0 { 60.0 } else { 10.0 };
            if k == 7 {
                r.sample.strata = vec![(0, 0)];
            }
            r.refs.insert(Target::Line, Estimate { value: 1.0, error: 0.0 });
            r.refs.insert(
                Target::LineUpper,
                Estimate {
                    value: 1.0 - k as f64 / 16.0,
                    error: 0.0,
                },
            );
        }
        let one = analyse(&case, &methods, &rows);
        let (mut whole, mut leak) = (Accumulators::new(&case, &methods), LeakAccumulator::new(2));
        for part in [&rows[..5], &rows[5..6], &rows[6..]] {
            let (mut accs, mut l) = (Accumulators::new(&case, &methods), LeakAccumulator::new(2));
            fold(&case, &methods, part, &mut accs, &mut l);
            merge_each::<Fold, _>(std::slice::from_mut(&mut whole), std::slice::from_ref(&accs)).unwrap();
            <LeakAccumulator as Accumulate<Fold>>::merge(&mut leak, &l).unwrap();
        }
        assert_eq!(whole.configurations, rows.len());
        let merged = (whole.finish(&case, &methods), leak.finish(&case));
        let json = |x: &(Analysis, Vec<Leak>)| serde_json::to_string(x).unwrap();
        assert_eq!(json(&merged), json(&one));
        assert!(one.0.comparisons[0].materials[0].all.count > 0 && one.1[0].leaking > 0);
        // Parts that do not fit together.
        let other = case_with_pairs(&[]);
        let err = whole.merge(&Accumulators::new(&other, &methods)).unwrap_err();
        assert!(err.contains("different methods"), "{err}");
        let swapped: Vec<Method> = methods.iter().rev().cloned().collect();
        assert!(Accumulators::new(&case, &methods)
            .merge(&Accumulators::new(&case, &swapped))
            .is_err());
        let mut pairs = Accumulators::new(&case, &methods).pairs;
        let mut flipped = pairs.clone();
        (flipped[0].a, flipped[0].b) = (flipped[0].b, flipped[0].a);
        assert!(<PairAcc as Accumulate<(&Chunk, &[Placement])>>::merge(&mut pairs[0], &flipped[0]).is_err());
        let same = pairs[0].clone();
        assert!(<PairAcc as Accumulate<(&Chunk, &[Placement])>>::merge(&mut pairs[0], &same).is_ok());
        let mut m = Accumulators::new(&case, &methods).methods;
        let other = m[1].clone();
        type MethodIn<'a> = (&'a Case, &'a Chunk<'a>, &'a [Placement], &'a MethodRun);
        assert!(<MethodAcc as Accumulate<MethodIn>>::merge(&mut m[0], &other).is_err());
        let err = <LeakAccumulator as Accumulate<Fold>>::merge(&mut LeakAccumulator::new(2), &LeakAccumulator::new(3));
        assert!(err.is_err());
    }

    fn case_with_pairs(pairs: &[[&str; 2]]) -> Case {
        let compare: Vec<String> = pairs.iter().map(|[a, b]| format!("[\"{a}\", \"{b}\"]")).collect();
        case(
            &["line_isotropic.closest_point", "line_isotropic.closest_point_r2"],
            &format!("compare = [{}]", compare.join(", ")),
        )
    }

    #[test]
    fn statistics_size_counts_the_accumulators() {
        let extra = r#"
compare = [["line.ltc2023", "line.ltc2017"]]
[[maps]]
x = { axis = "length", edges = [0.1, 1.0, 10.0] }
y = { axis = "elevation", edges = [0.0, 30.0, 60.0, 90.0] }
methods = ["line.ltc2017"]
"#;
        let case = case(&["line_isotropic.closest_point", "line.ltc2023", "line.ltc2017"], extra);
        let methods = methods(&case);
        // 3 methods (2 with a surface view), 1 pair, 2 families, 2 axes of 2 bins (4 bins),
        // one map of 2 × 3 cells drawing 1 method. Per family: each method's 4 bins + all +
        // own or below (3·6), the surface views' own bins (2·4), the pair's bins + all (5),
        // the bins once (4): 35; ×2. Cells 6 × 2. Per configuration: each method's 2 axes +
        // 2 (3·4), own axes (2·2), the pair (3), the map (1): 20.
        assert_eq!(
            statistics_size(&case, &methods),
            crate::limits::StatisticsSize {
                bins: 70,
                map_cells: 12,
                per_configuration: 20,
            }
        );
    }

    #[test]
    fn verdicts_and_their_names() {
        let check = |pass| Check {
            method: "m".into(),
            material: "a".into(),
            what: "w".into(),
            limit: 1.0,
            measured: 0.5,
            pass,
            too_few: None,
        };
        assert_eq!(Verdict::of(&[]), Verdict::NoVerdict);
        // A quantile of too few configurations: no verdict, unless another check failed.
        let few = Check {
            pass: false,
            too_few: Some(1),
            ..check(true)
        };
        assert_eq!(Verdict::of(&[check(true), few.clone()]), Verdict::NoVerdict);
        assert_eq!(Verdict::of(&[few, check(false)]), Verdict::Fail);
        assert_eq!(Verdict::of(&[check(true), check(true)]), Verdict::Pass);
        assert_eq!(Verdict::of(&[check(true), check(false)]), Verdict::Fail);
        assert_eq!(Verdict::of(&[check(false), check(true)]), Verdict::Fail);
        let names = [Verdict::Pass, Verdict::Fail, Verdict::NoVerdict].map(Verdict::name);
        assert_eq!(names, ["PASS", "FAIL", "no verdict"]);
        assert_eq!(headline_target(Target::Cylinder), Target::CylinderUpper);
        assert_eq!(headline_target(ISO), ISO);
        assert_eq!(
            BinStatsRef::Bin {
                axis: "length".into(),
                lo: 0.1
            }
            .to_string(),
            "of `length` with lower edge 0.1"
        );
        // A case without tolerances has no checks and no verdict.
        assert_eq!(case_iso().verdict, Verdict::NoVerdict);
    }

    #[test]
    fn a_reference_exactly_at_the_floor_is_not_below_it() {
        // The segment is at distance 1, so the floor of `line_isotropic` is the default 1e-6
        // exactly: a reference of 1e-6 is not below it, one of 5e-7 is.
        let case = case(&["line_isotropic.closest_point"], "");
        let methods = methods(&case);
        let rows = vec![
            row(&[(ISO, 1e-6)], vec![(1.5e-6, None, None)]),
            row(&[(ISO, 5e-7)], vec![(1e-6, None, None)]),
        ];
        let (a, _) = analyse(&case, &methods, &rows);
        let s = &a.methods[0].materials[0].all;
        assert_eq!((s.count, s.below_floor), (2, 1));
    }

    #[test]
    fn a_bin_folds_and_merges_judged_configurations_through_the_trait() {
        // `Accumulate<Judged>` must do what `push` and the inherent merge do: a lit
        // configuration 0.25 off, a missed one (rel 1) in another part, and a false light.
        let lit = |v: f32| Judged::Lit {
            gpu: Outcome::of_f32(v, 1.0, 1e-6),
            cpu: None,
            f64: None,
            reference_rel: 0.0,
            below_floor: false,
            dark: (v == 0.0, false),
            reference: 1.0,
            input_rounding: None,
        };
        let mut a = BinAccumulator::default();
        Accumulate::<Judged>::add(&mut a, lit(1.25));
        Accumulate::<Judged>::add(&mut a, Judged::Zero { gpu: 0.5, f64: None });
        let mut b = BinAccumulator::default();
        Accumulate::<Judged>::add(&mut b, lit(0.0));
        <BinAccumulator as Accumulate<Judged>>::merge(&mut a, &b).unwrap();
        let s = a.finish();
        assert_eq!((s.count, s.dark), (2, 1));
        let rel = s.rel.unwrap();
        assert_eq!((rel.median, rel.max), (0.25, 1.0));
        assert_eq!((s.false_light.configurations, s.false_light.lit), (1, 1));
    }

    #[test]
    fn a_pair_bin_folds_and_merges_through_the_trait() {
        // Differences 0.25 (f64 0.125) and 0.5 (no f64) in one part, 0.75 (f64 0.5) in another.
        let mut a = PairAccumulator::default();
        Accumulate::add(&mut a, (0.25, Some(0.125)));
        Accumulate::add(&mut a, (0.5, None));
        let mut b = PairAccumulator::default();
        Accumulate::add(&mut b, (0.75, Some(0.5)));
        Accumulate::merge(&mut a, &b).unwrap();
        let s = a.finish();
        assert_eq!(s.count, 3);
        let d32 = s.diff_f32.unwrap();
        assert_eq!((d32.median, d32.max), (0.5, 0.75));
        // Nearest rank of two: the lower.
        let d64 = s.diff_f64.unwrap();
        assert_eq!((d64.median, d64.max), (0.125, 0.5));
    }

    #[test]
    fn the_nan_inf_check_counts_nans_infinities_and_non_finite_false_light() {
        // One NaN and one +inf against references of 1, and one +inf where the reference is 0:
        // three non-finite values, none cancelling another (and one exact value, so that the
        // family has something to judge).
        let case = case(
            &["line_isotropic.closest_point"],
            "[tolerances.\"line_isotropic.closest_point\"]\nnan = 2\n",
        );
        let methods = methods(&case);
        let rows = vec![
            row(&[(ISO, 1.0)], vec![(1.0, None, None)]),
            row(&[(ISO, 1.0)], vec![(f32::NAN, None, None)]),
            row(&[(ISO, 1.0)], vec![(f32::INFINITY, None, None)]),
            row(&[(ISO, 0.0)], vec![(f32::INFINITY, None, None)]),
        ];
        let (a, _) = analyse(&case, &methods, &rows);
        let s = &a.methods[0].materials[0].all;
        assert_eq!((s.nan, s.inf, s.false_light.nonfinite), (1, 1, 1));
        let c = a
            .checks
            .iter()
            .find(|c| c.material == "a" && c.what == "NaN/inf count")
            .unwrap();
        assert_eq!((c.limit, c.measured, c.pass), (2.0, 3.0, false));
    }
}

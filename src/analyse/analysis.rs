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

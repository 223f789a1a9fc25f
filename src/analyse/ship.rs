//! The answer a user opens a report for (docs/statistics.md, "What to ship"): per material, the
//! cheapest method that meets the case's budget over the whole scene; the regions (bins) where
//! the shipped method does not meet it, and which method, if any, does there; and what each
//! choice costs. Computed from the analysis and the measured costs, never typed. Pure.

use crate::analyse::analysis::{Analysis, AxisStats, MethodStats};
use crate::analyse::bench::Cost;
use crate::analyse::stats::{BinStats, Bound, BOUND_CONFIDENCE};
use crate::input::case::Budget;
use crate::input::target::Target;
use serde::Serialize;

/// The case's budget with its target resolved: what every method is judged against.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShipBudget {
    pub statistic: String,
    pub quantile: f64,
    pub value: f64,
    pub target: Target,
    pub min_count: usize,
    pub cost_matters: bool,
    /// The confidence of the upper bound of the quantile (`stats::BOUND_CONFIDENCE`).
    pub confidence: f64,
    /// False when the case has no `[budget]` and the default holds.
    pub stated: bool,
}

/// The surface-clipped target of a method's own target (what a real surface receives), where
/// the target has one other than itself (`line` → `line_upper`, `cylinder` →
/// `cylinder_upper`, …): the headline's target (`analysis::headline_target`).
pub fn surface_target(own: Target) -> Option<Target> {
    own.upper().filter(|&u| u != own)
}

/// Whether a method of target `own` is judged against `target`: its own, or its surface view.
pub fn judged_against(own: Target, target: Target) -> bool {
    own == target || surface_target(own) == Some(target)
}

impl ShipBudget {
    /// `budget` with its target resolved: the stated one, or else the first method's headline
    /// target (clipped to the surface where it can be). None when there is no method.
    pub fn resolve(budget: &Budget, stated: bool, analysis: &Analysis) -> Option<ShipBudget> {
        let target = budget.target.or_else(|| Some(analysis.methods.first()?.judged))?;
        Some(ShipBudget {
            statistic: budget.statistic.clone(),
            quantile: budget.quantile,
            value: budget.value,
            target,
            min_count: budget.min_count,
            cost_matters: budget.cost_matters,
            confidence: BOUND_CONFIDENCE,
            stated,
        })
    }

    /// "p99", "p99.9", "p50".
    pub fn quantile_name(&self) -> String {
        format!("p{}", (self.quantile * 1e8).round() / 1e6)
    }
}

/// A method's results on one material judged against the budget's target: the whole material
/// and every bin.
#[derive(Clone, Copy, Debug)]
pub struct JudgedView<'a> {
    pub target: Target,
    pub all: &'a BinStats,
    pub axes: &'a [AxisStats],
}

/// The one place that says which of a method's views the budget reads: the headline (its
/// surface view, or its own target where it has none) when that is the budget's target, its
/// own-target view when that is. None when the method is judged against neither (it computes
/// something else, and is not a candidate).
pub fn judged_view<'a>(method: &'a MethodStats, material: usize, budget: &ShipBudget) -> Option<JudgedView<'a>> {
    let mat = method.materials.get(material)?;
    if method.judged == budget.target {
        return Some(JudgedView {
            target: method.judged,
            all: &mat.all,
            axes: &mat.axes,
        });
    }
    if method.target == budget.target {
        return Some(JudgedView {
            target: method.target,
            all: mat.own_target.as_ref()?,
            axes: &mat.own_axes,
        });
    }
    None
}

/// Whether a region meets the budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Meets {
    Meets,
    Breaks,
    /// Fewer configurations than `min_count`, or too few for the bound at its confidence.
    TooFew,
}

/// One method in one region against the budget.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Judgement {
    /// Configurations judged (zero references included).
    pub n: usize,
    /// The upper confidence bound of the quantile.
    pub bound: Bound,
    /// The plain nearest-rank quantile (None: infinite, a false light or NaN).
    pub point: Option<f64>,
    pub meets: Meets,
}

/// A region's statistics against the budget.
pub fn judge(stats: &BinStats, budget: &ShipBudget) -> Judgement {
    let (n, bound, point) = stats.bound.map_or((stats.configurations(), Bound::TooFew, None), |b| {
        (b.n, b.bound, b.point)
    });
    let meets = if n < budget.min_count || bound == Bound::TooFew {
        Meets::TooFew
    } else if bound.within(budget.value) {
        Meets::Meets
    } else {
        Meets::Breaks
    };
    Judgement { n, bound, point, meets }
}

/// Input rounding alone breaks the budget in a region: its quantile at the budget's exceeds
/// the budget's value, so no f32 kernel fed the configuration rounded to f32 can meet it.
pub fn unattainable_in_f32(stats: &BinStats, budget: &ShipBudget) -> bool {
    stats.input_rounding_at_budget.is_some_and(|x| x > budget.value)
}

/// What a method costs: the op count of the cost model (`eval::cost`, `total`), which ranks,
/// and the ns per evaluation measured on this run's adapter, shown beside it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Price {
    pub ops: Option<u64>,
    /// Median GPU ns per evaluation measured in this run (lavapipe is a software driver: its ns
    /// rank methods on a CPU, not on a GPU).
    pub measured_ns: Option<f64>,
}

/// A method that may be shipped for a material: judged against the budget's target.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Candidate {
    pub label: String,
    /// The view judged (the method's own target, or its surface-clipped one).
    pub judged_against: Target,
    pub price: Price,
    pub whole: Judgement,
    /// Over the whole material: configurations whose reference is 0 that it lights (or gives
    /// NaN), and lit ones where it gives NaN or ±inf; each an infinite error in the statistic.
    pub false_light: usize,
    pub nonfinite: usize,
    /// Regions (bins of every axis) where it meets the budget, breaks it, or cannot be told.
    pub regions_met: usize,
    pub regions_broken: usize,
    pub regions_too_few: usize,
}

/// Another method that meets the budget in a region where the shipped one does not.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Instead {
    pub label: String,
    pub price: Price,
    pub judgement: Judgement,
}

/// A region (one bin of one axis) where the shipped method does not meet the budget.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Region {
    pub axis: String,
    pub lo: f64,
    pub hi: f64,
    /// The shipped method there.
    pub shipped: Judgement,
    /// The first candidate (in the ranking's order) that meets the budget there, if any.
    pub instead: Option<Instead>,
    /// The input rounding there (|reference at f32 inputs − reference| / |reference|) at the
    /// budget's quantile, where measured.
    pub input_rounding: Option<f64>,
    /// Input rounding alone breaks the budget there: no f32 kernel can meet it ("unattainable
    /// in f32").
    pub unattainable_in_f32: bool,
}

/// The answer for one material.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShipMaterial {
    pub material: String,
    /// Every candidate, in the ranking's order (cheapest first when cost matters).
    pub candidates: Vec<Candidate>,
    /// The first candidate that meets the budget over the whole material (its natural sample).
    pub meets_everywhere: Option<String>,
    /// What to ship: `meets_everywhere`, or when none does, the candidate that meets the budget
    /// in the most regions (ties: the ranking's order). None without candidates.
    pub ship: Option<String>,
    /// The regions where `ship` breaks the budget or cannot be told, with who meets it there.
    pub regions: Vec<Region>,
    /// Methods not judged against the budget's target on this material (another target, or a
    /// material they do not claim to handle).
    pub not_candidates: Vec<String>,
}

/// The "What to ship" answer of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Ship {
    pub budget: ShipBudget,
    pub materials: Vec<ShipMaterial>,
}

fn price(label: &str, costs: &[Cost]) -> Price {
    let c = costs.iter().find(|c| c.label == label);
    Price {
        ops: c.and_then(|c| c.ops.as_ref()).map(|o| o.total),
        measured_ns: c.map(|c| c.ns_per_eval_median),
    }
}

/// The ranking: by op count when cost matters (an unknown count last), else by the whole
/// material's bound (most accurate first) then op count; the label breaks ties, so the order
/// never depends on a timing.
fn rank_key(c: &Candidate, cost_matters: bool) -> (f64, f64, String) {
    let ops = c.price.ops.map_or(f64::INFINITY, |o| o as f64);
    if cost_matters {
        (ops, 0.0, c.label.clone())
    } else {
        (c.whole.bound.sort_key(), ops, c.label.clone())
    }
}

/// The answer for every material of `analysis`, judged against `budget`, priced by `costs`.
pub fn choose(budget: &ShipBudget, analysis: &Analysis, costs: &[Cost]) -> Ship {
    let materials = analysis.methods.first().map_or(0, |m| m.materials.len());
    let materials = (0..materials)
        .map(|k| choose_material(budget, analysis, costs, k))
        .collect();
    Ship {
        budget: budget.clone(),
        materials,
    }
}

fn choose_material(budget: &ShipBudget, analysis: &Analysis, costs: &[Cost], k: usize) -> ShipMaterial {
    let mut views = Vec::new();
    let mut not_candidates = Vec::new();
    for m in &analysis.methods {
        match judged_view(m, k, budget).filter(|_| m.materials[k].supported) {
            Some(v) => views.push((m, v)),
            None => not_candidates.push(m.label.clone()),
        }
    }
    let mut ranked: Vec<(Candidate, JudgedView)> = views
        .into_iter()
        .map(|(m, v)| {
            let bins = v.axes.iter().flat_map(|a| &a.bins).map(|b| judge(&b.stats, budget));
            let (mut met, mut broken, mut few) = (0, 0, 0);
            for j in bins {
                match j.meets {
                    Meets::Meets => met += 1,
                    Meets::Breaks => broken += 1,
                    Meets::TooFew => few += 1,
                }
            }
            let c = Candidate {
                label: m.label.clone(),
                judged_against: v.target,
                price: price(&m.label, costs),
                whole: judge(v.all, budget),
                false_light: v.all.false_light.lit + v.all.false_light.nonfinite,
                nonfinite: v.all.nan + v.all.inf,
                regions_met: met,
                regions_broken: broken,
                regions_too_few: few,
            };
            (c, v)
        })
        .collect();
    ranked.sort_by(|(a, _), (b, _)| {
        let (x, y) = (rank_key(a, budget.cost_matters), rank_key(b, budget.cost_matters));
        x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2))
    });
    let meets_everywhere = ranked.iter().position(|(c, _)| c.whole.meets == Meets::Meets);
    // Most regions met (at least one); `max_by_key` keeps the last of equals, so walk the
    // ranking backwards.
    let shipped = meets_everywhere.or_else(|| {
        (0..ranked.len())
            .rev()
            .max_by_key(|&i| ranked[i].0.regions_met)
            .filter(|&i| ranked[i].0.regions_met > 0)
    });
    let mut regions = Vec::new();
    if let Some(s) = shipped {
        let view = ranked[s].1;
        for (a, axis) in view.axes.iter().enumerate() {
            for (b, bin) in axis.bins.iter().enumerate() {
                let shipped = judge(&bin.stats, budget);
                if shipped.meets == Meets::Meets || shipped.n == 0 {
                    continue;
                }
                let instead = ranked.iter().find_map(|(c, v)| {
                    let j = judge(&v.axes.get(a)?.bins.get(b)?.stats, budget);
                    (j.meets == Meets::Meets).then(|| Instead {
                        label: c.label.clone(),
                        price: c.price.clone(),
                        judgement: j,
                    })
                });
                let input_rounding = bin.stats.input_rounding_at_budget;
                regions.push(Region {
                    axis: axis.axis.clone(),
                    lo: bin.lo,
                    hi: bin.hi,
                    shipped,
                    instead,
                    input_rounding,
                    unattainable_in_f32: unattainable_in_f32(&bin.stats, budget),
                });
            }
        }
    }
    ShipMaterial {
        material: analysis
            .methods
            .first()
            .map_or(String::new(), |m| m.materials[k].material.clone()),
        meets_everywhere: meets_everywhere.map(|i| ranked[i].0.label.clone()),
        ship: shipped.map(|i| ranked[i].0.label.clone()),
        candidates: ranked.into_iter().map(|(c, _)| c).collect(),
        regions,
        not_candidates,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analyse::analysis::{Bin, MaterialStats, Verdict};
    use crate::analyse::stats::{BinAccumulator, Outcome};

    /// A bin's statistics from relative errors (references 1) and `zeros` exact zeros.
    fn stats(errors: &[(usize, f64)], zeros: usize, q: f64) -> BinStats {
        let mut acc = BinAccumulator::default();
        for &(n, e) in errors {
            for _ in 0..n {
                acc.push_gpu(Outcome::of_f32((1.0 + e) as f32, 1.0, 1e-6));
            }
        }
        for _ in 0..zeros {
            acc.push_zero(0.0, Some(0.0));
        }
        acc.finish_bounded(q)
    }

    /// A method on one material with axis `reach` of bins [0, 10), [10, 100), [100, 1000).
    fn method(label: &str, target: Target, all: BinStats, bins: [BinStats; 3]) -> MethodStats {
        let edges = [0.0, 10.0, 100.0, 1000.0];
        let axes = vec![AxisStats {
            axis: "reach".into(),
            bins: bins
                .into_iter()
                .enumerate()
                .map(|(k, stats)| Bin {
                    lo: edges[k],
                    hi: edges[k + 1],
                    stats,
                })
                .collect(),
        }];
        MethodStats {
            label: label.into(),
            describe: label.into(),
            id: label.into(),
            target,
            judged: target,
            source: String::new(),
            kernel: String::new(),
            has_f64: true,
            materials: vec![MaterialStats {
                material: "diffuse".into(),
                supported: true,
                all,
                axes,
                maps: Vec::new(),
                own_target: None,
                own_axes: Vec::new(),
                wholly_below: None,
            }],
        }
    }

    fn cost(label: &str, ops: u64, ns: f64) -> Cost {
        Cost {
            label: label.into(),
            clock: "gpu-timestamp".into(),
            configurations: 1,
            cpu_configurations: 1,
            repeats: 1,
            ns_per_eval_median: ns,
            ns_per_eval_min: ns,
            ns_per_eval_max: ns,
            configs_per_second: 1e9 / ns,
            cpu_f32_ns_per_eval: None,
            gpu_cpu_speed_ratio: None,
            ops: Some(crate::eval::cost::OpCount {
                total: ops,
                ..Default::default()
            }),
            ops_error: None,
            gpu_ns_per_eval: vec![ns],
            cpu_f32_ns_per_eval_runs: Vec::new(),
            envelope_ns_per_config: None,
            envelope_over_cpu_f32: None,
            envelope_configurations: None,
            envelope_ns_per_config_runs: Vec::new(),
            envelope_error: None,
            cpu_engine: String::new(),
            interp_f32_ns_per_eval: None,
            compiled_speedup: None,
            interp_f32_ns_per_eval_runs: Vec::new(),
            settled: false,
        }
    }

    fn budget(cost_matters: bool) -> ShipBudget {
        ShipBudget::resolve(
            &Budget {
                target: Some(Target::Line),
                cost_matters,
                ..Budget::default()
            },
            true,
            &Analysis {
                methods: Vec::new(),
                comparisons: Vec::new(),
                checks: Vec::new(),
                verdict: Verdict::NoVerdict,
            },
        )
        .unwrap()
    }

    /// The known answer: `cheap` meets p99 ≤ 1e-2 over the whole scene, where the far region is
    /// rare (20 of 10000 natural configurations), but not in that region once it is topped up
    /// to 500; `dear` meets it there too; `cheapest` meets it nowhere; `tube` computes another
    /// target. The region [100, 1000) has too few configurations for anyone.
    fn run() -> Analysis {
        let q = 0.99;
        let methods = vec![
            method(
                "cheap",
                Target::Line,
                stats(&[(9980, 1e-3), (20, 0.5)], 0, q),
                [
                    stats(&[(9980, 1e-3)], 0, q),
                    stats(&[(500, 0.5)], 0, q),
                    stats(&[(50, 1e-3)], 0, q),
                ],
            ),
            method(
                "dear",
                Target::Line,
                stats(&[(10_000, 1e-4)], 0, q),
                [
                    stats(&[(9980, 1e-4)], 0, q),
                    stats(&[(500, 1e-4)], 0, q),
                    stats(&[(50, 1e-4)], 0, q),
                ],
            ),
            method(
                "cheapest",
                Target::Line,
                stats(&[(10_000, 0.2)], 0, q),
                [
                    stats(&[(9980, 0.2)], 0, q),
                    stats(&[(500, 0.2)], 0, q),
                    stats(&[(50, 0.2)], 0, q),
                ],
            ),
            method(
                "tube",
                Target::Tube,
                stats(&[(10_000, 0.0)], 0, q),
                [stats(&[], 0, q), stats(&[], 0, q), stats(&[], 0, q)],
            ),
        ];
        Analysis {
            methods,
            comparisons: Vec::new(),
            checks: Vec::new(),
            verdict: Verdict::NoVerdict,
        }
    }

    fn costs() -> Vec<Cost> {
        vec![
            cost("cheap", 200, 40.0),
            cost("dear", 20_000, 900.0),
            cost("cheapest", 100, 30.0),
            cost("tube", 10, 5.0),
        ]
    }

    #[test]
    fn the_cheapest_that_meets_it_everywhere_with_the_region_it_breaks_and_who_meets_it_there() {
        let ship = choose(&budget(true), &run(), &costs());
        let m = &ship.materials[0];
        let order: Vec<&str> = m.candidates.iter().map(|c| c.label.as_str()).collect();
        assert_eq!(order, ["cheapest", "cheap", "dear"]);
        assert_eq!(m.not_candidates, ["tube"]);
        assert_eq!(m.meets_everywhere.as_deref(), Some("cheap"));
        assert_eq!(m.ship.as_deref(), Some("cheap"));
        let broken: Vec<&Region> = m.regions.iter().filter(|r| r.shipped.meets == Meets::Breaks).collect();
        assert_eq!(broken.len(), 1);
        let r = broken[0];
        assert_eq!((r.axis.as_str(), r.lo, r.hi), ("reach", 10.0, 100.0));
        let instead = r.instead.as_ref().unwrap();
        assert_eq!(instead.label, "dear");
        assert_eq!(instead.price.ops, Some(20_000));
        assert!(instead.judgement.bound.within(1e-2));
        // The rare region: 50 configurations, fewer than min_count, cannot be told.
        let few: Vec<&Region> = m.regions.iter().filter(|r| r.shipped.meets == Meets::TooFew).collect();
        assert_eq!((few.len(), few[0].lo, few[0].instead.is_none()), (1, 100.0, true));
        let cheap = &m.candidates[1];
        assert_eq!(
            (cheap.regions_met, cheap.regions_broken, cheap.regions_too_few),
            (1, 1, 1)
        );
        assert_eq!(
            cheap.price,
            Price {
                ops: Some(200),
                measured_ns: Some(40.0)
            }
        );
    }

    #[test]
    fn without_cost_the_most_accurate_that_meets_it() {
        let ship = choose(&budget(false), &run(), &costs());
        let m = &ship.materials[0];
        assert_eq!(m.ship.as_deref(), Some("dear"));
        assert!(m.regions.iter().all(|r| r.shipped.meets == Meets::TooFew));
    }

    #[test]
    fn when_none_meets_it_everywhere_the_one_meeting_it_in_most_regions() {
        let mut a = run();
        // `dear` is gone; `cheap` breaks over the whole material too now.
        a.methods.remove(1);
        a.methods[0].materials[0].all = stats(&[(9000, 1e-3), (1000, 0.5)], 0, 0.99);
        let ship = choose(&budget(true), &a, &costs());
        let m = &ship.materials[0];
        assert_eq!(m.meets_everywhere, None);
        assert_eq!(m.ship.as_deref(), Some("cheap"));
        let r = m.regions.iter().find(|r| r.shipped.meets == Meets::Breaks).unwrap();
        assert_eq!((r.lo, r.instead.is_none()), (10.0, true));
        // And with no one meeting it anywhere, nothing is shipped.
        a.methods.remove(0);
        let m = &choose(&budget(true), &a, &costs()).materials[0];
        assert_eq!((m.ship.as_deref(), m.regions.len()), (None, 0));
    }

    #[test]
    fn the_budget_reads_the_surface_view_of_a_line_method() {
        let mut a = run();
        // `cheap` as a method with a surface view: its headline against `line_upper`, where it
        // lights 200 configurations the surface receives nothing from (an infinite error past
        // the p99); the view run() gave it becomes its own-target view (against `line`).
        let q = 0.99;
        let m = &mut a.methods[0];
        m.judged = Target::LineUpper;
        let mat = &mut m.materials[0];
        mat.own_target = Some(mat.all.clone());
        // Its surface view has no bins in this constructed run: it meets the budget nowhere.
        mat.own_axes = std::mem::take(&mut mat.axes);
        mat.all = {
            let mut acc = BinAccumulator::default();
            for _ in 0..9800 {
                acc.push_gpu(Outcome::of_f32(1.0, 1.0, 1e-6));
            }
            for _ in 0..200 {
                acc.push_zero(0.1, Some(0.1));
            }
            acc.finish_bounded(q)
        };
        // A budget stated against `line` reads the own-target view: the answer is unchanged.
        let own = &choose(&budget(true), &a, &costs()).materials[0];
        assert_eq!(own.ship.as_deref(), Some("cheap"));
        assert_eq!(own.candidates[1].judged_against, Target::Line);
        let mut b = budget(true);
        b.target = Target::LineUpper;
        let m = &choose(&b, &a, &costs()).materials[0];
        let cheap = m.candidates.iter().find(|c| c.label == "cheap").unwrap();
        assert_eq!(
            (cheap.judged_against, cheap.whole.bound, cheap.false_light),
            (Target::LineUpper, Bound::Infinite, 200)
        );
        // The others have no `line_upper` view in this constructed run: not candidates.
        assert_eq!(m.candidates.len(), 1);
        assert_eq!(m.ship, None);
        // The default target: the first method's headline, clipped to the surface.
        let d = ShipBudget::resolve(&Budget::default(), false, &a).unwrap();
        assert_eq!(
            (d.target, d.quantile_name().as_str(), d.stated),
            (Target::LineUpper, "p99", false)
        );
    }

    #[test]
    fn a_region_where_input_rounding_alone_breaks_the_budget_is_unattainable_in_f32() {
        let mut a = run();
        a.methods.truncate(1);
        let q = 0.99;
        // `cheap` breaks p99 <= 1e-2 in [10, 100); there the reference at the f32-rounded
        // inputs is 5 % away from the exact one on 10 % of the lights (above the budget at p99),
        // and 1e-4 away in [0, 10).
        let bin = |errors: &[(usize, f64)], rounding: &[(usize, f64)]| {
            let mut acc = BinAccumulator::default();
            for &(n, e) in errors {
                for _ in 0..n {
                    acc.push_gpu(Outcome::of_f32((1.0 + e) as f32, 1.0, 1e-6));
                }
            }
            for &(n, r) in rounding {
                for _ in 0..n {
                    acc.push_input_rounding(r);
                }
            }
            acc.finish_bounded(q)
        };
        let axes = &mut a.methods[0].materials[0].axes[0].bins;
        axes[0].stats = bin(&[(9980, 1e-3)], &[(9980, 1e-4)]);
        axes[1].stats = bin(&[(500, 0.5)], &[(450, 1e-6), (50, 0.05)]);
        assert_eq!(axes[1].stats.input_rounding.unwrap().max, 0.05);
        let m = &choose(&budget(true), &a, &costs()).materials[0];
        let r = m.regions.iter().find(|r| r.lo == 10.0).unwrap();
        assert_eq!(r.shipped.meets, Meets::Breaks);
        assert_eq!((r.input_rounding, r.unattainable_in_f32), (Some(0.05), true));
        // Where input rounding is within the budget the region is not so labelled, and where it
        // was not measured there is no input-rounding figure at all.
        let few = m.regions.iter().find(|r| r.lo == 100.0).unwrap();
        assert_eq!((few.input_rounding, few.unattainable_in_f32), (None, false));
        let near = &a.methods[0].materials[0].axes[0].bins[0].stats;
        assert!(!unattainable_in_f32(near, &budget(true)));
        assert_eq!(near.input_rounding_at_budget, Some(1e-4));
    }
}

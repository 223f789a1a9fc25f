//! Findings computed from the data. A claim (`[[claims]]` in a case file) is an expectation
//! over this run's analysis, e.g.
//! `p99("line.ltc2023", "diffuse") > 100 * p99("line.ltc2017", "diffuse")`, and an explanation
//! whose `{expression}` placeholders are filled in from the run. A claim whose expectation does
//! not hold is STALE: printed at the top of the report, and the sweep exits with status 3.
//!
//! Expressions are Rhai (a maintained embedded language; only expressions, no statements) over
//! the functions registered here; `docs/claims.md` lists them. Pure: no I/O, no measuring.

use crate::analyse::analysis::{Analysis, BinStatsRef, MaterialStats, MethodStats, PairMaterial};
use crate::analyse::bench::Cost;
use crate::analyse::bench::{cpu_time_ratio, gpu_time_ratio};
use crate::analyse::stats::{BinStats, Quantiles};
use crate::input::case::{Case, ClaimSpec};
use crate::measure::search::Disagreement;
use rhai::{Dynamic, Engine, EvalAltResult, ImmutableString};
use serde::Serialize;
use std::rc::Rc;

/// One claim as this run found it.
#[derive(Clone, Debug, Serialize)]
pub struct ClaimResult {
    pub id: String,
    pub expect: String,
    /// The expectation holds in this run.
    pub holds: bool,
    /// Why the expectation could not be evaluated (an unknown name, a missing statistic).
    pub error: Option<String>,
    /// The explanation with its numbers from this run.
    pub text: String,
}

/// What the claims may read: the analysis, the measured costs, the disagreements found, and
/// the names they may use. With `analysis` None the functions only check names (a dry run
/// before measuring, so a misspelt method is bad input, not a stale claim).
pub struct Facts {
    pub labels: Vec<String>,
    pub materials: Vec<String>,
    pub axes: Vec<String>,
    /// Each bin axis's edges (`[[bins]]`), so a claim on a lower edge that no bin has is bad
    /// input before measuring, not a stale claim after.
    pub edges: Vec<(String, Vec<f64>)>,
    pub configurations: usize,
    pub analysis: Option<Analysis>,
    pub costs: Vec<Cost>,
    pub disagreements: Vec<Disagreement>,
    pub found: Vec<crate::measure::search::Found>,
    /// The case's budget and whether the case states it (for `shipped`).
    pub budget: crate::input::case::Budget,
    pub budget_stated: bool,
}

type Fail = Box<EvalAltResult>;

fn fail<T>(message: String) -> Result<T, Fail> {
    Err(message.into())
}

impl Facts {
    fn method(&self, label: &str) -> Result<Option<&MethodStats>, Fail> {
        if !self.labels.iter().any(|l| l == label) {
            return fail(format!(
                "no method `{label}` in this case (methods: {})",
                self.labels.join(", ")
            ));
        }
        Ok(self
            .analysis
            .as_ref()
            .and_then(|a| a.methods.iter().find(|m| m.label == label)))
    }

    fn check_material(&self, material: &str) -> Result<(), Fail> {
        if !self.materials.iter().any(|m| m == material) {
            return fail(format!(
                "no material `{material}` in this case (materials: {})",
                self.materials.join(", ")
            ));
        }
        Ok(())
    }

    fn check_axis(&self, axis: &str) -> Result<(), Fail> {
        if !self.axes.iter().any(|a| a == axis) {
            return fail(format!(
                "no bin axis `{axis}` in this case (axes: {})",
                self.axes.join(", ")
            ));
        }
        Ok(())
    }

    /// Refuses a bin lower edge that no bin of `axis` has (the last edge is an upper edge only).
    fn check_lower_edge(&self, axis: &str, lo: f64) -> Result<(), Fail> {
        let lowers: Vec<f64> = self
            .edges
            .iter()
            .filter(|(a, _)| a == axis)
            .flat_map(|(_, e)| e[..e.len().saturating_sub(1)].iter().copied())
            .collect();
        if lowers.contains(&lo) {
            return Ok(());
        }
        let shown: Vec<String> = lowers
            .iter()
            .take(crate::limits::MAX_ERRORS)
            .map(|x| x.to_string())
            .collect();
        let more = if lowers.len() > shown.len() { ", …" } else { "" };
        fail(format!(
            "no bin of `{axis}` has the lower edge {lo} in this case (its lower edges: {}{more})",
            shown.join(", ")
        ))
    }

    /// A method's statistics on a material; None in a dry run.
    fn material(&self, label: &str, material: &str) -> Result<Option<&MaterialStats>, Fail> {
        self.check_material(material)?;
        Ok(self
            .method(label)?
            .and_then(|m| m.materials.iter().find(|x| x.material == material)))
    }

    /// Statistic `f` of a method's bins selected by `which`.
    fn stat(
        &self,
        label: &str,
        material: &str,
        which: &BinStatsRef,
        f: &dyn Fn(&BinStats) -> Option<f64>,
    ) -> Result<f64, Fail> {
        if let BinStatsRef::Bin { axis, lo } | BinStatsRef::OwnBin { axis, lo } = which {
            self.check_axis(axis)?;
            self.check_lower_edge(axis, *lo)?;
        }
        let Some(mat) = self.material(label, material)? else {
            return Ok(1.0);
        };
        let Some(s) = mat.select(which) else {
            return fail(format!("`{label}` on `{material}`: no bin {which}"));
        };
        Ok(f(s).unwrap_or(f64::NAN))
    }

    fn pair(&self, a: &str, b: &str, material: &str) -> Result<Option<&PairMaterial>, Fail> {
        self.method(a)?;
        self.method(b)?;
        self.check_material(material)?;
        let Some(analysis) = &self.analysis else {
            return Ok(None);
        };
        let c = analysis
            .comparisons
            .iter()
            .find(|c| (c.a == a && c.b == b) || (c.a == b && c.b == a));
        match c {
            Some(c) => Ok(c.materials.iter().find(|m| m.material == material)),
            None => fail(format!("[{a}, {b}] is not a compared pair of this case")),
        }
    }

    /// The disagreements found where `a` is less accurate than `b` on `material`, best first.
    fn disagreements(&self, a: &str, b: &str, material: &str) -> Result<Option<Vec<&Disagreement>>, Fail> {
        if self.pair(a, b, material)?.is_none() && self.analysis.is_none() {
            return Ok(None);
        }
        let mut d: Vec<&Disagreement> = self
            .disagreements
            .iter()
            .filter(|d| d.a == a && d.b == b && d.family == material)
            .collect();
        d.sort_by(|x, y| y.ratio.total_cmp(&x.ratio));
        Ok(Some(d))
    }

    fn cost(&self, label: &str) -> Result<Option<&Cost>, Fail> {
        self.method(label)?;
        if self.analysis.is_none() {
            return Ok(None);
        }
        match self.costs.iter().find(|c| c.label == label) {
            Some(c) => Ok(Some(c)),
            None => fail(format!("no cost measured for `{label}`")),
        }
    }
}

fn q(f: fn(&Quantiles) -> f64) -> impl Fn(Option<Quantiles>) -> Option<f64> {
    move |x| x.map(|q| f(&q))
}

/// Formats a value for a finding: integers with thousands separators, other numbers with two
/// significant digits, strings as they are.
pub fn format_value(v: &Dynamic) -> String {
    if let Some(s) = v.clone().try_cast::<ImmutableString>() {
        return s.to_string();
    }
    if let Ok(i) = v.as_int() {
        return group(i);
    }
    if let Ok(x) = v.as_float() {
        return format_number(x);
    }
    if let Ok(b) = v.as_bool() {
        return b.to_string();
    }
    v.to_string()
}

fn group(i: i64) -> String {
    let digits = i.unsigned_abs().to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    if i < 0 {
        format!("-{out}")
    } else {
        out
    }
}

pub fn format_number(x: f64) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x.is_infinite() {
        if x > 0.0 { "∞" } else { "−∞" }.into()
    } else if x == x.trunc() && x.abs() < 1e15 {
        group(x as i64)
    } else if (0.01..1000.0).contains(&x.abs()) {
        let digits = (1 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.digits$}")
    } else {
        format!("{x:.1e}")
    }
}

/// The engine with every function a claim may call, reading `facts`.
fn engine(facts: Rc<Facts>) -> Engine {
    use crate::limits;
    let mut e = Engine::new();
    // Bounded: a claim that loops or builds a huge value stops with an error naming the limit.
    e.set_max_operations(limits::MAX_CLAIM_OPERATIONS);
    e.set_max_string_size(limits::MAX_CLAIM_STRING);
    e.set_max_array_size(limits::MAX_CLAIM_ARRAY);
    e.set_max_map_size(limits::MAX_CLAIM_ARRAY);
    e.set_max_expr_depths(limits::MAX_CLAIM_DEPTH, limits::MAX_CLAIM_DEPTH);
    e.set_max_call_levels(limits::MAX_CLAIM_CALLS);

    type S = ImmutableString;
    macro_rules! whole {
        ($name:literal, $get:expr) => {{
            let f = facts.clone();
            e.register_fn($name, move |m: S, mat: S| -> Result<f64, Fail> {
                f.stat(&m, &mat, &BinStatsRef::All, &$get)
            });
        }};
    }
    macro_rules! binned {
        ($name:literal, $get:expr) => {{
            let f = facts.clone();
            e.register_fn($name, move |m: S, mat: S, axis: S, lo: f64| -> Result<f64, Fail> {
                f.stat(
                    &m,
                    &mat,
                    &BinStatsRef::Bin {
                        axis: axis.to_string(),
                        lo,
                    },
                    &$get,
                )
            });
            let f = facts.clone();
            e.register_fn($name, move |m: S, mat: S, axis: S, lo: i64| -> Result<f64, Fail> {
                f.stat(
                    &m,
                    &mat,
                    &BinStatsRef::Bin {
                        axis: axis.to_string(),
                        lo: lo as f64,
                    },
                    &$get,
                )
            });
        }};
    }
    macro_rules! both {
        ($whole:literal, $bin:literal, $get:expr) => {
            whole!($whole, $get);
            binned!($bin, $get);
        };
    }
    // Relative error of the GPU f32 result, no floor, over non-zero references.
    both!("median", "bin_median", |s: &BinStats| q(|q| q.median)(s.rel));
    both!("p90", "bin_p90", |s: &BinStats| q(|q| q.p90)(s.rel));
    both!("p99", "bin_p99", |s: &BinStats| q(|q| q.p99)(s.rel));
    both!("max", "bin_max", |s: &BinStats| q(|q| q.max)(s.rel));
    // The same formula in f64 and in CPU f32.
    both!("f64_median", "bin_f64_median", |s: &BinStats| q(|q| q.median)(
        s.rel_f64
    ));
    both!("f64_p99", "bin_f64_p99", |s: &BinStats| q(|q| q.p99)(s.rel_f64));
    both!("f64_max", "bin_f64_max", |s: &BinStats| q(|q| q.max)(s.rel_f64));
    both!("cpu_p99", "bin_cpu_p99", |s: &BinStats| q(|q| q.p99)(s.rel_cpu_f32));
    both!("cpu_max", "bin_cpu_max", |s: &BinStats| q(|q| q.max)(s.rel_cpu_f32));
    both!("floored_p99", "bin_floored_p99", |s: &BinStats| q(|q| q.p99)(
        s.rel_floored
    ));
    both!("abs_max", "bin_abs_max", |s: &BinStats| q(|q| q.max)(s.abs));
    // Counts.
    both!("count", "bin_count", |s: &BinStats| Some(s.lit_configurations() as f64));
    both!("nan", "bin_nan", |s: &BinStats| Some(
        (s.nan + s.inf + s.false_light.nonfinite) as f64
    ));
    both!("below_floor", "bin_below_floor", |s: &BinStats| Some(
        s.below_floor as f64
    ));
    // Missed light: a non-zero reference, the method exactly 0 (f32 GPU; f64 formula).
    both!("dark", "bin_dark", |s: &BinStats| Some(s.dark as f64));
    both!("dark_f64", "bin_dark_f64", |s: &BinStats| Some(s.dark_f64 as f64));
    // False light: configurations whose reference is exactly 0.
    both!("zero", "bin_zero", |s: &BinStats| Some(
        s.false_light.configurations as f64
    ));
    both!("false_lit", "bin_false_lit", |s: &BinStats| Some(
        s.false_light.lit as f64
    ));
    both!("false_lit_f64", "bin_false_lit_f64", |s: &BinStats| Some(
        s.false_light.lit_f64 as f64
    ));
    both!("false_max", "bin_false_max", |s: &BinStats| q(|q| q.max)(
        s.false_light.value
    ));
    // The error of what the method returns, missed light (`dark`) apart.
    both!("lit_median", "bin_lit_median", |s: &BinStats| q(|q| q.median)(
        s.rel_lit
    ));
    both!("lit_p99", "bin_lit_p99", |s: &BinStats| q(|q| q.p99)(s.rel_lit));
    both!("lit_max", "bin_lit_max", |s: &BinStats| q(|q| q.max)(s.rel_lit));
    both!("lit_f64_p99", "bin_lit_f64_p99", |s: &BinStats| q(|q| q.p99)(
        s.rel_f64_lit
    ));
    // How bright the lights are: |reference| over the non-zero references.
    both!("ref_median", "bin_ref_median", |s: &BinStats| q(|q| q.median)(
        s.reference
    ));
    both!("ref_max", "bin_ref_max", |s: &BinStats| q(|q| q.max)(s.reference));
    for (name, t) in [("within_1e3", 0usize), ("within_1e2", 1), ("within_1e1", 2)] {
        let f = facts.clone();
        e.register_fn(name, move |m: S, mat: S| -> Result<f64, Fail> {
            f.stat(&m, &mat, &BinStatsRef::All, &|s| Some(s.within[t]))
        });
    }
    // Input rounding: |reference at the f32-rounded inputs − reference| / |reference|.
    both!(
        "rounding_median",
        "bin_rounding_median",
        |s: &BinStats| q(|q| q.median)(s.input_rounding)
    );
    both!("rounding_p99", "bin_rounding_p99", |s: &BinStats| q(|q| q.p99)(
        s.input_rounding
    ));
    both!("rounding_max", "bin_rounding_max", |s: &BinStats| q(|q| q.max)(
        s.input_rounding
    ));
    // A method with a surface view (`line`, `cylinder`, `caps`, `tube`, `rectangle`): `upper_*`
    // read the headline, judged against what a real surface receives; `own_*` the same results
    // against the method's own target (the lobe as the LTC defines it, leak included: the
    // formula's own error); `below_*` the lights wholly below the surface.
    for (name, get) in [
        (
            "upper_p99",
            (|s: &BinStats| q(|q| q.p99)(s.rel)) as fn(&BinStats) -> Option<f64>,
        ),
        ("upper_median", |s| q(|q| q.median)(s.rel)),
        ("upper_max", |s| q(|q| q.max)(s.rel)),
        ("upper_f64_p99", |s| q(|q| q.p99)(s.rel_f64)),
        ("upper_count", |s| Some(s.lit_configurations() as f64)),
        ("upper_dark", |s| Some(s.dark as f64)),
        ("upper_dark_f64", |s| Some(s.dark_f64 as f64)),
        ("upper_zero", |s| Some(s.false_light.configurations as f64)),
        ("upper_false_lit", |s| Some(s.false_light.lit as f64)),
        ("upper_false_lit_f64", |s| Some(s.false_light.lit_f64 as f64)),
        ("upper_false_max", |s| q(|q| q.max)(s.false_light.value)),
    ] {
        for (prefix, which) in [
            ("upper_", BinStatsRef::Upper),
            ("own_", BinStatsRef::Own),
            ("below_", BinStatsRef::WhollyBelow),
        ] {
            let name = name.replacen("upper_", prefix, 1);
            let f = facts.clone();
            e.register_fn(name.as_str(), move |m: S, mat: S| -> Result<f64, Fail> {
                f.stat(&m, &mat, &which, &get)
            });
        }
        // The own-target view per bin: `bin_own_p99(method, material, axis, lo)`.
        let binned = format!("bin_{}", name.replacen("upper_", "own_", 1));
        let f = facts.clone();
        e.register_fn(
            binned.as_str(),
            move |m: S, mat: S, axis: S, lo: f64| -> Result<f64, Fail> {
                f.stat(
                    &m,
                    &mat,
                    &BinStatsRef::OwnBin {
                        axis: axis.to_string(),
                        lo,
                    },
                    &get,
                )
            },
        );
        let f = facts.clone();
        e.register_fn(
            binned.as_str(),
            move |m: S, mat: S, axis: S, lo: i64| -> Result<f64, Fail> {
                f.stat(
                    &m,
                    &mat,
                    &BinStatsRef::OwnBin {
                        axis: axis.to_string(),
                        lo: lo as f64,
                    },
                    &get,
                )
            },
        );
    }
    // Compared pairs: |a − b| / reference.
    for (name, get) in [
        (
            "diff_p99",
            (|p: &PairMaterial| p.all.diff_f32.map(|q| q.p99)) as fn(&PairMaterial) -> Option<f64>,
        ),
        ("diff_max", |p| p.all.diff_f32.map(|q| q.max)),
        ("diff_f64_max", |p| p.all.diff_f64.map(|q| q.max)),
        ("diff_f64_p99", |p| p.all.diff_f64.map(|q| q.p99)),
    ] {
        let f = facts.clone();
        e.register_fn(name, move |a: S, b: S, mat: S| -> Result<f64, Fail> {
            Ok(f.pair(&a, &b, &mat)?.map_or(1.0, |p| get(p).unwrap_or(f64::NAN)))
        });
    }
    // Disagreements: where `a` is least accurate relative to `b`.
    {
        let f = facts.clone();
        e.register_fn("disagree", move |a: S, b: S, mat: S| -> Result<f64, Fail> {
            Ok(f.disagreements(&a, &b, &mat)?
                .map_or(1.0, |d| d.first().map_or(0.0, |d| d.ratio)))
        });
        let f = facts.clone();
        e.register_fn("disagree_err_a", move |a: S, b: S, mat: S| -> Result<f64, Fail> {
            Ok(f.disagreements(&a, &b, &mat)?
                .map_or(1.0, |d| d.first().map_or(f64::NAN, |d| d.err_a)))
        });
        let f = facts.clone();
        e.register_fn("disagree_err_b", move |a: S, b: S, mat: S| -> Result<f64, Fail> {
            Ok(f.disagreements(&a, &b, &mat)?
                .map_or(1.0, |d| d.first().map_or(f64::NAN, |d| d.err_b)))
        });
        // How bright the top disagreement's light is, and where it is (docs/claims.md: a quoted
        // worst case states its reference and the angle it subtends).
        let f = facts.clone();
        e.register_fn("disagree_ref", move |a: S, b: S, mat: S| -> Result<f64, Fail> {
            Ok(f.disagreements(&a, &b, &mat)?
                .map_or(1.0, |d| d.first().map_or(f64::NAN, |d| d.reference.value)))
        });
        let f = facts.clone();
        e.register_fn(
            "disagree_axis",
            move |a: S, b: S, mat: S, axis: S| -> Result<f64, Fail> {
                if !crate::input::sampler::Axes::REGION.contains(&axis.as_str()) {
                    return fail(format!(
                        "`{axis}` is not a region axis ({})",
                        crate::input::sampler::Axes::REGION.join(", ")
                    ));
                }
                Ok(f.disagreements(&a, &b, &mat)?
                    .map_or(1.0, |d| d.first().map_or(f64::NAN, |d| d.axes.get(&axis))))
            },
        );
        let f = facts.clone();
        e.register_fn(
            "disagree_count",
            move |a: S, b: S, mat: S, at_least: f64| -> Result<f64, Fail> {
                Ok(f.disagreements(&a, &b, &mat)?
                    .map_or(1.0, |d| d.iter().filter(|d| d.ratio >= at_least).count() as f64))
            },
        );
        // An axis over the disagreements found with a ratio of at least `at_least`: its range
        // as "lo–hi", its least and its largest value.
        let axis_values =
            |f: &Facts, a: &str, b: &str, mat: &str, axis: &str, at_least: f64| -> Result<Option<Vec<f64>>, Fail> {
                let Some(d) = f.disagreements(a, b, mat)? else {
                    return Ok(None);
                };
                if !crate::input::sampler::Axes::REGION.contains(&axis) {
                    return fail(format!(
                        "`{axis}` is not a region axis ({})",
                        crate::input::sampler::Axes::REGION.join(", ")
                    ));
                }
                Ok(Some(
                    d.iter()
                        .filter(|d| d.ratio >= at_least)
                        .map(|d| d.axes.get(axis))
                        .filter(|x| x.is_finite())
                        .collect(),
                ))
            };
        let f = facts.clone();
        e.register_fn(
            "disagree_range",
            move |a: S, b: S, mat: S, axis: S, at_least: f64| -> Result<S, Fail> {
                let Some(v) = axis_values(&f, &a, &b, &mat, &axis, at_least)? else {
                    return Ok("".into());
                };
                if v.is_empty() {
                    return Ok("(none found)".into());
                }
                let (lo, hi) = v
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
                Ok(format!("{}–{}", format_number(lo), format_number(hi)).into())
            },
        );
        for (name, largest) in [("disagree_axis_min", false), ("disagree_axis_max", true)] {
            let f = facts.clone();
            e.register_fn(
                name,
                move |a: S, b: S, mat: S, axis: S, at_least: f64| -> Result<f64, Fail> {
                    let Some(v) = axis_values(&f, &a, &b, &mat, &axis, at_least)? else {
                        return Ok(1.0);
                    };
                    let pick = |x: f64, y: f64| if largest { x.max(y) } else { x.min(y) };
                    Ok(v.into_iter().reduce(pick).unwrap_or(f64::NAN))
                },
            );
        }
    }
    // Worst case found by the search (`[search]`).
    {
        let f = facts.clone();
        e.register_fn("worst", move |m: S, family: S| -> Result<f64, Fail> {
            f.material(&m, &family)?;
            Ok(f.analysis.as_ref().map_or(1.0, |_| {
                f.found
                    .iter()
                    .find(|x| x.method == m.as_str() && x.family == family.as_str())
                    .map_or(f64::NAN, |x| x.worst)
            }))
        });
        // The worst configuration's value, reference and subtended angle (radians).
        for (name, pick) in [("worst_value", 0usize), ("worst_ref", 1), ("worst_subtended", 2)] {
            let f = facts.clone();
            e.register_fn(name, move |m: S, family: S| -> Result<f64, Fail> {
                f.material(&m, &family)?;
                Ok(f.analysis.as_ref().map_or(1.0, |_| {
                    f.found
                        .iter()
                        .find(|x| x.method == m.as_str() && x.family == family.as_str())
                        .map_or(f64::NAN, |x| match pick {
                            0 => x.value as f64,
                            1 => x.reference.value,
                            _ => crate::input::sampler::line_axes(x.config.p1, x.config.p2).2,
                        })
                }))
            });
        }
    }
    // Speed: per-round ratios of time per evaluation, measured in this run.
    for (name, pick) in [
        ("gpu_ratio", 0usize),
        ("gpu_ratio_min", 1),
        ("gpu_ratio_max", 2),
        ("cpu_ratio", 3),
        ("cpu_ratio_min", 4),
        ("cpu_ratio_max", 5),
    ] {
        let f = facts.clone();
        e.register_fn(name, move |a: S, b: S| -> Result<f64, Fail> {
            let (Some(ca), Some(cb)) = (f.cost(&a)?, f.cost(&b)?) else {
                return Ok(1.0);
            };
            let r = if pick < 3 {
                gpu_time_ratio(ca, cb)
            } else {
                cpu_time_ratio(ca, cb)
            };
            Ok(r.map_or(f64::NAN, |r| [r.median, r.min, r.max][pick % 3]))
        });
    }
    {
        // The noise rule: a ratio whose per-round range includes 1 is no measurable difference.
        let f = facts.clone();
        e.register_fn("speed", move |a: S, b: S| -> Result<S, Fail> {
            let (Some(ca), Some(cb)) = (f.cost(&a)?, f.cost(&b)?) else {
                return Ok("".into());
            };
            Ok(speed_sentence(&a, &b, ca, cb).into())
        });
        let f = facts.clone();
        e.register_fn("ops", move |m: S| -> Result<f64, Fail> {
            Ok(f.cost(&m)?
                .map_or(1.0, |c| c.ops.as_ref().map_or(f64::NAN, |o| o.total as f64)))
        });
        let f = facts.clone();
        e.register_fn("configurations", move || -> f64 { f.configurations as f64 });
        // The "What to ship" answer, so prose that quotes it goes STALE when it changes.
        let f = facts.clone();
        e.register_fn("shipped", move |mat: S| -> Result<S, Fail> {
            f.check_material(&mat)?;
            let Some(analysis) = &f.analysis else {
                return Ok("".into());
            };
            use crate::analyse::ship;
            let shipped = ship::ShipBudget::resolve(&f.budget, f.budget_stated, analysis)
                .map(|b| ship::choose(&b, analysis, &f.costs))
                .and_then(|s| s.materials.into_iter().find(|m| m.material == mat.as_str()))
                .and_then(|m| m.ship);
            Ok(shipped.unwrap_or_else(|| "none".into()).into())
        });
    }
    e.register_fn("pct", |x: f64| -> S {
        format!("{} %", format_number(100.0 * x)).into()
    });
    e.register_fn("sci", |x: f64| -> S { format!("{x:.1e}").into() });
    e
}

/// What the per-round GPU and CPU ratios of `a` over `b` say, by the noise rule.
pub fn speed_sentence(a: &str, b: &str, ca: &Cost, cb: &Cost) -> String {
    let part = |what: &str, r: Option<crate::analyse::bench::Ratio>| match r {
        None => format!("{what}: not measured"),
        Some(r) if r.min <= 1.0 && 1.0 <= r.max => format!(
            "{what}: no measurable difference (time of `{a}` over `{b}` {} per round, range [{}–{}] includes 1)",
            format_number(r.median),
            format_number(r.min),
            format_number(r.max)
        ),
        Some(r) if r.min > 1.0 => format!(
            "{what}: `{b}` is faster, time of `{a}` over `{b}` {} [{}–{}] over {} rounds",
            format_number(r.median),
            format_number(r.min),
            format_number(r.max),
            r.rounds
        ),
        Some(r) => format!(
            "{what}: `{a}` is faster, time of `{a}` over `{b}` {} [{}–{}] over {} rounds",
            format_number(r.median),
            format_number(r.min),
            format_number(r.max),
            r.rounds
        ),
    };
    format!(
        "{}; {}",
        part("GPU", gpu_time_ratio(ca, cb)),
        part("CPU f32", cpu_time_ratio(ca, cb))
    )
}

/// Fills the text's `{expression}` placeholders (`{{` and `}}` are literal braces).
fn fill(engine: &Engine, text: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = text;
    while let Some(k) = rest.find(['{', '}']) {
        out += &rest[..k];
        let c = rest.as_bytes()[k];
        if rest[k + 1..].starts_with(c as char) {
            out.push(c as char);
            rest = &rest[k + 2..];
            continue;
        }
        if c == b'}' {
            return Err("a `}` without its `{` (write `}}` for a brace)".into());
        }
        let Some(end) = rest[k + 1..].find('}') else {
            return Err("a `{` without its `}` (write `{{` for a brace)".into());
        };
        let expr = &rest[k + 1..k + 1 + end];
        let v = engine
            .eval_expression::<Dynamic>(expr)
            .map_err(|e| format!("in `{{{expr}}}`: {}", explain(&e)))?;
        out += &format_value(&v);
        rest = &rest[k + 2 + end..];
    }
    out += rest;
    Ok(out)
}

/// The facts a case's claims may name, before anything is measured.
pub fn dry_facts(case: &Case, labels: Vec<String>) -> Facts {
    Facts {
        labels,
        materials: case.materials.iter().map(|m| m.name.clone()).collect(),
        axes: case.bins.iter().map(|b| b.axis.clone()).collect(),
        edges: case.bins.iter().map(|b| (b.axis.clone(), b.edges.clone())).collect(),
        configurations: 0,
        analysis: None,
        costs: Vec::new(),
        disagreements: Vec::new(),
        found: Vec::new(),
        budget: case.budget(),
        budget_stated: case.budget.is_some(),
    }
}

/// An evaluation error as a message, with the limit it hit where it hit one.
fn explain(e: &EvalAltResult) -> String {
    use crate::limits;
    let limit = match e {
        EvalAltResult::ErrorTooManyOperations(..) => {
            format!("a claim may take at most {} operations", limits::MAX_CLAIM_OPERATIONS)
        }
        EvalAltResult::ErrorDataTooLarge(..) => format!(
            "a claim may build strings of at most {} bytes and arrays of at most {} elements",
            limits::MAX_CLAIM_STRING,
            limits::MAX_CLAIM_ARRAY
        ),
        EvalAltResult::ErrorStackOverflow(..) => {
            format!("a claim may nest at most {} calls", limits::MAX_CLAIM_CALLS)
        }
        _ => return e.to_string(),
    };
    format!("{e} ({limit})")
}

/// Checks every claim's expression and text against the names of the case (a dry run).
pub fn check(claims: &[ClaimSpec], facts: Facts) -> Result<(), String> {
    let engine = engine(Rc::new(facts));
    for c in claims {
        let v = engine
            .eval_expression::<Dynamic>(&c.expect)
            .map_err(|e| format!("claim `{}`: expect `{}`: {}", c.id, c.expect, explain(&e)))?;
        if !v.is_bool() {
            return Err(format!(
                "claim `{}`: expect `{}` is not a comparison (it gives a {})",
                c.id,
                c.expect,
                v.type_name()
            ));
        }
        fill(&engine, &c.text).map_err(|e| format!("claim `{}`: text: {e}", c.id))?;
    }
    Ok(())
}

/// Evaluates every claim against this run's facts.
pub fn evaluate(claims: &[ClaimSpec], facts: Facts) -> Vec<ClaimResult> {
    let engine = engine(Rc::new(facts));
    claims
        .iter()
        .map(|c| {
            let (holds, error) = match engine.eval_expression::<bool>(&c.expect) {
                Ok(b) => (b, None),
                Err(e) => (false, Some(explain(&e))),
            };
            let text = fill(&engine, &c.text).unwrap_or_else(|e| format!("(text not filled: {e})"));
            ClaimResult {
                id: c.id.clone(),
                expect: c.expect.clone(),
                holds,
                error,
                text,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_written_by_hand() {
        assert_eq!(format_number(60000.0), "60,000");
        assert_eq!(format_number(0.0391), "0.039");
        assert_eq!(format_number(3.25), "3.2");
        assert_eq!(format_number(2.4e-5), "2.4e-5");
        assert_eq!(format_number(58.3), "58");
        assert_eq!(format_number(f64::INFINITY), "∞");
    }
}

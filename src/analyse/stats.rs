//! Error measures and per-bin statistics (docs/statistics.md). Measuring is elsewhere; this
//! module only turns values and references into numbers about them.
//!
//! The primary statistic is the relative error with no floor, over the configurations whose
//! reference is not 0: a far or dim light's relative error is what a viewer sees once exposure
//! adapts. Configurations whose reference is exactly 0 are kept apart ("false light").

use serde::{Deserialize, Serialize};
use sketches_ddsketch::{Config, DDSketch};

/// Relative error |value − reference| / |reference|, no floor (the reference is not 0).
pub fn relative_error(value: f64, reference: f64) -> f64 {
    (value - reference).abs() / reference.abs()
}

/// The floored variant shown beside the primary one: the denominator is max(|reference|, floor).
pub fn relative_error_floored(value: f64, reference: f64, floor: f64) -> f64 {
    (value - reference).abs() / reference.abs().max(floor)
}

/// Maps an f32 to an integer that orders like the float and whose difference counts ULPs.
fn ordered(x: f32) -> i64 {
    let b = x.to_bits() as i32;
    (if b < 0 { i32::MIN.wrapping_sub(b) } else { b }) as i64
}

/// `log2(1 + ulp distance)` between an f32 result and the f32-rounded reference.
pub fn bits_of_error(value: f32, reference: f64) -> f64 {
    let r = reference as f32;
    ((ordered(value) - ordered(r)).unsigned_abs() as f64 + 1.0).log2()
}

/// How a method's value on one configuration compares with the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
/// For a reference of exactly 0, `rel` and `rel_floored` are not defined: the value itself is
/// the false light (`abs`).
pub enum Outcome {
    Finite {
        rel: f64,
        rel_floored: f64,
        abs: f64,
        bits: f64,
    },
    Nan,
    Inf,
}

impl Outcome {
    pub fn of_f32(value: f32, reference: f64, floor: f64) -> Outcome {
        if value.is_nan() {
            Outcome::Nan
        } else if value.is_infinite() {
            Outcome::Inf
        } else {
            Outcome::Finite {
                rel: relative_error(value as f64, reference),
                rel_floored: relative_error_floored(value as f64, reference, floor),
                abs: (value as f64 - reference).abs(),
                bits: bits_of_error(value, reference),
            }
        }
    }

    pub fn of_f64(value: f64, reference: f64, floor: f64) -> Outcome {
        if value.is_nan() {
            Outcome::Nan
        } else if value.is_infinite() {
            Outcome::Inf
        } else {
            Outcome::Finite {
                rel: relative_error(value, reference),
                rel_floored: relative_error_floored(value, reference, floor),
                abs: (value - reference).abs(),
                bits: f64::NAN,
            }
        }
    }
}

/// Which kind of number a quantile is: nearest-rank over every value (exact), or read from a
/// DDSketch of relative accuracy [`SKETCH_ALPHA`] (a bin that held more than [`EXACT_LIMIT`]
/// values). The maximum is exact either way.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum QuantileKind {
    #[default]
    Exact,
    Sketch,
}

impl QuantileKind {
    pub fn name(self) -> &'static str {
        match self {
            QuantileKind::Exact => "exact",
            QuantileKind::Sketch => "sketch",
        }
    }
}

/// The spacing of f32 numbers at `reference` rounded to f32 (one ULP of what an f32 kernel
/// can return there), over |reference|: an error that grows by less than a few of these is
/// a last-bit change. Subnormals and 0 use the smallest subnormal spacing; None for 0 or NaN.
pub fn ulp_relative(reference: f64) -> Option<f64> {
    let r = reference as f32;
    if !(r.is_finite() && reference != 0.0) {
        return None;
    }
    let exponent = ((r.to_bits() >> 23) & 0xff) as i32;
    let ulp = 2f64.powi(exponent.max(1) - 127 - 23);
    Some(ulp / reference.abs())
}

/// One-sided binomial test: P(X ≥ k) for X ~ Binomial(n, p), the chance of `k` or more
/// successes in `n` trials if each succeeds with probability `p`. 1 when k = 0.
pub fn binomial_upper_tail(k: usize, n: usize, p: f64) -> f64 {
    use statrs::distribution::{Binomial, DiscreteCDF};
    if k == 0 {
        return 1.0;
    }
    if k > n {
        return 0.0;
    }
    let b = Binomial::new(p, n as u64).expect("p in [0, 1]");
    // sf(x) = P(X > x).
    b.sf(k as u64 - 1).clamp(0.0, 1.0)
}

/// Exact two-sided 95 % Clopper–Pearson interval of a binomial rate k/n: the p at which the
/// regularized incomplete beta function reaches 0.025 and 0.975, found by bisection (statrs's
/// `beta_reg`; its `Beta::inverse_cdf` is far too slow for n of 10⁹).
pub fn clopper_pearson(k: u64, n: u64) -> (f64, f64) {
    use statrs::function::beta::beta_reg;
    if n == 0 {
        return (0.0, 1.0);
    }
    let (kf, nf) = (k as f64, n as f64);
    // The p in (0, 1) where the increasing cdf(p) crosses `target`, in log space: rates of
    // 1e-10 and below must keep their digits.
    let solve = |cdf: &dyn Fn(f64) -> f64, target: f64| {
        let (mut lo, mut hi) = (-60.0f64, 0.0f64); // log10 p
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if cdf(10f64.powf(mid)) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        10f64.powf(0.5 * (lo + hi))
    };
    let low = if k == 0 {
        0.0
    } else {
        solve(&|p| beta_reg(kf, nf - kf + 1.0, p), 0.025)
    };
    let high = if k == n {
        1.0
    } else {
        solve(&|p| beta_reg(kf + 1.0, nf - kf, p), 0.975)
    };
    (low, high)
}

/// A mergeable accumulator, the pattern every statistic of a sweep follows: inputs folded in
/// one at a time ([`Accumulate::add`]), and another part's accumulator of the same shape (other
/// chunks of the run, another shard) merged in ([`Accumulate::merge`]), which gives what one
/// pass over both parts would (counts exactly, sketches bucket for bucket). The sweep's fold
/// ([`add_to_each`]) and the shard merge ([`merge_each`]) use it without knowing which
/// accumulator they hold.
pub trait Accumulate<In> {
    /// Folds in one input.
    fn add(&mut self, input: In);
    /// Adds another part's accumulator; an `Err` says why the parts do not fit together.
    fn merge(&mut self, other: &Self) -> Result<(), String>
    where
        Self: Sized;
}

/// Folds one input into every accumulator.
pub fn add_to_each<In: Copy>(accumulators: &mut [&mut dyn Accumulate<In>], input: In) {
    for a in accumulators {
        a.add(input);
    }
}

/// Merges `from` into `into`, accumulator by accumulator (the same number, in the same order).
pub fn merge_each<In, A: Accumulate<In>>(into: &mut [A], from: &[A]) -> Result<(), String> {
    if into.len() != from.len() {
        return Err(format!("{} accumulators against {}", into.len(), from.len()));
    }
    into.iter_mut().zip(from).try_for_each(|(a, b)| a.merge(b))
}

impl Accumulate<f64> for Distribution {
    fn add(&mut self, v: f64) {
        self.push(v);
    }

    fn merge(&mut self, other: &Distribution) -> Result<(), String> {
        Distribution::merge(self, other);
        Ok(())
    }
}

/// Order statistics of a sample of non-negative errors.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Quantiles {
    pub median: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
    /// Exact nearest-rank, or within the sketch's relative accuracy (median, p90, p99).
    pub kind: QuantileKind,
}

/// The nearest-rank `p`-quantile of `sorted` (ascending, not empty): the value at rank
/// ⌈p·n⌉ (at least 1). No interpolation, so every number reported is one observed. The one
/// quantile of the crate: bins, the gate, the bench, the chain and the fits all use it.
pub fn nearest_rank(sorted: &[f64], p: f64) -> f64 {
    sorted[rank(sorted.len(), p) - 1]
}

/// The nearest rank (1-based) of the `p`-quantile among `n` values: ⌈p·n⌉, at least 1.
fn rank(n: usize, p: f64) -> usize {
    ((p * n as f64).ceil() as usize).clamp(1, n)
}

/// [`nearest_rank`] of `values` in any order (not empty), by selection rather than a sort: the
/// same value, in linear time, for a quantile taken many times (the gate's bootstrap). `values`
/// is reordered.
pub fn nearest_rank_unsorted(values: &mut [f64], p: f64) -> f64 {
    let k = rank(values.len(), p) - 1;
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The nearest-rank median of `values` (any order; NaN sorts last), None when empty.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    (!v.is_empty()).then(|| nearest_rank(&v, 0.5))
}

/// The confidence of every upper bound of a quantile ([`quantile_upper_rank`]): the budget's
/// "meets" holds with at least this probability of the bound not being below the true quantile.
pub const BOUND_CONFIDENCE: f64 = 0.95;

/// The rank (1-based) of the order statistic that is a distribution-free upper confidence bound
/// of the `p`-quantile from `n` independent draws: the smallest k with
/// P(Binomial(n, p) ≤ k − 1) ≥ `confidence`. None when even the largest value is not enough
/// (pⁿ > 1 − confidence: too few draws, e.g. fewer than 299 for p = 0.99 at 95 %).
///
/// Why it holds for any distribution: with ξ the p-quantile (the smallest x with F(x) ≥ p),
/// each draw is below ξ with probability at most p, so the count below ξ is at most
/// Binomial(n, p) in distribution, and X₍ₖ₎ < ξ needs k or more draws below ξ. So
/// P(X₍ₖ₎ ≥ ξ) ≥ P(Binomial(n, p) ≤ k − 1). The tail is summed in log space from k = n down;
/// a tail within a relative 1e-9 of 1 − confidence counts as above it, so rounding can only
/// make the rank larger (the bound more conservative), never smaller.
pub fn quantile_upper_rank(n: usize, p: f64, confidence: f64) -> Option<usize> {
    assert!(p > 0.0 && p < 1.0 && confidence > 0.0 && confidence < 1.0);
    let allowed = (1.0 - confidence) * (1.0 - 1e-9);
    let (lp, lq) = (p.ln(), (1.0 - p).ln());
    // log P(X = i), starting at i = n: n·ln p; then P(X = i − 1) = P(X = i)·i/(n − i + 1)·q/p.
    let mut log_pmf = n as f64 * lp;
    let mut log_tail = f64::NEG_INFINITY; // log P(X ≥ i + 1)
    let mut rank = None;
    for i in (1..=n).rev() {
        log_tail = log_add(log_tail, log_pmf); // now log P(X ≥ i)
        if log_tail > allowed.ln() {
            break;
        }
        // P(X ≥ i) ≤ 1 − confidence: X₍ᵢ₎ is a bound; keep going down for a smaller one.
        rank = Some(i);
        log_pmf += (i as f64).ln() - ((n - i + 1) as f64).ln() + lq - lp;
    }
    rank
}

/// ln(eᵃ + eᵇ) without overflow.
fn log_add(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a > b { (a, b) } else { (b, a) };
    if lo == f64::NEG_INFINITY {
        hi
    } else {
        hi + (lo - hi).exp().ln_1p()
    }
}

/// An upper confidence bound of a quantile of the budget's statistic in one bin
/// (docs/statistics.md, "What to ship").
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Bound {
    /// Too few configurations for any order statistic to be a bound at this confidence.
    TooFew,
    /// The bounding order statistic is a false light or a NaN/inf: the bound is infinite.
    Infinite,
    /// The bounding order statistic (from a sketch: its reading / (1 − α)).
    At { value: f64 },
}

impl Bound {
    /// Whether the bound is known to be within `limit`.
    pub fn within(self, limit: f64) -> bool {
        matches!(self, Bound::At { value } if value <= limit)
    }

    /// The bound as a number for ordering: TooFew and Infinite sort last.
    pub fn sort_key(self) -> f64 {
        match self {
            Bound::At { value } => value,
            _ => f64::INFINITY,
        }
    }
}

/// The bound of one quantile over one bin, with what it was taken from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct QuantileBound {
    pub quantile: f64,
    pub confidence: f64,
    /// Configurations judged: every one in the bin, zero references included.
    pub n: usize,
    /// The order statistic's rank (1-based), when there is one.
    pub rank: Option<usize>,
    pub bound: Bound,
    /// The plain nearest-rank quantile of the same values (the point estimate the bound sits
    /// above): a number, or infinite (None) when it falls on a false light or NaN.
    pub point: Option<f64>,
}

impl Quantiles {
    /// Nearest-rank quantiles (no interpolation: every number reported is one observed).
    pub fn of(values: &mut [f64]) -> Option<Quantiles> {
        if values.is_empty() {
            return None;
        }
        values.sort_by(f64::total_cmp);
        let q = |p: f64| nearest_rank(values, p);
        Some(Quantiles {
            median: q(0.5),
            p90: q(0.9),
            p99: q(0.99),
            max: values[values.len() - 1],
            kind: QuantileKind::Exact,
        })
    }
}

/// A bin keeps its values, for exact nearest-rank quantiles, while it holds at most this many;
/// past that it keeps a sketch. Memory per bin is bounded either way.
pub const EXACT_LIMIT: usize = 2048;

/// The sketch's relative accuracy: a sketched quantile q̂ of true value q has |q̂ − q| ≤ α·q.
pub const SKETCH_ALPHA: f64 = 0.01;

/// Most buckets a sketch keeps (α = 1 %: about 17 decades of values at full accuracy; past
/// that the lowest buckets are merged, so only the smallest quantiles would lose accuracy).
const SKETCH_BINS: u32 = 2048;

fn sketch_config() -> Config {
    // Every positive value is bucketed (errors of f64 formulas reach 1e-17 and below); exact
    // zeros are counted apart by the sketch.
    Config::new(SKETCH_ALPHA, SKETCH_BINS, f64::MIN_POSITIVE)
}

/// A mergeable distribution of non-negative values: exact values up to [`EXACT_LIMIT`], then a
/// DDSketch (`sketches-ddsketch`). Merging two parts gives what one pass over both would give:
/// the same values, or the same sketch buckets.
#[derive(Clone, Serialize, Deserialize)]
pub enum Distribution {
    Exact(Vec<f64>),
    Sketch(Box<DDSketch>),
}

impl std::fmt::Debug for Distribution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kind = match self {
            Distribution::Exact(_) => "Exact",
            Distribution::Sketch(_) => "Sketch",
        };
        write!(f, "{kind}({} values)", self.len())
    }
}

impl Default for Distribution {
    fn default() -> Self {
        Distribution::Exact(Vec::new())
    }
}

impl Distribution {
    pub fn len(&self) -> usize {
        match self {
            Distribution::Exact(v) => v.len(),
            Distribution::Sketch(s) => s.count(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn sketch_of(values: &[f64]) -> Box<DDSketch> {
        let mut s = Box::new(DDSketch::new(sketch_config()));
        for &v in values {
            s.add(v);
        }
        s
    }

    pub fn push(&mut self, v: f64) {
        match self {
            Distribution::Exact(values) => {
                values.push(v);
                if values.len() > EXACT_LIMIT {
                    *self = Distribution::Sketch(Self::sketch_of(values));
                }
            }
            Distribution::Sketch(s) => s.add(v),
        }
    }

    pub fn merge(&mut self, other: &Distribution) {
        match (&mut *self, other) {
            (Distribution::Exact(a), Distribution::Exact(b)) if a.len() + b.len() <= EXACT_LIMIT => {
                a.extend_from_slice(b)
            }
            (Distribution::Sketch(a), Distribution::Sketch(b)) => {
                a.merge(b).expect("every sketch has the same configuration")
            }
            (Distribution::Sketch(a), Distribution::Exact(b)) => b.iter().for_each(|&v| a.add(v)),
            (Distribution::Exact(a), _) => {
                let mut s = Self::sketch_of(a);
                match other {
                    Distribution::Exact(b) => b.iter().for_each(|&v| s.add(v)),
                    Distribution::Sketch(b) => s.merge(b).expect("every sketch has the same configuration"),
                }
                *self = Distribution::Sketch(s);
            }
        }
    }

    /// The value at 0-based `rank` of a sketch (not empty), within α of the exact one at the
    /// same rank, clamped to the observed range (which the sketch keeps exactly).
    fn sketch_at(s: &DDSketch, rank: usize) -> f64 {
        let (lo, hi) = (s.min().unwrap_or(0.0), s.max().unwrap_or(0.0));
        let n = s.count();
        // The sketch reads rank ⌊q·(n − 1)⌋; ask for the middle of the wanted rank.
        let at = ((rank as f64 + 0.5) / (n - 1).max(1) as f64).min(1.0);
        // A sketch of only NaNs (bits of an f64 result) has no observed range.
        s.quantile(at)
            .expect("quantile in [0, 1]")
            .map_or(f64::NAN, |v| if lo <= hi { v.clamp(lo, hi) } else { v })
    }

    /// An upper bound of the `k`-th smallest value (1-based, 1 ≤ k ≤ len): the value itself
    /// while exact; from a sketch, its reading divided by (1 − α), never below the true one since
    /// the reading is within α of it, and at most the observed maximum.
    pub fn order_statistic_upper(&self, k: usize) -> f64 {
        assert!(k >= 1 && k <= self.len(), "rank {k} of {}", self.len());
        match self {
            Distribution::Exact(v) => {
                let mut v = v.clone();
                *v.select_nth_unstable_by(k - 1, f64::total_cmp).1
            }
            Distribution::Sketch(s) => {
                let hi = s.max().unwrap_or(f64::INFINITY);
                (Self::sketch_at(s, k - 1) / (1.0 - SKETCH_ALPHA)).min(hi)
            }
        }
    }

    /// The nearest-rank `p`-quantile (the ⌈p·n⌉-th smallest); None when empty. From a sketch,
    /// within α of the exact one at the same rank.
    pub fn quantile_at(&self, p: f64) -> Option<f64> {
        let n = self.len();
        if n == 0 {
            return None;
        }
        let k = ((p * n as f64).ceil() as usize).clamp(1, n);
        Some(match self {
            Distribution::Exact(v) => {
                let mut v = v.clone();
                *v.select_nth_unstable_by(k - 1, f64::total_cmp).1
            }
            Distribution::Sketch(s) => Self::sketch_at(s, k - 1),
        })
    }

    /// Median, p90, p99 and max; None when empty. Exact nearest-rank while exact; from the
    /// sketch after (clamped to the observed range, which the sketch keeps exactly).
    pub fn quantiles(&self) -> Option<Quantiles> {
        match self {
            Distribution::Exact(v) => Quantiles::of(&mut v.clone()),
            Distribution::Sketch(s) => {
                let hi = s.max()?;
                let n = s.count();
                // The nearest rank ⌈q·n⌉ − 1 (0-based), so a sketched quantile is within α of
                // the exact one at the same rank.
                let q = |p: f64| Self::sketch_at(s, ((p * n as f64).ceil() as usize).clamp(1, n) - 1);
                Some(Quantiles {
                    median: q(0.5),
                    p90: q(0.9),
                    p99: q(0.99),
                    max: hi,
                    kind: QuantileKind::Sketch,
                })
            }
        }
    }
}

/// Light a method returns where the reference is exactly 0 (docs/statistics.md, "false light"): how
/// often and how much. Such configurations never enter the relative-error statistics.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FalseLight {
    /// Configurations in the bin whose reference is exactly 0.
    pub configurations: usize,
    /// Of those, how many the method (f32, GPU) gives a finite non-zero value.
    pub lit: usize,
    /// Of those, how many give NaN or ±inf.
    pub nonfinite: usize,
    /// |value| over the lit ones (units where d = 1).
    pub value: Option<Quantiles>,
    /// The same formula in f64: how many it lights (the formula's own false light).
    pub lit_f64: usize,
}

/// Everything reported for one method in one bin.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BinStats {
    /// Configurations in the bin with a non-zero reference and a finite f32 result.
    pub count: usize,
    pub nan: usize,
    pub inf: usize,
    /// Relative error of the f32 (GPU) result, no floor, over non-zero references.
    pub rel: Option<Quantiles>,
    /// The floored variant: |value − reference| / max(|reference|, floor) (floor in the report).
    pub rel_floored: Option<Quantiles>,
    /// Configurations (non-zero reference) whose |reference| is below the floor: those the
    /// floored variant changes.
    pub below_floor: usize,
    /// Absolute error of the f32 (GPU) result (units where d = 1).
    pub abs: Option<Quantiles>,
    /// Relative error of the same formula in f32 on the CPU (correctly rounded libm):
    /// the GPU against this separates the driver's arithmetic from the formula's rounding.
    pub rel_cpu_f32: Option<Quantiles>,
    /// Relative error of the same formula in f64 (CPU): the formula's own error.
    pub rel_f64: Option<Quantiles>,
    pub nan_f64: usize,
    pub bits: Option<Quantiles>,
    /// Fractions of the non-zero-reference configurations in the bin (NaN/inf count as
    /// outside) within 1e-3, 1e-2, 1e-1.
    pub within: [f64; 3],
    /// The reference's own relative error estimate over the bin.
    pub reference_rel: Option<Quantiles>,
    /// True when the reference is not far below the method's error (see `ACCURACY_MARGIN`).
    pub reference_flag: bool,
    /// Configurations whose reference is exactly 0.
    pub false_light: FalseLight,
    /// Missed light: configurations with a non-zero reference where the method (f32, GPU)
    /// returns exactly 0. Their relative error is exactly 1, so they sit in every quantile
    /// as a plateau at 1; counted here so the cause reads as such.
    pub dark: usize,
    /// The same formula in f64 returns exactly 0 there too (the formula's own missed light,
    /// not rounding).
    pub dark_f64: usize,
    /// The budget's upper confidence bound of its quantile ([`BinAccumulator::quantile_bound`]),
    /// where the analysis asked for it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound: Option<QuantileBound>,
    /// `rel` over the configurations the method does not miss (its value is not exactly 0):
    /// the error of what it returns, with missed light apart (counted in `dark`).
    pub rel_lit: Option<Quantiles>,
    /// `rel_f64` over the configurations the f64 formula does not miss (`dark_f64` apart).
    pub rel_f64_lit: Option<Quantiles>,
    /// |reference| over the configurations with a non-zero reference: how bright the lights
    /// of the bin are (a worst case is dim or typical against these).
    pub reference: Option<Quantiles>,
    /// Input rounding: |reference at the f32-rounded configuration − reference| / |reference|
    /// over the non-zero references, where the sweep measured it. No f32 kernel can do better
    /// than this; the f32 columns (`rel`, `rel_cpu_f32`) are judged against the rounded one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_rounding: Option<Quantiles>,
    /// The input rounding's nearest-rank quantile at the budget's quantile, where the analysis
    /// asked for it (`finish_bounded`): above the budget's value, the bin is "unattainable in
    /// f32" (docs/statistics.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_rounding_at_budget: Option<f64>,
}

impl BinStats {
    /// Configurations with a non-zero reference (finite, NaN or inf result).
    pub fn lit_configurations(&self) -> usize {
        self.count + self.nan + self.inf
    }

    /// Every configuration in the bin, zero references included.
    pub fn configurations(&self) -> usize {
        self.lit_configurations() + self.false_light.configurations
    }
}

/// A bin is flagged when the reference's worst error estimate is not this far below the
/// method's median error: the reference could then move the statistics.
pub const ACCURACY_MARGIN: f64 = 100.0;

/// Accumulates the outcomes of one method in one bin; mergeable (shards, parallel parts), in
/// memory bounded whatever the count (see [`Distribution`]).
#[derive(Default, Clone, Debug, Serialize, Deserialize)]
pub struct BinAccumulator {
    rel: Distribution,
    rel_floored: Distribution,
    below_floor: usize,
    abs: Distribution,
    rel_cpu_f32: Distribution,
    rel_f64: Distribution,
    bits: Distribution,
    reference_rel: Distribution,
    /// Finite results within 1e-3, 1e-2, 1e-1 (exact counts).
    within: [usize; 3],
    nan: usize,
    inf: usize,
    nan_f64: usize,
    zero: usize,
    zero_lit: usize,
    zero_nonfinite: usize,
    zero_values: Distribution,
    zero_lit_f64: usize,
    /// Non-zero reference, result exactly 0 (f32 GPU; f64 formula).
    #[serde(default)]
    dark: usize,
    #[serde(default)]
    dark_f64: usize,
    rel_lit: Distribution,
    rel_f64_lit: Distribution,
    reference: Distribution,
    /// |reference at f32 inputs − reference| / |reference| (docs/statistics.md).
    #[serde(default)]
    input_rounding: Distribution,
}

impl BinAccumulator {
    /// The input rounding of one configuration with a non-zero reference.
    pub fn push_input_rounding(&mut self, rel: f64) {
        self.input_rounding.push(rel);
    }

    /// A test's configuration: only the GPU result, against a reference of 1 known exactly.
    #[cfg(test)]
    pub(crate) fn push_gpu(&mut self, gpu: Outcome) {
        self.push(gpu, None, None, 0.0, false, (false, false), 1.0);
    }

    /// One configuration with a non-zero reference: the GPU result, the CPU f32 and f64
    /// evaluations where they exist, the reference's own relative error estimate, whether
    /// the reference lies below the floor of the floored variant, whether the GPU and
    /// f64 results are exactly 0 (missed light), and |reference|.
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        gpu: Outcome,
        cpu_f32: Option<Outcome>,
        f64_outcome: Option<Outcome>,
        reference_rel: f64,
        below_floor: bool,
        (dark, dark_f64): (bool, bool),
        reference: f64,
    ) {
        self.dark += dark as usize;
        self.dark_f64 += dark_f64 as usize;
        self.reference.push(reference.abs());
        match gpu {
            Outcome::Finite {
                rel,
                rel_floored,
                abs,
                bits,
            } => {
                self.rel.push(rel);
                if !dark {
                    self.rel_lit.push(rel);
                }
                self.rel_floored.push(rel_floored);
                self.abs.push(abs);
                self.bits.push(bits);
                for (w, t) in self.within.iter_mut().zip([1e-3, 1e-2, 1e-1]) {
                    *w += (rel <= t) as usize;
                }
            }
            Outcome::Nan => self.nan += 1,
            Outcome::Inf => self.inf += 1,
        }
        self.below_floor += below_floor as usize;
        if let Some(Outcome::Finite { rel, .. }) = cpu_f32 {
            self.rel_cpu_f32.push(rel);
        }
        match f64_outcome {
            Some(Outcome::Finite { rel, .. }) => {
                self.rel_f64.push(rel);
                if !dark_f64 {
                    self.rel_f64_lit.push(rel);
                }
            }
            Some(Outcome::Nan | Outcome::Inf) => self.nan_f64 += 1,
            None => {}
        }
        self.reference_rel.push(reference_rel);
    }

    /// One configuration whose reference is exactly 0: the f32 (GPU) value and the f64 one.
    pub fn push_zero(&mut self, gpu: f32, f64_value: Option<f64>) {
        self.zero += 1;
        if !gpu.is_finite() {
            self.zero_nonfinite += 1;
        } else if gpu != 0.0 {
            self.zero_lit += 1;
            self.zero_values.push((gpu as f64).abs());
        }
        if f64_value.is_some_and(|v| v != 0.0) {
            self.zero_lit_f64 += 1;
        }
    }

    /// Adds another part's outcomes (the same method and bin, other configurations).
    pub fn merge(&mut self, o: &BinAccumulator) {
        for (a, b) in [
            (&mut self.rel, &o.rel),
            (&mut self.rel_floored, &o.rel_floored),
            (&mut self.abs, &o.abs),
            (&mut self.rel_cpu_f32, &o.rel_cpu_f32),
            (&mut self.rel_f64, &o.rel_f64),
            (&mut self.bits, &o.bits),
            (&mut self.reference_rel, &o.reference_rel),
            (&mut self.zero_values, &o.zero_values),
            (&mut self.rel_lit, &o.rel_lit),
            (&mut self.rel_f64_lit, &o.rel_f64_lit),
            (&mut self.reference, &o.reference),
            (&mut self.input_rounding, &o.input_rounding),
        ] {
            a.merge(b);
        }
        for (a, b) in self.within.iter_mut().zip(o.within) {
            *a += b;
        }
        for (a, b) in [
            (&mut self.below_floor, o.below_floor),
            (&mut self.nan, o.nan),
            (&mut self.inf, o.inf),
            (&mut self.nan_f64, o.nan_f64),
            (&mut self.zero, o.zero),
            (&mut self.zero_lit, o.zero_lit),
            (&mut self.zero_nonfinite, o.zero_nonfinite),
            (&mut self.zero_lit_f64, o.zero_lit_f64),
            (&mut self.dark, o.dark),
            (&mut self.dark_f64, o.dark_f64),
        ] {
            *a += b;
        }
    }

    /// The budget's upper confidence bound of the `p`-quantile of the relative error of the f32
    /// (GPU) result over every configuration of the bin, at [`BOUND_CONFIDENCE`]. Unlike the
    /// headline statistics, zero references are judged too: exact when the method returns 0,
    /// an infinite error when it returns light (false light) or NaN; a NaN or ±inf result on a
    /// lit configuration is an infinite error as well. So nothing a viewer would see is left out.
    pub fn quantile_bound(&self, p: f64) -> QuantileBound {
        let exact_zeros = self.zero - self.zero_lit - self.zero_nonfinite;
        let finite = self.rel.len();
        let n = exact_zeros + finite + self.nan + self.inf + self.zero_lit + self.zero_nonfinite;
        // The k-th smallest of: the exact zeros (0), the finite errors, then the infinite ones.
        let at = |k: usize| -> Option<f64> {
            if k <= exact_zeros {
                Some(0.0)
            } else if k <= exact_zeros + finite {
                Some(self.rel.order_statistic_upper(k - exact_zeros))
            } else {
                None
            }
        };
        let rank = (n > 0).then(|| quantile_upper_rank(n, p, BOUND_CONFIDENCE)).flatten();
        let bound = match rank.map(at) {
            None => Bound::TooFew,
            Some(None) => Bound::Infinite,
            Some(Some(value)) => Bound::At { value },
        };
        let point = if n == 0 {
            None
        } else {
            match (self.rel.is_empty(), ((p * n as f64).ceil() as usize).clamp(1, n)) {
                (_, k) if k <= exact_zeros => Some(0.0),
                (false, k) if k <= exact_zeros + finite => Some(match &self.rel {
                    Distribution::Exact(v) => {
                        let mut v = v.clone();
                        *v.select_nth_unstable_by(k - exact_zeros - 1, f64::total_cmp).1
                    }
                    Distribution::Sketch(s) => Distribution::sketch_at(s, k - exact_zeros - 1),
                }),
                _ => None,
            }
        };
        QuantileBound {
            quantile: p,
            confidence: BOUND_CONFIDENCE,
            n,
            rank,
            bound,
            point,
        }
    }

    /// [`BinAccumulator::finish`] with the budget's bound of the `p`-quantile.
    pub fn finish_bounded(&self, p: f64) -> BinStats {
        BinStats {
            bound: Some(self.quantile_bound(p)),
            input_rounding_at_budget: self.input_rounding.quantile_at(p),
            ..self.finish()
        }
    }

    pub fn finish(&self) -> BinStats {
        let total = self.rel.len() + self.nan + self.inf;
        let within = self
            .within
            .map(|w| if total == 0 { f64::NAN } else { w as f64 / total as f64 });
        let rel = self.rel.quantiles();
        let reference_rel = self.reference_rel.quantiles();
        let reference_flag = match (rel, reference_rel) {
            (Some(m), Some(r)) => r.max * ACCURACY_MARGIN > m.median,
            _ => false,
        };
        BinStats {
            count: self.rel.len(),
            nan: self.nan,
            inf: self.inf,
            rel,
            rel_floored: self.rel_floored.quantiles(),
            below_floor: self.below_floor,
            abs: self.abs.quantiles(),
            rel_cpu_f32: self.rel_cpu_f32.quantiles(),
            rel_f64: self.rel_f64.quantiles(),
            nan_f64: self.nan_f64,
            bits: self.bits.quantiles(),
            within,
            reference_rel,
            reference_flag,
            false_light: FalseLight {
                configurations: self.zero,
                lit: self.zero_lit,
                nonfinite: self.zero_nonfinite,
                value: self.zero_values.quantiles(),
                lit_f64: self.zero_lit_f64,
            },
            dark: self.dark,
            dark_f64: self.dark_f64,
            bound: None,
            rel_lit: self.rel_lit.quantiles(),
            rel_f64_lit: self.rel_f64_lit.quantiles(),
            reference: self.reference.quantiles(),
            input_rounding: self.input_rounding.quantiles(),
            input_rounding_at_budget: None,
        }
    }
}

pub use crate::input::case::bin_index;

#[cfg(test)]
mod tests {

    #[test]
    fn binomial_tail_matches_the_sum_of_its_terms() {
        // P(X >= 4) for n = 20, p = 0.05: 1 - (P0 + P1 + P2 + P3) = 0.0159015...
        assert!((binomial_upper_tail(4, 20, 0.05) - 0.015_901_5).abs() < 1e-6);
        // Against the exact sum with exact binomial coefficients.
        for (n, p) in [(30usize, 0.05f64), (50, 0.2), (12, 0.5)] {
            let term = |i: usize| {
                let c = (0..i).fold(1.0f64, |c, j| c * (n - j) as f64 / (j + 1) as f64);
                c * p.powi(i as i32) * (1.0 - p).powi((n - i) as i32)
            };
            for k in 0..=n {
                let sum: f64 = (k..=n).map(term).sum();
                let t = binomial_upper_tail(k, n, p);
                assert!(
                    (t - sum).abs() < 1e-9 * sum.max(1e-300) + 1e-15,
                    "n {n} p {p} k {k}: {t} vs {sum}"
                );
            }
        }
        assert_eq!(binomial_upper_tail(0, 10, 0.05), 1.0);
        assert_eq!(binomial_upper_tail(11, 10, 0.05), 0.0);
    }

    #[test]
    fn ulp_relative_is_the_f32_spacing_over_the_value() {
        assert_eq!(ulp_relative(1.0), Some(2f64.powi(-23)));
        // Just below 2: the spacing of [1, 2) over a value near 2.
        let r = ulp_relative(1.999_999).unwrap();
        assert!((r - 2f64.powi(-23) / 1.999_999).abs() < 1e-20, "{r}");
        assert_eq!(ulp_relative(-4.0), Some(2f64.powi(-23)));
        assert_eq!(ulp_relative(0.0), None);
        assert_eq!(ulp_relative(f64::NAN), None);
        // A subnormal: the smallest spacing.
        assert_eq!(ulp_relative(1e-40), Some(2f64.powi(-149) / 1e-40));
    }
    use super::*;

    // Written for the mutants a cargo-mutants pass found unkilled (docs/mutation.md).
    #[test]
    fn floored_errors_and_outcomes_by_hand() {
        // |reference| above the floor: the plain relative error; below: over the floor.
        assert_eq!(relative_error_floored(1.5, 1.0, 0.25), 0.5);
        assert!((relative_error_floored(0.3, 0.1, 0.5) - 0.4).abs() < 1e-15);
        assert!((relative_error_floored(-0.1, 0.1, 0.5) - 0.4).abs() < 1e-15);
        let f32_outcome = Outcome::of_f32(1.5, 1.0, 2.0);
        assert_eq!(
            f32_outcome,
            Outcome::Finite {
                rel: 0.5,
                rel_floored: 0.25,
                abs: 0.5,
                bits: bits_of_error(1.5, 1.0),
            }
        );
        match Outcome::of_f64(0.25, 1.0, 2.0) {
            Outcome::Finite {
                rel,
                rel_floored,
                abs,
                bits,
            } => {
                assert_eq!((rel, rel_floored, abs), (0.75, 0.375, 0.75));
                assert!(bits.is_nan());
            }
            o => panic!("{o:?}"),
        }
        assert_eq!(Outcome::of_f64(f64::NAN, 1.0, 0.0), Outcome::Nan);
        assert_eq!(Outcome::of_f32(f32::NEG_INFINITY, 1.0, 0.0), Outcome::Inf);
        assert_eq!(
            (QuantileKind::Exact.name(), QuantileKind::Sketch.name()),
            ("exact", "sketch")
        );
    }

    #[test]
    fn median_is_nearest_rank_with_nan_last() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[7.0]), Some(7.0));
        // Four values: rank ⌈0.5·4⌉ = 2 of the sorted values, NaN sorting last.
        assert_eq!(median(&[f64::NAN, 3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[5.0, -1.0, 4.0]), Some(4.0));
    }

    #[test]
    fn log_add_is_exact_far_apart_in_either_order() {
        assert_eq!(log_add(f64::NEG_INFINITY, -3.0), -3.0);
        assert_eq!(log_add(-3.0, f64::NEG_INFINITY), -3.0);
        // e^1000 overflows: the larger term must be factored out, whichever comes first.
        assert_eq!(log_add(1000.0, 0.0), 1000.0);
        assert_eq!(log_add(0.0, 1000.0), 1000.0);
        assert!((log_add(0.0, 0.0) - 2f64.ln()).abs() < 1e-15);
        assert!((log_add(2.0, 1.0) - (2f64.exp() + 1f64.exp()).ln()).abs() < 1e-14);
    }

    #[test]
    fn bounds_are_within_a_limit_only_when_finite_and_sort_last_otherwise() {
        assert!(Bound::At { value: 0.5 }.within(0.5) && !Bound::At { value: 0.6 }.within(0.5));
        assert!(!Bound::Infinite.within(1e300) && !Bound::TooFew.within(1e300));
        assert_eq!(Bound::At { value: 0.25 }.sort_key(), 0.25);
        assert_eq!(Bound::TooFew.sort_key(), f64::INFINITY);
        assert_eq!(Bound::Infinite.sort_key(), f64::INFINITY);
    }

    #[test]
    fn merging_two_exact_parts_past_the_limit_sketches_as_one_pass_would() {
        let (mut a, mut b, mut one) = (
            Distribution::default(),
            Distribution::default(),
            Distribution::default(),
        );
        assert!(a.is_empty());
        for i in 0..3000 {
            let v = 1.0 + i as f64;
            if i < 1500 {
                a.push(v)
            } else {
                b.push(v)
            }
            one.push(v);
        }
        assert!(!a.is_empty() && matches!(a, Distribution::Exact(_)));
        a.merge(&b);
        assert!(matches!(a, Distribution::Sketch(_)), "{a:?}");
        assert_eq!(a.len(), 3000);
        assert_eq!(a.quantiles(), one.quantiles());
    }

    #[test]
    fn order_statistics_by_rank_exact_and_never_below_when_sketched() {
        let mut d = Distribution::default();
        for v in [5.0, 1.0, 3.0, 2.0, 4.0] {
            d.push(v);
        }
        let exact: Vec<f64> = (1..=5).map(|k| d.order_statistic_upper(k)).collect();
        assert_eq!(exact, [1.0, 2.0, 3.0, 4.0, 5.0]);
        // A sketch of one repeated value reads it exactly (clamped to the observed range), so
        // its upper bound is the value itself: dividing by (1 + α) would put it below.
        let mut same = Distribution::default();
        for _ in 0..3000 {
            same.push(0.75);
        }
        assert!(matches!(same, Distribution::Sketch(_)));
        for k in [1, 1500, 3000] {
            assert_eq!(same.order_statistic_upper(k), 0.75, "rank {k}");
        }
        // Distinct values: the bound of rank k is the sketch's reading there, within α each way
        // of the k-th value, over (1 − α): not the reading of a higher rank.
        let mut spread = Distribution::default();
        for v in 1..=3000 {
            spread.push(f64::from(v));
        }
        for k in [10, 100, 1000, 2999] {
            let b = spread.order_statistic_upper(k);
            let most = k as f64 * (1.0 + SKETCH_ALPHA) / (1.0 - SKETCH_ALPHA);
            assert!(b >= k as f64 && b <= most, "rank {k}: {b} outside [{k}, {most}]");
        }
    }

    #[test]
    fn accumulating_in_parts_and_merging_is_one_pass() {
        // Past the exact limit, so the sketch's merge is exercised too.
        let values: Vec<f64> = (1..=3 * EXACT_LIMIT).map(|i| (i as f64).sqrt() * 1e-4).collect();
        let mut whole = Distribution::default();
        for &v in &values {
            Accumulate::add(&mut whole, v);
        }
        let mut parts = vec![
            Distribution::default(),
            Distribution::default(),
            Distribution::default(),
        ];
        for (i, &v) in values.iter().enumerate() {
            Accumulate::add(&mut parts[i % 3], v);
        }
        let mut merged = vec![Distribution::default()];
        for p in &parts {
            merge_each(&mut merged, std::slice::from_ref(p)).unwrap();
        }
        assert_eq!(merged[0].len(), whole.len());
        assert_eq!(merged[0].quantiles(), whole.quantiles());
        assert!(merge_each(&mut merged, &parts).is_err(), "1 against 3 accumulators");
        // add_to_each folds one input into every accumulator.
        let (mut a, mut b) = (Distribution::default(), Distribution::default());
        add_to_each(&mut [&mut a, &mut b], 2.0);
        assert_eq!((a.len(), b.len()), (1, 1));
    }

    #[test]
    fn selection_gives_the_sorted_nearest_rank() {
        let values = [5.0, 1.0, 4.0, 2.0, 3.0, 9.0, 0.5];
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        for p in [0.01, 0.25, 0.5, 0.9, 0.99, 1.0] {
            assert_eq!(
                nearest_rank_unsorted(&mut values.to_vec(), p),
                nearest_rank(&sorted, p),
                "p {p}"
            );
        }
        assert_eq!(median(&values), Some(3.0));
        assert_eq!(median(&[2.0, 1.0]), Some(1.0), "nearest rank: the lower of two");
    }

    #[test]
    fn clopper_pearson_is_exact_at_the_edges() {
        // No event in n: the upper bound solves (1 − p)^n = 0.025.
        let (lo, hi) = clopper_pearson(0, 1_000_000);
        assert_eq!(lo, 0.0);
        let expect = 1.0 - 0.025f64.powf(1.0 / 1e6);
        assert!((hi - expect).abs() < 1e-9 * expect, "{hi} vs {expect}");
        let (lo, hi) = clopper_pearson(5, 100);
        assert!(lo < 0.05 && 0.05 < hi && lo > 0.01 && hi < 0.12, "{lo} {hi}");
    }

    #[test]
    fn clopper_pearson_matches_closed_forms_and_an_independent_inverse() {
        let close = |got: f64, want: f64| (got - want).abs() <= 1e-9 * want;
        // One event in 10: the lower bound solves I_p(1, 10) = 1 − (1 − p)^10 = 0.025.
        let (lo, hi) = clopper_pearson(1, 10);
        assert!(close(lo, 1.0 - 0.975f64.powf(0.1)), "{lo}");
        // Its upper bound has no closed form: I_p(2, 9) = 0.975, SciPy 1.17's
        // `beta.ppf(0.975, 2, 9)` (an independent inverse) gives 0.4450161170281954.
        assert!(close(hi, 0.445_016_117_028_195_4), "{hi}");
        // Nine in 10: the upper bound solves I_p(10, 1) = p^10 = 0.975.
        let (lo, hi) = clopper_pearson(9, 10);
        assert!(close(hi, 0.975f64.powf(0.1)), "{hi}");
        // Its lower bound against beta.ppf(0.025, 9, 2).
        assert!(close(lo, 0.554_983_882_971_804_7), "{lo}");
        // All 10: the lower bound solves p^10 = 0.025, the upper is 1.
        let (lo, hi) = clopper_pearson(10, 10);
        assert!(close(lo, 0.025f64.powf(0.1)), "{lo}");
        assert_eq!(hi, 1.0);
        // An interior rate, both ends against beta.ppf(0.025, 3, 5) and beta.ppf(0.975, 4, 4).
        let (lo, hi) = clopper_pearson(3, 7);
        assert!(close(lo, 0.098_988_278_442_507_86), "{lo}");
        assert!(close(hi, 0.815_948_432_359_916_9), "{hi}");
    }

    #[test]
    fn bits_count_ulps() {
        assert_eq!(bits_of_error(1.0, 1.0), 0.0);
        let next = f32::from_bits(1.0f32.to_bits() + 1);
        assert_eq!(bits_of_error(next, 1.0), 1.0);
        assert_eq!(bits_of_error(f32::from_bits(1.0f32.to_bits() + 3), 1.0), 2.0);
        // Across zero: -0.0 and +0.0 are the same, the smallest subnormals are 1 ulp apart.
        assert_eq!(bits_of_error(-0.0, 0.0), 0.0);
        assert_eq!(bits_of_error(f32::from_bits(1), 0.0), 1.0);
        assert_eq!(
            bits_of_error(-f32::from_bits(1), f32::from_bits(1) as f64),
            (3.0f64).log2()
        );
    }

    #[test]
    fn quantiles_are_nearest_rank() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        let q = Quantiles::of(&mut v).unwrap();
        assert_eq!((q.median, q.p90, q.p99, q.max), (50.0, 90.0, 99.0, 100.0));
        assert_eq!(Quantiles::of(&mut []), None);
    }

    #[test]
    fn nan_and_inf_are_counted_not_averaged() {
        let mut acc = BinAccumulator::default();
        acc.push_gpu(Outcome::of_f32(f32::NAN, 1.0, 1e-6));
        acc.push_gpu(Outcome::of_f32(f32::INFINITY, 1.0, 1e-6));
        acc.push_gpu(Outcome::of_f32(1.001, 1.0, 1e-6));
        let s = acc.finish();
        assert_eq!((s.count, s.nan, s.inf), (1, 1, 1));
        assert!((s.rel.unwrap().max - 1e-3).abs() < 1e-6);
        assert!((s.within[2] - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn inaccurate_reference_is_flagged() {
        let mut acc = BinAccumulator::default();
        acc.push(
            Outcome::of_f32(1.0001, 1.0, 1e-6),
            None,
            None,
            1e-5,
            false,
            (false, false),
            1.0,
        );
        assert!(acc.finish().reference_flag);
        let mut acc = BinAccumulator::default();
        acc.push(
            Outcome::of_f32(1.0001, 1.0, 1e-6),
            None,
            None,
            1e-12,
            false,
            (false, false),
            1.0,
        );
        assert!(!acc.finish().reference_flag);
    }

    #[test]
    fn no_floor_and_zero_references_apart() {
        // A dim light: the floored variant hides a 100 % error, the primary statistic shows it.
        let mut acc = BinAccumulator::default();
        acc.push(
            Outcome::of_f32(2e-9, 1e-9, 1e-6),
            None,
            None,
            0.0,
            true,
            (false, false),
            1.0,
        );
        // A reference of exactly 0 lit by the method: false light, not a relative error.
        acc.push_zero(0.25, Some(0.0));
        acc.push_zero(0.0, Some(0.0));
        let s = acc.finish();
        assert!((s.rel.unwrap().max - 1.0).abs() < 1e-6);
        assert!(s.rel_floored.unwrap().max < 1e-2);
        assert_eq!((s.count, s.below_floor), (1, 1));
        assert_eq!(
            (s.false_light.configurations, s.false_light.lit, s.false_light.lit_f64),
            (2, 1, 0)
        );
        assert_eq!(s.false_light.value.unwrap().max, 0.25);
        assert_eq!(s.configurations(), 3);
    }

    #[test]
    fn missed_light_is_counted_and_merges() {
        // Non-zero references: one result exactly 0 in f32 only (rounding), one 0 in both
        // (the formula's own), one lit.
        let mut a = BinAccumulator::default();
        a.push(
            Outcome::of_f32(0.0, 1.0, 1e-6),
            None,
            Some(Outcome::of_f64(1e-3, 1.0, 1e-6)),
            0.0,
            false,
            (true, false),
            1.0,
        );
        a.push(
            Outcome::of_f32(0.0, 1.0, 1e-6),
            None,
            Some(Outcome::of_f64(0.0, 1.0, 1e-6)),
            0.0,
            false,
            (true, true),
            1.0,
        );
        let mut b = BinAccumulator::default();
        b.push(
            Outcome::of_f32(0.5, 1.0, 1e-6),
            None,
            None,
            0.0,
            false,
            (false, false),
            1.0,
        );
        a.merge(&b);
        let s = a.finish();
        assert_eq!((s.count, s.dark, s.dark_f64), (3, 2, 1));
        // The missed ones are relative error exactly 1 in the statistics.
        assert_eq!(s.rel.unwrap().max, 1.0);
        // Apart from them, the error of what the method returns: the lit one only in f32
        // (0.5); in f64 the one the formula lit (1e-3 against 1: 0.999).
        let lit = s.rel_lit.unwrap();
        assert_eq!((lit.max, lit.median), (0.5, 0.5));
        let f64_lit = s.rel_f64_lit.unwrap();
        assert_eq!(f64_lit.median, f64_lit.max);
        assert!((f64_lit.max - 0.999).abs() < 1e-12);
        assert_eq!(s.reference.unwrap().max, 1.0);
    }

    /// A deterministic spread of errors over twelve decades.
    fn spread(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| 10f64.powf(-10.0 + 12.0 * ((i * 7919) % n) as f64 / n as f64))
            .collect()
    }

    #[test]
    fn small_bins_stay_exact_large_ones_are_sketched_within_alpha() {
        let mut d = Distribution::default();
        let values = spread(EXACT_LIMIT);
        values.iter().for_each(|&v| d.push(v));
        assert_eq!(d.quantiles(), Quantiles::of(&mut values.clone()));
        let values = spread(50_000);
        let mut d = Distribution::default();
        values.iter().for_each(|&v| d.push(v));
        d.push(0.0);
        let mut all = values.clone();
        all.push(0.0);
        let (q, exact) = (d.quantiles().unwrap(), Quantiles::of(&mut all).unwrap());
        assert_eq!(q.kind, QuantileKind::Sketch);
        assert_eq!(q.max, exact.max);
        for (a, b) in [(q.median, exact.median), (q.p90, exact.p90), (q.p99, exact.p99)] {
            // Within α of the exact value at the same (nearest) rank.
            assert!((a - b).abs() <= SKETCH_ALPHA * b * (1.0 + 1e-9), "{a} against {b}");
        }
        // A jump in the distribution at the quantile's rank: the rank is the nearest rank's.
        let mut d = Distribution::default();
        let mut v: Vec<f64> = (0..2576).map(|i| if i < 2318 { 1e-10 } else { 1.0 }).collect();
        v.iter().for_each(|&x| d.push(x));
        let (q, exact) = (d.quantiles().unwrap(), Quantiles::of(&mut v).unwrap());
        assert_eq!((q.p90, exact.p90), (1.0, 1.0));
    }

    #[test]
    fn merging_parts_equals_one_pass() {
        for n in [100, EXACT_LIMIT, 3 * EXACT_LIMIT, 20_000] {
            let values = spread(n);
            let mut one = Distribution::default();
            values.iter().for_each(|&v| one.push(v));
            let mut merged = Distribution::default();
            for part in values.chunks(n / 3 + 1) {
                let mut p = Distribution::default();
                part.iter().for_each(|&v| p.push(v));
                merged.merge(&p);
            }
            assert_eq!(merged.len(), n);
            assert_eq!(merged.quantiles(), one.quantiles(), "n = {n}");
        }
    }

    /// The smallest k with P(Binomial(n, a/d) ≥ k) ≤ 1/20, in exact integer arithmetic:
    /// 20·Σᵢ₌ₖⁿ C(n, i)·aⁱ·(d − a)ⁿ⁻ⁱ ≤ dⁿ.
    fn exact_rank_95(n: u32, a: u128, d: u128) -> Option<usize> {
        let binom = |n: u32, i: u32| -> u128 { (0..i).fold(1u128, |c, j| c * (n - j) as u128 / (j + 1) as u128) };
        let mut tail = 0u128;
        let mut rank = None;
        for i in (1..=n).rev() {
            tail += binom(n, i) * a.pow(i) * (d - a).pow(n - i);
            if 20 * tail > d.pow(n) {
                break;
            }
            rank = Some(i as usize);
        }
        rank
    }

    #[test]
    fn quantile_bound_rank_matches_exact_binomial() {
        // p = 0.9 (n ≤ 35: 20·10³⁵ fits in u128) and p = 0.5 (n ≤ 100).
        for n in 1..=35 {
            assert_eq!(
                quantile_upper_rank(n, 0.9, 0.95),
                exact_rank_95(n as u32, 9, 10),
                "p 0.9, n {n}"
            );
        }
        for n in 1..=100 {
            assert_eq!(
                quantile_upper_rank(n, 0.5, 0.95),
                exact_rank_95(n as u32, 1, 2),
                "p 0.5, n {n}"
            );
        }
        // p99 at 95 % needs 299 draws: 1 − 0.99²⁹⁸ = 0.94997, 1 − 0.99²⁹⁹ = 0.95047.
        assert_eq!(quantile_upper_rank(298, 0.99, 0.95), None);
        assert_eq!(quantile_upper_rank(299, 0.99, 0.95), Some(299));
        // With more draws the bound moves below the maximum but stays above the nearest rank.
        let k = quantile_upper_rank(20_000, 0.99, 0.95).unwrap();
        assert!(k > 19_800 && k < 20_000, "{k}");
    }

    #[test]
    fn quantile_bound_covers_the_true_quantile() {
        // Uniform draws on (0, 1): the p90 is 0.9. Over many independent bins the bound falls
        // below it in no more than 5 % of them (binomial spread: allow 8 %).
        let mut state = 12345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (trials, mut below) = (400, 0);
        for _ in 0..trials {
            let mut acc = BinAccumulator::default();
            for _ in 0..200 {
                let e = uniform();
                acc.push_gpu(Outcome::of_f64(1.0 + e, 1.0, 1e-6));
            }
            let b = acc.quantile_bound(0.9);
            below += (b.bound.sort_key() < 0.9) as usize;
            assert!(b.point.unwrap() <= b.bound.sort_key());
        }
        assert!(
            below <= trials * 8 / 100,
            "{below} of {trials} bounds below the true p90"
        );
    }

    #[test]
    fn quantile_bound_judges_zero_references_and_nonfinite() {
        let mut acc = BinAccumulator::default();
        for _ in 0..400 {
            acc.push_gpu(Outcome::of_f32(1.0, 1.0, 1e-6));
        }
        // 100 exact zeros are exact; they count, and lower nothing above them.
        for _ in 0..100 {
            acc.push_zero(0.0, Some(0.0));
        }
        let b = acc.quantile_bound(0.99);
        assert_eq!((b.n, b.bound), (500, Bound::At { value: 0.0 }));
        // Ten false lights: the top 2 % are infinite, so the p99 bound is.
        for _ in 0..10 {
            acc.push_zero(0.5, Some(0.5));
        }
        let b = acc.quantile_bound(0.99);
        assert_eq!((b.n, b.bound, b.point), (510, Bound::Infinite, None));
        assert!(!b.bound.within(1e30));
        // A NaN is as bad.
        let mut acc = BinAccumulator::default();
        for i in 0..300 {
            let v = if i == 0 { f32::NAN } else { 1.0 };
            acc.push_gpu(Outcome::of_f32(v, 1.0, 1e-6));
        }
        assert_eq!(acc.quantile_bound(0.99).bound, Bound::Infinite);
        // Too few for p99 at 95 %.
        let mut acc = BinAccumulator::default();
        for _ in 0..298 {
            acc.push_gpu(Outcome::of_f32(1.0, 1.0, 1e-6));
        }
        assert_eq!(acc.quantile_bound(0.99).bound, Bound::TooFew);
    }

    #[test]
    fn sketched_order_statistics_are_never_below_the_exact_ones() {
        let values = spread(20_000);
        let mut d = Distribution::default();
        values.iter().for_each(|&v| d.push(v));
        let mut sorted = values.clone();
        sorted.sort_by(f64::total_cmp);
        for k in [1, 100, 10_000, 19_800, 19_950, 20_000] {
            let (up, exact) = (d.order_statistic_upper(k), sorted[k - 1]);
            assert!(
                up >= exact && up <= exact * (1.0 + SKETCH_ALPHA) / (1.0 - SKETCH_ALPHA),
                "rank {k}: {up} against {exact}"
            );
        }
    }

    /// Nine configurations of every kind, and three input roundings (the second mutation
    /// pass, docs/mutation.md).
    fn fill(acc: &mut BinAccumulator) {
        let f = 1e-6;
        // rel 0.25 (CPU f32 exact, f64 0.5), the reference's own estimate 1e-9.
        let cpu = Some(Outcome::of_f32(1.0, 1.0, f));
        acc.push(
            Outcome::of_f32(1.25, 1.0, f),
            cpu,
            Some(Outcome::of_f64(1.5, 1.0, f)),
            1e-9,
            false,
            (false, false),
            1.0,
        );
        // Missed in f32 and f64: rel 1 in both; |reference| 2.
        let f64_dark = Some(Outcome::of_f64(0.0, 2.0, f));
        acc.push(
            Outcome::of_f32(0.0, 2.0, f),
            None,
            f64_dark,
            0.0,
            false,
            (true, true),
            -2.0,
        );
        acc.push(Outcome::Nan, None, Some(Outcome::Nan), 0.0, false, (false, false), 1.0);
        acc.push(Outcome::Inf, None, Some(Outcome::Inf), 0.0, false, (false, false), 1.0);
        // rel 2⁻¹⁰, below the floor.
        acc.push(
            Outcome::of_f32(1.0 + 1.0 / 1024.0, 1.0, f),
            None,
            None,
            0.0,
            true,
            (false, false),
            1.0,
        );
        // Zero references: lit; NaN (lit in f64); dark (lit in f64); −inf.
        acc.push_zero(0.5, Some(0.0));
        acc.push_zero(f32::NAN, Some(1.0));
        acc.push_zero(0.0, Some(0.25));
        acc.push_zero(f32::NEG_INFINITY, None);
        for r in [0.125, 0.5, 0.25] {
            acc.push_input_rounding(r);
        }
    }

    #[test]
    fn a_bin_by_hand_and_merged_from_parts_as_one_pass() {
        let mut acc = BinAccumulator::default();
        fill(&mut acc);
        let s = acc.finish_bounded(0.5);
        assert_eq!((s.count, s.nan, s.inf, s.nan_f64), (3, 1, 1, 2));
        assert_eq!((s.lit_configurations(), s.configurations()), (5, 9));
        assert_eq!((s.dark, s.dark_f64, s.below_floor), (1, 1, 1));
        let fl = &s.false_light;
        assert_eq!((fl.configurations, fl.lit, fl.nonfinite, fl.lit_f64), (4, 1, 2, 2));
        assert_eq!(fl.value.unwrap().max, 0.5);
        // rel: 2⁻¹⁰, 0.25, 1; within 1e-3 only the first, of 5 (NaN and inf outside).
        let rel = s.rel.unwrap();
        assert_eq!((rel.median, rel.max), (0.25, 1.0));
        assert_eq!(s.within, [0.2, 0.2, 0.2]);
        assert_eq!(s.rel_lit.unwrap().max, 0.25);
        assert_eq!((s.rel_f64.unwrap().max, s.rel_f64_lit.unwrap().max), (1.0, 0.5));
        assert_eq!(s.rel_cpu_f32.unwrap().max, 0.0);
        assert_eq!(s.reference.unwrap().max, 2.0);
        assert_eq!(s.reference_rel.unwrap().max, 1e-9);
        let rounding = s.input_rounding.unwrap();
        assert_eq!((rounding.median, rounding.max), (0.25, 0.5));
        // The median of 0.125, 0.25, 0.5 at rank ⌈1.5⌉ = 2.
        assert_eq!(s.input_rounding_at_budget, Some(0.25));
        // n = 9 judged: 1 exact zero, 3 finite, 5 infinite (NaN, inf, the lit zero, two
        // non-finite zeros). P(Binomial(9, ½) ≥ 8) = 10/512 ≤ 0.05 < P(≥ 7) = 46/512: rank 8,
        // an infinite one; the point estimate at rank 5 is infinite too.
        assert_eq!(
            s.bound,
            Some(QuantileBound {
                quantile: 0.5,
                confidence: BOUND_CONFIDENCE,
                n: 9,
                rank: Some(8),
                bound: Bound::Infinite,
                point: None,
            })
        );
        assert_eq!(
            (acc.finish().bound, acc.finish().input_rounding_at_budget),
            (None, None)
        );
        // Two fills merged with one: every count three times (a sum, not a product of 2c and c).
        let (mut a, mut b, mut one) = (
            BinAccumulator::default(),
            BinAccumulator::default(),
            BinAccumulator::default(),
        );
        fill(&mut a);
        fill(&mut a);
        fill(&mut b);
        (0..3).for_each(|_| fill(&mut one));
        a.merge(&b);
        let (merged, one) = (a.finish_bounded(0.5), one.finish_bounded(0.5));
        assert_eq!(format!("{merged:?}"), format!("{one:?}"));
        assert_eq!(
            (one.count, one.nan, one.inf, one.nan_f64, one.dark, one.dark_f64),
            (9, 3, 3, 6, 3, 3)
        );
        let fl = &one.false_light;
        assert_eq!((fl.configurations, fl.lit, fl.nonfinite, fl.lit_f64), (12, 3, 6, 6));
        assert_eq!((one.below_floor, one.within), (3, [0.2, 0.2, 0.2]));
    }

    #[test]
    fn quantile_at_is_the_nearest_rank_exact_and_sketched() {
        let mut d = Distribution::default();
        assert_eq!(d.quantile_at(0.5), None);
        for v in [5.0, 1.0, 3.0, 2.0, 4.0] {
            d.push(v);
        }
        // Ranks ⌈p·5⌉: 0 → 1 (at least 1), 0.2 → 1, 0.21 → 2, 0.5 → 3, 1 → 5.
        let at: Vec<_> = [0.0, 0.2, 0.21, 0.5, 1.0].map(|p| d.quantile_at(p).unwrap()).into();
        assert_eq!(at, [1.0, 1.0, 2.0, 3.0, 5.0]);
        // Sketched, with a jump from 1e-10 to 1 after rank m: the rank read is the nearest
        // rank itself (the sketch is within α of the value there), not one either side.
        let (n, m) = (2576, 2318);
        let mut d = Distribution::default();
        (0..n).for_each(|i| d.push(if i < m { 1e-10 } else { 1.0 }));
        assert!(matches!(d, Distribution::Sketch(_)));
        let low = d.quantile_at((m as f64 - 0.5) / n as f64).unwrap();
        assert!(low <= 1e-10 * (1.0 + SKETCH_ALPHA), "rank {m}: {low}");
        assert_eq!(d.quantile_at((m as f64 + 0.5) / n as f64), Some(1.0), "rank {}", m + 1);
        // The same for the p90 of `quantiles`: ⌈0.9·n⌉ values of 1e-10, the rest 1.
        let n = 2560;
        let m = (0.9 * n as f64).ceil() as usize;
        let mut d = Distribution::default();
        (0..n).for_each(|i| d.push(if i < m { 1e-10 } else { 1.0 }));
        let q = d.quantiles().unwrap();
        assert_eq!(q.kind, QuantileKind::Sketch);
        assert!(q.p90 <= 1e-10 * (1.0 + SKETCH_ALPHA), "p90 {}", q.p90);
        assert_eq!((q.p99, q.max), (1.0, 1.0));
    }

    #[test]
    fn the_point_estimate_takes_the_exact_zeros_first_then_the_errors_by_rank() {
        // 10 exact zeros and the errors 1/8, 2/8, 3/8, 4/8: n = 14, rank ⌈p·14⌉.
        let mut acc = BinAccumulator::default();
        (0..10).for_each(|_| acc.push_zero(0.0, None));
        let point =
            |acc: &BinAccumulator, rank: usize, n: usize| acc.quantile_bound((rank as f64 - 0.5) / n as f64).point;
        assert_eq!(point(&acc, 7, 10), Some(0.0), "only zeros");
        for e in [4.0, 1.0, 3.0, 2.0] {
            acc.push_gpu(Outcome::of_f64(1.0 + e / 8.0, 1.0, 1e-6));
        }
        let points: Vec<_> = [7, 10, 11, 12, 13, 14].map(|k| point(&acc, k, 14)).into();
        assert_eq!(points, [0.0, 0.0, 0.125, 0.25, 0.375, 0.5].map(Some));
        // Sketched errors (3000 > EXACT_LIMIT) after the same 10 zeros: m = 2000 of about 1e-10,
        // then 1. Rank 10 + m is the last small one, 10 + m + 1 the first 1.
        let mut acc = BinAccumulator::default();
        (0..10).for_each(|_| acc.push_zero(0.0, None));
        let m = 2000;
        for i in 0..3000 {
            acc.push_gpu(Outcome::of_f64(if i < m { 1.0 + 1e-10 } else { 2.0 }, 1.0, 1e-6));
        }
        let (last_small, first_one) = (point(&acc, 10 + m, 3010).unwrap(), point(&acc, 11 + m, 3010).unwrap());
        assert!(last_small < 1e-9, "{last_small}");
        assert!((1.0 - SKETCH_ALPHA..=1.0).contains(&first_one), "{first_one}");
    }

    #[test]
    fn a_reference_exactly_the_margin_below_the_median_is_not_flagged() {
        // rel 100/1024 in every configuration, the reference's estimate 1/1024: exactly
        // ACCURACY_MARGIN below, so not flagged; a little more and it is.
        let flag = |estimate: f64| {
            let mut acc = BinAccumulator::default();
            let gpu = Outcome::of_f32(1.0 + 100.0 / 1024.0, 1.0, 1e-6);
            acc.push(gpu, None, None, estimate, false, (false, false), 1.0);
            acc.finish().reference_flag
        };
        assert_eq!(ACCURACY_MARGIN, 100.0);
        assert!(!flag(1.0 / 1024.0));
        assert!(flag(1.0 / 1024.0 * (1.0 + 1e-12)));
    }

    #[test]
    fn bins() {
        let e = [0.0, 1.0, 10.0];
        assert_eq!(bin_index(&e, 0.0), Some(0));
        assert_eq!(bin_index(&e, 1.0), Some(1));
        assert_eq!(bin_index(&e, 10.0), Some(1));
        assert_eq!(bin_index(&e, 10.5), None);
        assert_eq!(bin_index(&e, f64::NAN), None);
    }
}

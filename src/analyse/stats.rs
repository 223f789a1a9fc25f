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
    let n = sorted.len();
    sorted[((p * n as f64).ceil() as usize).clamp(1, n) - 1]
}

/// The nearest-rank median of `values` (any order; NaN sorts last), None when empty.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    (!v.is_empty()).then(|| nearest_rank(&v, 0.5))
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

    /// Median, p90, p99 and max; None when empty. Exact nearest-rank while exact; from the
    /// sketch after (clamped to the observed range, which the sketch keeps exactly).
    pub fn quantiles(&self) -> Option<Quantiles> {
        match self {
            Distribution::Exact(v) => Quantiles::of(&mut v.clone()),
            Distribution::Sketch(s) => {
                let (lo, hi) = (s.min()?, s.max()?);
                let n = s.count();
                // The sketch reads rank ⌊p·(n − 1)⌋; ask for the nearest rank ⌈q·n⌉ − 1, so a
                // sketched quantile is within α of the exact one at the same rank.
                let q = |p: f64| {
                    let rank = ((p * n as f64).ceil() as usize).clamp(1, n) - 1;
                    let at = ((rank as f64 + 0.5) / (n - 1).max(1) as f64).min(1.0);
                    s.quantile(at)
                        .expect("quantile in [0, 1]")
                        .map_or(f64::NAN, |v| v.clamp(lo, hi))
                };
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
    /// `rel` over the configurations the method does not miss (its value is not exactly 0):
    /// the error of what it returns, with missed light apart (counted in `dark`).
    pub rel_lit: Option<Quantiles>,
    /// `rel_f64` over the configurations the f64 formula does not miss (`dark_f64` apart).
    pub rel_f64_lit: Option<Quantiles>,
    /// |reference| over the configurations with a non-zero reference: how bright the lights
    /// of the bin are (a worst case is dim or typical against these).
    pub reference: Option<Quantiles>,
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
}

impl BinAccumulator {
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
            rel_lit: self.rel_lit.quantiles(),
            rel_f64_lit: self.rel_f64_lit.quantiles(),
            reference: self.reference.quantiles(),
        }
    }
}

pub use crate::input::case::bin_index;

#[cfg(test)]
mod tests {
    use super::*;

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
        acc.push(
            Outcome::of_f32(f32::NAN, 1.0, 1e-6),
            None,
            None,
            0.0,
            false,
            (false, false),
            1.0,
        );
        acc.push(
            Outcome::of_f32(f32::INFINITY, 1.0, 1e-6),
            None,
            None,
            0.0,
            false,
            (false, false),
            1.0,
        );
        acc.push(
            Outcome::of_f32(1.001, 1.0, 1e-6),
            None,
            None,
            0.0,
            false,
            (false, false),
            1.0,
        );
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

//! Error measures and per-bin statistics (DESIGN §4). Measuring is elsewhere; this
//! module only turns values and references into numbers about them.
//!
//! The primary statistic is the relative error with no floor, over the configurations whose
//! reference is not 0: a far or dim light's relative error is what a viewer sees once exposure
//! adapts. Configurations whose reference is exactly 0 are kept apart ("false light").

use serde::Serialize;

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

/// Order statistics of a sample of non-negative errors.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Quantiles {
    pub median: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Quantiles {
    /// Nearest-rank quantiles (no interpolation: every number reported is one observed).
    pub fn of(values: &mut [f64]) -> Option<Quantiles> {
        if values.is_empty() {
            return None;
        }
        values.sort_by(f64::total_cmp);
        let q = |p: f64| values[((p * values.len() as f64).ceil() as usize).clamp(1, values.len()) - 1];
        Some(Quantiles {
            median: q(0.5),
            p90: q(0.9),
            p99: q(0.99),
            max: values[values.len() - 1],
        })
    }
}

/// Light a method returns where the reference is exactly 0 (DESIGN §4, "false light"): how
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

/// Accumulates the outcomes of one method in one bin.
#[derive(Default, Clone)]
pub struct BinAccumulator {
    rel: Vec<f64>,
    rel_floored: Vec<f64>,
    below_floor: usize,
    abs: Vec<f64>,
    rel_cpu_f32: Vec<f64>,
    rel_f64: Vec<f64>,
    bits: Vec<f64>,
    reference_rel: Vec<f64>,
    nan: usize,
    inf: usize,
    nan_f64: usize,
    zero: usize,
    zero_lit: usize,
    zero_nonfinite: usize,
    zero_values: Vec<f64>,
    zero_lit_f64: usize,
}

impl BinAccumulator {
    /// One configuration with a non-zero reference: the GPU result, the CPU f32 and f64
    /// evaluations where they exist, the reference's own relative error estimate, and whether
    /// the reference lies below the floor of the floored variant.
    pub fn push(
        &mut self,
        gpu: Outcome,
        cpu_f32: Option<Outcome>,
        f64_outcome: Option<Outcome>,
        reference_rel: f64,
        below_floor: bool,
    ) {
        match gpu {
            Outcome::Finite {
                rel,
                rel_floored,
                abs,
                bits,
            } => {
                self.rel.push(rel);
                self.rel_floored.push(rel_floored);
                self.abs.push(abs);
                self.bits.push(bits);
            }
            Outcome::Nan => self.nan += 1,
            Outcome::Inf => self.inf += 1,
        }
        self.below_floor += below_floor as usize;
        if let Some(Outcome::Finite { rel, .. }) = cpu_f32 {
            self.rel_cpu_f32.push(rel);
        }
        match f64_outcome {
            Some(Outcome::Finite { rel, .. }) => self.rel_f64.push(rel),
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

    pub fn finish(mut self) -> BinStats {
        let total = self.rel.len() + self.nan + self.inf;
        let within = [1e-3, 1e-2, 1e-1].map(|t| {
            if total == 0 {
                f64::NAN
            } else {
                self.rel.iter().filter(|&&e| e <= t).count() as f64 / total as f64
            }
        });
        let rel = Quantiles::of(&mut self.rel);
        let reference_rel = Quantiles::of(&mut self.reference_rel);
        let reference_flag = match (rel, reference_rel) {
            (Some(m), Some(r)) => r.max * ACCURACY_MARGIN > m.median,
            _ => false,
        };
        BinStats {
            count: self.rel.len(),
            nan: self.nan,
            inf: self.inf,
            rel,
            rel_floored: Quantiles::of(&mut self.rel_floored),
            below_floor: self.below_floor,
            abs: Quantiles::of(&mut self.abs),
            rel_cpu_f32: Quantiles::of(&mut self.rel_cpu_f32),
            rel_f64: Quantiles::of(&mut self.rel_f64),
            nan_f64: self.nan_f64,
            bits: Quantiles::of(&mut self.bits),
            within,
            reference_rel,
            reference_flag,
            false_light: FalseLight {
                configurations: self.zero,
                lit: self.zero_lit,
                nonfinite: self.zero_nonfinite,
                value: Quantiles::of(&mut self.zero_values),
                lit_f64: self.zero_lit_f64,
            },
        }
    }
}

pub use crate::case::bin_index;

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
        acc.push(Outcome::of_f32(f32::NAN, 1.0, 1e-6), None, None, 0.0, false);
        acc.push(Outcome::of_f32(f32::INFINITY, 1.0, 1e-6), None, None, 0.0, false);
        acc.push(Outcome::of_f32(1.001, 1.0, 1e-6), None, None, 0.0, false);
        let s = acc.finish();
        assert_eq!((s.count, s.nan, s.inf), (1, 1, 1));
        assert!((s.rel.unwrap().max - 1e-3).abs() < 1e-6);
        assert!((s.within[2] - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn inaccurate_reference_is_flagged() {
        let mut acc = BinAccumulator::default();
        acc.push(Outcome::of_f32(1.0001, 1.0, 1e-6), None, None, 1e-5, false);
        assert!(acc.finish().reference_flag);
        let mut acc = BinAccumulator::default();
        acc.push(Outcome::of_f32(1.0001, 1.0, 1e-6), None, None, 1e-12, false);
        assert!(!acc.finish().reference_flag);
    }

    #[test]
    fn no_floor_and_zero_references_apart() {
        // A dim light: the floored variant hides a 100 % error, the primary statistic shows it.
        let mut acc = BinAccumulator::default();
        acc.push(Outcome::of_f32(2e-9, 1e-9, 1e-6), None, None, 0.0, true);
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
    fn bins() {
        let e = [0.0, 1.0, 10.0];
        assert_eq!(bin_index(&e, 0.0), Some(0));
        assert_eq!(bin_index(&e, 1.0), Some(1));
        assert_eq!(bin_index(&e, 10.0), Some(1));
        assert_eq!(bin_index(&e, 10.5), None);
        assert_eq!(bin_index(&e, f64::NAN), None);
    }
}

//! The bench's analysis: a method's spread over the repeats, and the ratios between two
//! methods (or GPU and CPU) as medians of the per-round ratios. Pure: no device.

use crate::measure::bench::Cost;

/// A ratio between two measurements taken round by round in one run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Ratio {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    /// Rounds it was taken over.
    pub rounds: usize,
}

impl Ratio {
    /// The per-round ratios `numerator[r] / denominator[r]`; None if either is empty or
    /// their lengths differ.
    pub fn per_round(numerator: &[f64], denominator: &[f64]) -> Option<Ratio> {
        if numerator.is_empty() || numerator.len() != denominator.len() {
            return None;
        }
        let ratios: Vec<f64> = numerator.iter().zip(denominator).map(|(a, b)| a / b).collect();
        let s = Spread::of(&ratios);
        Some(Ratio {
            median: s.median,
            min: s.min,
            max: s.max,
            rounds: ratios.len(),
        })
    }
}

/// GPU time of `a` over GPU time of `b`, round by round: above 1, `b` is the faster.
pub fn gpu_time_ratio(a: &Cost, b: &Cost) -> Option<Ratio> {
    Ratio::per_round(&a.gpu_ns_per_eval, &b.gpu_ns_per_eval)
}

/// CPU f32 port time of `a` over that of `b`, round by round (None without both ports).
pub fn cpu_time_ratio(a: &Cost, b: &Cost) -> Option<Ratio> {
    Ratio::per_round(&a.cpu_f32_ns_per_eval_runs, &b.cpu_f32_ns_per_eval_runs)
}

/// Median (mean of the middle two for an even count), min and max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Spread {
    pub(crate) median: f64,
    pub(crate) min: f64,
    pub(crate) max: f64,
}

impl Spread {
    /// Of a non-empty slice without NaN.
    pub(crate) fn of(xs: &[f64]) -> Spread {
        let mut v = xs.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Spread {
            median,
            min: v[0],
            max: v[n - 1],
        }
    }
}

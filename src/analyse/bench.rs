//! The bench's analysis: a method's cost from its raw times (the spread over the repeats, a
//! nearest-rank median like every other median here), and the ratios between two methods (or
//! GPU and CPU) as medians of the per-round ratios. Pure: no device.

use crate::analyse::stats::nearest_rank;
use crate::eval::cost::OpCount;
use crate::measure::bench::Times;

/// What one method costs, measured in one run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Cost {
    /// The method label (`Method.label`).
    pub label: String,
    /// `"gpu-timestamp"` or `"wall"` (submit + wait, when the adapter has no timestamps).
    pub clock: String,
    /// Configurations per dispatch.
    pub configurations: usize,
    /// Configurations per timed CPU-column run (all, or a spread subset in a sweep's cost pass).
    pub cpu_configurations: usize,
    /// Timed repeats (warm-up runs not counted).
    pub repeats: usize,
    pub ns_per_eval_median: f64,
    pub ns_per_eval_min: f64,
    pub ns_per_eval_max: f64,
    /// Configurations per second, from the median.
    pub configs_per_second: f64,
    /// The kernel's f32 column on the CPU evaluator, all cores (rayon): median of the same
    /// number of repeats; None for a method the evaluator cannot run.
    pub cpu_f32_ns_per_eval: Option<f64>,
    /// How many times faster the GPU dispatch is than the CPU f32 column: the median of the
    /// per-round ratios CPU ns / GPU ns. None without a CPU column.
    pub gpu_cpu_speed_ratio: Option<f64>,
    /// The operation count of one invocation (`crate::eval::cost`); None if it failed.
    pub ops: Option<OpCount>,
    /// Why `ops` is None.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ops_error: Option<String>,
    /// GPU ns per evaluation of each timed repeat, in the order run (round r is index r).
    pub gpu_ns_per_eval: Vec<f64>,
    /// CPU f32 ns per evaluation of each timed repeat (empty without a CPU column).
    pub cpu_f32_ns_per_eval_runs: Vec<f64>,
    /// The envelope's cost (`bench --envelope N`, docs/envelope.md): ns per configuration,
    /// median [min, max] over the timed rounds, on all cores; absent when not timed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub envelope_ns_per_config: Option<[f64; 3]>,
    /// How many times the envelope costs the CPU f32 column: the median of the per-round ratios
    /// envelope ns / CPU f32 ns (each per configuration).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub envelope_over_cpu_f32: Option<f64>,
    /// Configurations per timed envelope run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub envelope_configurations: Option<usize>,
    /// The envelope's ns per configuration of each timed repeat.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub envelope_ns_per_config_runs: Vec<f64>,
    /// Why the envelope was asked for and not timed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub envelope_error: Option<String>,
    /// Which CPU evaluator ran that column: `compiled`, or `interpreter (why)`.
    pub cpu_engine: String,
    /// The interpreter's ns per evaluation of the same column beside the compiled one
    /// (median over the same rounds); None where it was not timed beside.
    pub interp_f32_ns_per_eval: Option<f64>,
    /// How many times faster the compiled evaluator is than the interpreter: the median of
    /// the per-round ratios interpreter ns / compiled ns, with their range.
    pub compiled_speedup: Option<Ratio>,
    pub interp_f32_ns_per_eval_runs: Vec<f64>,
    /// Whether the timing of this method stopped because it was settled (a sweep's cost
    /// pass: `measure::bench::Rounds::settle`).
    pub settled: bool,
}

impl Cost {
    /// The statistics of one method's raw times (at least one GPU round).
    pub fn of(t: &Times) -> Cost {
        let g = Spread::of(&t.gpu_ns_per_eval);
        let cpu = &t.cpu_f32_ns_per_eval_runs;
        Cost {
            label: t.label.clone(),
            clock: t.clock.clone(),
            configurations: t.configurations,
            cpu_configurations: t.cpu_configurations,
            repeats: t.repeats,
            ns_per_eval_median: g.median,
            ns_per_eval_min: g.min,
            ns_per_eval_max: g.max,
            configs_per_second: 1e9 / g.median,
            cpu_f32_ns_per_eval: (!cpu.is_empty()).then(|| Spread::of(cpu).median),
            gpu_cpu_speed_ratio: Ratio::per_round(cpu, &t.gpu_ns_per_eval).map(|r| r.median),
            ops: t.ops.clone(),
            ops_error: t.ops_error.clone(),
            gpu_ns_per_eval: t.gpu_ns_per_eval.clone(),
            cpu_f32_ns_per_eval_runs: cpu.clone(),
            envelope_ns_per_config: (!t.envelope_ns_per_config_runs.is_empty()).then(|| {
                let s = Spread::of(&t.envelope_ns_per_config_runs);
                [s.median, s.min, s.max]
            }),
            envelope_over_cpu_f32: Ratio::per_round(&t.envelope_ns_per_config_runs, cpu).map(|r| r.median),
            envelope_configurations: (t.envelope_configurations > 0).then_some(t.envelope_configurations),
            envelope_ns_per_config_runs: t.envelope_ns_per_config_runs.clone(),
            envelope_error: t.envelope_error.clone(),
            cpu_engine: t.cpu_engine.clone(),
            interp_f32_ns_per_eval: (!t.interp_f32_ns_per_eval_runs.is_empty())
                .then(|| Spread::of(&t.interp_f32_ns_per_eval_runs).median),
            compiled_speedup: Ratio::per_round(&t.interp_f32_ns_per_eval_runs, cpu),
            interp_f32_ns_per_eval_runs: t.interp_f32_ns_per_eval_runs.clone(),
            settled: t.settled,
        }
    }
}

impl Cost {
    /// Whether the GPU times are the wall clock of submit + wait (no timestamp queries).
    pub fn wall_clock(&self) -> bool {
        self.clock == crate::measure::gpu::Clock::Wall.name()
    }
}

/// [`Cost::of`] for each method, in order.
pub fn costs(times: &[Times]) -> Vec<Cost> {
    times.iter().map(Cost::of).collect()
}

/// What a bench measured, ready to report.
pub struct BenchRun {
    pub adapter: String,
    pub case: String,
    pub materials: usize,
    pub warmup: usize,
    /// Threads of the CPU evaluator (rayon's pool).
    pub cpu_threads: usize,
    pub costs: Vec<Cost>,
    /// The case's compared pairs whose two methods were both measured.
    pub pairs: Vec<[String; 2]>,
}

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
    /// The per-round ratios `numerator[r] / denominator[r]` over the rounds both have (the
    /// first ones); None if either is empty.
    pub fn per_round(numerator: &[f64], denominator: &[f64]) -> Option<Ratio> {
        // Round r is index r of both; a method whose timing settled stops early, so two
        // methods are compared over the rounds both were timed in (the first ones).
        let k = numerator.len().min(denominator.len());
        if k == 0 {
            return None;
        }
        let ratios: Vec<f64> = numerator[..k]
            .iter()
            .zip(&denominator[..k])
            .map(|(a, b)| a / b)
            .collect();
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

/// CPU f32 column time (the CPU evaluator) of `a` over that of `b`, round by round (None
/// without both columns).
pub fn cpu_time_ratio(a: &Cost, b: &Cost) -> Option<Ratio> {
    Ratio::per_round(&a.cpu_f32_ns_per_eval_runs, &b.cpu_f32_ns_per_eval_runs)
}

/// Nearest-rank median (one observed value, as every median of this crate), min and max.
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
        let median = nearest_rank(&v, 0.5);
        let n = v.len();
        Spread {
            median,
            min: v[0],
            max: v[n - 1],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_and_ratios() {
        assert_eq!(
            Spread::of(&[3.0, 1.0, 2.0]),
            Spread {
                median: 2.0,
                min: 1.0,
                max: 3.0
            }
        );
        // Nearest rank: ⌈0.5·4⌉ = the 2nd of 1, 2, 4, 10.
        assert_eq!(Spread::of(&[4.0, 1.0, 2.0, 10.0]).median, 2.0);
        let r = Ratio::per_round(&[2.0, 6.0, 3.0], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!((r.median, r.min, r.max, r.rounds), (2.0, 1.0, 3.0, 3));
        assert_eq!(Ratio::per_round(&[], &[]), None);
        assert_eq!(Ratio::per_round(&[1.0], &[]), None);
        // A method that stopped early (settled) is compared over the rounds both have.
        let r = Ratio::per_round(&[3.0], &[1.5, 2.0]).unwrap();
        assert_eq!((r.median, r.rounds), (2.0, 1));
    }
}

//! Cost per method (`linelight bench`): what one evaluation costs, measured on the adapter
//! in use, beside a deterministic operation count from the kernel's naga IR.
//!
//! Measuring, analysing and reporting are separate, as criterion.rs and hyperfine do it:
//!
//! - **Measuring** (this file, [`bench_methods`]): the configurations are uploaded once
//!   ([`crate::measure::gpu::DispatchTimer`]); every method is compiled before anything is timed.
//!   Then `warmup` untimed rounds and `repeats` timed rounds. One round runs every method
//!   once on the GPU (one dispatch over all configurations, its own submission, waited on,
//!   timed by GPU timestamps at the beginning and end of the compute pass, or by the wall
//!   clock on an adapter without them) and then every method's CPU f32 column (the CPU evaluator) once over the
//!   same configurations on all cores (rayon). The order of the methods rotates from round
//!   to round, so drift and machine noise spread evenly over the methods, and the ratios
//!   between methods, and between GPU and CPU, are taken within one run.
//! - **Analysing** (`analyse.rs`: [`Cost`] spreads, [`Ratio`]): per method, the median ns per evaluation over
//!   the repeats with its min and max (every repeat's value is kept); ratios are medians
//!   of the per-round ratios, with their min and max.
//! - **Reporting** (`report.rs`, [`render`]): a table and a ratio line per compared pair. The command
//!   itself (sampling the case, then these three) is `app::bench`.
//!
//! Speed is measured, never asserted: no test checks a duration beyond its being a
//! positive number.
//!
//! On lavapipe the "GPU" is the CPU: llvmpipe's threads run the dispatch on the same cores
//! the CPU evaluator uses, so the GPU/CPU ratio there compares lavapipe's compiled SIMD kernel
//! with the evaluator of the same kernel's naga IR, not two pieces of hardware.

use crate::eval::cost::OpCount;
use crate::eval::interp::{CpuColumns, Engine, Mode};
use crate::input::scene::{Config, GpuScene};
use crate::kernel::methods::Method;
use crate::measure::gpu::Gpu;

use std::hint::black_box;
use std::time::Instant;

/// What timing one method measured, raw: one value per timed round. Its statistics (medians,
/// spreads, ratios) are the analyse stage's (`analyse::bench::Cost`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Times {
    /// The method label (`Method.label`).
    pub label: String,
    /// `"gpu-timestamp"` or `"wall"` (submit + wait, when the adapter has no timestamps).
    pub clock: String,
    /// Configurations per dispatch.
    pub configurations: usize,
    /// Configurations per timed CPU-column run (all of them, or a spread subset: [`Rounds`]).
    pub cpu_configurations: usize,
    /// Timed repeats (warm-up runs not counted).
    pub repeats: usize,
    /// The operation count of one invocation (`crate::eval::cost`); None if it failed.
    pub ops: Option<OpCount>,
    /// Why `ops` is None.
    pub ops_error: Option<String>,
    /// GPU ns per evaluation of each timed repeat, in the order run (round r is index r).
    pub gpu_ns_per_eval: Vec<f64>,
    /// CPU f32 ns per evaluation of each timed repeat (empty without a CPU column).
    pub cpu_f32_ns_per_eval_runs: Vec<f64>,
    /// Configurations per timed envelope run (0: the envelope is not timed).
    pub envelope_configurations: usize,
    /// The envelope's ns per configuration of each timed repeat, on all cores (empty when not
    /// timed, or when the envelope cannot walk this method).
    pub envelope_ns_per_config_runs: Vec<f64>,
    /// Why the envelope is not timed for this method although asked.
    pub envelope_error: Option<String>,
    /// Which evaluator ran the CPU column (`Program::engines`), empty without one.
    pub cpu_engine: String,
    /// The interpreter's ns per evaluation of the same f32 column, timed in the same rounds
    /// beside the compiled evaluator ([`Rounds::beside_interpreter`]; empty otherwise).
    pub interp_f32_ns_per_eval_runs: Vec<f64>,
    /// Whether this method's timing stopped because it was settled ([`Rounds::settle`])
    /// before the budget or the last round.
    pub settled: bool,
}

/// Whether the CPU evaluator runs `method` (every kernel it can compose and evaluate:
/// built-in or user's).
pub fn has_cpu_column(method: &Method) -> bool {
    crate::eval::interp::program(method).is_ok()
}

/// How a timing runs: its rounds, when it may stop early, and how much of the CPU column
/// each round times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rounds {
    /// Untimed rounds first.
    pub warmup: usize,
    /// Timed rounds at most.
    pub repeats: usize,
    /// Timed rounds at least, whatever the budget.
    pub min_repeats: usize,
    /// Wall-clock budget of the whole timing: once it is spent, no further timed round starts
    /// (after `min_repeats`). Every method stops at the same round, so per-round ratios stay paired.
    pub budget: Option<std::time::Duration>,
    /// Seconds one CPU-column run aims at. The first warm-up run times the column on a spread
    /// subset of [`CPU_PROBE`] configurations; the rest of the rounds time it on a spread subset
    /// sized from that probe (at least `CPU_PROBE`, at most all). None: every configuration.
    pub cpu_run_seconds: Option<f64>,
    /// Also time the envelope (docs/envelope.md) on this many configurations spread over
    /// them, in every round after the CPU columns (`bench --envelope N`). None: not timed.
    pub envelope: Option<usize>,
    /// Also time the interpreter on the same CPU column in every round, where the compiled
    /// evaluator runs the method (`bench`: the two side by side, their ratio from one run).
    pub beside_interpreter: bool,
    /// Stop timing a method once it is settled ([`settled`]): after at least `min_repeats`
    /// timed rounds, when the largest of its per-round ratios CPU f32 ns / GPU ns (of its GPU
    /// ns without a CPU column) is at most 1 + this share times the smallest. The other
    /// methods go on; None: every method runs every round.
    pub settle: Option<f64>,
}

/// Configurations of the CPU column's first warm-up run, which sizes the timed runs.
pub const CPU_PROBE: usize = 256;

impl Rounds {
    /// `warmup` untimed and exactly `repeats` timed rounds over every configuration (`bench`).
    pub fn fixed(warmup: usize, repeats: usize) -> Rounds {
        Rounds {
            warmup,
            repeats,
            min_repeats: repeats,
            budget: None,
            cpu_run_seconds: None,
            envelope: None,
            beside_interpreter: true,
            settle: None,
        }
    }
}

/// Whether per-round values are settled: all positive and finite, the largest at most
/// `1 + share` times the smallest. Over k rounds that range covers the median of the rounds'
/// distribution with probability 1 − 2^(1−k) (75 % at 3 rounds, 97 % at 6), whatever the
/// distribution; the median is inside it, so every round is within `share` of the median.
pub fn settled(values: &[f64], share: f64) -> bool {
    if values.is_empty() || !values.iter().all(|v| v.is_finite() && *v > 0.0) {
        return false;
    }
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    let max = values.iter().copied().fold(0.0, f64::max);
    max <= min * (1.0 + share)
}

/// Every `n / k`-th of `n` configurations, `k` of them (all when `k >= n`): a subset spread over
/// the families, which `configs` holds one after another.
fn spread(configs: &[Config], k: usize) -> Vec<Config> {
    let n = configs.len();
    if k >= n {
        return configs.to_vec();
    }
    (0..k).map(|j| configs[j * n / k].clone()).collect()
}

/// Measures every method on `configs`: `warmup` untimed rounds, then `repeats` timed
/// rounds (see the module doc). One [`Times`] per method, in input order.
pub fn bench_methods(
    gpu: &Gpu,
    methods: &[Method],
    configs: &[Config],
    warmup: usize,
    repeats: usize,
) -> anyhow::Result<Vec<Times>> {
    bench_methods_with(gpu, methods, configs, Rounds::fixed(warmup, repeats), &mut |_, _| {})
}

/// [`bench_methods`] by `rounds`, calling `progress(done, total)` after every timed or
/// warm-up step (one method on the GPU, or its CPU f32 column).
pub fn bench_methods_with(
    gpu: &Gpu,
    methods: &[Method],
    configs: &[Config],
    rounds: Rounds,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<Vec<Times>> {
    let Rounds {
        warmup,
        repeats,
        min_repeats,
        budget,
        cpu_run_seconds,
        envelope,
        beside_interpreter,
        settle,
    } = rounds;
    anyhow::ensure!(repeats > 0, "bench: at least one timed repeat is needed");
    anyhow::ensure!(!configs.is_empty(), "bench: no configurations to time");
    let start = Instant::now();
    let n = configs.len();
    // Textured configurations are timed reading their own texels.
    let (scenes, texels): (Vec<GpuScene>, Vec<f32>) = crate::input::scene::gpu_scenes(configs);
    let timer = gpu.dispatch_timer_textured(&scenes, &texels)?;
    drop(texels);
    // Everything that can fail on bad input fails before anything is timed.
    let pipelines = methods
        .iter()
        .map(|m| timer.pipeline(m))
        .collect::<Result<Vec<_>, _>>()?;
    let evaluated: Vec<bool> = methods.iter().map(has_cpu_column).collect();
    let engines: Vec<(Engine, String)> = methods
        .iter()
        .map(|m| match crate::eval::interp::program(m) {
            Ok(p) => (p.engine(Mode::F32), p.engines()),
            Err(_) => (Engine::Interpreter, String::new()),
        })
        .collect();
    // The interpreter beside the compiled evaluator, on the same configurations each round.
    let beside: Vec<bool> = evaluated
        .iter()
        .zip(&engines)
        .map(|(&e, (engine, _))| beside_interpreter && e && *engine == Engine::Compiled)
        .collect();
    // The CPU column's configurations per method: all, or a probe first (sized below).
    let sized = cpu_run_seconds.is_some() && warmup > 0;
    let probe = spread(configs, CPU_PROBE);
    let mut cpu_configs: Vec<Option<Vec<Config>>> = vec![None; methods.len()];
    // The envelope's configurations, and per method whether its walk runs (an error here is
    // the method's, reported beside its row, never timed).
    let envelope_configs = envelope.map(|k| spread(configs, k.max(1)));
    let envelope_error: Vec<Option<String>> = methods
        .iter()
        .map(|m| {
            let subset = envelope_configs.as_ref()?;
            match crate::eval::interp::envelope(m, &subset[0]) {
                Ok(_) => None,
                Err(e) => Some(format!("{e:#}")),
            }
        })
        .collect();
    let enveloped: Vec<bool> = envelope_error
        .iter()
        .map(|e| envelope_configs.is_some() && e.is_none())
        .collect();

    let steps_per_round = methods.len()
        + evaluated.iter().filter(|&&p| p).count()
        + enveloped.iter().filter(|&&p| p).count()
        + beside.iter().filter(|&&p| p).count();
    let mut total = (warmup + repeats) * steps_per_round;
    let mut done = 0;
    let mut gpu_ns = vec![Vec::with_capacity(repeats); methods.len()];
    let mut cpu_ns = vec![Vec::with_capacity(repeats); methods.len()];
    let mut envelope_ns = vec![Vec::with_capacity(repeats); methods.len()];
    let mut interp_ns = vec![Vec::with_capacity(repeats); methods.len()];
    // Methods still timed, and those that stopped because they were settled.
    let mut active = vec![true; methods.len()];
    let mut settled_early = vec![false; methods.len()];
    let steps_of = |i: usize| 1 + usize::from(evaluated[i]) + usize::from(enveloped[i]) + usize::from(beside[i]);
    for round in 0..warmup + repeats {
        let timed = round >= warmup;
        if timed && round - warmup >= min_repeats && budget.is_some_and(|b| start.elapsed() >= b) {
            // The budget is spent: the remaining rounds are not run.
            total = done;
            progress(done, total);
            break;
        }
        // Rotate the order: every method is first, second, … equally often.
        let order: Vec<usize> = (0..methods.len())
            .map(|k| (k + round) % methods.len())
            .filter(|&i| active[i])
            .collect();
        for &i in &order {
            let ns = timer.time(&pipelines[i])?;
            if timed {
                gpu_ns[i].push(ns / n as f64);
            }
            done += 1;
            progress(done, total);
        }
        for &i in order.iter().filter(|&&i| evaluated[i]) {
            let engine = engines[i].0;
            let (ns, used) = match (&cpu_configs[i], sized && round == 0) {
                (_, true) => {
                    let ns = time_cpu_column(&methods[i], &probe, engine);
                    let per = ns / probe.len() as f64;
                    let want = cpu_run_seconds.unwrap_or(0.0) * 1e9 / per.max(1.0);
                    cpu_configs[i] = Some(spread(configs, (want.ceil() as usize).clamp(CPU_PROBE.min(n), n)));
                    (ns, probe.len())
                }
                (Some(subset), false) => (time_cpu_column(&methods[i], subset, engine), subset.len()),
                (None, false) => (time_cpu_column(&methods[i], configs, engine), n),
            };
            if timed {
                cpu_ns[i].push(ns / used as f64);
            }
            done += 1;
            progress(done, total);
            if beside[i] {
                let same = cpu_configs[i].as_deref().filter(|_| !(sized && round == 0));
                let (set, used) = match (sized && round == 0, same) {
                    (true, _) => (&probe[..], probe.len()),
                    (false, Some(s)) => (s, s.len()),
                    (false, None) => (configs, n),
                };
                let ns = time_cpu_column(&methods[i], set, Engine::Interpreter);
                if timed {
                    interp_ns[i].push(ns / used as f64);
                }
                done += 1;
                progress(done, total);
            }
        }
        if let Some(subset) = &envelope_configs {
            for &i in order.iter().filter(|&&i| enveloped[i]) {
                let ns = time_envelope(&methods[i], subset);
                if timed {
                    envelope_ns[i].push(ns / subset.len() as f64);
                }
                done += 1;
                progress(done, total);
            }
        }
        if let Some(share) = settle.filter(|_| timed && round + 1 - warmup >= min_repeats) {
            let rounds_left = warmup + repeats - round - 1;
            for i in 0..methods.len() {
                let per_round: Vec<f64> = if cpu_ns[i].len() == gpu_ns[i].len() {
                    cpu_ns[i].iter().zip(&gpu_ns[i]).map(|(c, g)| c / g).collect()
                } else {
                    gpu_ns[i].clone()
                };
                if active[i] && settled(&per_round, share) {
                    active[i] = false;
                    settled_early[i] = rounds_left > 0;
                    total -= rounds_left * steps_of(i);
                }
            }
            if !active.contains(&true) {
                progress(done, total);
                break;
            }
        }
    }
    let cpu_counts: Vec<usize> = cpu_configs.iter().map(|c| c.as_ref().map_or(n, Vec::len)).collect();

    let clock = timer.clock().name().to_string();
    let envelope_count = envelope_configs.as_ref().map_or(0, Vec::len);
    let times = methods
        .iter()
        .zip(gpu_ns.into_iter().zip(cpu_ns))
        .zip(cpu_counts)
        .zip(envelope_ns.into_iter().zip(envelope_error))
        .zip(interp_ns.into_iter().zip(engines))
        .zip(settled_early)
        .map(
            |(
                (
                    (((m, (gpu_runs, cpu_runs)), cpu_configurations), (envelope_runs, envelope_error)),
                    (interp_runs, (_, engine)),
                ),
                settled,
            )| {
                let (ops, ops_error) = match crate::eval::cost::method_cost_of(m) {
                    Ok(ops) => (Some(ops), None),
                    Err(e) => (None, Some(format!("{e:#}"))),
                };
                Times {
                    label: m.label.clone(),
                    clock: clock.clone(),
                    configurations: n,
                    cpu_configurations,
                    repeats: gpu_runs.len(),
                    ops,
                    ops_error,
                    envelope_configurations: envelope_count,
                    envelope_ns_per_config_runs: envelope_runs,
                    envelope_error,
                    cpu_engine: if cpu_runs.is_empty() { String::new() } else { engine },
                    gpu_ns_per_eval: gpu_runs,
                    cpu_f32_ns_per_eval_runs: cpu_runs,
                    interp_f32_ns_per_eval_runs: interp_runs,
                    settled,
                }
            },
        )
        .collect();
    Ok(times)
}

/// Wall-clock ns of the method's kernel in f32 on the CPU evaluator `engine` over every
/// configuration, on all cores.
fn time_cpu_column(method: &Method, configs: &[Config], engine: Engine) -> f64 {
    let start = Instant::now();
    black_box(method.cpu_column_on(black_box(configs), Mode::F32, engine).ok());
    start.elapsed().as_nanos() as f64
}

/// Wall-clock ns of the method's envelope (docs/envelope.md) over `configs`, one interval walk
/// per configuration, on all cores (rayon), as the sweep's "Any conforming driver" pass runs it.
fn time_envelope(method: &Method, configs: &[Config]) -> f64 {
    use rayon::prelude::*;
    let start = Instant::now();
    let walked = configs
        .par_iter()
        .filter(|c| crate::eval::interp::envelope(method, black_box(c)).is_ok_and(|o| o.is_some()))
        .count();
    black_box(walked);
    start.elapsed().as_nanos() as f64
}

/// `count` of the samples, split as evenly as possible over the `materials` (the first
/// of each material's, in sampling order); the samples hold at least ⌈count/materials⌉
/// of each.
pub fn split_evenly(samples: &[crate::input::sampler::Sample], materials: usize, count: usize) -> Vec<Config> {
    let share = |i: usize| count * (i + 1) / materials - count * i / materials;
    let mut taken = vec![0; materials];
    samples
        .iter()
        .filter(|s| {
            let keep = taken[s.material] < share(s.material);
            taken[s.material] += usize::from(keep);
            keep
        })
        .map(|s| s.config.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::case::Case;

    fn gpu() -> &'static Gpu {
        crate::measure::gpu::test_gpu()
    }

    fn configs(n: usize) -> Vec<Config> {
        let case = Case::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/cases/line_fwt.toml"
        )))
        .expect("the line_fwt case loads");
        let materials = case.materials.len();
        let setup =
            crate::app::prepare(case, &[], &crate::kernel::Includes::none(), Some(n.div_ceil(materials))).unwrap();
        split_evenly(&setup.samples, materials, n)
    }

    #[test]
    fn one_cost_per_method_in_input_order() {
        let kernels = crate::kernel::methods::kernel_set(&[], &crate::kernel::Includes::none()).unwrap();
        let specs = ["line.numeric@8", "line.ltc2023", "line.ltc2017"];
        let methods: Vec<Method> = specs
            .iter()
            .map(|s| crate::kernel::methods::resolve(s, &kernels).unwrap())
            .collect();
        let configs = configs(500);
        assert_eq!(configs.len(), 500);
        let costs = crate::analyse::bench::costs(&bench_methods(gpu(), &methods, &configs, 1, 3).unwrap());
        let labels: Vec<&str> = costs.iter().map(|c| c.label.as_str()).collect();
        assert_eq!(labels, specs);
        for c in &costs {
            assert_eq!(c.configurations, 500);
            assert_eq!(c.repeats, 3);
            assert_eq!(c.clock, "gpu-timestamp");
            assert_eq!(c.gpu_ns_per_eval.len(), 3);
            assert_eq!(c.cpu_f32_ns_per_eval_runs.len(), 3, "{} has a CPU f32 column", c.label);
            assert!(c.ns_per_eval_min <= c.ns_per_eval_median && c.ns_per_eval_median <= c.ns_per_eval_max);
            assert!(c.ns_per_eval_min > 0.0 && c.ns_per_eval_max.is_finite(), "{c:?}");
            assert!(c.cpu_f32_ns_per_eval.is_some_and(|x| x > 0.0), "{c:?}");
            assert!(c.gpu_cpu_speed_ratio.is_some_and(|x| x > 0.0 && x.is_finite()), "{c:?}");
            let ops = c
                .ops
                .as_ref()
                .unwrap_or_else(|| panic!("{}: {:?}", c.label, c.ops_error));
            assert!(ops.total > 0);
        }
        // The deterministic count beside the measurement is the method's own.
        for (c, m) in costs.iter().zip(&methods) {
            assert_eq!(
                c.ops,
                Some(crate::eval::cost::method_cost_of(m).unwrap()),
                "{}",
                c.label
            );
        }
        let json = serde_json::to_value(&costs).unwrap();
        assert_eq!(json[1]["label"], "line.ltc2023");
        assert_eq!(json[1]["clock"], "gpu-timestamp");
    }

    #[test]
    fn a_user_kernel_is_timed_on_the_cpu_too() {
        let text = "//! id: user.half\n//! target: line\nfn method(scene: Scene) -> f32 { return 0.5 * scene.p1.z; }\n";
        let m = Method {
            label: "user.half".to_string(),
            kernel: crate::kernel::KernelFile::parse("half.wgsl", text).unwrap(),
            params: Vec::new(),
            inner: None,
            judged: None,
        };
        assert!(has_cpu_column(&m));
        let costs = crate::analyse::bench::costs(&bench_methods(gpu(), &[m], &configs(64), 0, 2).unwrap());
        assert!(costs[0].cpu_f32_ns_per_eval.is_some());
        assert_eq!(costs[0].cpu_f32_ns_per_eval_runs.len(), 2);
        assert_eq!(costs[0].gpu_ns_per_eval.len(), 2);
        assert!(bench_methods(gpu(), &[], &configs(64), 0, 0).is_err(), "zero repeats");
    }
    #[test]
    fn a_spent_budget_stops_every_method_at_the_same_round_and_the_cpu_column_is_sized() {
        let kernels = crate::kernel::methods::kernel_set(&[], &crate::kernel::Includes::none()).unwrap();
        let methods: Vec<Method> = ["line.numeric@64", "line.ltc2017"]
            .iter()
            .map(|s| crate::kernel::methods::resolve(s, &kernels).unwrap())
            .collect();
        let configs = configs(2000);
        let rounds = Rounds {
            warmup: 1,
            repeats: 7,
            min_repeats: 2,
            budget: Some(std::time::Duration::ZERO),
            cpu_run_seconds: Some(1e-9),
            envelope: None,
            beside_interpreter: true,
            settle: None,
        };
        let mut last = (0, 0);
        let times = bench_methods_with(gpu(), &methods, &configs, rounds, &mut |d, t| last = (d, t)).unwrap();
        assert_eq!(last.0, last.1, "the progress ends complete: {last:?}");
        for t in &times {
            // A zero budget is spent at once: the minimum of timed rounds, GPU and CPU paired.
            assert_eq!(
                (t.repeats, t.gpu_ns_per_eval.len(), t.cpu_f32_ns_per_eval_runs.len()),
                (2, 2, 2)
            );
            // The interpreter is timed beside the compiled evaluator in the same rounds.
            assert_eq!(t.cpu_engine, "compiled", "{}", t.label);
            assert_eq!(t.interp_f32_ns_per_eval_runs.len(), 2, "{}", t.label);
            // A 1 ns run asks for less than the probe: the probe's count is the floor.
            assert_eq!(
                (t.configurations, t.cpu_configurations),
                (2000, CPU_PROBE),
                "{}",
                t.label
            );
        }
        let whole = bench_methods_with(gpu(), &methods[1..], &configs, Rounds::fixed(0, 1), &mut |_, _| {}).unwrap();
        assert_eq!(
            (whole[0].repeats, whole[0].cpu_configurations),
            (1, 2000),
            "fixed rounds time every configuration"
        );
        // Fewer configurations than the probe: the probe is all of them, and so is every run.
        let few = bench_methods_with(gpu(), &methods[1..], &configs[..100], rounds, &mut |_, _| {}).unwrap();
        assert_eq!((few[0].configurations, few[0].cpu_configurations), (100, 100));
        let sub = spread(&configs, 4);
        assert_eq!(
            sub,
            vec![
                configs[0].clone(),
                configs[500].clone(),
                configs[1000].clone(),
                configs[1500].clone()
            ]
        );
    }

    #[test]
    fn settled_is_a_range_within_the_share_and_a_settled_method_stops() {
        assert!(settled(&[1.0, 1.1, 1.05], 0.2));
        assert!(settled(&[2.0], 0.0));
        assert!(!settled(&[1.0, 1.3, 1.1], 0.2), "1.3 is 30 % above 1.0");
        assert!(!settled(&[], 0.2));
        assert!(!settled(&[1.0, f64::NAN], 0.2));
        assert!(!settled(&[0.0, 0.0], 0.2));
        assert!(!settled(&[1.0, f64::INFINITY], 0.2));
        // Any spread is settled under a huge share: every method stops after the minimum of
        // rounds, marked settled, its GPU and CPU rounds paired; a zero share never settles
        // two different values, so the methods run every round.
        let kernels = crate::kernel::methods::kernel_set(&[], &crate::kernel::Includes::none()).unwrap();
        let methods: Vec<Method> = ["line.numeric@8", "line.ltc2017"]
            .iter()
            .map(|s| crate::kernel::methods::resolve(s, &kernels).unwrap())
            .collect();
        let configs = configs(300);
        let rounds = |settle| Rounds {
            warmup: 0,
            repeats: 6,
            min_repeats: 2,
            budget: None,
            cpu_run_seconds: None,
            envelope: None,
            beside_interpreter: false,
            settle: Some(settle),
        };
        let mut last = (0, 0);
        let quick = bench_methods_with(gpu(), &methods, &configs, rounds(1e9), &mut |d, t| last = (d, t)).unwrap();
        assert_eq!(last.0, last.1, "the progress ends complete: {last:?}");
        for t in &quick {
            assert_eq!(
                (t.repeats, t.cpu_f32_ns_per_eval_runs.len(), t.settled),
                (2, 2, true),
                "{}",
                t.label
            );
        }
        let all = bench_methods_with(gpu(), &methods, &configs, rounds(0.0), &mut |_, _| {}).unwrap();
        for t in &all {
            assert_eq!((t.repeats, t.settled), (6, false), "{}", t.label);
        }
    }

    #[test]
    fn split_evenly_takes_count_over_the_materials() {
        let case = Case::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/cases/line_fwt.toml"
        )))
        .unwrap();
        let materials = case.materials.len();
        let setup = crate::app::prepare(case, &[], &crate::kernel::Includes::none(), Some(4)).unwrap();
        let picked = split_evenly(&setup.samples, materials, 10);
        assert_eq!(picked.len(), 10);
        // 3 + 3 + 4 over three families, 2 + 3 + 2 + 3 over four, 2 each over five: the
        // first of each material's samples.
        let shares: &[usize] = match materials {
            3 => &[3, 3, 4],
            4 => &[2, 3, 2, 3],
            5 => &[2, 2, 2, 2, 2],
            n => panic!("line_fwt has {n} families: add their shares here"),
        };
        let by_material = |i: usize| setup.samples.iter().filter(move |s| s.material == i);
        let expected: Vec<&Config> = shares
            .iter()
            .enumerate()
            .flat_map(|(i, &n)| by_material(i).take(n))
            .map(|s| &s.config)
            .collect();
        assert_eq!(picked.iter().collect::<Vec<_>>(), expected);
    }
}

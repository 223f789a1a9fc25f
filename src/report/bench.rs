//! The bench's report: the table of costs and a ratio line per compared pair.

use crate::analyse::bench::{cpu_time_ratio, gpu_time_ratio, Spread};
use crate::analyse::bench::{BenchRun, Cost};
use crate::report::markup::Doc as _;

/// The report: a header, one row per method, a note on the op counts, and a ratio line
/// per compared pair (everything after the adapter line `run` prints).
pub fn render(bench: &BenchRun) -> String {
    let mut out = String::new();
    let Some(first) = bench.costs.first() else {
        return "no methods measured\n".to_string();
    };
    out.line(format_args!(
        "case {}: {} configurations per dispatch ({} material(s)); {} warm-up + {} timed rounds, \
         methods interleaved in rotated order",
        bench.case, first.configurations, bench.materials, bench.warmup, first.repeats
    ));
    let clock = if first.wall_clock() {
        "wall clock of submit + wait (this adapter has no timestamp queries)"
    } else {
        "GPU timestamps at the beginning and end of the compute pass"
    };
    out.para(format_args!(
        "GPU: {clock}; CPU: the kernel in f32 on the CPU evaluator (src/eval/interp: compiled to native code where \
         the compiler handles the kernel, else interpreted), {} thread(s) (rayon)",
        bench.cpu_threads
    ));

    let header = [
        "method",
        "GPU ns/eval median [min–max]",
        "Mconfigs/s",
        "CPU f32 ns/eval median [min–max]",
        "GPU/CPU speed",
        "CPU evaluator",
        "interpreter f32 ns/eval",
        "compiled/interpreter speed",
        "ops arith / transc / total",
    ];
    let mut rows: Vec<[String; 9]> = Vec::new();
    let mut open_loops = false;
    for c in &bench.costs {
        let cpu = match c.cpu_f32_ns_per_eval {
            Some(median) => {
                let s = Spread::of(&c.cpu_f32_ns_per_eval_runs);
                format!("{} [{}–{}]", sig(median), sig(s.min), sig(s.max))
            }
            None => "no port".to_string(),
        };
        let ops = match &c.ops {
            Some(o) => {
                let open = o.loops > 0 && o.loop_trips.is_none();
                open_loops |= open;
                format!(
                    "{} / {} / {}{}",
                    o.arithmetic,
                    o.transcendental,
                    o.total,
                    if open { " *" } else { "" }
                )
            }
            None => "–".to_string(),
        };
        rows.push([
            c.label.clone(),
            format!(
                "{} [{}–{}]",
                sig(c.ns_per_eval_median),
                sig(c.ns_per_eval_min),
                sig(c.ns_per_eval_max)
            ),
            sig(c.configs_per_second / 1e6),
            cpu,
            c.gpu_cpu_speed_ratio
                .map_or("–".to_string(), |r| format!("{}×", sig(r))),
            if c.cpu_engine.is_empty() {
                "–".to_string()
            } else {
                c.cpu_engine.clone()
            },
            c.interp_f32_ns_per_eval.map_or("–".to_string(), sig),
            c.compiled_speedup.as_ref().map_or("–".to_string(), |r| {
                format!("{}× [{}–{}]", sig(r.median), sig(r.min), sig(r.max))
            }),
            ops,
        ]);
    }
    let widths: Vec<usize> = (0..header.len())
        .map(|j| {
            rows.iter()
                .map(|r| r[j].chars().count())
                .chain([header[j].chars().count()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: &[&str]| {
        let mut s = String::new();
        for (j, cell) in cells.iter().enumerate() {
            let pad = widths[j] - cell.chars().count();
            if j == 0 {
                s.push_str(&format!("{cell}{}", " ".repeat(pad)));
            } else {
                s.push_str(&format!("  {}{cell}", " ".repeat(pad)));
            }
        }
        s.push('\n');
        s
    };
    out.push_str(&line(&header));
    for r in &rows {
        out.push_str(&line(&r.iter().map(String::as_str).collect::<Vec<_>>()));
    }
    out.line(format_args!(
        "\nGPU/CPU speed: median of the per-round CPU ns / GPU ns (above 1: the dispatch is faster).\n\
         compiled/interpreter speed: median [min–max] of the per-round interpreter ns / compiled ns, the \
         interpreter timed on the same configurations in the same rounds (the values are bit-identical: \
         tests/compiled.rs).\n\
         ops: one invocation's operation count from the naga IR (src/eval/cost.rs); \
         total = arithmetic + other math + {}×transcendental + branches.",
        crate::eval::cost::TRANSCENDENTAL_WEIGHT
    ));
    if open_loops {
        out.push_str("* a loop without a static trip count, its body counted once.\n");
    }
    for c in bench.costs.iter().filter(|c| c.ops_error.is_some()) {
        out.line(format_args!(
            "ops of {}: {}",
            c.label,
            c.ops_error.as_deref().unwrap_or_default()
        ));
    }

    if let Some(n) = bench.costs.iter().find_map(|c| c.envelope_configurations) {
        out.line(format_args!(
            "\nEnvelope (docs/envelope.md): one interval walk of the kernel's IR per configuration, on {n} \
             configurations spread over the dispatch's, all cores (rayon), timed in the same rounds; ns per \
             configuration, median [min–max], and its cost over the CPU f32 column's (median of the per-round \
             ratios):"
        ));
        for c in &bench.costs {
            match (c.envelope_ns_per_config, &c.envelope_error) {
                (Some([median, min, max]), _) => {
                    out.line(format_args!(
                        "  {}: {} [{}–{}] ns per configuration{}",
                        c.label,
                        sig(median),
                        sig(min),
                        sig(max),
                        c.envelope_over_cpu_f32
                            .map_or(String::new(), |r| format!(", {}× the CPU f32 column", sig(r)))
                    ));
                }
                (None, Some(e)) => {
                    out.line(format_args!("  {}: not timed ({e})", c.label));
                }
                (None, None) => {
                    out.line(format_args!("  {}: not timed", c.label));
                }
            }
        }
    }

    let pairs: Vec<(&Cost, &Cost)> = bench
        .pairs
        .iter()
        .filter_map(|[a, b]| {
            let find = |l: &str| bench.costs.iter().find(|c| c.label == l);
            Some((find(a)?, find(b)?))
        })
        .collect();
    if !pairs.is_empty() {
        out.push_str(
            "\nCompared pairs: time per evaluation of the first over the second, median [min–max] of the \
             per-round ratios, one run (above 1: the second is faster).\n",
        );
    }
    for (a, b) in pairs {
        let Some(g) = gpu_time_ratio(a, b) else {
            continue;
        };
        out.put(format_args!(
            "  {} / {}: GPU {} [{}–{}] over {} rounds",
            a.label,
            b.label,
            sig3(g.median),
            sig3(g.min),
            sig3(g.max),
            g.rounds
        ));
        if let Some(c) = cpu_time_ratio(a, b) {
            out.put(format_args!(
                ", CPU f32 {} [{}–{}]",
                sig3(c.median),
                sig3(c.min),
                sig3(c.max)
            ));
        }
        // The noise rule: a ratio whose per-round range includes 1 is no measurable difference.
        let verdict = if g.min <= 1.0 && 1.0 <= g.max {
            "no measurable difference on the GPU (the per-round range includes 1)".to_string()
        } else if g.min > 1.0 {
            format!("on the GPU {} is faster in every round", b.label)
        } else {
            format!("on the GPU {} is faster in every round", a.label)
        };
        out.line(format_args!(": {verdict}"));
    }
    out
}

/// Three significant digits, without exponent for everyday magnitudes.
fn sig(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    let a = x.abs();
    if a >= 1e7 || (a < 1e-3 && a != 0.0) {
        return format!("{x:.2e}");
    }
    let decimals = if a >= 100.0 {
        0
    } else if a >= 10.0 {
        1
    } else if a >= 1.0 {
        2
    } else {
        3
    };
    format!("{x:.decimals$}")
}

/// Ratios: always three decimals, so that close ratios stay comparable.
fn sig3(x: f64) -> String {
    format!("{x:.3}")
}

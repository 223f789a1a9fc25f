//! What the methods and the run cost: GPU and CPU time per evaluation with op counts, speed
//! ratios and Pareto fronts, and the wall-clock split of this sweep.

use crate::analyse::summary::Summary;
use crate::report::markup::{Align, Doc as _, Table};

/// Cost per evaluation and speed against accuracy (nothing when costs were not measured).
pub(super) fn speed_against_accuracy(w: &mut String, input: &Summary) {
    if input.costs.is_empty() {
        return;
    }
    let c0 = &input.costs[0];
    w.heading(2, "Speed against accuracy");
    let cpu_min = input.costs.iter().map(|c| c.cpu_configurations).min().unwrap_or(0);
    let cpu_max = input.costs.iter().map(|c| c.cpu_configurations).max().unwrap_or(0);
    let (r_min, r_max) = (
        input.costs.iter().map(|c| c.repeats).min().unwrap_or(0),
        input.costs.iter().map(|c| c.repeats).max().unwrap_or(0),
    );
    let rule = if input.timing.cost_rule.is_empty() {
        String::new()
    } else {
        format!(" Timing rule: {}.", input.timing.cost_rule)
    };
    w.para(format_args!(
        "Cost per evaluation on {} ({} clock), {} configurations per dispatch, {} interleaved repeats \
         after warm-up (per method: the rounds column); median [min–max].{rule} CPU f32: the kernel on the CPU \
         evaluator on all cores, in the same rounds, on a \
         spread subset of {} configurations per method sized from a first warm-up run to about 50 ms. \
         ops: one invocation's operation count from the naga IR (a deterministic cost; \
         total = arithmetic + other + 8 × transcendental + branches). Timings are measured in this run, \
         on this machine: compare ratios, not absolute numbers, across machines.",
        input.timing.adapter,
        c0.clock,
        c0.configurations,
        if r_min == r_max {
            r_min.to_string()
        } else {
            format!("{r_min}–{r_max}")
        },
        if cpu_min == cpu_max {
            cpu_min.to_string()
        } else {
            format!("{cpu_min}–{cpu_max}")
        }
    ));
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("GPU ns/eval", Align::Right),
        ("Mconfigs/s", Align::Right),
        ("CPU f32 ns/eval", Align::Right),
        ("ops arith / transc / total", Align::Right),
        ("rounds", Align::Right),
    ]);
    for c in &input.costs {
        let ops = c.ops.as_ref().map_or("—".to_string(), |o| {
            format!("{} / {} / {}", o.arithmetic, o.transcendental, o.total)
        });
        let cpu = c.cpu_f32_ns_per_eval.map_or("—".to_string(), |v| format!("{v:.0}"));
        table.row(vec![
            format!("`{}`", c.label),
            format!(
                "{:.0} [{:.0}–{:.0}]",
                c.ns_per_eval_median, c.ns_per_eval_min, c.ns_per_eval_max
            ),
            format!("{:.2}", c.configs_per_second / 1e6),
            cpu,
            ops,
            format!("{}{}", c.repeats, if c.settled { " (settled)" } else { "" }),
        ]);
    }
    w.table(&table);
    w.blank();
    speed_notes(w, input);
}

/// The speed sentence per compared pair, the charts and the Pareto front per material.
fn speed_notes(w: &mut String, input: &Summary) {
    let case = &input.case;
    for [x, y] in &case.compare {
        let (Some(cx), Some(cy)) = (
            input.costs.iter().find(|c| &c.label == x),
            input.costs.iter().find(|c| &c.label == y),
        ) else {
            continue;
        };
        // The noise rule: a ratio whose per-round range includes 1 is no measurable difference.
        w.line(format_args!(
            "- `{x}` against `{y}`, measured in this run: {}.",
            crate::analyse::claims::speed_sentence(x, y, cx, cy)
        ));
    }
    w.blank();
    for family in &case.materials {
        w.para(format_args!(
            "![speed against accuracy, {}]({})",
            family.name,
            crate::report::chart_file(&family.name)
        ));
    }
    for (k, family) in case.materials.iter().enumerate() {
        let points = &input.charts[k];
        let front = crate::analyse::pareto::pareto_front(points, true);
        let names: Vec<String> = front.iter().map(|&i| format!("`{}`", points[i].label)).collect();
        w.line(format_args!(
            "- Pareto front by p99 on `{}`: {}.",
            family.name,
            names.join(", ")
        ));
    }
    w.blank();
}

/// Wall-clock time per method and of the references in this run.
pub(super) fn timing(w: &mut String, input: &Summary) {
    let t = &input.timing;
    w.heading(2, "Timing (this run)");
    w.para(format_args!(
        "Wall-clock time of one run on {} ({} configurations): GPU time includes upload, dispatch \
         and readback; the CPU evaluator (the kernel's f32 and f64 columns: compiled to native code, or \
         interpreted where the compiler does not handle the kernel, as the last column says) runs on all CPU \
         cores. Cost per method as measured by GPU timestamps is `linelight bench`'s job; these numbers say \
         what the sweep itself spent.",
        t.adapter, t.configurations
    ));
    if t.shards > 1 {
        w.para(format_args!(
            "Merged from {} shards (`linelight merge`, which used no GPU): the times below, the searches' and the \
             split's are the sum over the shards, each on its own machine. The timing of methods (\"Speed against \
             accuracy\", the cost measurement) and the attribution ran in shard 0 of {} alone, on its adapter \
             and its own configurations: those numbers are shard 0's.",
            t.shards, t.shards
        ));
    }
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("GPU s", Align::Right),
        ("configs/s (GPU)", Align::Right),
        ("CPU f32 evaluator s (all cores)", Align::Right),
        ("CPU f32 / GPU", Align::Right),
        ("f64 evaluator s", Align::Right),
        ("CPU evaluator", Align::Left),
    ]);
    for (((label, s, rate), (_, f)), (_, c)) in t.gpu.iter().zip(&t.cpu_f64_seconds).zip(&t.cpu_f32_seconds) {
        let engine = t
            .cpu_engines
            .iter()
            .find(|(l, _)| l == label)
            .map_or("–", |(_, e)| e.as_str());
        table.row(vec![
            format!("`{label}`"),
            format!("{s:.3}"),
            format!("{rate:.3e}"),
            format!("{c:.3}"),
            format!("{:.2}", c / s),
            format!("{f:.3}"),
            engine.replace('|', "\\|"),
        ]);
    }
    w.table(&table);
    w.para(format_args!("\nReferences: {} values (a target at a configuration; what targets share, `tube`'s `cylinder` and `caps` or a `_upper` target the clip leaves unchanged, integrated once: src/reference/mod.rs) in {:.2} s ({:.0} per second).", t.references_evaluated, t.references_seconds, t.references_evaluated as f64 / t.references_seconds));
}

/// Harness throughput (where the measuring time went) and the whole sweep's time.
pub(super) fn throughput(w: &mut String, input: &Summary) {
    let t = &input.timing;
    let gpu: f64 = t.gpu.iter().map(|g| g.1).sum();
    let evaluator: f64 = t.cpu_f64_seconds.iter().chain(&t.cpu_f32_seconds).map(|p| p.1).sum();
    let other = (t.total_seconds
        - gpu
        - evaluator
        - t.references_seconds
        - t.references_f32_seconds
        - t.attribution_seconds
        - t.search_seconds
        - t.disagree_seconds
        - t.cost_seconds
        - t.sampling_seconds
        - t.statistics_seconds)
        .max(0.0);
    let pct = |x: f64| 100.0 * x / t.total_seconds;
    w.para(format_args!("Harness throughput: {} configurations × {} methods measured in {:.2} s, {:.0} configurations per \
         second end to end (finishing the statistics and the claims, and writing the report, excluded). Split: drawing the configurations {:.2} s ({:.0} %, on \
         all threads, each from its own stream), GPU runs {:.2} s ({:.0} %), CPU evaluator (f64 and f32) {:.2} s ({:.0} %), references {:.2} s ({:.0} %), references at the f32-rounded inputs {:.2} s ({:.0} %), \
         attribution (\"where the bits go\", interpreted) {:.2} s ({:.0} %), worst-case search {:.2} s ({:.0} %), \
         disagreement search {:.2} s ({:.0} %, {} candidates), cost measurement {:.2} s ({:.0} %, budget {:.2} s), folding into the \
         statistics {:.2} s ({:.0} %), set-up and the rest {:.2} s ({:.0} %).", t.configurations, t.gpu.len(), t.total_seconds, t.configurations as f64 / t.total_seconds, t.sampling_seconds, pct(t.sampling_seconds), gpu, pct(gpu), evaluator, pct(evaluator), t.references_seconds, pct(t.references_seconds), t.references_f32_seconds, pct(t.references_f32_seconds), t.attribution_seconds, pct(t.attribution_seconds), t.search_seconds, pct(t.search_seconds), t.disagree_seconds, pct(t.disagree_seconds), t.disagree_evaluations, t.cost_seconds, pct(t.cost_seconds), t.cost_budget_seconds, t.statistics_seconds, pct(t.statistics_seconds), other, pct(other)));

    w.para(format_args!(
        "The whole sweep, from the command's start to this report (sampling, top-ups, GPU runs, CPU \
         evaluations, references, searches, statistics and claims; writing the files excluded): {:.1} s, of \
         which statistics and claims {:.2} s.",
        input.stages.until_report_seconds, input.stages.analysis_seconds
    ));
}

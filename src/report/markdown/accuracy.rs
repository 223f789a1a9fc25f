//! Accuracy against the reference: the error table per material and its per-axis view, the
//! convergence of methods run at several sample counts, false light (reference 0), missed
//! light (the method 0 where light arrives) and the light from below the horizon.

use super::{pct, q3, share};
use crate::analyse::stats::ACCURACY_MARGIN;
use crate::analyse::summary::Summary;
use crate::report::sci;
use std::fmt::Write;

/// Per material: every method's error statistics (f32 GPU, CPU f32, f64, bits, floored), then
/// its per-axis view.
pub(super) fn error_tables(w: &mut String, input: &Summary) {
    let (case, a) = (&input.case, &input.analysis);
    let _ = writeln!(w, "## Error against the reference\n");
    let _ = writeln!(
        w,
        "Relative error of each method's f32 GPU result, no floor, over the configurations whose reference \
         is not 0 (n); its absolute error (units where d = 1); the relative error of the same formula in \
         f32 on the CPU (correctly rounded libm: the gap to the GPU column is the driver's arithmetic) and \
         in f64 (the formula's own error); bits of error; NaN/inf counts; the share within 1e-3 and 1e-2 \
         (more columns in `stats.csv`). Beside them, labelled, the floored variant \
         |value − reference| / max(|reference|, floor) and how many configurations it changes (reference \
         below the floor). `ref!` marks a row whose reference error estimate is not {ACCURACY_MARGIN}× \
         below the method's median error. Configurations whose reference is exactly 0 are in *False light*.\n"
    );
    for (k, family) in case.materials.iter().enumerate() {
        let _ = writeln!(w, "### Material `{}`\n", family.name);
        let _ = writeln!(
            w,
            "| method | n | NaN | inf | median | p90 | p99 | max | abs p99 | abs max | CPU f32 p99 | f64 median | f64 p99 | f64 max | bits med | bits p99 | ≤1e-3 % | ≤1e-2 % | floored p99 (floor {}) | below floor | |",
            sci(Some(case.floor(a.methods.first().map_or(crate::input::target::Target::Line, |m| m.target))))
        );
        let _ = writeln!(
            w,
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
        );
        for ms in &a.methods {
            let mat = &ms.materials[k];
            let s = &mat.all;
            let [med, p90, p99, max] = q3(s, |s| s.rel);
            let [_, _, ap99, amax] = q3(s, |s| s.abs);
            let [_, _, cp99, _] = q3(s, |s| s.rel_cpu_f32);
            let [fm, _, fp99, fmax] = q3(s, |s| s.rel_f64);
            let [_, _, flp99, _] = q3(s, |s| s.rel_floored);
            let [bm, bp99] = s.bits.map_or(["—".into(), "—".into()], |q| {
                [q.median, q.p99].map(|b| format!("{b:.1}"))
            });
            let mut mark = String::new();
            if !mat.supported {
                mark += "unsupported M⁻¹ (shown, not gated) ";
            }
            if s.reference_flag {
                mark += "ref!";
            }
            let _ = writeln!(
                w,
                "| `{}` | {} | {} | {} | {med} | {p90} | {p99} | {max} | {ap99} | {amax} | {cp99} | {fm} | {fp99} | {fmax} | {bm} | {bp99} | {} | {} | {flp99} | {} ({}) | {mark} |",
                ms.label,
                s.count,
                s.nan,
                s.inf,
                pct(s.within[0]),
                pct(s.within[1]),
                s.below_floor,
                share(s.below_floor, s.lit_configurations()),
            );
        }
        let _ = writeln!(w);
        axis_tables(w, input, k);
    }
}

/// Material `k`, per axis: p99 (f32 / f64) of every method in every bin.
fn axis_tables(w: &mut String, input: &Summary, k: usize) {
    let (case, a) = (&input.case, &input.analysis);
    let family = &case.materials[k];
    for (ax, axis) in case.bins.iter().enumerate() {
        let populated = a.methods.first().is_some_and(|ms| {
            ms.materials[k].axes[ax]
                .bins
                .iter()
                .any(|b| b.stats.configurations() > 0)
        });
        if !populated {
            continue; // an axis this material has no values on (alpha for diffuse)
        }
        let min = axis.min_per_bin(case.min_per_bin);
        let _ = writeln!(
            w,
            "p99 relative error by `{}` (f32 / f64), material `{}`; n counts every configuration in the \
             bin, \"ref 0\" those whose reference is 0 (left out of the quantiles); a bin below {} \
             configurations is marked thin:\n",
            axis.axis, family.name, min
        );
        let head: Vec<String> = a.methods.iter().map(|ms| format!("`{}`", ms.label)).collect();
        let _ = writeln!(w, "| {} | n | ref 0 | {} |", axis.axis, head.join(" | "));
        let _ = writeln!(w, "|---|---:|---:|{}", "---:|".repeat(head.len()));
        for (b, (lo, hi)) in axis.edges.windows(2).map(|e| (e[0], e[1])).enumerate() {
            // Configurations in the bin, reference 0 included (the same for every method).
            let (n, zero) = a.methods.first().map_or((0, 0), |ms| {
                let s = &ms.materials[k].axes[ax].bins[b].stats;
                (s.configurations(), s.false_light.configurations)
            });
            if n == 0 {
                continue;
            }
            let cells: Vec<String> = a
                .methods
                .iter()
                .map(|ms| {
                    let s = &ms.materials[k].axes[ax].bins[b].stats;
                    let mut c = format!("{} / {}", sci(s.rel.map(|q| q.p99)), sci(s.rel_f64.map(|q| q.p99)));
                    let nonfinite = s.nan + s.inf + s.false_light.nonfinite;
                    if nonfinite > 0 {
                        c += &format!(" ({nonfinite} NaN/inf)");
                    }
                    if s.false_light.lit > 0 {
                        c += &format!(" (lit 0: {})", s.false_light.lit);
                    }
                    c
                })
                .collect();
            let thin = if n < min { " thin" } else { "" };
            let _ = writeln!(w, "| [{lo}, {hi}){thin} | {n} | {zero} | {} |", cells.join(" | "));
        }
        let _ = writeln!(w);
    }
}

/// A method run at several parameter values (sample counts): its error as the count grows.
pub(super) fn convergence(w: &mut String, input: &Summary) {
    let (case, a) = (&input.case, &input.analysis);
    let mut ids: Vec<&str> = Vec::new();
    for m in &a.methods {
        if !ids.contains(&m.id.as_str()) {
            ids.push(&m.id);
        }
    }
    for id in ids {
        let runs: Vec<_> = a.methods.iter().filter(|m| m.id == id).collect();
        if runs.len() < 2 {
            continue;
        }
        let _ = writeln!(w, "## Convergence of `{id}`\n");
        let _ = writeln!(
            w,
            "Relative error against the reference as the sample count grows: median / p99 / max of the GPU \
             f32 result, and p99 of the same rule in f64 (its discretisation error alone).\n"
        );
        let names: Vec<String> = case
            .materials
            .iter()
            .map(|f| format!("`{}` (f32 median / p99 / max; f64 p99)", f.name))
            .collect();
        let _ = writeln!(w, "| method | {} |", names.join(" | "));
        let _ = writeln!(w, "|---|{}", "---:|".repeat(names.len()));
        for ms in runs {
            let cells: Vec<String> = ms
                .materials
                .iter()
                .map(|mat| {
                    let q = mat.all.rel;
                    format!(
                        "{} / {} / {}; {}",
                        sci(q.map(|q| q.median)),
                        sci(q.map(|q| q.p99)),
                        sci(q.map(|q| q.max)),
                        sci(mat.all.rel_f64.map(|q| q.p99))
                    )
                })
                .collect();
            let _ = writeln!(w, "| `{}` | {} |", ms.label, cells.join(" | "));
        }
        let _ = writeln!(w);
    }
}

/// Configurations whose reference is exactly 0: how often and how much each method lights them.
pub(super) fn false_light(w: &mut String, input: &Summary) {
    let a = &input.analysis;
    let any = a
        .methods
        .iter()
        .flat_map(|m| &m.materials)
        .any(|m| m.all.false_light.configurations > 0);
    if !any {
        return;
    }
    let _ = writeln!(w, "## False light\n");
    let _ = writeln!(
        w,
        "Configurations whose reference is exactly 0 (no light arrives: the light is wholly outside D's \
         support) are not averaged into any error statistic. Here is how often each method returns light \
         there anyway (f32 GPU, and the same formula in f64), how much (|value|, units where d = 1), and \
         its NaN/inf there.\n"
    );
    let _ = writeln!(
        w,
        "| method | material | reference 0 | lit (f32) | lit (f64) | median lit value | max lit value | NaN/inf |"
    );
    let _ = writeln!(w, "|---|---|---:|---:|---:|---:|---:|---:|");
    for ms in &a.methods {
        for mat in &ms.materials {
            let f = &mat.all.false_light;
            if f.configurations == 0 {
                continue;
            }
            let _ = writeln!(
                w,
                "| `{}` | `{}` | {} | {} ({}) | {} | {} | {} | {} |",
                ms.label,
                mat.material,
                f.configurations,
                f.lit,
                share(f.lit, f.configurations),
                f.lit_f64,
                sci(f.value.map(|q| q.median)),
                sci(f.value.map(|q| q.max)),
                f.nonfinite
            );
        }
    }
    let _ = writeln!(w);
}

/// Missed light: configurations whose reference is not 0 where a method returns exactly 0.
/// They stay in the error statistics (each an error of exactly 1); the count names the cause.
pub(super) fn missed_light(w: &mut String, input: &Summary) {
    let a = &input.analysis;
    let rows: Vec<_> = a
        .methods
        .iter()
        .flat_map(|ms| ms.materials.iter().map(move |mat| (ms, mat)))
        .filter(|(_, mat)| mat.all.dark > 0)
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        w,
        "## Missed light
"
    );
    let _ = writeln!(
        w,
        "Configurations whose reference is not 0 (light arrives) where the method returns exactly 0. \
         They are in every error statistic above, each a relative error of exactly 1, so a quantile \
         that reads exactly 1.0 is usually them. \"0 in f64\" counts those where the same formula in \
         f64 returns 0 too: the light is lost by the formula, not by rounding.\n"
    );
    let _ = writeln!(
        w,
        "| method | material | lit configurations | 0 (f32, GPU) | 0 in f64 |"
    );
    let _ = writeln!(w, "|---|---|---:|---:|---:|");
    for (ms, mat) in rows {
        let s = &mat.all;
        let lit = s.lit_configurations();
        let _ = writeln!(
            w,
            "| `{}` | `{}` | {} | {} ({}) | {} |",
            ms.label,
            mat.material,
            lit,
            s.dark,
            share(s.dark, lit),
            s.dark_f64
        );
    }
    let _ = writeln!(w);
}

/// `line` against `line_upper`: the share of light from below the horizon, and the `line`
/// methods judged against `line_upper`.
pub(super) fn below_horizon(w: &mut String, input: &Summary) {
    let a = &input.analysis;
    let leaks = &input.leak;
    if !leaks.is_empty() {
        let _ = writeln!(w, "## Light from below the horizon (`line` − `line_upper`)\n");
        let _ = writeln!(
            w,
            "`line` integrates the whole lobe; a real surface receives only `line_upper`. The share of \
             `line` that comes from below the horizon is what every `line` method leaks.\n"
        );
        let _ = writeln!(
            w,
            "| material | configurations | leaking > 1e-6 | median share (leaking) | max share |"
        );
        let _ = writeln!(w, "|---|---:|---:|---:|---:|");
        for l in leaks {
            let _ = writeln!(
                w,
                "| `{}` | {} | {} | {} | {} |",
                l.material,
                l.configurations,
                l.leaking,
                sci(Some(l.median_fraction)),
                sci(Some(l.max_fraction))
            );
        }
        let _ = writeln!(w);
        let _ = writeln!(
            w,
            "The `line` methods judged against `line_upper` instead (p99 / max relative error), and how \
             many configurations with the light wholly below the horizon (`line_upper` = 0) get a \
             non-zero value from them:\n"
        );
        let _ = writeln!(
            w,
            "| method | material | p99 vs line_upper | max vs line_upper | false light: lit of wholly below | largest value there |"
        );
        let _ = writeln!(w, "|---|---|---:|---:|---:|---:|");
        for ms in &a.methods {
            for mat in &ms.materials {
                let Some(up) = &mat.against_line_upper else { continue };
                let _ = writeln!(
                    w,
                    "| `{}` | `{}` | {} | {} | {} of {} | {} |",
                    ms.label,
                    mat.material,
                    sci(up.rel.map(|q| q.p99)),
                    sci(up.rel.map(|q| q.max)),
                    up.false_light.lit,
                    up.false_light.configurations,
                    sci(up.false_light.value.map(|q| q.max)),
                );
            }
        }
        let _ = writeln!(w);
    }
}

//! Accuracy against the reference: the error table per material and its per-axis view, the
//! convergence of methods run at several sample counts, false light (reference 0), missed
//! light (the method 0 where light arrives) and the light from below the horizon.

use super::q3;
use crate::analyse::stats::ACCURACY_MARGIN;
use crate::analyse::summary::Summary;
use crate::report::markup::{percent as pct, sci, share, Align, Doc as _, Table};

/// Per material: every method's error statistics (f32 GPU, CPU f32, f64, bits, floored), then
/// its per-axis view.
pub(super) fn error_tables(w: &mut String, input: &Summary) {
    let (case, a) = (&input.case, &input.analysis);
    w.heading(2, "Error against the reference");
    w.para(
        "Each method is judged against what the surface receives: its target's surface view (`line_upper` \
         for `line`, `cylinder_upper` for `cylinder`, `caps_upper`, `tube_upper`, `rectangle_upper`; \
         column \"judged\"), where a quit test's 0 for a light wholly below the surface is right and a \
         lobe's leak below the horizon is an error. The f32 columns (GPU, CPU f32, bits) are judged against \
         the reference at the configuration rounded to f32 (what an f32 kernel could at best return), the \
         f64 columns against the exact reference; \"input rounding p99\" is the gap between the two \
         references (no f32 kernel can do better). The formula's own error (against its own target, leak \
         included) is in *The formula's own error*.",
    );
    w.para(format_args!(
        "Relative error of each method's f32 GPU result, no floor, over the configurations whose reference \
         is not 0 (n); its absolute error (units where d = 1); the relative error of the same formula in \
         f32 on the CPU (correctly rounded libm: the gap to the GPU column is the driver's arithmetic) and \
         in f64 (the formula's own error); bits of error; NaN/inf counts; the share within 1e-3 and 1e-2 \
         (more columns in `stats.csv`). Beside them, labelled, the floored variant \
         |value − reference| / max(|reference|, floor) and how many configurations it changes (reference \
         below the floor). `ref!` marks a row whose reference error estimate is not {ACCURACY_MARGIN}× \
         below the method's median error. Configurations whose reference is exactly 0 are in *False light*."
    ));
    for (k, family) in case.materials.iter().enumerate() {
        w.heading(3, format_args!("Material `{}`", family.name));
        let floored = format!(
            "floored p99 (floor {})",
            sci(Some(
                case.floor(
                    a.methods
                        .first()
                        .map_or(crate::input::target::Target::Line, |m| m.target)
                )
            ))
        );
        let mut columns: Vec<(String, Align)> = ["method", "judged"].map(|c| (c.to_string(), Align::Left)).to_vec();
        for c in [
            "n",
            "NaN",
            "inf",
            "median",
            "p90",
            "p99",
            "max",
            "abs p99",
            "abs max",
            "CPU f32 p99",
            "f64 median",
            "f64 p99",
            "f64 max",
            "input rounding p99",
            "bits med",
            "bits p99",
            "≤1e-3 %",
            "≤1e-2 %",
            floored.as_str(),
            "below floor",
        ] {
            columns.push((c.to_string(), Align::Right));
        }
        columns.push((String::new(), Align::Left));
        let mut table = Table::with_columns(columns);
        for ms in &a.methods {
            let mat = &ms.materials[k];
            let s = &mat.all;
            let [med, p90, p99, max] = q3(s, |s| s.rel);
            let [_, _, ap99, amax] = q3(s, |s| s.abs);
            let [_, _, cp99, _] = q3(s, |s| s.rel_cpu_f32);
            let [fm, _, fp99, fmax] = q3(s, |s| s.rel_f64);
            let [_, _, flp99, _] = q3(s, |s| s.rel_floored);
            let [_, _, rp99, _] = q3(s, |s| s.input_rounding);
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
            table.row(vec![
                format!("`{}`", ms.label),
                format!("`{}`", ms.judged),
                s.count.to_string(),
                s.nan.to_string(),
                s.inf.to_string(),
                med,
                p90,
                p99,
                max,
                ap99,
                amax,
                cp99,
                fm,
                fp99,
                fmax,
                rp99,
                bm,
                bp99,
                pct(s.within[0]),
                pct(s.within[1]),
                flp99,
                format!("{} ({})", s.below_floor, share(s.below_floor, s.lit_configurations())),
                mark,
            ]);
        }
        w.table(&table);
        w.blank();
        axis_tables(w, input, k);
    }
}

/// Material `k`, per axis: p99 (f32 / f64) of every method in every bin.
fn axis_tables(w: &mut String, input: &Summary, k: usize) {
    let (case, a) = (&input.case, &input.analysis);
    let budget = case.budget();
    let quantile = format!("p{}", (budget.quantile * 1e8).round() / 1e6);
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
        w.para(format_args!(
            "p99 relative error by `{}` (f32 / f64; the headline view, as above), material `{}`; n counts \
             every configuration in the bin, \"ref 0\" those whose reference is 0 (left out of the \
             quantiles); \"input rounding\" is the gap between the reference at the f32-rounded inputs \
             and the exact one ({} over the bin), and a bin where it alone breaks the budget ({} ≤ {}) is \
             marked **unattainable in f32**; a bin below {} configurations is marked thin:",
            axis.axis,
            family.name,
            quantile,
            quantile,
            sci(Some(budget.value)),
            min
        ));
        let mut columns = vec![(axis.axis.clone(), Align::Left)];
        columns.extend(["n", "ref 0", "input rounding"].map(|c| (c.to_string(), Align::Right)));
        columns.extend(a.methods.iter().map(|ms| (format!("`{}`", ms.label), Align::Right)));
        let mut table = Table::with_columns(columns);
        for (b, (lo, hi)) in axis.edges.windows(2).map(|e| (e[0], e[1])).enumerate() {
            // Configurations in the bin, reference 0 included (the same for every method).
            let (n, zero) = a.methods.first().map_or((0, 0), |ms| {
                let s = &ms.materials[k].axes[ax].bins[b].stats;
                (s.configurations(), s.false_light.configurations)
            });
            if n == 0 {
                continue;
            }
            // Input rounding of the first method's headline target (the same configurations).
            let rounding = a
                .methods
                .first()
                .and_then(|ms| ms.materials[k].axes[ax].bins[b].stats.input_rounding_at_budget);
            let unattainable = rounding.is_some_and(|x| x > budget.value);
            let rounding = format!(
                "{}{}",
                sci(rounding),
                if unattainable { " **unattainable in f32**" } else { "" }
            );
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
            let mut row = vec![format!("[{lo}, {hi}){thin}"), n.to_string(), zero.to_string(), rounding];
            row.extend(cells);
            table.row(row);
        }
        w.table(&table);
        w.blank();
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
        w.heading(2, format_args!("Convergence of `{id}`"));
        w.para(
            "Relative error against the reference as the sample count grows: median / p99 / max of the GPU \
             f32 result, and p99 of the same rule in f64 (its discretisation error alone).",
        );
        let mut columns = vec![("method".to_string(), Align::Left)];
        columns.extend(
            case.materials
                .iter()
                .map(|f| (format!("`{}` (f32 median / p99 / max; f64 p99)", f.name), Align::Right)),
        );
        let mut table = Table::with_columns(columns);
        for ms in runs {
            let cells = ms
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
                .collect::<Vec<String>>();
            table.row([vec![format!("`{}`", ms.label)], cells].concat());
        }
        w.table(&table);
        w.blank();
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
    w.heading(2, "False light");
    w.para(
        "Configurations whose reference is exactly 0 (no light arrives: the light is wholly outside D's \
         support) are not averaged into any error statistic. Here is how often each method returns light \
         there anyway (f32 GPU, and the same formula in f64), how much (|value|, units where d = 1), and \
         its NaN/inf there.",
    );
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("material", Align::Left),
        ("reference 0", Align::Right),
        ("lit (f32)", Align::Right),
        ("lit (f64)", Align::Right),
        ("median lit value", Align::Right),
        ("max lit value", Align::Right),
        ("NaN/inf", Align::Right),
    ]);
    for ms in &a.methods {
        for mat in &ms.materials {
            let f = &mat.all.false_light;
            if f.configurations == 0 {
                continue;
            }
            table.row(vec![
                format!("`{}`", ms.label),
                format!("`{}`", mat.material),
                f.configurations.to_string(),
                format!("{} ({})", f.lit, share(f.lit, f.configurations)),
                f.lit_f64.to_string(),
                sci(f.value.map(|q| q.median)),
                sci(f.value.map(|q| q.max)),
                f.nonfinite.to_string(),
            ]);
        }
    }
    w.table(&table);
    w.blank();
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
    w.line(
        "## Missed light
",
    );
    w.para(
        "Configurations whose reference is not 0 (light arrives) where the method returns exactly 0. \
         They are in every error statistic above, each a relative error of exactly 1, so a quantile \
         that reads exactly 1.0 is usually them. \"0 in f64\" counts those where the same formula in \
         f64 returns 0 too: the light is lost by the formula, not by rounding.",
    );
    let mut table = Table::new(&[
        ("method", Align::Left),
        ("material", Align::Left),
        ("lit configurations", Align::Right),
        ("0 (f32, GPU)", Align::Right),
        ("0 in f64", Align::Right),
    ]);
    for (ms, mat) in rows {
        let s = &mat.all;
        let lit = s.lit_configurations();
        table.row(vec![
            format!("`{}`", ms.label),
            format!("`{}`", mat.material),
            lit.to_string(),
            format!("{} ({})", s.dark, share(s.dark, lit)),
            s.dark_f64.to_string(),
        ]);
    }
    w.table(&table);
    w.blank();
}

/// `line` against `line_upper`: the share of light from below the horizon; and every method
/// with a surface view judged against its own target (the formula's own error).
pub(super) fn below_horizon(w: &mut String, input: &Summary) {
    let a = &input.analysis;
    let leaks = &input.leak;
    if !leaks.is_empty() {
        w.heading(2, "Light from below the horizon (`line` − `line_upper`)");
        w.para(
            "`line` integrates the whole lobe; a real surface receives only `line_upper`. The share of \
             `line` that comes from below the horizon is what every `line` method leaks.",
        );
        let mut table = Table::new(&[
            ("material", Align::Left),
            ("configurations", Align::Right),
            ("leaking > 1e-6", Align::Right),
            ("median share (leaking)", Align::Right),
            ("max share", Align::Right),
        ]);
        for l in leaks {
            table.row(vec![
                format!("`{}`", l.material),
                l.configurations.to_string(),
                l.leaking.to_string(),
                sci(Some(l.median_fraction)),
                sci(Some(l.max_fraction)),
            ]);
        }
        w.table(&table);
        w.blank();
    }
    let rows: Vec<_> = a
        .methods
        .iter()
        .flat_map(|ms| ms.materials.iter().map(move |mat| (ms, mat)))
        .filter(|(_, mat)| mat.own_target.is_some())
        .collect();
    if !rows.is_empty() {
        w.heading(2, "The formula's own error (against its own target)");
        w.para(
            "The headline judges each method against what the surface receives. Here the same results \
             are judged against the method's own target (`line`, `cylinder`, `caps`, `tube`, `rectangle`: \
             the lobe as the LTC defines it, leak below the horizon included), which is what the formula \
             models: p99 / max relative error, and its configurations whose own target is 0. Beside them, \
             against the surface view: how many lights are wholly below the surface (both end points, and \
             for a tube or rectangle the whole shape, at z ≤ 0), of the configurations the surface receives \
             nothing from, and how many of those wholly below the method lights.",
        );
        let mut table = Table::new(&[
            ("method", Align::Left),
            ("material", Align::Left),
            ("own target", Align::Left),
            ("p99 vs own", Align::Right),
            ("max vs own", Align::Right),
            ("own = 0 (lit)", Align::Right),
            ("surface receives nothing", Align::Right),
            ("wholly below (lit)", Align::Right),
        ]);
        for (ms, mat) in rows {
            let Some(own) = &mat.own_target else { continue };
            let below = mat.wholly_below.as_ref().map_or("—".to_string(), |b| {
                format!("{} ({})", b.false_light.configurations, b.false_light.lit)
            });
            table.row(vec![
                format!("`{}`", ms.label),
                format!("`{}`", mat.material),
                format!("`{}`", ms.target),
                sci(own.rel.map(|q| q.p99)),
                sci(own.rel.map(|q| q.max)),
                format!("{} ({})", own.false_light.configurations, own.false_light.lit),
                mat.all.false_light.configurations.to_string(),
                below,
            ]);
        }
        w.table(&table);
        w.blank();
    }
}

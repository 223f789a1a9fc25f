//! "Any conforming driver" (docs/envelope.md): the envelope's worst relative error per method
//! and material, the share past the budget, the configurations without a finite envelope and
//! where the freedom goes. Rendered only when the case asks (`envelope = { sample = N }`).

use crate::analyse::envelope::AnyDriver;
use crate::report::markup::{Align, Doc as _, Table};

/// Lines shown per method in "where the freedom goes".
const TOP: usize = 5;

fn sig(x: f64) -> String {
    format!("{x:.3e}")
}

pub fn render(a: &AnyDriver) -> String {
    let mut o = String::new();
    o.heading(2, "Any conforming driver");
    o.para(format_args!(
        "The envelope: every f32 result a WGSL implementation within the spec's accuracy rules may \
         return when it evaluates the kernel in its written order (interval arithmetic with outward \
         rounding over the kernel's IR; reassociation excluded; docs/envelope.md). An outer bound, \
         not an estimate: interval dependency can make it far wider than any real driver. On a \
         stated subsample: at most {} configurations per method, spread evenly over those it \
         applies to ({:.1} s in all). Worst relative error = max(|lo − ref|, |hi − ref|) / |ref| \
         against the budget's target (`{}`) where the method is judged against it, else against \
         its own; \"past the budget\": envelopes whose worst relative error exceeds the budget's \
         value {}. \"No finite envelope\": an intermediate may be Inf or NaN (undefined on a \
         driver that assumes finite math), an operation leaves the range the spec bounds, or the \
         interval is too wide to inform. \"GPU outside\": configurations whose GPU value (this run's \
         adapter) lies outside its finite envelope, of those with one: the driver left the written \
         order or broke the spec (a finding, listed below).",
        a.sample,
        a.seconds,
        a.budget_target,
        sig(a.budget_value)
    ));
    let mut columns: Vec<(&str, Align)> = ["method", "material", "target"].map(|c| (c, Align::Left)).to_vec();
    columns.extend(
        [
            "n",
            "p50",
            "p90",
            "p99",
            "max",
            "past the budget",
            "no finite envelope",
            "GPU outside",
        ]
        .map(|c| (c, Align::Right)),
    );
    let mut table = Table::new(&columns);
    for r in &a.rows {
        let q = |i: usize| r.quantiles.map_or("—".to_string(), |q| sig(q[i]));
        let past = match r.breaks {
            Some((k, n)) if n > 0 => format!("{k}/{n} ({:.1}%)", 100.0 * k as f64 / n as f64),
            Some(_) => "—".into(),
            None => "not judged".into(),
        };
        table.row(vec![
            format!("`{}`", r.label),
            r.material.to_string(),
            format!("`{}`", r.target),
            r.n.to_string(),
            q(0),
            q(1),
            q(2),
            q(3),
            past,
            r.undefined.to_string(),
            format!("{}/{}", r.gpu_outside, r.gpu_checked),
        ]);
    }
    o.table(&table);
    o.blank();
    let outside: Vec<_> = a.rows.iter().filter(|r| r.gpu_outside > 0).collect();
    if !outside.is_empty() {
        o.para(format_args!(
            "GPU values outside their envelope (the first {} per method and material; each line \
             replayable with `linelight eval`):",
            crate::analyse::envelope::OUTSIDE_SHOWN
        ));
        for r in outside {
            for (config, value, lo, hi) in &r.outside {
                o.line(format_args!(
                    "- `{}` ({}): GPU {value:e} outside [{lo:e}, {hi:e}]: `{}`",
                    r.label,
                    r.material,
                    serde_json::to_string(config).unwrap_or_default()
                ));
            }
        }
        o.blank();
    }
    let named: Vec<_> = a.rows.iter().filter(|r| !r.lines.is_empty()).collect();
    if !named.is_empty() {
        o.para("Where the envelope has no finite bound (configurations, per method and material):");
        for r in named {
            for (at, k) in &r.lines {
                o.line(format_args!(
                    "- `{}` ({}): {k} × {}",
                    r.label,
                    r.material,
                    at.replace('|', "\\|")
                ));
            }
        }
        o.blank();
    }
    o.para(
        "### Where the freedom goes\n\nPer method, the source lines whose allowed error (beyond correct \
         rounding) widens the envelope most: the mean over the configurations of log2(envelope width / \
         width with that line's operations held to correct rounding), in bits, on an evenly spread part \
         of the subsample (count per method).",
    );
    for f in &a.freedom {
        if f.lines.is_empty() {
            continue;
        }
        o.para(format_args!("`{}` ({} configurations):", f.label, f.configurations));
        let mut table = Table::new(&[
            ("file:line", Align::Left),
            ("source", Align::Left),
            ("mean bits", Align::Right),
        ]);
        for (at, text, bits) in f.lines.iter().take(TOP) {
            table.row(vec![
                format!("`{at}`"),
                format!("`{}`", text.replace('|', "\\|")),
                format!("{bits:.2}"),
            ]);
        }
        o.table(&table);
        o.blank();
    }
    o
}

//! `linelight eval`: explicit configurations in (JSONL), references and method values
//! out (JSONL, DESIGN §3). Input is checked whole before the GPU is touched. The `f64`
//! and `cpu_f32` values and the attribution come from the CPU evaluator (src/interp).

use crate::methods::Method;
use crate::reference::Estimate;
use crate::scene::Config;
use crate::target::Target;
use anyhow::Context;
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A number as DESIGN §3 writes it: NaN and infinities as strings, never dropped.
pub fn number(x: f64) -> Value {
    if x.is_nan() {
        json!("NaN")
    } else if x == f64::INFINITY {
        json!("inf")
    } else if x == f64::NEG_INFINITY {
        json!("-inf")
    } else {
        json!(x)
    }
}

/// Reads a JSONL file of configurations; every bad line is reported with its number.
pub fn read_configs(path: &Path) -> anyhow::Result<Vec<Config>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut configs = Vec::new();
    let mut errors = Vec::new();
    let mut ids = BTreeSet::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let at = format!("{}:{}", path.display(), i + 1);
        match serde_json::from_str::<Config>(line) {
            Err(e) => errors.push(format!("{at}: {e}")),
            Ok(mut c) => {
                if c.orthonormalize_rect().is_some_and(|moved| moved > 1e-9) {
                    eprintln!(
                        "note: {at}: `{}`: rect.normal made perpendicular to the segment (DESIGN §1)",
                        c.id
                    );
                }
                if let Err(d) = c.validate() {
                    errors.push(format!("{at}: configuration `{}` is degenerate: {d}", c.id));
                } else if !ids.insert(c.id.clone()) {
                    errors.push(format!("{at}: id `{}` appears twice", c.id));
                } else {
                    configs.push(c);
                }
            }
        }
    }
    if !errors.is_empty() {
        anyhow::bail!(
            "{} bad line(s) in {}:\n{}",
            errors.len(),
            path.display(),
            errors.join("\n")
        );
    }
    if configs.is_empty() {
        anyhow::bail!("{}: no configurations", path.display());
    }
    Ok(configs)
}

/// The targets whose references apply to a configuration.
pub fn targets_of(c: &Config) -> BTreeSet<Target> {
    let mut t = BTreeSet::from([Target::Line, Target::LineUpper]);
    if c.radius.is_some() {
        t.extend([Target::Cylinder, Target::Caps, Target::Tube]);
    }
    if c.rect.is_some() {
        t.insert(Target::Rectangle);
    }
    t
}

/// One output line: references with their error estimates and every applicable method.
pub fn result_row(
    c: &Config,
    references: &BTreeMap<Target, Estimate>,
    methods: &[Method],
    f32_values: &[f32],
    f64_values: &[Option<f64>],
    cpu_f32_values: &[Option<f64>],
) -> Value {
    let mut reference = Map::new();
    let mut reference_error = Map::new();
    for (t, e) in references {
        reference.insert(t.name().into(), number(e.value));
        reference_error.insert(t.name().into(), number(e.error));
    }
    let mut values = Map::new();
    for (((m, &v32), &v64), &c32) in methods.iter().zip(f32_values).zip(f64_values).zip(cpu_f32_values) {
        if !m.applies(c) {
            continue;
        }
        let mut entry = Map::new();
        entry.insert("f32".into(), number(v32 as f64));
        entry.insert("f64".into(), v64.map_or(Value::Null, number));
        entry.insert("cpu_f32".into(), c32.map_or(Value::Null, number));
        if !m.supports(c) {
            // Outside the matrices the method claims to handle: shown, flagged.
            entry.insert("supported".into(), json!(false));
        }
        values.insert(m.label.clone(), Value::Object(entry));
    }
    json!({"id": c.id, "reference": reference, "reference_error": reference_error, "methods": values})
}

/// Every output line of `linelight eval`: `f32s[m][i]` is method m's GPU value on
/// configuration i; the `f64` and `cpu_f32` columns come from the CPU evaluator, and with
/// `attribution` each line gets its methods' source lines by bits lost (DESIGN §3).
pub fn rows(
    configs: &[Config],
    methods: &[Method],
    f32s: &[Vec<f32>],
    attribution: bool,
) -> anyhow::Result<Vec<Value>> {
    use rayon::prelude::*;
    let mut f64s = Vec::new();
    let mut cpu32s = Vec::new();
    let mut attributions = Vec::new();
    for m in methods {
        f64s.push(m.cpu_column(configs, crate::interp::Mode::F64)?);
        cpu32s.push(m.cpu_column(configs, crate::interp::Mode::F32)?);
        if attribution {
            attributions.push(attribution_column(m, configs)?);
        }
    }
    Ok(configs
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let refs = targets_of(c)
                .into_iter()
                .filter_map(|t| crate::reference::reference(c, t).map(|e| (t, e)))
                .collect();
            let v32: Vec<f32> = f32s.iter().map(|v| v[i]).collect();
            let v64: Vec<Option<f64>> = f64s.iter().map(|v| v[i]).collect();
            let c32: Vec<Option<f64>> = cpu32s.iter().map(|v| v[i]).collect();
            let mut row = result_row(c, &refs, methods, &v32, &v64, &c32);
            if attribution {
                let mut per = Map::new();
                for (m, a) in methods.iter().zip(&attributions) {
                    if let Some(lines) = &a[i] {
                        per.insert(m.label.clone(), lines.clone());
                    }
                }
                row["attribution"] = Value::Object(per);
            }
            row
        })
        .collect())
}

/// Per configuration (None where the method does not apply): the kernel's source lines
/// with the local error of their f32 operations, most bits first (src/interp).
fn attribution_column(m: &Method, configs: &[Config]) -> anyhow::Result<Vec<Option<Value>>> {
    let program = crate::interp::program(m)?;
    let applies: Vec<&Config> = configs.iter().filter(|c| m.applies(c)).collect();
    let a = program.attribute(&applies)?;
    let mut per = a.per_config.into_iter();
    Ok(configs
        .iter()
        .map(|c| {
            if !m.applies(c) {
                return None;
            }
            let lines = per.next().unwrap_or_default();
            Some(Value::Array(
                lines
                    .iter()
                    .map(|b| {
                        let l = &a.lines[b.line];
                        json!({"file": l.path, "line": l.line, "source": l.text.trim(),
                               "bits_mean": number(b.mean), "bits_max": number(b.max)})
                    })
                    .collect(),
            ))
        })
        .collect())
}

/// Serialises rows as JSONL.
pub fn to_jsonl(rows: &[Value]) -> Vec<u8> {
    let mut out = Vec::new();
    for r in rows {
        out.extend(serde_json::to_vec(r).expect("JSON values serialise"));
        out.push(b'\n');
    }
    out
}

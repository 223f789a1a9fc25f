//! `linelight eval`: explicit configurations in (JSONL), references and method values
//! out (JSONL, DESIGN §3). Input is checked whole before the GPU is touched.

use crate::methods::Method;
use crate::reference::Estimate;
use crate::scene::Config;
use crate::target::Target;
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
    let text = std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
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
    let mut t = BTreeSet::from([Target::Line, Target::LineUpper, Target::LineIsotropic]);
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
) -> Value {
    let mut reference = Map::new();
    let mut reference_error = Map::new();
    for (t, e) in references {
        reference.insert(t.name().into(), number(e.value));
        reference_error.insert(t.name().into(), number(e.error));
    }
    let mut values = Map::new();
    for ((m, &v32), &v64) in methods.iter().zip(f32_values).zip(f64_values) {
        if !m.applies(c) {
            continue;
        }
        let mut entry = Map::new();
        entry.insert("f32".into(), number(v32 as f64));
        entry.insert("f64".into(), v64.map_or(Value::Null, number));
        if !m.supports(c) {
            // Outside the matrices the method claims to handle: shown, flagged.
            entry.insert("supported".into(), json!(false));
        }
        values.insert(m.label.clone(), Value::Object(entry));
    }
    json!({"id": c.id, "reference": reference, "reference_error": reference_error, "methods": values})
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

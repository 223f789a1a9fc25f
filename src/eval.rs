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

/// Output rows made and written at a time (eval, sweep --raw): memory stays bounded.
pub const ROW_BLOCK: usize = 4096;

/// Lines in a file, counted without holding it (for the memory estimate).
pub fn count_lines(path: &Path) -> anyhow::Result<u64> {
    use std::io::BufRead;
    let f = std::fs::File::open(path).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    let mut r = std::io::BufReader::new(f);
    let mut buf = Vec::new();
    let mut n = 0u64;
    loop {
        buf.clear();
        let got = r
            .read_until(b'\n', &mut buf)
            .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
        if got == 0 {
            return Ok(n);
        }
        n += 1;
    }
}

/// Reads a JSONL file of configurations, a line at a time; every bad line is reported with
/// its number (at most [`MAX_ERRORS`] of them, then a count).
pub fn read_configs(path: &Path) -> anyhow::Result<Vec<Config>> {
    use std::io::BufRead;
    let f = std::fs::File::open(path).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    let mut configs = Vec::new();
    let mut errors = Vec::new();
    let mut bad = 0usize;
    let mut ids = BTreeSet::new();
    for (i, line) in std::io::BufReader::new(f).split(b'\n').enumerate() {
        let line = line.map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
        let at = format!("{}:{}", path.display(), i + 1);
        let line = match std::str::from_utf8(&line) {
            Ok(l) => l.strip_prefix('\u{feff}').filter(|_| i == 0).unwrap_or(l),
            Err(e) => {
                bad += 1;
                if errors.len() < MAX_ERRORS {
                    errors.push(format!("{at}: not UTF-8 text ({e})"));
                }
                continue;
            }
        };
        if line.trim().is_empty() {
            continue;
        }
        let result = match serde_json::from_str::<Config>(line) {
            Err(e) => Err(format!("{at}: {e}")),
            Ok(c) => check_config(c, &at, &mut ids),
        };
        match result {
            Ok(c) => configs.push(c),
            Err(e) => {
                bad += 1;
                if errors.len() < MAX_ERRORS {
                    errors.push(e);
                }
            }
        }
    }
    if bad > 0 {
        let more = if bad > errors.len() {
            format!("\n… and {} more", bad - errors.len())
        } else {
            String::new()
        };
        anyhow::bail!("{bad} bad line(s) in {}:\n{}{more}", path.display(), errors.join("\n"));
    }
    if configs.is_empty() {
        anyhow::bail!("{}: no configurations", path.display());
    }
    Ok(configs)
}

/// Bad lines listed in one message.
pub const MAX_ERRORS: usize = 20;

/// One parsed line: the rect normal made perpendicular (recorded in the output, see
/// [`result_row`]), degenerate configurations and repeated ids refused.
fn check_config(mut c: Config, at: &str, ids: &mut BTreeSet<String>) -> Result<Config, String> {
    let id = crate::case_values::clip(&c.id);
    if c.orthonormalize_rect().is_some_and(|moved| moved > 1e-9) {
        eprintln!("note: {at}: `{id}`: rect.normal made perpendicular to the segment (DESIGN §1); the output's `rect` records the normal used");
    }
    if let Err(d) = c.validate() {
        Err(format!("{at}: configuration `{id}` is degenerate: {d}"))
    } else if !ids.insert(c.id.clone()) {
        Err(format!("{at}: id `{id}` appears twice"))
    } else {
        Ok(c)
    }
}

/// Every reference must be a number with a finite error estimate: one that cannot be
/// computed is an error naming the configuration, never a NaN in the output.
pub fn check_references(
    path: &Path,
    configs: &[Config],
    references: &[BTreeMap<Target, Estimate>],
) -> anyhow::Result<()> {
    let bad: Vec<String> = configs
        .iter()
        .zip(references)
        .flat_map(|(c, r)| {
            r.iter()
                .filter(|(_, e)| !(e.value.is_finite() && e.error.is_finite()))
                .map(move |(t, e)| {
                    format!(
                        "configuration `{}`: the {} reference cannot be computed (value {}, error {})",
                        crate::case_values::clip(&c.id),
                        t.name(),
                        e.value,
                        e.error
                    )
                })
        })
        .collect();
    if !bad.is_empty() {
        anyhow::bail!(
            "{}: {} reference(s) not finite:\n{}",
            path.display(),
            bad.len(),
            bad.join("\n")
        );
    }
    Ok(())
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
    let mut row = json!({"id": c.id, "reference": reference, "reference_error": reference_error, "methods": values});
    if let Some(rect) = &c.rect {
        // The rectangle as evaluated: its normal made perpendicular to the segment.
        row["rect"] = json!({"normal": rect.normal, "width": rect.width});
    }
    row
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

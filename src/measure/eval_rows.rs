//! `linelight eval`: explicit configurations in (JSONL), references and method values
//! out (JSONL, docs/eval-format.md). Input is checked whole before the GPU is touched, then streamed in
//! chunks ([`EVAL_CHUNK`]), output in input order. The `f64`
//! and `cpu_f32` values and the attribution come from the CPU evaluator (src/eval/interp).

use crate::eval::interp::CpuColumns;
use crate::input::scene::Config;
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::limits::MAX_ERRORS;
use crate::reference::Estimate;
use anyhow::Context;
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A number as docs/eval-format.md writes it: NaN and infinities as strings, never dropped.
pub use crate::io::json_number as number;

/// Output rows made and written at a time (eval, sweep --raw): memory stays bounded.
pub const ROW_BLOCK: usize = 4096;

/// The size of an input, measured without holding any of it (for the memory estimate).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LineCount {
    pub lines: u64,
    /// The longest line, in bytes.
    pub longest: u64,
    pub bytes: u64,
}

impl LineCount {
    /// The most bytes of text `chunk` lines can hold together.
    pub fn chunk_bytes(&self, chunk: u64) -> u64 {
        self.bytes.min(self.longest.saturating_mul(chunk))
    }
}

/// Lines in a file, counted a block at a time: a line is never held whole, so a
/// gigabyte line costs nothing here (the estimate refuses it before it is read).
pub fn count_lines(path: &Path) -> anyhow::Result<LineCount> {
    use std::io::Read;
    let mut f = crate::io::open_stream(path, "configurations")?;
    let mut buf = vec![0u8; 1 << 16];
    let (mut count, mut current) = (LineCount::default(), 0u64);
    loop {
        let got = match f.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        };
        if got == 0 {
            break;
        }
        count.bytes += got as u64;
        for &b in &buf[..got] {
            current += 1;
            if b == b'\n' {
                count.lines += 1;
                count.longest = count.longest.max(current);
                current = 0;
            }
        }
    }
    if current > 0 {
        count.lines += 1;
        count.longest = count.longest.max(current);
    }
    Ok(count)
}

/// Reads a JSONL file of configurations, a line at a time; every bad line is reported with
/// its number (at most [`MAX_ERRORS`] of them, then a count).
pub fn read_configs(path: &Path) -> anyhow::Result<Vec<Config>> {
    let mut configs = Vec::new();
    for_each_config(path, usize::MAX, true, &mut |c| {
        configs.extend(c);
        Ok(())
    })?;
    Ok(configs)
}

/// Configurations `eval` holds at a time: it streams its input in chunks of this many.
pub const EVAL_CHUNK: usize = 1 << 16;

/// Reads a JSONL file of configurations in chunks of at most `chunk`, handing each to `f` in
/// order. Every line is checked first: with a bad line (at most [`MAX_ERRORS`] listed, then a
/// count) nothing is handed on, so a caller that wants the whole input checked before any
/// work calls it once with a no-op `f` (only the ids are held, to find repeated ones).
/// `notes`: print the notes on corrected lines (once per input, not once per pass).
pub fn for_each_config(
    path: &Path,
    chunk: usize,
    notes: bool,
    f: &mut dyn FnMut(Vec<Config>) -> anyhow::Result<()>,
) -> anyhow::Result<usize> {
    use std::io::BufRead;
    let file = crate::io::open_stream(path, "configurations")?;
    let mut configs = Vec::new();
    let mut errors = Vec::new();
    let mut bad = 0usize;
    let mut total = 0usize;
    let mut ids = BTreeSet::new();
    for (i, line) in std::io::BufReader::new(file).split(b'\n').enumerate() {
        let line = line.with_context(|| format!("cannot read {}", path.display()))?;
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
            Ok(c) => check_config(c, &at, &mut ids, notes),
        };
        match result {
            Ok(c) => {
                total += 1;
                if bad == 0 {
                    configs.push(c);
                    if configs.len() >= chunk {
                        f(std::mem::take(&mut configs))?;
                    }
                }
            }
            Err(e) => {
                bad += 1;
                configs.clear();
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
    if total == 0 {
        anyhow::bail!("{}: no configurations", path.display());
    }
    if !configs.is_empty() {
        f(configs)?;
    }
    Ok(total)
}

/// One parsed line: the rect normal made perpendicular (recorded in the output, see
/// [`result_row`]), degenerate configurations and repeated ids refused.
/// An id as held to find repeats: itself when short, else its length and two hashes, so the
/// ids of a whole input cost a bounded size each, however long (the memory estimate counts
/// [`ID_BYTES`] per line).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum IdKey {
    Short(String),
    Long(usize, u64, u64),
}

/// The longest id held as itself.
const SHORT_ID: usize = 64;

/// Bytes an input line's id takes in the set of ids: the key and the set's own node.
pub const ID_BYTES: u64 = 2 * SHORT_ID as u64;

impl IdKey {
    fn of(id: &str) -> IdKey {
        if id.len() <= SHORT_ID {
            return IdKey::Short(id.to_string());
        }
        use std::hash::{Hash, Hasher};
        let hash = |salt: u8| {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            (salt, id).hash(&mut h);
            h.finish()
        };
        IdKey::Long(id.len(), hash(0), hash(1))
    }
}

fn check_config(mut c: Config, at: &str, ids: &mut BTreeSet<IdKey>, notes: bool) -> Result<Config, String> {
    let id = crate::input::names::clip(&c.id);
    if c.orthonormalize_rect().is_some_and(|moved| moved > 1e-9) && notes {
        crate::warnings::raise(crate::warnings::Warning::NormalMadePerpendicular {
            at: at.to_string(),
            id: id.to_string(),
        });
    }
    if let Err(d) = c.validate() {
        Err(format!("{at}: configuration `{id}` is degenerate: {d}"))
    } else if !ids.insert(IdKey::of(&c.id)) {
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
                        crate::input::names::clip(&c.id),
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

/// The targets whose references apply to a configuration: the line targets, the surfaces it
/// has (each with its `_upper` view), and the summed targets (`line_sum`, `line_isotropic_sum`) when a method evaluated is
/// judged against one (each costs its parts' integrals again, so only then).
pub fn targets_of(c: &Config, methods: &[Method]) -> BTreeSet<Target> {
    let mut t = BTreeSet::from([Target::Line, Target::LineUpper, Target::LineIsotropic]);
    t.extend(
        methods
            .iter()
            .map(Method::target)
            .filter(|m| matches!(m, Target::LineSum | Target::LineIsotropicSum)),
    );
    if c.radius.is_some() {
        t.extend([
            Target::Cylinder,
            Target::Caps,
            Target::Tube,
            Target::CylinderUpper,
            Target::CapsUpper,
            Target::TubeUpper,
        ]);
    }
    if c.rect.is_some() {
        t.extend([Target::Rectangle, Target::RectangleUpper]);
    }
    t
}

/// The references of `targets` at the configuration rounded to f32 ([`Config::rounded_to_f32`]):
/// what an f32 kernel could at best return. A configuration already in f32 gets `exact`'s
/// values (copied, not recomputed). One that rounding makes degenerate (`validate` refuses it:
/// the rounded shading point inside the tube, say), or a reference there that is not finite,
/// gets none: its f32 columns are then judged against the exact reference.
pub fn references_f32_inputs(
    c: &Config,
    targets: &BTreeSet<Target>,
    exact: &BTreeMap<Target, Estimate>,
) -> BTreeMap<Target, Estimate> {
    let rounded = c.rounded_to_f32();
    if rounded == *c {
        return targets.iter().filter_map(|t| Some((*t, *exact.get(t)?))).collect();
    }
    if rounded.validate().is_err() {
        return BTreeMap::new();
    }
    crate::reference::references(&rounded, targets)
        .into_iter()
        .filter(|(_, e)| e.value.is_finite() && e.error.is_finite())
        .collect()
}

/// The version of the eval output format (docs/eval-format.md): 2 added
/// `reference_f32_inputs` and `reference_f32_inputs_error`, and `version` itself.
pub const EVAL_FORMAT_VERSION: u32 = 2;

/// References by target name as eval writes them: the values, and their error estimates.
fn value_and_error(references: &BTreeMap<Target, Estimate>) -> (Value, Value) {
    let (mut value, mut error) = (Map::new(), Map::new());
    for (t, e) in references {
        value.insert(t.name().into(), number(e.value));
        error.insert(t.name().into(), number(e.error));
    }
    (Value::Object(value), Value::Object(error))
}

/// One output line: references with their error estimates (and, where computed, those at the
/// configuration rounded to f32) and every applicable method.
pub fn result_row(
    c: &Config,
    references: &BTreeMap<Target, Estimate>,
    references_f32: Option<&BTreeMap<Target, Estimate>>,
    methods: &[Method],
    f32_values: &[f32],
    f64_values: &[Option<f64>],
    cpu_f32_values: &[Option<f64>],
) -> Value {
    let (reference, reference_error) = value_and_error(references);
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
    let mut row = json!({"version": EVAL_FORMAT_VERSION, "id": c.id, "reference": reference,
        "reference_error": reference_error, "methods": values});
    if let Some(references_f32) = references_f32 {
        let (value, error) = value_and_error(references_f32);
        row["reference_f32_inputs"] = value;
        row["reference_f32_inputs_error"] = error;
    }
    if let Some(rect) = &c.rect {
        // The rectangle as evaluated: its normal made perpendicular to the segment.
        row["rect"] = json!({"normal": rect.normal, "width": rect.width});
    }
    row
}

/// Every output line of `linelight eval`: `f32s[m][i]` is method m's GPU value on
/// configuration i; the `f64` and `cpu_f32` columns come from the CPU evaluator, and with
/// `attribution` each line gets its methods' source lines by bits lost (docs/eval-format.md).
pub fn rows(
    configs: &[Config],
    methods: &[Method],
    f32s: &[&[f32]],
    references: &[BTreeMap<Target, Estimate>],
    references_f32: Option<&[BTreeMap<Target, Estimate>]>,
    attribution: bool,
    envelope: bool,
) -> anyhow::Result<Vec<Value>> {
    use rayon::prelude::*;
    let mut f64s = Vec::new();
    let mut cpu32s = Vec::new();
    let mut attributions = Vec::new();
    for m in methods {
        f64s.push(m.cpu_column_or_none(configs, crate::eval::interp::Mode::F64));
        cpu32s.push(m.cpu_column_or_none(configs, crate::eval::interp::Mode::F32));
        if attribution {
            attributions.push(attribution_column(m, configs)?);
        }
    }
    Ok(configs
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let v32: Vec<f32> = f32s.iter().map(|v| v[i]).collect();
            let v64: Vec<Option<f64>> = f64s.iter().map(|v| v[i]).collect();
            let c32: Vec<Option<f64>> = cpu32s.iter().map(|v| v[i]).collect();
            let mut row = result_row(
                c,
                &references[i],
                references_f32.map(|r| &r[i]),
                methods,
                &v32,
                &v64,
                &c32,
            );
            if attribution {
                let mut per = Map::new();
                for (m, a) in methods.iter().zip(&attributions) {
                    if let Some(lines) = &a[i] {
                        per.insert(m.label.clone(), lines.clone());
                    }
                }
                row["attribution"] = Value::Object(per);
            }
            if envelope {
                let (bounds, undefined) = envelope_fields(c, methods);
                row["envelope"] = bounds;
                if let Some(u) = undefined {
                    row["envelope_undefined"] = u;
                }
            }
            row
        })
        .collect())
}

/// `"envelope": {"<method>": [lo, hi]}` and, where an intermediate may be infinite or NaN or an
/// operation leaves the range the spec bounds, `"envelope_undefined": {"<method>": {"line": N,
/// "source": "…", "file": "…", "why": "…"}}` (the interval is then `["-inf", "inf"]`). A method
/// the envelope cannot bound (too wide, an unsupported construct) gets `["-inf", "inf"]` and
/// `"why"` without a line.
fn envelope_fields(c: &Config, methods: &[Method]) -> (Value, Option<Value>) {
    use crate::eval::interp::EnvelopeStop as Stop;
    let mut bounds = Map::new();
    let mut undefined = Map::new();
    let unbounded = || json!([number(f64::NEG_INFINITY), number(f64::INFINITY)]);
    for m in methods {
        let outcome = match crate::eval::interp::envelope(m, c) {
            Ok(Some(o)) => o,
            Ok(None) => continue,
            Err(e) => {
                bounds.insert(m.label.clone(), unbounded());
                undefined.insert(m.label.clone(), json!({"why": format!("{e:#}")}));
                continue;
            }
        };
        match outcome.value {
            Ok(v) => {
                bounds.insert(m.label.clone(), json!([number(v.lo), number(v.hi)]));
            }
            Err(stop) => {
                bounds.insert(m.label.clone(), unbounded());
                let entry = match stop {
                    Stop::Gap { gap, line, forked } => {
                        let why = match gap {
                            crate::eval::envelope::interval::Gap::NonFinite(w) => {
                                format!("undefined on a driver that assumes finite math: {w}")
                            }
                            crate::eval::envelope::interval::Gap::Domain(w) => {
                                format!("outside the spec's accuracy domain: {w}")
                            }
                        };
                        let mut e = json!({"why": why, "forked": forked});
                        if let Some(l) = line.and_then(|l| crate::eval::interp::program(m).ok()?.lines.get(l).cloned())
                        {
                            e["file"] = json!(l.path);
                            e["line"] = json!(l.line);
                            e["source"] = json!(l.text.trim());
                        }
                        e
                    }
                    Stop::TooWide(w) => json!({"why": format!("too wide to inform: {w}")}),
                    Stop::Unsupported(w) => json!({"why": w}),
                };
                undefined.insert(m.label.clone(), entry);
            }
        }
    }
    let undefined = (!undefined.is_empty()).then_some(Value::Object(undefined));
    (Value::Object(bounds), undefined)
}

/// Per configuration (None where the method does not apply): the kernel's source lines
/// with the local error of their f32 operations, most bits first (src/eval/interp).
fn attribution_column(m: &Method, configs: &[Config]) -> anyhow::Result<Vec<Option<Value>>> {
    let program = crate::eval::interp::program(m)?;
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

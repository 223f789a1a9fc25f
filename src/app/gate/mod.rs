//! Baselines for the CI gate (docs/ci/): what `sweep --save-baseline DIR` writes, and how
//! `sweep --baseline DIR` compares a run with it. The same seed gives the same configurations,
//! so every comparison is paired, configuration by configuration. Rules per method × material:
//! `error` (bootstrap of the log error ratios, with a noise threshold), `nan` (new NaN/inf),
//! `false_light` (new light where the reference is 0); per method: `ops` (op-count growth).
//! Timings are reported beside, never gated. The format is in docs/ci/baseline.md.

use crate::io::write_atomic;
use crate::measure::sweep::{Measured, Setup};
use crate::reference::Estimate;
use anyhow::Context;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// JUnit XML of the checks and the gate's rules.
mod junit;

/// Version of the on-disk format; a baseline of another version is bad input.
pub const FORMAT: u32 = 1;

/// Relative errors below this count as this: f32 cannot resolve them (2⁻²⁴, half an ulp at 1),
/// so ratios of two such errors are rounding noise, not a change.
pub const ERROR_FLOOR: f64 = 1.0 / 16_777_216.0;

/// One natural configuration of one method, as the gate sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Obs {
    /// Relative error |value − reference| / |reference| of a finite result (reference ≠ 0).
    Lit(f64),
    /// NaN or ±inf.
    NonFinite,
    /// Reference 0 and the method returns 0.
    Dark,
    /// Reference 0 and the method returns light (false light).
    FalseLight,
    /// The method does not apply (its target needs data this configuration lacks).
    NotApplicable,
}

impl Obs {
    /// The token of the errors files: 4 significant digits are far below the noise threshold.
    pub fn token(self) -> String {
        match self {
            Obs::Lit(e) => format!("{e:.3e}"),
            Obs::NonFinite => "nan".into(),
            Obs::Dark => "dark".into(),
            Obs::FalseLight => "light".into(),
            Obs::NotApplicable => "-".into(),
        }
    }

    pub fn parse(token: &str) -> Option<Obs> {
        Some(match token {
            "nan" => Obs::NonFinite,
            "dark" => Obs::Dark,
            "light" => Obs::FalseLight,
            "-" => Obs::NotApplicable,
            t => Obs::Lit(t.parse::<f64>().ok().filter(|e| e.is_finite() && *e >= 0.0)?),
        })
    }
}

/// The observation of a GPU result against its reference.
pub fn observe(value: f32, reference: Option<Estimate>) -> Obs {
    let Some(r) = reference else {
        return Obs::NotApplicable;
    };
    if !value.is_finite() {
        Obs::NonFinite
    } else if r.value == 0.0 {
        if value == 0.0 {
            Obs::Dark
        } else {
            Obs::FalseLight
        }
    } else {
        Obs::Lit((f64::from(value) - r.value).abs() / r.value.abs())
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Baseline {
    pub format: u32,
    pub case: String,
    pub seed: u64,
    /// `--count` when it overrode the case's counts (a compared run must use the same).
    pub count_override: Option<usize>,
    pub adapter: String,
    /// The materials in case order, with their natural configurations.
    pub materials: Vec<MaterialCount>,
    pub methods: Vec<MethodEntry>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialCount {
    pub material: String,
    pub configurations: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MethodEntry {
    pub label: String,
    pub kernel: String,
    /// `total` of the naga op count (src/eval/cost.rs): deterministic, so it is gated.
    pub ops_total: Option<u64>,
    /// GPU ns per evaluation (median): reported, never gated. Saved in `timings.json`, not
    /// here, so that `baseline.json` is the same file whenever the errors are the same;
    /// read from here in baselines saved before that split.
    #[serde(default = "no_timing", skip_serializing)]
    pub ns_per_eval: f64,
    pub materials: Vec<MaterialEntry>,
}

fn no_timing() -> f64 {
    f64::NAN
}

/// `timings.json`: the run's timings, kept apart from the gated `baseline.json` because
/// they change on every save.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Timings {
    pub adapter: String,
    /// (method label, GPU ns per evaluation, median).
    pub ns_per_eval: Vec<(String, f64)>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MaterialEntry {
    pub material: String,
    pub supported: bool,
    /// Relative path of the errors file (one token per natural configuration, in sample
    /// order); None when the method does not support the material.
    pub errors: Option<String>,
    pub lit: usize,
    pub rel_median: Option<f64>,
    pub rel_p99: Option<f64>,
    pub rel_max: Option<f64>,
    pub non_finite: usize,
    pub false_light: usize,
}

/// Per method: per material (case order), whether supported, and the observations of its
/// natural configurations in sample order.
pub struct Observed {
    pub label: String,
    pub kernel: String,
    pub ops_total: Option<u64>,
    pub ns_per_eval: f64,
    pub materials: Vec<(bool, Vec<Obs>)>,
}

/// Per method, per family: whether supported, and each natural configuration's observation,
/// in sample order. O(N): kept only for the gate (`--baseline`, `--save-baseline`), whose case
/// is small.
pub type Observations = Vec<Vec<(bool, Vec<Obs>)>>;

/// Empty observations for `methods` methods over `families` families.
pub fn observations(methods: usize, families: usize) -> Observations {
    vec![vec![(true, Vec::new()); families]; methods]
}

/// Folds one measured chunk's natural configurations into `obs` (chunks in sample order).
pub fn observe_chunk(obs: &mut Observations, chunk: &crate::analyse::analysis::Chunk) {
    for (i, s) in chunk.samples.iter().enumerate().filter(|(_, s)| s.natural()) {
        let c = &s.config;
        for (per_method, run) in obs.iter_mut().zip(chunk.runs) {
            let (supported, list) = &mut per_method[s.material];
            if list.is_empty() {
                *supported = run.method.supports(c);
            }
            let target = run.method.target();
            list.push(if run.method.applies(c) {
                observe(run.f32[i], chunk.references[i].get(&target).copied())
            } else {
                Obs::NotApplicable
            });
        }
    }
}

/// The gate's observations of a measured sweep, with each method's cost.
pub fn observed(setup: &Setup, measured: &Measured, observations: &Observations) -> Vec<Observed> {
    setup
        .methods
        .iter()
        .zip(observations)
        .map(|(method, materials)| {
            let cost = measured.costs.iter().find(|c| c.label == method.label);
            Observed {
                label: method.label.clone(),
                kernel: method.kernel.path.clone(),
                ops_total: cost.and_then(|c| c.ops.as_ref()).map(|o| o.total),
                ns_per_eval: cost.map_or(f64::NAN, |t| crate::analyse::bench::Cost::of(t).ns_per_eval_median),
                materials: materials.clone(),
            }
        })
        .collect()
}

/// A method label as a file name: `line.numeric@64` → `line.numeric_64`.
fn file_name(label: &str) -> String {
    label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Nearest-rank quantile of sorted values (every number reported is one observed).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    let k = ((q * n as f64).ceil() as usize).clamp(1, n);
    sorted[k - 1]
}

/// Writes DIR/baseline.json, DIR/timings.json and DIR/errors/<method>/<material>.txt as one
/// set ([`crate::io::write_set`]): built in a sibling folder and swapped in whole, so a
/// failed or killed save leaves the previous baseline as it was. Returns the paths.
pub fn save(
    dir: &Path,
    setup: &Setup,
    measured: &Measured,
    observations: &Observations,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let case = &setup.case;
    let obs = observed(setup, measured, observations);
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut methods = Vec::new();
    for o in &obs {
        let mut materials = Vec::new();
        for (family, (supported, values)) in case.materials.iter().zip(&o.materials) {
            let mut lit: Vec<f64> = values
                .iter()
                .filter_map(|v| if let Obs::Lit(e) = v { Some(*e) } else { None })
                .collect();
            lit.sort_by(f64::total_cmp);
            let q = |p: f64| (!lit.is_empty()).then(|| quantile(&lit, p));
            let errors = supported.then(|| format!("errors/{}/{}.txt", file_name(&o.label), file_name(&family.name)));
            if let Some(rel) = &errors {
                let text: String = values.iter().map(|v| v.token() + "\n").collect();
                files.push((rel.clone(), text.into_bytes()));
            }
            materials.push(MaterialEntry {
                material: family.name.clone(),
                supported: *supported,
                errors,
                lit: lit.len(),
                rel_median: q(0.5),
                rel_p99: q(0.99),
                rel_max: q(1.0),
                non_finite: values.iter().filter(|v| **v == Obs::NonFinite).count(),
                false_light: values.iter().filter(|v| **v == Obs::FalseLight).count(),
            });
        }
        methods.push(MethodEntry {
            label: o.label.clone(),
            kernel: o.kernel.clone(),
            ops_total: o.ops_total,
            ns_per_eval: o.ns_per_eval,
            materials,
        });
    }
    let baseline = Baseline {
        format: FORMAT,
        case: case.name.clone(),
        seed: case.seed,
        count_override: setup.count_override,
        adapter: measured.timing.adapter.clone(),
        materials: natural_counts(setup),
        methods,
    };
    let mut json = serde_json::to_string_pretty(&baseline)?;
    json.push('\n');
    files.push(("baseline.json".into(), json.into_bytes()));
    let timings = Timings {
        adapter: baseline.adapter.clone(),
        ns_per_eval: baseline
            .methods
            .iter()
            .map(|m| (m.label.clone(), m.ns_per_eval))
            .collect(),
    };
    let mut json = serde_json::to_string_pretty(&timings)?;
    json.push('\n');
    files.push(("timings.json".into(), json.into_bytes()));
    Ok(crate::io::write_set(dir, crate::io::SetKind::Baseline, &files)?)
}

fn natural_counts(setup: &Setup) -> Vec<MaterialCount> {
    setup
        .case
        .materials
        .iter()
        .map(|f| {
            // The natural sample draws exactly the family's count (degenerate draws are redrawn).
            let n = f.count;
            MaterialCount {
                material: f.name.clone(),
                configurations: n,
            }
        })
        .collect()
}

/// Bytes a line of an errors file may take (a token is at most about a dozen).
const MAX_TOKEN_LINE: u64 = 32;

/// A loaded baseline with its errors files.
pub struct Loaded {
    pub baseline: Baseline,
    /// Per method, per material: the observations (None when unsupported).
    pub errors: Vec<Vec<Option<Vec<Obs>>>>,
}

/// Reads a baseline and checks it was saved from this case with these configurations;
/// any mismatch is bad input (exit 2), found before measuring.
pub fn load(dir: &Path, setup: &Setup) -> anyhow::Result<Loaded> {
    use crate::io::read_regular;
    use crate::limits::MAX_RECORD_BYTES;
    let path = dir.join("baseline.json");
    let text = read_regular(&path, "baseline", MAX_RECORD_BYTES)?;
    let mut baseline: Baseline =
        serde_json::from_slice(&text).with_context(|| format!("{}: not a linelight baseline", path.display()))?;
    // Timings are optional (reported, never gated): a baseline without timings.json
    // compares the same.
    let timings = dir.join("timings.json");
    if std::fs::symlink_metadata(&timings).is_ok() {
        let text = read_regular(&timings, "baseline timings", MAX_RECORD_BYTES)?;
        let t: Timings =
            serde_json::from_slice(&text).with_context(|| format!("{}: not linelight timings", timings.display()))?;
        for m in &mut baseline.methods {
            if let Some((_, ns)) = t.ns_per_eval.iter().find(|(l, _)| *l == m.label) {
                m.ns_per_eval = *ns;
            }
        }
    }
    let here = |what: String| anyhow::anyhow!("{}: {what}", path.display());
    if baseline.format != FORMAT {
        return Err(here(format!(
            "format {} (this linelight reads {FORMAT})",
            baseline.format
        )));
    }
    if baseline.case != setup.case.name || baseline.seed != setup.case.seed {
        return Err(here(format!(
            "saved from case `{}` seed {}; this run is case `{}` seed {}",
            baseline.case, baseline.seed, setup.case.name, setup.case.seed
        )));
    }
    let counts = natural_counts(setup);
    if baseline.materials != counts || baseline.count_override != setup.count_override {
        let show = |c: &[MaterialCount], o: Option<usize>| {
            let list: Vec<String> = c
                .iter()
                .map(|m| format!("{} {}", m.material, m.configurations))
                .collect();
            format!(
                "{} (--count {})",
                list.join(", "),
                o.map_or("not set".into(), |n| n.to_string())
            )
        };
        return Err(here(format!(
            "saved with configurations {}; this run has {}: the comparison is paired, so both \
             need the same case counts and --count",
            show(&baseline.materials, baseline.count_override),
            show(&counts, setup.count_override)
        )));
    }
    let mut errors = Vec::new();
    let inside = crate::io::resolved(dir);
    for m in &baseline.methods {
        let mut per = Vec::new();
        for (entry, count) in m.materials.iter().zip(&baseline.materials) {
            let n = count.configurations;
            let Some(rel) = &entry.errors else {
                per.push(None);
                continue;
            };
            // The errors file is the baseline's own: a path that leaves the folder (`..`, an
            // absolute path, a symlink out) is refused, never read.
            let file = dir.join(rel);
            let plain = Path::new(rel)
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_)));
            if !plain || !crate::io::resolved(&file).starts_with(&inside) {
                return Err(here(format!(
                    "`{}` on `{}`: errors file `{}` is not inside the baseline folder {}",
                    crate::input::names::clip(&m.label),
                    crate::input::names::clip(&entry.material),
                    crate::input::names::clip(rel),
                    dir.display()
                )));
            }
            // One token a line: the longest is a number such as `1.234e-300`.
            let max = (n as u64).saturating_mul(MAX_TOKEN_LINE).saturating_add(MAX_TOKEN_LINE);
            let text = read_regular(&file, "baseline errors file", max)?;
            let text = String::from_utf8_lossy(&text);
            let obs = text
                .lines()
                .enumerate()
                .map(|(i, t)| {
                    Obs::parse(t.trim()).ok_or_else(|| {
                        anyhow::anyhow!(
                            "{}:{}: `{}` is not an error token (a number, nan, dark, light or -)",
                            file.display(),
                            i + 1,
                            crate::input::names::clip(t)
                        )
                    })
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            if obs.len() != n {
                anyhow::bail!(
                    "{}: {} lines, but material `{}` has {n} configurations",
                    file.display(),
                    obs.len(),
                    entry.material
                );
            }
            per.push(Some(obs));
        }
        errors.push(per);
    }
    Ok(Loaded { baseline, errors })
}

/// What a sweep's gate options ask for, checked before measuring.
pub struct GateRun {
    save: Option<std::path::PathBuf>,
    baseline: Option<Loaded>,
    junit: Option<std::path::PathBuf>,
    options: GateOptions,
}

impl GateRun {
    /// Checks the thresholds and loads the baseline (bad input: exit 2 before any work).
    pub fn prepare(
        save: Option<std::path::PathBuf>,
        baseline: Option<&Path>,
        junit: Option<std::path::PathBuf>,
        options: GateOptions,
        setup: &Setup,
    ) -> anyhow::Result<GateRun> {
        use crate::app::options::{check_float, FRACTION};
        check_float("--noise", options.noise, FRACTION).map_err(anyhow::Error::msg)?;
        check_float("--ops-growth", options.ops_growth, FRACTION).map_err(anyhow::Error::msg)?;
        let baseline = baseline.map(|dir| load(dir, setup)).transpose()?;
        Ok(GateRun {
            save,
            baseline,
            junit,
            options,
        })
    }

    /// After the sweep: saves the baseline, compares with the loaded one (every rule to
    /// stderr), writes the JUnit file; returns the comparison, if there was a baseline.
    /// Whether the sweep must keep per-configuration observations (saving or comparing a
    /// baseline pairs errors configuration by configuration: O(N), small at a gate's count).
    pub fn wants_observations(&self) -> bool {
        self.save.is_some() || self.baseline.is_some()
    }

    pub fn finish(
        &self,
        setup: &Setup,
        (measured, observations): (&Measured, Option<&Observations>),
        checks: &[crate::analyse::analysis::Check],
    ) -> anyhow::Result<Option<GateReport>> {
        let observations = || observations.expect("the gate's sweep keeps its observations (wants_observations)");
        if let Some(dir) = &self.save {
            for path in save(dir, setup, measured, observations())? {
                eprintln!("wrote {}", path.display());
            }
        }
        let report = self
            .baseline
            .as_ref()
            .map(|b| compare(b, setup, (measured, observations()), self.options));
        if let Some(g) = &report {
            eprint!("{}", g.details());
        }
        if let Some(path) = &self.junit {
            let xml = junit::junit(&setup.case.name, checks, report.as_ref())?;
            write_atomic(path, xml.as_bytes())?;
            eprintln!("wrote {}", path.display());
        }
        Ok(report)
    }
}

/// Thresholds of the comparison.
#[derive(Clone, Copy, Debug)]
pub struct GateOptions {
    /// A ratio within [1/(1+noise), 1+noise] (at the 95 % bootstrap bounds) is unchanged.
    pub noise: f64,
    /// Op-count growth beyond this fraction is a regression.
    pub ops_growth: f64,
    pub resamples: usize,
}

impl Default for GateOptions {
    fn default() -> Self {
        GateOptions {
            noise: 0.05,
            ops_growth: 0.10,
            resamples: 1000,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Change {
    Regressed,
    Improved,
    Unchanged,
    /// Not compared (unsupported material, or a method new since the baseline).
    Skipped,
}

impl Change {
    pub fn name(self) -> &'static str {
        match self {
            Change::Regressed => "regressed",
            Change::Improved => "improved",
            Change::Unchanged => "unchanged",
            Change::Skipped => "skipped",
        }
    }
}

/// One gated rule for one method × material (material `(all)` for per-method rules).
#[derive(Clone, Debug, Serialize)]
pub struct RuleResult {
    pub method: String,
    pub material: String,
    pub rule: &'static str,
    pub change: Change,
    /// The numbers behind the outcome, one line.
    pub message: String,
}

/// The paired statistics of one method × material.
#[derive(Clone, Debug, Serialize)]
pub struct Paired {
    pub pairs: usize,
    /// exp(mean log ratio): the geometric mean of now / baseline error, with its 95 % bounds.
    pub geomean: [f64; 3],
    /// p99 of now over p99 of baseline (over the paired configurations), with its bounds.
    pub p99_ratio: [f64; 3],
    /// Configurations worse / better by more than the noise threshold (a sign test's counts).
    pub worse: usize,
    pub better: usize,
}

/// Paired bootstrap of (geometric-mean ratio, p99 ratio) over (baseline, now) error pairs.
pub fn paired(pairs: &[(f64, f64)], resamples: usize, noise: f64) -> Paired {
    let n = pairs.len();
    let fl = |e: f64| e.max(ERROR_FLOOR);
    let logs: Vec<f64> = pairs.iter().map(|&(b, a)| (fl(a) / fl(b)).ln()).collect();
    let base: Vec<f64> = pairs.iter().map(|&(b, _)| fl(b)).collect();
    let now: Vec<f64> = pairs.iter().map(|&(_, a)| fl(a)).collect();
    let stat = |idx: &mut dyn Iterator<Item = usize>| {
        let (mut sum, mut b, mut a) = (0.0, Vec::with_capacity(n), Vec::with_capacity(n));
        for i in idx {
            sum += logs[i];
            b.push(base[i]);
            a.push(now[i]);
        }
        let k = ((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1;
        let pb = *b.select_nth_unstable_by(k, f64::total_cmp).1;
        let pa = *a.select_nth_unstable_by(k, f64::total_cmp).1;
        ((sum / n as f64).exp(), pa / pb)
    };
    if n == 0 {
        return Paired {
            pairs: 0,
            geomean: [f64::NAN; 3],
            p99_ratio: [f64::NAN; 3],
            worse: 0,
            better: 0,
        };
    }
    let (g, p) = stat(&mut (0..n));
    // Seeded: the same inputs give the same verdict on every machine.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x6c696e65);
    let (mut gs, mut ps) = (Vec::with_capacity(resamples), Vec::with_capacity(resamples));
    for _ in 0..resamples {
        let (gi, pi) = stat(&mut (0..n).map(|_| rng.random_range(0..n)));
        gs.push(gi);
        ps.push(pi);
    }
    gs.sort_by(f64::total_cmp);
    ps.sort_by(f64::total_cmp);
    let bounds = |v: &[f64], mid: f64| {
        if v.is_empty() {
            [mid, mid, mid]
        } else {
            [quantile(v, 0.025), mid, quantile(v, 0.975)]
        }
    };
    let t = (1.0 + noise).ln();
    Paired {
        pairs: n,
        geomean: bounds(&gs, g),
        p99_ratio: bounds(&ps, p),
        worse: logs.iter().filter(|&&d| d > t).count(),
        better: logs.iter().filter(|&&d| d < -t).count(),
    }
}

impl Paired {
    /// Regressed when either ratio's lower bound is above 1 + noise; otherwise improved when
    /// either ratio's upper bound is below 1/(1 + noise); otherwise unchanged (within noise).
    pub fn change(&self, noise: f64) -> Change {
        let up = 1.0 + noise;
        let [g_lo, _, g_hi] = self.geomean;
        let [p_lo, _, p_hi] = self.p99_ratio;
        if self.pairs == 0 {
            Change::Unchanged
        } else if g_lo > up || p_lo > up {
            Change::Regressed
        } else if g_hi < 1.0 / up || p_hi < 1.0 / up {
            Change::Improved
        } else {
            Change::Unchanged
        }
    }
}

/// The comparison of a run with a baseline.
#[derive(Clone, Debug, Serialize)]
pub struct GateReport {
    pub baseline_adapter: String,
    pub adapter: String,
    pub rules: Vec<RuleResult>,
    /// (method, baseline ns/eval, now ns/eval): reported, never gated.
    pub timings: Vec<(String, f64, f64)>,
    /// Methods run now that the baseline does not have (not gated).
    pub new_methods: Vec<String>,
    pub change: Change,
}

fn g(x: f64) -> String {
    format!("{x:.4}")
}

pub fn compare(
    loaded: &Loaded,
    setup: &Setup,
    (measured, observations): (&Measured, &Observations),
    options: GateOptions,
) -> GateReport {
    let obs = observed(setup, measured, observations);
    let mut rules = Vec::new();
    let mut timings = Vec::new();
    for (entry, base_errors) in loaded.baseline.methods.iter().zip(&loaded.errors) {
        let rule = |material: &str, rule: &'static str, change: Change, message: String| RuleResult {
            method: entry.label.clone(),
            material: material.to_string(),
            rule,
            change,
            message,
        };
        let Some(now) = obs.iter().find(|o| o.label == entry.label) else {
            rules.push(rule(
                "(all)",
                "present",
                Change::Regressed,
                format!("`{}` is in the baseline but not in this run", entry.label),
            ));
            continue;
        };
        timings.push((entry.label.clone(), entry.ns_per_eval, now.ns_per_eval));
        rules.push(match (entry.ops_total, now.ops_total) {
            (Some(b), Some(a)) => {
                let ratio = a as f64 / b.max(1) as f64;
                let change = if ratio > 1.0 + options.ops_growth {
                    Change::Regressed
                } else if ratio < 1.0 / (1.0 + options.ops_growth) {
                    Change::Improved
                } else {
                    Change::Unchanged
                };
                rule(
                    "(all)",
                    "ops",
                    change,
                    format!(
                        "op count {a} against baseline {b} (×{}; growth limit ×{})",
                        g(ratio),
                        g(1.0 + options.ops_growth)
                    ),
                )
            }
            _ => rule("(all)", "ops", Change::Skipped, "no op count on one side".into()),
        });
        for ((m_entry, base), (supported, values)) in entry.materials.iter().zip(base_errors).zip(&now.materials) {
            let mat = m_entry.material.as_str();
            let Some(base) = base else {
                for r in ["error", "nan", "false_light"] {
                    rules.push(rule(mat, r, Change::Skipped, "unsupported in the baseline".into()));
                }
                continue;
            };
            if !supported {
                rules.push(rule(
                    mat,
                    "support",
                    Change::Regressed,
                    "supported in the baseline, unsupported now".into(),
                ));
                continue;
            }
            let mut pairs = Vec::new();
            let (mut new_nan, mut fixed_nan, mut new_light, mut fixed_light) = (vec![], 0, vec![], 0);
            for (i, (b, a)) in base.iter().zip(values).enumerate() {
                match (b, a) {
                    (Obs::Lit(eb), Obs::Lit(ea)) => pairs.push((*eb, *ea)),
                    (b, Obs::NonFinite) if *b != Obs::NonFinite => new_nan.push(i),
                    (Obs::NonFinite, a) if *a != Obs::NonFinite => fixed_nan += 1,
                    (Obs::Dark, Obs::FalseLight) => new_light.push(i),
                    (Obs::FalseLight, Obs::Dark) => fixed_light += 1,
                    _ => {}
                }
            }
            // The first few, by index among the material's natural configurations.
            let first = |v: &[usize]| {
                if v.is_empty() {
                    return String::new();
                }
                let shown: Vec<String> = v.iter().take(5).map(|i| i.to_string()).collect();
                format!(
                    " (configurations {}{})",
                    shown.join(", "),
                    if v.len() > 5 { ", …" } else { "" }
                )
            };
            let p = paired(&pairs, options.resamples, options.noise);
            let [gl, gm, gh] = p.geomean;
            let [pl, pm, ph] = p.p99_ratio;
            rules.push(rule(
                mat,
                "error",
                p.change(options.noise),
                format!(
                    "error ratio now/baseline over {} paired configurations: geometric mean ×{} [{}–{}], \
                     p99 ×{} [{}–{}] (95 % bootstrap, noise ±{} %); worse on {}, better on {}",
                    p.pairs,
                    g(gm),
                    g(gl),
                    g(gh),
                    g(pm),
                    g(pl),
                    g(ph),
                    options.noise * 100.0,
                    p.worse,
                    p.better
                ),
            ));
            rules.push(rule(
                mat,
                "nan",
                if !new_nan.is_empty() {
                    Change::Regressed
                } else if fixed_nan > 0 {
                    Change::Improved
                } else {
                    Change::Unchanged
                },
                format!("{} new NaN/inf{}, {fixed_nan} fixed", new_nan.len(), first(&new_nan)),
            ));
            rules.push(rule(
                mat,
                "false_light",
                if !new_light.is_empty() {
                    Change::Regressed
                } else if fixed_light > 0 {
                    Change::Improved
                } else {
                    Change::Unchanged
                },
                format!(
                    "{} new false light{}, {fixed_light} fixed",
                    new_light.len(),
                    first(&new_light)
                ),
            ));
        }
    }
    let new_methods = obs
        .iter()
        .filter(|o| !loaded.baseline.methods.iter().any(|m| m.label == o.label))
        .map(|o| o.label.clone())
        .collect();
    let change = if rules.iter().any(|r| r.change == Change::Regressed) {
        Change::Regressed
    } else if rules.iter().any(|r| r.change == Change::Improved) {
        Change::Improved
    } else {
        Change::Unchanged
    };
    GateReport {
        baseline_adapter: loaded.baseline.adapter.clone(),
        adapter: measured.timing.adapter.clone(),
        rules,
        timings,
        new_methods,
        change,
    }
}

impl GateReport {
    pub fn regressed(&self) -> bool {
        self.change == Change::Regressed
    }

    /// The one-line summary: verdict, counts, and the regressed rules by name.
    pub fn summary(&self) -> String {
        let count = |c: Change| self.rules.iter().filter(|r| r.change == c).count();
        let regressed: Vec<String> = self
            .rules
            .iter()
            .filter(|r| r.change == Change::Regressed)
            .map(|r| format!("{} {} {}", r.method, r.material, r.rule))
            .collect();
        let improved: Vec<String> = self
            .rules
            .iter()
            .filter(|r| r.change == Change::Improved && r.rule == "error")
            .map(|r| format!("{} {}", r.method, r.material))
            .collect();
        let mut s = format!(
            "gate: {} ({} regressed, {} improved, {} unchanged, {} skipped)",
            self.change.name().to_uppercase(),
            count(Change::Regressed),
            count(Change::Improved),
            count(Change::Unchanged),
            count(Change::Skipped)
        );
        if !regressed.is_empty() {
            s += &format!("; regressed: {}", regressed.join(", "));
        }
        if !improved.is_empty() {
            s += &format!("; error improved: {}", improved.join(", "));
        }
        if self.adapter != self.baseline_adapter {
            // Another driver's transcendentals differ: a change may be the adapter's, not the kernel's.
            s += "; WARNING: the baseline was saved on another adapter";
        }
        s
    }

    /// Every rule and the timings, for the terminal.
    pub fn details(&self) -> String {
        let mut s = format!(
            "baseline adapter: {}\nthis run's adapter: {}\n",
            self.baseline_adapter, self.adapter
        );
        for r in &self.rules {
            s += &format!(
                "  {:<10} {} on {} [{}]: {}\n",
                r.change.name(),
                r.method,
                r.material,
                r.rule,
                r.message
            );
        }
        for (m, b, a) in &self.timings {
            s += &format!(
                "  timing (not gated) {m}: {} ns/eval against baseline {} ns/eval (×{})\n",
                g(*a),
                g(*b),
                g(a / b)
            );
        }
        for m in &self.new_methods {
            s += &format!("  new (no baseline, not gated): {m}\n");
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_round_trip() {
        for o in [
            Obs::Lit(1.234e-5),
            Obs::Lit(0.0),
            Obs::NonFinite,
            Obs::Dark,
            Obs::FalseLight,
            Obs::NotApplicable,
        ] {
            assert_eq!(Obs::parse(&o.token()), Some(o));
        }
        assert_eq!(Obs::parse("1e-3x"), None);
        assert_eq!(Obs::parse("-1e-3"), None);
    }

    #[test]
    fn paired_test_sees_a_shift_and_not_the_noise() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let base: Vec<f64> = (0..2000).map(|_| 10f64.powf(rng.random_range(-7.0..-3.0))).collect();
        // Same errors, jittered by ±1 %: within noise.
        let same: Vec<(f64, f64)> = base.iter().map(|&b| (b, b * rng.random_range(0.99..1.01))).collect();
        assert_eq!(paired(&same, 200, 0.05).change(0.05), Change::Unchanged);
        // Every error ×1.5: regressed.
        let worse: Vec<(f64, f64)> = base.iter().map(|&b| (b, b * 1.5)).collect();
        assert_eq!(paired(&worse, 200, 0.05).change(0.05), Change::Regressed);
        // Only the worst 2 % ×10: the geometric mean barely moves, p99 catches it.
        let mut sorted = base.clone();
        sorted.sort_by(f64::total_cmp);
        let cut = sorted[sorted.len() * 98 / 100];
        let tail: Vec<(f64, f64)> = base.iter().map(|&b| (b, if b >= cut { b * 10.0 } else { b })).collect();
        assert_eq!(paired(&tail, 200, 0.05).change(0.05), Change::Regressed);
        // Every error halved: improved.
        let better: Vec<(f64, f64)> = base.iter().map(|&b| (b, b * 0.5)).collect();
        assert_eq!(paired(&better, 200, 0.05).change(0.05), Change::Improved);
    }
}

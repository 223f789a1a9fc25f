//! Baselines for the CI gate (docs/ci/): what `sweep --save-baseline DIR` writes, and how
//! `sweep --baseline DIR` compares a run with it. The same seed gives the same configurations,
//! so every comparison is paired, configuration by configuration. Rules per method × material:
//! `error` (bootstrap of the log error ratios, with a noise threshold), `share` (how many
//! configurations got worse, per material and bin: src/analyse/gate.rs), `nan` (new NaN/inf),
//! `false_light` (new light where the reference is 0); per method: `ops` (op-count growth).
//! Timings are reported beside, never gated. The format is in docs/ci/README.md.

use crate::analyse::analysis::Fold;
use crate::analyse::gate::{g, share_tests, Axis, Pair};
pub use crate::analyse::gate::{paired, Change, GateReport, Paired, RuleResult, ShareOptions, Shares, ERROR_FLOOR};
use crate::analyse::stats::{nearest_rank, Accumulate};
use crate::input::scene::Config;
use crate::limits::MAX_TOKEN_LINE;
use crate::measure::sweep::{Measured, Setup};
use crate::reference::Estimate;
use crate::report::format::{Format, Json, Layout, Plain};
use anyhow::Context;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// JUnit XML of the checks and the gate's rules.
mod junit;
/// Render baselines: `render --save-baseline` and `render --baseline` (docs/render.md).
pub mod render;

/// Version of the on-disk format; a baseline of another version is bad input. 2: every method
/// is judged against what the surface receives (`line_upper`, `cylinder_upper`, …, the
/// headline's target) and its f32 result against the reference at the f32-rounded
/// configuration; format 1 judged against the method's own target and the exact reference.
pub const FORMAT: u32 = 3;

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
    /// SHA-256 of the natural configurations in sample order (format 3): the comparison pairs
    /// configuration by configuration, so a run that draws others is refused, not compared.
    pub sample_sha256: String,
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

/// Every natural configuration as the gate sees it, in sample order. O(N): kept only for the
/// gate (`--baseline`, `--save-baseline`) and `diff`, whose cases are small.
#[derive(Clone, Debug, Default)]
pub struct Observations {
    /// Per method, per family: whether supported, and each configuration's observation.
    pub methods: Vec<Vec<(bool, Vec<Obs>)>>,
    /// Per method, per family, per configuration: the f32 ULP of the method's reference over
    /// |reference| (`stats::ulp_relative`; NaN where there is none), for the share rule.
    pub ulps: Vec<Vec<Vec<f64>>>,
    /// Per family: each configuration (for `regressed.jsonl`) and its bin on each of the
    /// case's bin axes.
    pub configs: Vec<Vec<(Config, Vec<Option<usize>>)>>,
}

/// Empty observations for `methods` methods over `families` families.
pub fn observations(methods: usize, families: usize) -> Observations {
    Observations {
        methods: vec![vec![(true, Vec::new()); families]; methods],
        ulps: vec![vec![Vec::new(); families]; methods],
        configs: vec![Vec::new(); families],
    }
}

/// The gate's observations are a mergeable accumulator like the analysis's: each measured
/// chunk's natural configurations are folded in, in sample order.
impl<'a> Accumulate<Fold<'a>> for Observations {
    fn add(&mut self, fold: Fold<'a>) {
        let (case, chunk) = (fold.case, fold.chunk);
        for (i, s) in chunk.samples.iter().enumerate().filter(|(_, s)| s.natural()) {
            let c = &s.config;
            let bins = case.bins.iter().map(|a| a.index(s.axes.get(&a.axis))).collect();
            self.configs[s.material].push((c.clone(), bins));
            for ((per_method, ulps), run) in self.methods.iter_mut().zip(&mut self.ulps).zip(chunk.runs) {
                let (supported, list) = &mut per_method[s.material];
                if list.is_empty() {
                    *supported = run.method.supports(c);
                }
                // The headline's target (the surface view), the f32 result against the reference
                // at the f32-rounded inputs where it is measured and not 0 (as the analysis does).
                let target = crate::analyse::analysis::headline_target(run.method.target());
                let reference = chunk.references[i].get(&target).copied();
                let judged = crate::analyse::analysis::f32_reference(chunk, i, target);
                list.push(if run.method.applies(c) {
                    observe(run.f32[i], judged)
                } else {
                    Obs::NotApplicable
                });
                let ulp = reference.and_then(|r| crate::analyse::stats::ulp_relative(r.value));
                ulps[s.material].push(ulp.unwrap_or(f64::NAN));
            }
        }
    }

    /// Observations are kept in sample order for one whole run (`--baseline`, `--save-baseline`,
    /// `diff`); shards interleave blocks and do not keep them, so two parts never merge.
    fn merge(&mut self, _other: &Observations) -> Result<(), String> {
        Err("the gate's per-configuration observations are not kept by shards: run the gate unsharded".into())
    }
}

/// The gate's observations of a measured sweep, with each method's cost.
pub fn observed(setup: &Setup, measured: &Measured, observations: &Observations) -> Vec<Observed> {
    setup
        .methods
        .iter()
        .zip(&observations.methods)
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
    let mut files: Vec<Box<dyn Format>> = Vec::new();
    let mut methods = Vec::new();
    for o in &obs {
        let mut materials = Vec::new();
        for (family, (supported, values)) in case.materials.iter().zip(&o.materials) {
            let mut lit: Vec<f64> = values
                .iter()
                .filter_map(|v| if let Obs::Lit(e) = v { Some(*e) } else { None })
                .collect();
            lit.sort_by(f64::total_cmp);
            let q = |p: f64| (!lit.is_empty()).then(|| nearest_rank(&lit, p));
            let errors = supported.then(|| format!("errors/{}/{}.txt", file_name(&o.label), file_name(&family.name)));
            if let Some(rel) = &errors {
                let text: String = values.iter().map(|v| v.token() + "\n").collect();
                files.push(Box::new(Plain::new(rel.clone(), text)));
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
        sample_sha256: sample_digest(observations),
        methods,
    };
    let timings = Timings {
        adapter: baseline.adapter.clone(),
        ns_per_eval: baseline
            .methods
            .iter()
            .map(|m| (m.label.clone(), m.ns_per_eval))
            .collect(),
    };
    // The struct itself, not a JSON value: its fields keep their order.
    files.push(Box::new(Json::new("baseline.json", baseline, Layout::PrettyLine)));
    files.push(Box::new(Json::new("timings.json", timings, Layout::PrettyLine)));
    crate::report::format::write_set(dir, crate::io::SetKind::Baseline, &files)
}

/// SHA-256 over every natural configuration (its eval-format JSON), family by family in
/// sample order: what a baseline was saved from, checked before a comparison pairs them.
pub fn sample_digest(observations: &Observations) -> String {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    for (family, configs) in observations.configs.iter().enumerate() {
        h.update(format!("family {family}\n").as_bytes());
        for (c, _) in configs {
            h.update(serde_json::to_vec(c).unwrap_or_default());
            h.update(b"\n");
        }
    }
    format!("{:x}", h.finalize())
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
            "baseline format {} (this linelight reads format {FORMAT}): save it again on this \
             linelight with the same case and kernels, `linelight sweep {} --kernel … \
             --save-baseline {}` (or `scripts/ci-gate --save …`), and commit the new folder.\n\
             Why: format 3 records which configurations it was saved from (their SHA-256), and \
             this linelight draws every configuration from its own counter-based stream (issue \
             23), so the same seed gives other configurations than a format-2 baseline holds; \
             format 2 judged every method against what the surface receives and f32 results \
             against the reference at the f32-rounded inputs, so format-1 errors are not \
             comparable either.",
            baseline.format,
            setup.case.name,
            dir.display()
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

/// `= 3.1e-5`, or `< 1e-300` as it stands.
fn p_eq(p: &str) -> String {
    if p.starts_with('<') {
        p.to_string()
    } else {
        format!("= {p}")
    }
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
        check_float("--worse-share", options.worse_share, FRACTION).map_err(anyhow::Error::msg)?;
        check_float("--worse-ulps", options.worse_ulps, crate::app::options::ULPS).map_err(anyhow::Error::msg)?;
        let baseline = baseline.map(|dir| load(dir, setup)).transpose()?;
        Ok(GateRun {
            save,
            baseline,
            junit,
            options,
        })
    }

    /// Whether the sweep must keep per-configuration observations (saving or comparing a
    /// baseline pairs errors configuration by configuration: O(N), small at a gate's count).
    pub fn wants_observations(&self) -> bool {
        self.save.is_some() || self.baseline.is_some()
    }

    /// After the sweep, before its report: the comparison with the loaded baseline (every
    /// rule to stderr), if there is one. The report carries it ("Against the baseline").
    pub fn compare(
        &self,
        setup: &Setup,
        (measured, observations): (&Measured, Option<&Observations>),
    ) -> anyhow::Result<Option<GateReport>> {
        let Some(b) = self.baseline.as_ref() else {
            return Ok(None);
        };
        let observations = observations.expect("the gate's sweep keeps its observations (wants_observations)");
        // Checked before any report is written: pairing other configurations is no comparison.
        let here = sample_digest(observations);
        if b.baseline.sample_sha256 != here {
            return Err(anyhow::Error::new(crate::io::InputError(format!(
                "the baseline was saved from other configurations than this run draws (sample \
                 SHA-256 {} in the baseline, {here} here; the case, seed and counts agree): the \
                 comparison is paired configuration by configuration, so save the baseline again \
                 with this linelight (`--save-baseline`, or `scripts/ci-gate --save …`)",
                b.baseline.sample_sha256
            ))));
        }
        let g = compare(b, setup, (measured, observations), self.options);
        eprint!("{}", g.details());
        Ok(Some(g))
    }

    /// After the report: saves the baseline and writes the JUnit file.
    pub fn finish(
        &self,
        setup: &Setup,
        (measured, observations): (&Measured, Option<&Observations>),
        checks: &[crate::analyse::analysis::Check],
        report: Option<&GateReport>,
        seconds: f64,
    ) -> anyhow::Result<()> {
        if let Some(dir) = &self.save {
            let observations = observations.expect("the gate's sweep keeps its observations (wants_observations)");
            for path in save(dir, setup, measured, observations)? {
                eprintln!("wrote {}", path.display());
            }
        }
        if let Some(path) = &self.junit {
            let xml = junit::junit(&setup.case.name, checks, report, seconds);
            crate::report::format::write_file(path, &crate::report::format::Junit::new("JUnit report", xml))?;
            eprintln!("wrote {}", path.display());
        }
        Ok(())
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
    /// The share rule: the share of configurations allowed to get worse (`--worse-share`).
    pub worse_share: f64,
    /// The share rule: an error growth up to this many ULPs of the reference is no change
    /// (`--worse-ulps`).
    pub worse_ulps: f64,
}

impl Default for GateOptions {
    fn default() -> Self {
        let share = ShareOptions::default();
        GateOptions {
            noise: 0.05,
            ops_growth: 0.10,
            resamples: 1000,
            worse_share: share.share,
            worse_ulps: share.ulps,
        }
    }
}

impl GateOptions {
    pub fn share_options(&self) -> ShareOptions {
        ShareOptions {
            noise: self.noise,
            ulps: self.worse_ulps,
            share: self.worse_share,
            ..ShareOptions::default()
        }
    }
}

pub fn compare(
    loaded: &Loaded,
    setup: &Setup,
    (measured, observations): (&Measured, &Observations),
    options: GateOptions,
) -> GateReport {
    let started = std::time::Instant::now();
    let obs = observed(setup, measured, observations);
    let share_options = options.share_options();
    let axes: Vec<Axis> = setup
        .case
        .bins
        .iter()
        .map(|b| Axis {
            name: &b.axis,
            edges: &b.edges,
        })
        .collect();
    let mut rules = Vec::new();
    let mut timings = Vec::new();
    let mut shares = Vec::new();
    // (family, index) of every configuration to replay, from any method.
    let mut replay = std::collections::BTreeSet::new();
    for (entry, base_errors) in loaded.baseline.methods.iter().zip(&loaded.errors) {
        let rule = |material: &str, rule: &'static str, change: Change, message: String| RuleResult {
            method: entry.label.clone(),
            material: material.to_string(),
            rule,
            change,
            message,
        };
        let Some(now_index) = obs.iter().position(|o| o.label == entry.label) else {
            rules.push(rule(
                "(all)",
                "present",
                Change::Regressed,
                format!("`{}` is in the baseline but not in this run", entry.label),
            ));
            continue;
        };
        let now = &obs[now_index];
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
        for (family, ((m_entry, base), (supported, values))) in
            entry.materials.iter().zip(base_errors).zip(&now.materials).enumerate()
        {
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
            // The share rule's pairs: the errors now rounded as the baseline's tokens are, so
            // an unchanged kernel pairs equal numbers.
            let (mut share_pairs, mut share_bins, mut share_index) = (Vec::new(), Vec::new(), Vec::new());
            let ulps = &observations.ulps[now_index][family];
            let (mut new_nan, mut fixed_nan, mut new_light, mut fixed_light) = (vec![], 0, vec![], 0);
            for (i, (b, a)) in base.iter().zip(values).enumerate() {
                match (b, a) {
                    (Obs::Lit(eb), Obs::Lit(ea)) => {
                        pairs.push((*eb, *ea));
                        let now = Obs::parse(&Obs::Lit(*ea).token()).map_or(*ea, |o| match o {
                            Obs::Lit(e) => e,
                            _ => *ea,
                        });
                        share_pairs.push(Pair {
                            base: *eb,
                            now,
                            ulp: ulps[i],
                        });
                        share_bins.push(observations.configs[family][i].1.clone());
                        share_index.push(i);
                    }
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
            let tests = share_tests(&share_pairs, &share_bins, &axes, &share_options);
            for (pair, i) in share_pairs.iter().zip(&share_index) {
                if pair.worse(&share_options) {
                    replay.insert((family, *i));
                }
            }
            replay.extend(new_nan.iter().chain(&new_light).map(|i| (family, *i)));
            let failed: Vec<String> = tests
                .iter()
                .filter(|t| t.regressed)
                .map(|t| format!("{} ({} of {}, P {})", t.scope, t.worse, t.pairs, p_eq(&t.p_text())))
                .collect();
            let all = &tests[0];
            rules.push(rule(
                mat,
                "share",
                if failed.is_empty() {
                    Change::Unchanged
                } else {
                    Change::Regressed
                },
                format!(
                    "worse on {} of {} paired configurations ({:.1} %; better on {}), allowed {} %{}",
                    all.worse,
                    all.pairs,
                    100.0 * all.share(),
                    all.better,
                    100.0 * share_options.share,
                    if failed.is_empty() {
                        format!(" (no material or bin beyond it at P < {})", share_options.alpha)
                    } else {
                        format!("; beyond it: {}", failed.join(", "))
                    }
                ),
            ));
            shares.push(Shares {
                method: entry.label.clone(),
                material: mat.to_string(),
                tests,
            });
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
    let change = Change::overall(&rules);
    GateReport {
        baseline_adapter: loaded.baseline.adapter.clone(),
        adapter: measured.timing.adapter.clone(),
        rules,
        timings,
        new_methods,
        change,
        share_options,
        shares,
        seconds: started.elapsed().as_secs_f64(),
        replay: replay
            .into_iter()
            .map(|(family, i)| observations.configs[family][i].0.clone())
            .collect(),
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
}

//! A gate baseline on disk (docs/ci/README.md): `baseline.json`, `timings.json` and one
//! errors file per method and material, saved as one set by `sweep --save-baseline DIR` and
//! loaded, checked against this run's case and configurations, by `sweep --baseline DIR`.

use super::{observed, sample_digest, Obs, Observations};
use crate::analyse::stats::nearest_rank;
use crate::limits::MAX_TOKEN_LINE;
use crate::measure::sweep::{Measured, Setup};
use crate::report::format::{Format, Json, Layout, Plain};
use anyhow::Context;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of the on-disk format; a baseline of another version is bad input. 2: every method
/// is judged against what the surface receives (`line_upper`, `cylinder_upper`, …, the
/// headline's target) and its f32 result against the reference at the f32-rounded
/// configuration; format 1 judged against the method's own target and the exact reference.
pub const FORMAT: u32 = 3;

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

/// A method label as a file name: `line.numeric@64` → `line.numeric_64`.
pub(super) fn file_name(label: &str) -> String {
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

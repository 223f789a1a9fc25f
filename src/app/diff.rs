//! `linelight diff CASE A B`: two methods, or two revisions of one kernel file, on a case's
//! configurations. Paired statistics (the gate's, src/app/gate/mod.rs, with A as the baseline),
//! the regions where they disagree (the disagreement search, src/measure/search.rs) and a verdict.

use crate::app::gate::{self, Change, Obs};
use crate::input::case::Case;
use crate::kernel::methods::{self, Method};
use crate::kernel::{Includes, KernelFile};
use crate::measure::gpu::Gpu;
use std::path::{Path, PathBuf};

/// Options of `linelight diff`.
#[derive(clap::Args)]
pub struct DiffOptions {
    /// Case file whose configurations (seed, materials, counts) the two are run on.
    pub case: PathBuf,
    /// A method spec (`line.ltc2023`) or a kernel file (`old/my_line.wgsl`).
    pub a: String,
    /// A method spec or a kernel file (may have the same id as A).
    pub b: String,
    /// Override every material's count.
    #[arg(long)]
    pub count: Option<usize>,
    /// Error ratios within ±NOISE (at the 95 % bootstrap bounds) are no difference (0 to 1).
    #[arg(long, default_value_t = 0.05, value_parser = super::options::fraction)]
    pub noise: f64,
    /// Write the disagreement configurations here (eval input format, replayable).
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Adapter to use: any part of its name (default: lavapipe / llvmpipe).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Configurations per dispatch (not an option of `diff`).
    #[arg(skip = 65536usize)]
    pub chunk: usize,
}

/// Whether A or B names a kernel file rather than a method spec.
fn is_kernel_file(spec: &str) -> bool {
    spec.ends_with(".wgsl") || Path::new(spec).is_file()
}

/// A method spec, or a kernel file (a path ending `.wgsl`): a file is labelled with its path,
/// so two revisions of one kernel (same id) stay apart.
fn method_of(spec: &str, includes: &Includes) -> anyhow::Result<Method> {
    if is_kernel_file(spec) {
        let k = KernelFile::read(Path::new(spec), includes)?;
        let mut kernels = crate::kernel::builtin_kernels();
        kernels.retain(|b| b.id != k.id);
        kernels.push(k.clone());
        let mut m = methods::resolve(&k.id, &kernels)?;
        m.label = format!("{} ({spec})", k.id);
        Ok(m)
    } else {
        methods::resolve(spec, &crate::kernel::builtin_kernels())
    }
}

/// What a diff found, over all materials: the exit code follows it (B regressed on any
/// material: exit 1, as the gate's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Unchanged,
    Improved,
    Regressed,
    /// B more accurate on some materials and less on others (a regression too).
    Mixed,
}

impl Outcome {
    pub fn regressed(self) -> bool {
        matches!(self, Outcome::Regressed | Outcome::Mixed)
    }

    /// As the gate: B less accurate than A on any material is exit 1.
    pub fn status(self) -> super::Status {
        if self.regressed() {
            super::Status::ToleranceFail
        } else {
            super::Status::Ok
        }
    }
}

/// Runs the diff and prints it, ending with the verdict line.
pub fn run(options: &DiffOptions, includes: &Includes) -> anyhow::Result<Outcome> {
    crate::app::options::check_float("--noise", options.noise, crate::app::options::FRACTION)
        .map_err(anyhow::Error::msg)?;
    // The output is checked before any work: not the case file, not a kernel file given
    // as A or B, not inside a report folder.
    if let Some(path) = &options.output {
        let mut plan = crate::io::OutputPlan::new();
        plan.input("the case file", &options.case);
        for (which, spec) in [("A", &options.a), ("B", &options.b)] {
            if is_kernel_file(spec) {
                plan.input(which, Path::new(spec));
            }
        }
        plan.file("--output", path).check()?;
    }
    let a = method_of(&options.a, includes)?;
    let b = method_of(&options.b, includes)?;
    if a.label == b.label {
        anyhow::bail!("diff: A and B are the same method `{}`", a.label);
    }
    if a.target() != b.target() {
        anyhow::bail!(
            "diff: `{}` approximates {} and `{}` {}: nothing to pair",
            a.label,
            a.target(),
            b.label,
            b.target()
        );
    }
    let mut case = Case::load(&options.case)?;
    // Only A and B run; the search compares them both ways. The case's claims and
    // tolerances are about its own methods, not these.
    case.methods.clear();
    case.compare = vec![[a.label.clone(), b.label.clone()]];
    case.claims.clear();
    case.search = None;
    // Every natural configuration's observation of both is kept, to pair them.
    let holds = crate::measure::setup::Holds {
        observations: true,
        ..Default::default()
    };
    let mut setup = crate::app::prepare_with(case, &[], includes, options.count, holds)?;
    setup.methods = vec![a.clone(), b.clone()];
    crate::app::check_memory(&setup, holds)?;
    let gpu = Gpu::new(options.adapter.as_deref())?;
    eprintln!("adapter: {}", gpu.adapter);
    let swept = crate::app::swept::measure(
        &setup,
        &gpu,
        crate::measure::sweep::MeasureOptions {
            chunk: options.chunk,
            raw: None,
            shard: None,
        },
        true,
    )?;
    let observations = swept.observations.as_ref().expect("measured with observe");
    let observed = gate::observed(&setup, &swept.measured, observations);
    println!(
        "diff on case {}: A = {}, B = {} (ratios are B / A)",
        setup.case.name, a.label, b.label
    );
    let mut changes = Vec::new();
    for (m, family) in setup.case.materials.iter().enumerate() {
        let (sa, oa) = &observed[0].materials[m];
        let (sb, ob) = &observed[1].materials[m];
        if !(sa & sb) {
            println!(
                "  {}: not compared (unsupported by {})",
                family.name,
                if *sa { &b.label } else { &a.label }
            );
            continue;
        }
        let pairs: Vec<(f64, f64)> = oa
            .iter()
            .zip(ob)
            .filter_map(|(x, y)| match (x, y) {
                (Obs::Lit(x), Obs::Lit(y)) => Some((*x, *y)),
                _ => None,
            })
            .collect();
        let count = |o: &[Obs], what: Obs| o.iter().filter(|v| **v == what).count();
        let p = gate::paired(&pairs, 1000, options.noise);
        let change = p.change(options.noise);
        changes.push(change);
        let verdict = match change {
            Change::Regressed => "B is less accurate",
            Change::Improved => "B is more accurate",
            _ => "no difference beyond the noise",
        };
        let [gl, gm, gh] = p.geomean;
        let [pl, pm, ph] = p.p99_ratio;
        println!(
            "  {}: {verdict}: over {} paired configurations, error ratio geometric mean ×{gm:.4} [{gl:.4}–{gh:.4}], \
             p99 ×{pm:.4} [{pl:.4}–{ph:.4}] (95 % bootstrap, noise ±{} %); B worse on {}, better on {}; \
             NaN/inf A {} B {}; false light A {} B {}",
            family.name,
            p.pairs,
            options.noise * 100.0,
            p.worse,
            p.better,
            count(oa, Obs::NonFinite),
            count(ob, Obs::NonFinite),
            count(oa, Obs::FalseLight),
            count(ob, Obs::FalseLight),
        );
    }
    println!("  where they disagree most (disagreement search, both ways):");
    for d in &swept.measured.disagreements {
        let who = if d.a == a.label { "A" } else { "B" };
        println!(
            "    {who} worse on {}: err {who} {:.3e} against {:.3e} (×{:.3e}; the sample's largest ×{:.3e}) at {}",
            d.family,
            d.err_a,
            d.err_b,
            d.ratio,
            d.sample_ratio,
            where_(&d.axes)?
        );
    }
    if let Some(path) = &options.output {
        let rows: Vec<_> = swept
            .measured
            .disagreements
            .iter()
            .map(|d| serde_json::to_value(&d.config))
            .collect::<Result<_, _>>()?;
        crate::report::format::write_file(path, &crate::report::format::Jsonl::new("disagreements", rows))?;
        eprintln!("wrote {} (replay with linelight eval)", path.display());
    }
    let (regressed, improved) = (
        changes.contains(&Change::Regressed),
        changes.contains(&Change::Improved),
    );
    let (outcome, verdict) = match (regressed, improved) {
        (true, true) => (
            Outcome::Mixed,
            "mixed (B is more accurate on some materials and less on others)",
        ),
        (true, false) => (Outcome::Regressed, "B is less accurate than A"),
        (false, true) => (Outcome::Improved, "B is more accurate than A"),
        (false, false) => (Outcome::Unchanged, "no difference beyond the noise"),
    };
    println!("verdict: {verdict}");
    Ok(outcome)
}

/// The sampled parameters of a configuration (the derived axes are in the JSONL output).
fn where_(axes: &crate::input::sampler::Axes) -> anyhow::Result<String> {
    let v = serde_json::to_value(axes)?;
    Ok(["length", "center", "elevation", "tilt", "alpha"]
        .iter()
        .filter_map(|k| Some(format!("{k} {:.4}", v.get(*k)?.as_f64()?)))
        .collect::<Vec<_>>()
        .join(", "))
}

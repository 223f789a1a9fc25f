//! `linelight diff CASE A B`: two methods, or two revisions of one kernel file, on a case's
//! configurations. This file chains the stages: the sweep's measuring with the disagreement
//! search (app::swept, measure::search), the paired statistics (analyse::diff, the gate's
//! comparison with A as the baseline), the printed lines and the replay file (report::diff).

use crate::analyse::diff::Outcome;
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

/// The exit status of a diff's outcome: as the gate, B less accurate than A on any material
/// is exit 1.
pub fn status(outcome: Outcome) -> super::Status {
    if outcome.regressed() {
        super::Status::ToleranceFail
    } else {
        super::Status::Ok
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
    let summary = crate::analyse::diff::analyse(&setup, &swept.measured, observations, options.noise)?;
    print!("{}", crate::report::diff::body(&summary));
    if let Some(path) = &options.output {
        crate::report::format::write_file(path, &crate::report::diff::replay(&summary)?)?;
        eprintln!("wrote {} (replay with linelight eval)", path.display());
    }
    println!("{}", crate::report::diff::verdict(summary.outcome));
    Ok(summary.outcome)
}

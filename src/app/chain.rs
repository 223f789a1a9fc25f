//! `linelight chain`: the error chain from the GGX BRDF to the pixel, per configuration, for
//! a case of `ggx` materials (cases/ggx.toml → reports/ggx-chain/chain.md, chain.csv, chain.json).
//!
//! Every link is measured against the GGX truth T (the f64 reference of the `ggx` lobe), so
//! the links add up to the total:
//!
//! | link | value compared | with |
//! |---|---|---|
//! | fit | exact integral of the exact per-configuration fit (× its magnitude) | T |
//! | table | exact integral of the table's bilinear f32 look-up | the exact fit's |
//! | storage | the same with binary16 texels | the f32 look-up's |
//! | formula | the method in f64 on the look-up | the look-up's exact integral |
//! | rounding | the method in f32 on the CPU | the method in f64 |
//! | driver | the GPU | the CPU f32 |
//!
//! each as |a − b|/T. Beside them, the Fresnel link: our feed's
//! f0·magnitude + (1 − f0)·fresnel (what an LTC method is multiplied by) against the exact ∫D·F
//! of the configuration's lobe, |a − b|/(∫D·F), with that value's own error estimate; it is the
//! magnitude part of the table link, shown apart. The published table, which has no Fresnel
//! channel, is not fed to configurations with F0 < 1. The look-up is our isotropic table for isotropic roughness and our
//! anisotropic table (seed 004, `data/ltc_ggx_aniso.csv`, quadrilinear) for anisotropic
//! roughness. The published table (Heitz et al. 2016, shipped in data/ltc_code/) is run through
//! the same look-up beside ours on isotropic configurations.
//!
//! This file chains the stages: measure::chain (the values), analyse::chain (links, bins,
//! findings), report::chain (the files), io (the set written whole).

use crate::input::case::Case;
use crate::report::chain::FitRecords;
use std::path::Path;

/// Options of `linelight chain`.
#[derive(clap::Args)]
pub struct ChainOptions {
    /// Case file with ggx materials, e.g. cases/ggx.toml.
    #[arg(default_value = "cases/ggx.toml")]
    pub case: std::path::PathBuf,
    /// Output folder, a chain report folder of its own (default: reports/<case name>-chain).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Override every material's count (quick runs).
    #[arg(long)]
    pub count: Option<usize>,
    #[command(flatten)]
    pub gpu: super::GpuOptions,
}

/// `linelight chain CASE [--out DIR] [--count N]`: the output folder (default
/// `reports/<case>-chain`, a chain report folder of its own) and the run's size checked before
/// any work, then measured and written.
pub fn run(
    case_path: &Path,
    out: Option<std::path::PathBuf>,
    count: Option<usize>,
    options: &super::GpuOptions,
) -> anyhow::Result<super::Status> {
    let case = Case::load(case_path)?;
    let dir = out.unwrap_or_else(|| Path::new("reports").join(format!("{}-chain", case.name)));
    let mut plan = crate::io::OutputPlan::new();
    plan.input("the case file", case_path);
    plan.set("--out", &dir, crate::io::SetKind::Chain).check()?;
    let case = sized(&case, count)?;
    let device = super::open_gpu(options.adapter.as_deref())?;
    let run = crate::measure::chain::measure(&case, &device, options.chunk)?;
    let chain = crate::analyse::chain::analyse(&run);
    let records = FitRecords {
        iso: run_record("data/ltc_ggx_iso.run.json"),
        aniso: run_record("data/ltc_ggx_aniso.run.json"),
    };
    let outputs = crate::report::chain::outputs(&case_path.display().to_string(), &case.title, &chain, &records);
    // Its own report folder, swapped in whole: never mixed into a sweep's.
    for path in crate::report::format::write_set(&dir, crate::io::SetKind::Chain, &outputs)? {
        eprintln!("wrote {}", path.display());
    }
    Ok(super::Status::Ok)
}

/// The case with `--count` applied, refused when a count or the memory it takes is past the
/// limits: the chain holds every configuration, its feeds and rows.
fn sized(case: &Case, count: Option<usize>) -> anyhow::Result<Case> {
    let mut case = case.clone();
    if let Some(n) = count {
        crate::limits::check_count("--count", n as u64).map_err(anyhow::Error::msg)?;
        for m in &mut case.materials {
            m.count = n;
        }
    }
    let configurations = case
        .materials
        .iter()
        .fold(0u64, |t, m| t.saturating_add(m.count as u64));
    let methods = case.methods.len() as u64;
    let mut budget = crate::limits::Budget::new();
    budget.add(
        format!("{configurations} configurations × {methods} methods, every one held"),
        crate::limits::chain_estimate(configurations, methods),
    );
    budget
        .check(&format!("chain of case `{}`", case.name))
        .map_err(anyhow::Error::msg)?;
    Ok(case)
}

/// A fit's run record committed beside its table (in the source tree), None when absent or
/// unreadable (the report then leaves its sentence out).
fn run_record(relative: &str) -> Option<serde_json::Value> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    crate::io::read_record(&path, crate::limits::MAX_RECORD_BYTES)
}

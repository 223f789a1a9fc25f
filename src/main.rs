//! The `linelight` command line: sweep, merge, eval, bench, scan, fit, chain, diff, adapters,
//! check. It only parses the arguments and dispatches to the app layer (`src/app/`), whose
//! options types carry their own flags.

use clap::{Parser, Subcommand};
use linelight::app::{self, bounded, status_of, Status};
use linelight::kernel::Includes;
use linelight::limits;
use linelight::measure::gpu;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "linelight",
    version,
    about = "Validates real-time line-light shading formulas on the GPU against f64 references"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Refuse a run whose estimated memory exceeds this (bytes, or with K, M, G, T);
    /// default: half of the machine's memory.
    #[arg(long, global = true, value_name = "SIZE", value_parser = limits::parse_memory)]
    max_memory: Option<limits::Bytes>,
    /// A folder `#include` in a GLSL or HLSL kernel searches, after the including file's own
    /// (repeatable, searched in order).
    #[arg(long = "include", global = true, value_name = "DIR")]
    include: Vec<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case file: sample, evaluate, compare with references, write reports, give a verdict.
    Sweep(app::sweep::SweepOptions),
    /// Merge the shard states of a sharded sweep (`sweep --shard i/n`) into the report the
    /// unsharded sweep writes (docs/scale.md). Needs no GPU: the shards ran the searches and
    /// shard 0 timed the methods.
    Merge(app::sweep::MergeOptions),
    /// Render a floor under the light, one configuration per floor pixel, per method, with
    /// relative-error and FLIP images against the reference (docs/render.md).
    Render(app::render::RenderOptions),
    /// Evaluate explicit configurations (JSONL in, JSONL out; docs/eval-format.md).
    Eval(app::eval::EvalOptions),
    /// Cost per method: GPU ns per evaluation (timestamp queries), the CPU evaluator's f32 column on all
    /// cores, and an operation count from the kernel's naga IR. Measured, never asserted.
    Bench(app::BenchOptions),
    /// Stability scan on the GPU: configurations generated on the device from the case's seed,
    /// only the counts of NaN, inf, negative and above-bound values read back; the first
    /// offending configurations captured for `linelight eval`.
    Scan(app::ScanOptions),
    /// Fit the isotropic GGX LTC table, or with --aniso the anisotropic one of seed 004
    /// (f64, Nelder–Mead; deterministic) and write it.
    Fit(app::fit::FitOptions),
    /// Seed 004's fitting objective (sliced Wasserstein, SGD) beside ours (L1) on the SW-fitted
    /// subset of the anisotropic table: line-light error against GGX truth near the highlight and
    /// overall, and the lobe errors. Writes OUT/objectives.{md,json}, lines.csv, entries.csv.
    Objectives(app::objectives::ObjectivesOptions),
    /// The GGX error chain (fit, table, storage, formula, rounding, driver) of a case of ggx
    /// materials, beside the published table: writes OUT/chain.{md,csv,json}
    /// (OUT: reports/<case name>-chain).
    Chain(app::chain::ChainOptions),
    /// The anisotropic table's resolution study (seed 004 Fig. 12): tables of other
    /// resolutions fed to a case of anisotropic ggx families, error against GGX truth near the
    /// highlight and overall; writes OUT/resolution.{md,csv,json} (OUT: reports/ggx-resolution).
    Resolution(app::resolution::ResolutionOptions),
    /// Compare two methods, or two revisions of one kernel file, on a case's configurations:
    /// paired statistics, where they disagree, and a verdict. Exit 1 when B is less accurate
    /// than A on any material (as the gate), 0 when it is more accurate or within the noise.
    Diff(app::diff::DiffOptions),
    /// List the Vulkan adapters wgpu can see.
    Adapters,
    /// Compose and validate kernel files with naga (no GPU needed).
    Check(app::CheckOptions),
}

fn main() -> ExitCode {
    gpu::quiet_driver_environment();
    let cli = Cli::parse();
    let result = run(cli);
    // What the run warned of, in one place, before its error if it failed.
    linelight::warnings::print();
    let status = match result {
        Ok(status) => status,
        Err(e) => {
            // Kernel diagnostics arrive formatted by naga, already starting with `error`.
            let message = bounded(&format!("{e:#}"));
            if message.starts_with("error") {
                eprintln!("{message}");
            } else {
                eprintln!("error: {message}");
            }
            status_of(&e)
        }
    };
    ExitCode::from(status.code())
}

fn run(cli: Cli) -> anyhow::Result<Status> {
    // The environment (LINELIGHT_*), checked before any work.
    linelight::tuning::init().map_err(anyhow::Error::msg)?;
    if let Some(limit) = cli.max_memory {
        limits::set_max_memory(limit);
    }
    // The `--include` folders, passed to every command that reads a kernel file.
    let includes = &Includes::new(cli.include);
    match cli.command {
        Command::Sweep(o) => app::sweep::sweep(o, includes),
        Command::Merge(o) => app::sweep::merge(o, includes),
        Command::Render(o) => app::render::render(o, includes),
        Command::Eval(o) => app::eval::eval(o, includes),
        Command::Bench(o) => app::bench(&o, includes).map(|_| Status::Ok),
        Command::Scan(o) => app::scan(o, includes),
        Command::Fit(o) => app::fit::run(o),
        Command::Objectives(o) => app::objectives::run(&o.subset, &o.out, o.lines),
        Command::Chain(o) => app::chain::run(&o.case, o.out, o.count, &o.gpu),
        Command::Resolution(o) => app::resolution::run(&o.case, o.tables, o.out),
        Command::Diff(o) => app::diff::run(&o, includes).map(app::diff::status),
        Command::Adapters => app::adapters(),
        Command::Check(o) => app::check(&o.kernels, o.emit, includes),
    }
}

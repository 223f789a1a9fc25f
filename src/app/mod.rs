//! The app layer: what each command does with the stages (measure → analyse → report), its
//! inputs checked before any work; `main.rs` parses the command line and calls these. Each
//! returns a [`Status`], and an error's [`Status`] says which exit code it is (README,
//! "Exit status"; docs/exit-codes.md).

mod bench;
pub mod chain;
mod check;
pub mod diff;
pub mod eval;
pub mod fit;
pub mod gate;
pub mod objectives;
pub mod options;
pub mod render;
pub mod resolution;
pub mod scan;
pub mod shard;
mod status;
pub mod sweep;
pub mod swept;

pub use bench::{bench, BenchOptions};
pub use check::{adapters, check, CheckOptions};
pub use scan::{scan, ScanOptions};

pub use status::{status_of, Status};

use crate::kernel::Includes;
use crate::measure::gpu::Gpu;
use anyhow::Result;
use std::path::{Path, PathBuf};

// The device options every GPU command takes (flattened into each command's options).
#[derive(clap::Args, Clone, Debug)]
pub struct GpuOptions {
    /// Adapter to use: any part of its name (default: lavapipe / llvmpipe).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Extra method kernel(s) to make available, validated like the built-ins.
    #[arg(long = "kernel", value_name = "FILE")]
    pub kernels: Vec<PathBuf>,
    /// Configurations per GPU dispatch and readback.
    #[arg(long, default_value_t = 65536)]
    pub chunk: usize,
}

/// A run's setup ([`crate::measure::setup::resolve`]) with its memory checked against
/// `--max-memory` ([`check_memory`]), for a streamed sweep: nothing sampled yet.
pub fn prepare_with(
    case: crate::input::case::Case,
    user_kernels: &[PathBuf],
    includes: &Includes,
    count: Option<usize>,
    holds: crate::measure::setup::Holds,
) -> Result<crate::measure::sweep::Setup> {
    let setup = crate::measure::setup::resolve(case, user_kernels, includes, count)?;
    check_memory(&setup, holds)?;
    Ok(setup)
}

/// [`prepare_with`] for a run that holds every configuration (bench), with the whole sample
/// drawn into `Setup::samples`.
pub fn prepare(
    case: crate::input::case::Case,
    user_kernels: &[PathBuf],
    includes: &Includes,
    count: Option<usize>,
) -> Result<crate::measure::sweep::Setup> {
    let holds = crate::measure::setup::Holds {
        all_samples: true,
        ..Default::default()
    };
    let mut setup = prepare_with(case, user_kernels, includes, count, holds)?;
    crate::measure::setup::draw_all(&mut setup)?;
    Ok(setup)
}

/// Refuses a run whose memory (the measure stage's sizes with the analysis's statistics,
/// `limits::run_budget`) exceeds `--max-memory`, before anything is allocated.
pub fn check_memory(setup: &crate::measure::sweep::Setup, holds: crate::measure::setup::Holds) -> Result<()> {
    let statistics = crate::analyse::analysis::statistics_size(&setup.case, &setup.methods);
    crate::measure::setup::check_memory(setup, holds, statistics)
}

/// `--kernel` files as inputs an output may not be.
pub fn kernel_inputs(kernels: &[PathBuf]) -> Vec<(&'static str, &Path)> {
    kernels.iter().map(|k| ("--kernel", k.as_path())).collect()
}

/// Opens the adapter asked for and says which it is.
pub fn open_gpu(adapter: Option<&str>) -> Result<Gpu> {
    let gpu = Gpu::new(adapter)?;
    eprintln!("adapter: {}", gpu.adapter);
    Ok(gpu)
}

/// A count as typed: `1000000`, `1e9` or `1_000_000`; a positive whole number.
pub fn parse_count(text: &str) -> Result<u64> {
    let clean = text.replace('_', "");
    let v: f64 = clean
        .parse()
        .map_err(|_| anyhow::anyhow!("--count `{text}`: not a number (write e.g. 1000000 or 1e9)"))?;
    if !((1.0..=crate::limits::MAX_SCAN_COUNT as f64).contains(&v) && v.fract() == 0.0) {
        anyhow::bail!("--count `{text}`: need a whole number from 1 to 1e15");
    }
    Ok(v as u64)
}

/// A message stays readable whatever the input: long lines (a 100 MB id, a minified JSON
/// line) are cut, and past a screenful of lines the rest is counted.
pub fn bounded(message: &str) -> String {
    const LINE: usize = 400;
    const LINES: usize = 40;
    let lines: Vec<&str> = message.lines().collect();
    let mut out: Vec<String> = lines
        .iter()
        .take(LINES)
        .map(|l| {
            if l.chars().count() > LINE {
                let head: String = l.chars().take(LINE).collect();
                format!("{head}… ({} more bytes)", l.len() - head.len())
            } else {
                l.to_string()
            }
        })
        .collect();
    if lines.len() > LINES {
        out.push(format!("… and {} more lines", lines.len() - LINES));
    }
    out.join("\n")
}

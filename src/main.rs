//! The `linelight` command line: sweep, merge, eval, bench, scan, fit, chain, diff, adapters,
//! check. It only parses the arguments and dispatches to the app layer (`src/app/`).

use clap::{Parser, Subcommand};
use linelight::app::{self, bounded, status_of, GpuOptions, Status};
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

#[derive(clap::Args)]
struct GpuArgs {
    /// Adapter to use: any part of its name (default: lavapipe / llvmpipe).
    #[arg(long)]
    adapter: Option<String>,
    /// Extra method kernel(s) to make available, validated like the built-ins.
    #[arg(long = "kernel", value_name = "FILE")]
    kernels: Vec<PathBuf>,
    /// Configurations per GPU dispatch and readback.
    #[arg(long, default_value_t = 65536)]
    chunk: usize,
}

/// The CI gate (docs/ci/): baselines and JUnit.
#[derive(clap::Args)]
struct GateArgs {
    /// Save this run as a baseline in DIR (baseline.json + errors/), for a later --baseline.
    #[arg(long, value_name = "DIR")]
    save_baseline: Option<PathBuf>,
    /// Compare with the baseline in DIR: any regression exits 1.
    #[arg(long, value_name = "DIR")]
    baseline: Option<PathBuf>,
    /// Write JUnit XML: one testcase per method × material × rule.
    #[arg(long, value_name = "FILE")]
    junit: Option<PathBuf>,
    /// Error ratios within ±NOISE (at the 95 % bootstrap bounds) are unchanged (0 to 1).
    #[arg(long, default_value_t = 0.05, value_parser = app::options::fraction)]
    noise: f64,
    /// Op-count growth beyond this fraction is a regression (0 to 1).
    #[arg(long, default_value_t = 0.10, value_parser = app::options::fraction)]
    ops_growth: f64,
    /// The share rule: the share of configurations allowed to get worse, per material and bin
    /// (0 to 1; a one-sided binomial test at P < 0.01, at least 5 worse).
    #[arg(long, default_value_t = 0.05, value_parser = app::options::fraction)]
    worse_share: f64,
    /// The share rule: an error that grew by at most K ULPs of the reference did not get worse
    /// (a driver's last-bit change).
    #[arg(long, value_name = "K", default_value_t = 4.0, value_parser = app::options::ulps)]
    worse_ulps: f64,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case file: sample, evaluate, compare with references, write reports, give a verdict.
    Sweep {
        /// Case file (TOML), e.g. cases/line_fwt.toml.
        case: PathBuf,
        /// Reports go to OUT/<case name>/.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
        /// Also write every configuration's values (JSONL) to this file.
        #[arg(long)]
        raw: Option<PathBuf>,
        /// Override every material's count (quick runs; the committed reports use the case's).
        #[arg(long)]
        count: Option<usize>,
        /// Evaluate shard I of N (a deterministic partition of the configurations) and write its
        /// mergeable state to OUT/shard-I-of-N.cbor instead of a report (docs/scale.md).
        #[arg(long, value_name = "I/N")]
        shard: Option<String>,
        #[command(flatten)]
        gpu: GpuArgs,
        #[command(flatten)]
        gate: GateArgs,
    },
    /// Merge the shard states of a sharded sweep (`sweep --shard i/n`) into the report the
    /// unsharded sweep writes (docs/scale.md). Needs no GPU: the shards ran the searches and
    /// shard 0 timed the methods.
    Merge {
        /// Directories holding the shard-I-of-N.cbor files (every shard exactly once).
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Reports go to OUT/<case name>/.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
    },
    /// Render a floor under the light, one configuration per floor pixel, per method, with
    /// relative-error and FLIP images against the reference (docs/render.md).
    Render {
        /// Scene file (TOML with a [render] table), e.g. cases/render/floor_tube.toml.
        scene: PathBuf,
        /// The render goes to OUT/<scene name>/.
        #[arg(long, default_value = "reports/render")]
        out: PathBuf,
        /// Save this render as a render baseline in DIR (render-baseline.json + images/), for a
        /// later --baseline.
        #[arg(long, value_name = "DIR")]
        save_baseline: Option<PathBuf>,
        /// Compare with the render baseline in DIR, pixel by pixel: any regression exits 1.
        #[arg(long, value_name = "DIR")]
        baseline: Option<PathBuf>,
        /// Write the render gate's rules as JUnit XML (with --baseline).
        #[arg(long, value_name = "FILE")]
        junit: Option<PathBuf>,
        /// A change of a method's mean FLIP against the reference within ±X is no change (0 to 1).
        #[arg(long, value_name = "X", default_value_t = app::render::FLIP_NOISE, value_parser = app::options::fraction)]
        flip_noise: f64,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Evaluate explicit configurations (JSONL in, JSONL out; docs/eval-format.md).
    Eval {
        #[arg(long)]
        input: PathBuf,
        #[arg(long)]
        output: PathBuf,
        /// Comma-separated method ids (`id` or `id@N`); default: every built-in and --kernel method.
        #[arg(long, value_delimiter = ',')]
        methods: Vec<String>,
        /// Also give each line the kernel source lines where f32 rounding loses bits
        /// (local error per operation, docs/eval-format.md `attribution`).
        #[arg(long)]
        attribution: bool,
        /// Also give each line the envelope of every method: the interval of f32 results any
        /// WGSL implementation within the spec's accuracy rules may return (docs/envelope.md).
        #[arg(long)]
        envelope: bool,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Cost per method: GPU ns per evaluation (timestamp queries), the CPU evaluator's f32 column on all
    /// cores, and an operation count from the kernel's naga IR. Measured, never asserted.
    Bench {
        /// Case file whose sampler makes the configurations and names the methods and pairs.
        #[arg(default_value = "cases/line_fwt.toml")]
        case: PathBuf,
        /// Comma-separated method specs (default: the case's methods).
        #[arg(long, value_delimiter = ',')]
        methods: Vec<String>,
        /// Configurations per dispatch, split evenly over the case's materials.
        #[arg(long, default_value_t = 65536)]
        count: usize,
        /// Timed rounds (every method once per round, in rotated order).
        #[arg(long, default_value_t = 9)]
        repeats: usize,
        /// Untimed rounds first.
        #[arg(long, default_value_t = 2)]
        warmup: usize,
        /// Adapter to use: any part of its name (default: lavapipe / llvmpipe).
        #[arg(long)]
        adapter: Option<String>,
        /// Extra method kernel(s) to make available, validated like the built-ins.
        #[arg(long = "kernel", value_name = "FILE")]
        kernels: Vec<PathBuf>,
        /// Also write the costs (one object per method) as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Also time each method's envelope (docs/envelope.md) on N configurations spread over
        /// the dispatch's, beside the CPU f32 column, in the same rounds.
        #[arg(long, value_name = "N")]
        envelope: Option<usize>,
    },
    /// Stability scan on the GPU: configurations generated on the device from the case's seed,
    /// only the counts of NaN, inf, negative and above-bound values read back; the first
    /// offending configurations captured for `linelight eval`.
    Scan {
        /// Case file whose families' distributions are scanned.
        case: PathBuf,
        /// Configurations per method, split evenly over the case's families (`1e9` is allowed).
        #[arg(long, default_value = "1e6")]
        count: String,
        /// Comma-separated method specs (default: the case's line methods).
        #[arg(long, value_delimiter = ',')]
        methods: Vec<String>,
        /// Offending configurations to capture per method and family.
        #[arg(long, default_value_t = 64)]
        capture: usize,
        /// Also count values above this bound (units where d = 1; above 0, at most f32's largest).
        #[arg(long, value_parser = app::options::bound)]
        bound: Option<f64>,
        /// The scan's report goes to OUT/<case name>-scan/.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Fit the isotropic GGX LTC table, or with --aniso the anisotropic one of seed 004
    /// (f64, Nelder–Mead; deterministic) and write it.
    Fit {
        /// Table file (CSV, docs/ggx.md; default data/ltc_ggx_iso.csv, with --aniso
        /// data/ltc_ggx_aniso.csv); a run record goes beside it (`.run.json`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Entries per axis of the isotropic table (roughness × view angle).
        #[arg(long, default_value_t = 64)]
        size: usize,
        /// Fit the anisotropic 4D table instead (θ × φ × α_max × ratio).
        #[arg(long)]
        aniso: bool,
        /// Entries per axis of the anisotropic table: θ,φ,α_max,ratio.
        #[arg(long, value_delimiter = ',', default_values_t = linelight::input::ltc::aniso::SIZE)]
        aniso_size: Vec<usize>,
        /// With --aniso: fit a fine slice instead, one view azimuth φ (radians, in [0, π/2])
        /// and one ratio r (in [0.25, 1]), with --aniso-size Nθ,1,Nα,1 (docs/ggx.md).
        #[arg(long, value_delimiter = ',', value_name = "PHI,R")]
        aniso_slice: Option<Vec<f64>>,
        /// With --aniso: the checkpoint file (default: the table's path with
        /// `.checkpoint.csv`); a run finding one resumes from it, a finished run removes it.
        #[arg(long)]
        checkpoint: Option<PathBuf>,
        /// With --aniso: write the checkpoint every this many finished chains (one chain: the
        /// α_max axis at one θ, φ, r).
        #[arg(long, default_value_t = 4)]
        checkpoint_every: usize,
        /// With --aniso: the objective, `l1` (the table, by Nelder–Mead) or `sw` (seed 004's
        /// sliced Wasserstein by SGD, on a documented subset of entries; default out
        /// data/ltc_ggx_aniso_sw_subset.csv).
        #[arg(long, default_value = "l1", value_parser = ["l1", "sw"])]
        objective: String,
        /// With --objective sw: SGD steps per entry.
        #[arg(long, default_value_t = linelight::input::ltc::sw::PARAMS.steps)]
        sw_steps: usize,
    },
    /// Seed 004's fitting objective (sliced Wasserstein, SGD) beside ours (L1) on the SW-fitted
    /// subset of the anisotropic table: line-light error against GGX truth near the highlight and
    /// overall, and the lobe errors (issue 24). Writes OUT/objectives.{md,json}, lines.csv, entries.csv.
    Objectives {
        /// The SW-fitted entries (`linelight fit --aniso --objective sw`).
        #[arg(long, default_value = "data/ltc_ggx_aniso_sw_subset.csv")]
        subset: PathBuf,
        /// Output folder, a report folder of its own.
        #[arg(long, default_value = "reports/ggx-objectives")]
        out: PathBuf,
        /// Lines per region (near the highlight, natural) and entry.
        #[arg(long, default_value_t = 8)]
        lines: usize,
    },
    /// The GGX error chain (fit, table, storage, formula, rounding, driver) of a case of ggx
    /// materials, beside the published table: writes OUT/chain.{md,csv,json}
    /// (OUT: reports/<case name>-chain).
    Chain {
        /// Case file with ggx materials, e.g. cases/ggx.toml.
        #[arg(default_value = "cases/ggx.toml")]
        case: PathBuf,
        /// Output folder, a chain report folder of its own (default: reports/<case name>-chain).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override every material's count (quick runs).
        #[arg(long)]
        count: Option<usize>,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// The anisotropic table's resolution study (issue 24, seed 004 Fig. 12): tables of other
    /// resolutions fed to a case of anisotropic ggx families, error against GGX truth near the
    /// highlight and overall; writes OUT/resolution.{md,csv,json} (OUT: reports/ggx-resolution).
    Resolution {
        /// Case file with anisotropic ggx families (a `slice` family for a slice table).
        #[arg(default_value = "cases/ggx_resolution.toml")]
        case: PathBuf,
        /// An anisotropic table file (repeatable, coarsest first; default: the 4⁴ table, the
        /// committed 8⁴ and the fine slice in data/).
        #[arg(long = "table")]
        tables: Vec<PathBuf>,
        /// Output folder (default: reports/<case name with - for _>).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Compare two methods, or two revisions of one kernel file, on a case's configurations:
    /// paired statistics, where they disagree, and a verdict. Exit 1 when B is less accurate
    /// than A on any material (as the gate), 0 when it is more accurate or within the noise.
    Diff {
        /// Case file whose configurations (seed, materials, counts) the two are run on.
        case: PathBuf,
        /// A method spec (`line.ltc2023`) or a kernel file (`old/my_line.wgsl`).
        a: String,
        /// A method spec or a kernel file (may have the same id as A).
        b: String,
        /// Override every material's count.
        #[arg(long)]
        count: Option<usize>,
        /// Error ratios within ±NOISE (at the 95 % bootstrap bounds) are no difference (0 to 1).
        #[arg(long, default_value_t = 0.05, value_parser = app::options::fraction)]
        noise: f64,
        /// Write the disagreement configurations here (eval input format, replayable).
        #[arg(long)]
        output: Option<PathBuf>,
        /// Adapter to use: any part of its name (default: lavapipe / llvmpipe).
        #[arg(long)]
        adapter: Option<String>,
    },
    /// List the Vulkan adapters wgpu can see.
    Adapters,
    /// Compose and validate kernel files with naga (no GPU needed).
    Check {
        #[arg(required = true)]
        kernels: Vec<PathBuf>,
        /// Print each composed WGSL module (prelude + kernel + entry point) to stdout.
        #[arg(long)]
        emit: bool,
    },
}

fn main() -> ExitCode {
    gpu::quiet_driver_environment();
    let cli = Cli::parse();
    linelight::kernel::set_include_dirs(cli.include.clone());
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

impl GpuArgs {
    fn options(&self) -> GpuOptions {
        GpuOptions {
            adapter: self.adapter.clone(),
            kernels: self.kernels.clone(),
            chunk: self.chunk,
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<Status> {
    // The environment (LINELIGHT_*), checked before any work.
    linelight::tuning::init().map_err(anyhow::Error::msg)?;
    if let Some(limit) = cli.max_memory {
        limits::set_max_memory(limit);
    }
    match cli.command {
        Command::Sweep {
            case,
            out,
            raw,
            count,
            shard,
            gpu,
            gate,
        } => app::sweep::sweep(
            app::sweep::SweepOptions {
                case,
                out,
                raw,
                count,
                shard,
                gate: app::sweep::GateFlags {
                    save_baseline: gate.save_baseline,
                    baseline: gate.baseline,
                    junit: gate.junit,
                    noise: gate.noise,
                    ops_growth: gate.ops_growth,
                    worse_share: gate.worse_share,
                    worse_ulps: gate.worse_ulps,
                },
            },
            &gpu.options(),
        ),
        Command::Merge { shards, out } => app::sweep::merge(&shards, &out),
        Command::Render {
            scene,
            out,
            save_baseline,
            baseline,
            junit,
            flip_noise,
            gpu,
        } => app::render::render(
            app::render::RenderOptions {
                scene,
                out,
                save_baseline,
                baseline,
                junit,
                flip_noise,
            },
            &gpu.options(),
        ),
        Command::Eval {
            input,
            output,
            methods,
            attribution,
            envelope,
            gpu,
        } => app::eval::eval(
            app::eval::EvalOptions {
                input,
                output,
                methods,
                attribution,
                envelope,
            },
            &gpu.options(),
        ),
        Command::Bench {
            case,
            methods,
            count,
            repeats,
            warmup,
            adapter,
            kernels,
            json,
            envelope,
        } => {
            let options = app::BenchOptions {
                case,
                methods,
                count,
                repeats,
                warmup,
                adapter,
                kernels,
                json,
                envelope,
            };
            app::bench(&options)?;
            Ok(Status::Ok)
        }
        Command::Scan {
            case,
            count,
            methods: specs,
            capture,
            bound,
            out,
            gpu,
        } => app::scan(
            app::ScanOptions {
                case,
                count,
                methods: specs,
                capture,
                bound,
                out,
            },
            &gpu.options(),
        ),
        Command::Fit {
            out,
            size,
            aniso,
            aniso_size,
            aniso_slice,
            checkpoint,
            checkpoint_every,
            objective,
            sw_steps,
        } => {
            if !aniso && aniso_slice.is_some() {
                anyhow::bail!("--aniso-slice is for --aniso fits");
            }
            if !aniso && checkpoint.is_some() {
                anyhow::bail!("--checkpoint is for --aniso fits (the isotropic table takes minutes, not hours)");
            }
            if objective == "sw" {
                if !aniso {
                    anyhow::bail!("--objective sw is for --aniso fits (seed 004's objective)");
                }
                if checkpoint.is_some() {
                    anyhow::bail!("--checkpoint is for the L1 table's fit (--objective sw fits a subset in minutes)");
                }
                let size: [usize; 4] = aniso_size
                    .try_into()
                    .map_err(|v: Vec<usize>| anyhow::anyhow!("--aniso-size takes 4 numbers, got {}", v.len()))?;
                let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_aniso_sw_subset.csv"));
                linelight::app::fit::aniso_sw(&out, size, sw_steps)?;
            } else if aniso {
                let size: [usize; 4] = aniso_size
                    .try_into()
                    .map_err(|v: Vec<usize>| anyhow::anyhow!("--aniso-size takes 4 numbers, got {}", v.len()))?;
                let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_aniso.csv"));
                let checkpoint = checkpoint.unwrap_or_else(|| linelight::app::fit::default_checkpoint(&out));
                let slice = aniso_slice
                    .map(|v| {
                        <[f64; 2]>::try_from(v)
                            .map_err(|v| anyhow::anyhow!("--aniso-slice takes 2 numbers (φ,r), got {}", v.len()))
                    })
                    .transpose()?;
                linelight::app::fit::aniso(&out, size, slice, &checkpoint, checkpoint_every)?;
            } else {
                let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_iso.csv"));
                linelight::app::fit::iso(&out, size)?;
            }
            Ok(Status::Ok)
        }
        Command::Objectives { subset, out, lines } => linelight::app::objectives::run(&subset, &out, lines),
        Command::Chain { case, out, count, gpu } => linelight::app::chain::run(&case, out, count, &gpu.options()),
        Command::Resolution { case, tables, out } => linelight::app::resolution::run(&case, tables, out),
        Command::Diff {
            case,
            a,
            b,
            count,
            noise,
            output,
            adapter,
        } => {
            let outcome = linelight::app::diff::run(&linelight::app::diff::DiffOptions {
                case,
                a,
                b,
                count,
                noise,
                adapter,
                chunk: 65536,
                output,
            })?;
            // As the gate: B less accurate than A on any material is exit 1.
            Ok(if outcome.regressed() {
                Status::ToleranceFail
            } else {
                Status::Ok
            })
        }
        Command::Adapters => app::adapters(),
        Command::Check { kernels, emit } => app::check(&kernels, emit),
    }
}

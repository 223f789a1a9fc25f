//! The `linelight` command line: sweep, eval, bench, fit, chain, adapters, check.

use clap::{Parser, Subcommand};
use linelight::analysis::{analyse, Verdict};
use linelight::case::Case;
use linelight::claims;
use linelight::gpu::{self, Gpu};
use linelight::report::{self, write_atomic, ReportInput};
use linelight::{eval, methods, sweep};
use rayon::prelude::*;
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
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Evaluate explicit configurations (JSONL in, JSONL out; DESIGN §3).
    Eval {
        #[arg(long)]
        input: PathBuf,
        #[arg(long)]
        output: PathBuf,
        /// Comma-separated method ids (`id` or `id@N`); default: every built-in and --kernel method.
        #[arg(long, value_delimiter = ',')]
        methods: Vec<String>,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Cost per method: GPU ns per evaluation (timestamp queries), the CPU f32 port on all
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
    },
    /// Fit the isotropic GGX LTC table (f64, Nelder–Mead; deterministic) and write it.
    Fit {
        /// Table file (CSV, docs/ggx.md); a run record goes beside it (`.run.json`).
        #[arg(long, default_value = "data/ltc_ggx_iso.csv")]
        out: PathBuf,
        /// Entries per axis (roughness × view angle).
        #[arg(long, default_value_t = 64)]
        size: usize,
    },
    /// The GGX error chain (fit, table, storage, formula, rounding, driver) of a case of ggx
    /// materials, beside the published table: writes OUT/chain.{md,csv,json}.
    Chain {
        /// Case file with ggx materials, e.g. cases/ggx.toml.
        #[arg(default_value = "cases/ggx.toml")]
        case: PathBuf,
        /// Output folder (default: reports/<case name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override every material's count (quick runs).
        #[arg(long)]
        count: Option<usize>,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// List the Vulkan adapters wgpu can see.
    Adapters,
    /// Compose and validate kernel files with naga (no GPU needed).
    Check {
        #[arg(required = true)]
        kernels: Vec<PathBuf>,
    },
}

fn main() -> ExitCode {
    gpu::quiet_driver_environment();
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            // Kernel diagnostics arrive formatted by naga, already starting with `error`.
            let message = format!("{e:#}");
            if message.starts_with("error") {
                eprintln!("{message}");
            } else {
                eprintln!("error: {message}");
            }
            ExitCode::from(2)
        }
    }
}

fn open_gpu(args: &GpuArgs) -> anyhow::Result<Gpu> {
    let gpu = Gpu::new(args.adapter.as_deref())?;
    eprintln!("adapter: {}", gpu.adapter);
    Ok(gpu)
}

fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Sweep {
            case,
            out,
            raw,
            count,
            gpu,
        } => {
            let started = std::time::Instant::now();
            let case_path = case.display().to_string();
            let command_line = shell_words::join(std::env::args());
            let setup = sweep::prepare(Case::load(&case)?, &gpu.kernels, count)?;
            // A claim that names what the case does not have is bad input, found before measuring.
            let labels = setup.methods.iter().map(|m| m.label.clone()).collect();
            claims::check(&setup.case.claims, claims::dry_facts(&setup.case, labels))
                .map_err(|e| anyhow::anyhow!("{case_path}: {e}"))?;
            let device = open_gpu(&gpu)?;
            eprintln!(
                "case {}: {} configurations, {} methods",
                setup.case.name,
                setup.samples.len(),
                setup.methods.len()
            );
            let measured = sweep::measure(&setup, &device, gpu.chunk)?;
            let t = std::time::Instant::now();
            let analysis = analyse(&setup.case, &setup.samples, &measured.references, &measured.runs);
            let facts = claims::Facts {
                analysis: Some(analysis.clone()),
                configurations: setup.samples.iter().filter(|s| s.natural()).count(),
                costs: measured.costs.clone(),
                disagreements: measured.disagreements.clone(),
                found: measured.found.clone(),
                ..claims::dry_facts(&setup.case, setup.methods.iter().map(|m| m.label.clone()).collect())
            };
            let claim_results = claims::evaluate(&setup.case.claims, facts);
            let stages = report::Stages {
                analysis_seconds: t.elapsed().as_secs_f64(),
                until_report_seconds: started.elapsed().as_secs_f64(),
            };
            let dir = out.join(&setup.case.name);
            let input = ReportInput {
                case_path: &case_path,
                command_line: &command_line,
                case: &setup.case,
                setup: &setup,
                measured: &measured,
                analysis: &analysis,
                claims: &claim_results,
                stages,
            };
            for path in report::write_reports(&dir, &input)? {
                eprintln!("wrote {}", path.display());
            }
            if let Some(raw) = raw {
                let rows: Vec<_> = setup
                    .samples
                    .par_iter()
                    .enumerate()
                    .map(|(i, s)| {
                        let f32s: Vec<f32> = measured.runs.iter().map(|r| r.f32[i]).collect();
                        let f64s: Vec<Option<f64>> = measured.runs.iter().map(|r| r.f64[i]).collect();
                        let mut row =
                            eval::result_row(&s.config, &measured.references[i], &setup.methods, &f32s, &f64s);
                        row["material"] = setup.case.materials[s.material].name.clone().into();
                        row["axes"] = serde_json::to_value(&s.axes).expect("axes serialise");
                        // Empty for the natural sample; a top-up lists the (axis, bin) it fills.
                        row["strata"] = serde_json::to_value(&s.strata).expect("strata serialise");
                        row["config"] = serde_json::to_value(&s.config).expect("config serialises");
                        row
                    })
                    .collect();
                write_atomic(&raw, &eval::to_jsonl(&rows))?;
                eprintln!("wrote {}", raw.display());
            }
            let failed = analysis.checks.iter().filter(|c| !c.pass).count();
            let stale: Vec<&str> = claim_results
                .iter()
                .filter(|c| !c.holds)
                .map(|c| c.id.as_str())
                .collect();
            println!(
                "verdict: {} ({} of {} checks pass); claims: {} of {} hold{}; report: {}",
                analysis.verdict.name(),
                analysis.checks.len() - failed,
                analysis.checks.len(),
                claim_results.len() - stale.len(),
                claim_results.len(),
                if stale.is_empty() {
                    String::new()
                } else {
                    format!(" (STALE: {})", stale.join(", "))
                },
                dir.join("report.md").display()
            );
            // 3: a finding no longer holds (the report says which); 1: a tolerance failed.
            Ok(if !stale.is_empty() {
                ExitCode::from(3)
            } else if analysis.verdict == Verdict::Fail {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            })
        }
        Command::Eval {
            input,
            output,
            methods: specs,
            gpu,
        } => {
            let configs = eval::read_configs(&input)?;
            let kernels = methods::kernel_set(&gpu.kernels)?;
            let specs = if specs.is_empty() {
                kernels.iter().map(|k| k.id.clone()).collect()
            } else {
                specs
            };
            let methods = specs
                .iter()
                .map(|s| methods::resolve(s, &kernels))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let device = open_gpu(&gpu)?;
            let pipelines = methods
                .iter()
                .map(|m| device.pipeline(m))
                .collect::<Result<Vec<_>, _>>()?;
            let scenes: Vec<_> = configs.iter().map(linelight::scene::GpuScene::from).collect();
            let mut f32s = Vec::new();
            for p in &pipelines {
                f32s.push(device.run(p, &scenes, gpu.chunk, &mut |_| {})?.values);
            }
            let rows: Vec<_> = configs
                .par_iter()
                .enumerate()
                .map(|(i, c)| {
                    let refs = eval::targets_of(c)
                        .into_iter()
                        .filter_map(|t| linelight::reference::reference(c, t).map(|e| (t, e)))
                        .collect();
                    let v32: Vec<f32> = f32s.iter().map(|v| v[i]).collect();
                    let v64: Vec<Option<f64>> = methods
                        .iter()
                        .map(|m| m.applies(c).then(|| m.eval_f64(c)).flatten())
                        .collect();
                    eval::result_row(c, &refs, &methods, &v32, &v64)
                })
                .collect();
            write_atomic(&output, &eval::to_jsonl(&rows))?;
            eprintln!("wrote {} results to {}", rows.len(), output.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Bench {
            case,
            methods,
            count,
            repeats,
            warmup,
            adapter,
            kernels,
            json,
        } => {
            let options = linelight::bench::BenchOptions {
                case,
                methods,
                count,
                repeats,
                warmup,
                adapter,
                kernels,
                json,
            };
            linelight::bench::run(&options)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Fit { out, size } => {
            linelight::ltc::fit_command(&out, size)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Chain { case, out, count, gpu } => {
            let case_path = case.display().to_string();
            let case = Case::load(&case)?;
            let device = open_gpu(&gpu)?;
            let run = linelight::chain::measure(&case, &device, count, gpu.chunk)?;
            let dir = out.unwrap_or_else(|| PathBuf::from("reports").join(&case.name));
            for path in linelight::chain::write(&dir, &case_path, &case, &run)? {
                eprintln!("wrote {}", path.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Adapters => {
            let adapters = gpu::list_adapters();
            if adapters.is_empty() {
                println!("no Vulkan adapter found (on Debian/Ubuntu: apt-get install mesa-vulkan-drivers)");
            }
            for a in adapters {
                println!("{a}");
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Check { kernels } => {
            let mut bad = 0;
            for path in &kernels {
                let result = linelight::kernel::KernelFile::read(path)
                    .and_then(|k| gpu::compose(&k).map(|_| k).map_err(anyhow::Error::from));
                match result {
                    Ok(k) => println!("{}: ok ({} → {})", path.display(), k.id, k.target),
                    Err(e) => {
                        eprintln!("{e}");
                        bad += 1;
                    }
                }
            }
            Ok(if bad == 0 { ExitCode::SUCCESS } else { ExitCode::from(2) })
        }
    }
}

//! The `linelight` command line: sweep, eval, bench, fit, chain, adapters, check.

use clap::{Parser, Subcommand};
use linelight::analysis::Verdict;
use linelight::app::{self, bounded, kernel_inputs, status_of, GpuOptions, Status};
use linelight::case::Case;
use linelight::claims;
use linelight::gpu::{self, Gpu};
use linelight::io::{check_output, check_set, stage_output, write_output};
use linelight::report;
use linelight::summary::{self, Summary};
use linelight::{eval, limits, methods, sweep};
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
    /// Refuse a run whose estimated memory exceeds this (bytes, or with K, M, G, T);
    /// default: half of the machine's memory.
    #[arg(long, global = true, value_name = "SIZE", value_parser = limits::parse_memory)]
    max_memory: Option<limits::Bytes>,
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
    /// Error ratios within ±NOISE (at the 95 % bootstrap bounds) are unchanged.
    #[arg(long, default_value_t = 0.05)]
    noise: f64,
    /// Op-count growth beyond this fraction is a regression.
    #[arg(long, default_value_t = 0.10)]
    ops_growth: f64,
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
    /// unsharded sweep writes (docs/scale.md).
    Merge {
        /// Directories holding the shard-I-of-N.cbor files (every shard exactly once).
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Reports go to OUT/<case name>/.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
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
        /// Also count values above this bound (units where d = 1).
        #[arg(long)]
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
        #[arg(long, value_delimiter = ',', default_values_t = linelight::ltc::aniso::SIZE)]
        aniso_size: Vec<usize>,
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
        /// Error ratios within ±NOISE (at the 95 % bootstrap bounds) are no difference.
        #[arg(long, default_value_t = 0.05)]
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
    let status = match run(cli) {
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

fn open_gpu(args: &GpuArgs) -> anyhow::Result<Gpu> {
    app::open_gpu(args.adapter.as_deref())
}

fn run(cli: Cli) -> anyhow::Result<Status> {
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
        } => {
            let started = std::time::Instant::now();
            let case_path = case.display().to_string();
            if count == Some(0) {
                anyhow::bail!("--count must be at least 1");
            }
            let shard = shard.as_deref().map(sweep::parse_shard).transpose()?;
            if shard.is_some()
                && (raw.is_some() || gate.save_baseline.is_some() || gate.baseline.is_some() || gate.junit.is_some())
            {
                anyhow::bail!(
                    "--shard writes a shard state only: --raw and the gate options belong to the unsharded sweep"
                );
            }
            let loaded = Case::load(&case)?;
            // Every output is checked before any work: the report folder, then --raw.
            let dir = out.join(&loaded.name);
            if shard.is_none() {
                check_set(&dir)?;
            }
            if let Some(raw) = &raw {
                let mut inputs = vec![("the case file", case.as_path())];
                inputs.extend(kernel_inputs(&gpu.kernels));
                check_output("--raw", raw, &inputs, &[&dir])?;
            }
            let command_line = shell_words::join(std::env::args());
            let setup = sweep::prepare_with(loaded, &gpu.kernels, count, raw.is_some())?;
            // A claim that names what the case does not have is bad input, found before measuring.
            let labels = setup.methods.iter().map(|m| m.label.clone()).collect();
            claims::check(&setup.case.claims, claims::dry_facts(&setup.case, labels))
                .map_err(|e| anyhow::anyhow!("{case_path}: {e}"))?;
            // A baseline that does not fit this run is bad input, found before measuring.
            let gate = linelight::baseline::GateRun::prepare(
                gate.save_baseline,
                gate.baseline.as_deref(),
                gate.junit,
                linelight::baseline::GateOptions {
                    noise: gate.noise,
                    ops_growth: gate.ops_growth,
                    ..Default::default()
                },
                &setup,
            )?;
            let device = open_gpu(&gpu)?;
            eprintln!(
                "case {}: {} natural configurations (and top-ups), {} methods",
                setup.case.name,
                setup.case.materials.iter().map(|m| m.count).sum::<usize>(),
                setup.methods.len()
            );
            if let Some(shard) = shard {
                let part = app::sweep::measure_part(
                    &setup,
                    &device,
                    sweep::MeasureOptions {
                        chunk: gpu.chunk,
                        raw: None,
                        shard: Some(shard),
                    },
                    false,
                )?;
                let path = app::sweep::write_shard(&out, &case, &gpu.kernels, &part)?;
                println!(
                    "shard {}/{}: {} configurations; state: {}",
                    shard.0,
                    shard.1,
                    part.measured.configurations(),
                    path.display()
                );
                return Ok(Status::Ok);
            }
            let observe = gate.wants_observations();
            // --raw is staged while measuring (rows streamed a chunk at a time, never all in
            // memory) and put in place after the report set: on an error neither replaces
            // anything.
            let (measured, staged) = match &raw {
                None => (
                    app::sweep::measure(
                        &setup,
                        &device,
                        sweep::MeasureOptions {
                            chunk: gpu.chunk,
                            raw: None,
                            shard: None,
                        },
                        observe,
                    )?,
                    None,
                ),
                Some(raw) => {
                    let mut measured = None;
                    let mut failed = None;
                    let staged = stage_output(raw, &mut |w| {
                        match app::sweep::measure(
                            &setup,
                            &device,
                            sweep::MeasureOptions {
                                chunk: gpu.chunk,
                                raw: Some(w),
                                shard: None,
                            },
                            observe,
                        ) {
                            Ok(m) => measured = Some(m),
                            Err(e) => failed = Some(e),
                        }
                        Ok(())
                    })?;
                    if let Some(e) = failed {
                        return Err(e);
                    }
                    (measured.expect("measured or failed"), Some(staged))
                }
            };
            report_sweep(
                SweepRun {
                    case_path: &case_path,
                    command_line: &command_line,
                    dir: &dir,
                    started,
                    raw: raw.as_deref(),
                },
                &setup,
                &measured,
                staged,
                &gate,
            )
        }
        Command::Merge { shards, out, gpu } => {
            let started = std::time::Instant::now();
            let command_line = shell_words::join(std::env::args());
            let (case_path, kernels, parts) = app::sweep::read_shards(&shards)?;
            let loaded = Case::load(std::path::Path::new(&case_path))?;
            let dir = out.join(&loaded.name);
            check_set(&dir)?;
            let setup = sweep::prepare_with(loaded, &kernels, parts[0].count_override, false)?;
            let part = app::sweep::Partial::merge_all(&setup, parts)?;
            let gate = linelight::baseline::GateRun::prepare(None, None, None, Default::default(), &setup)?;
            let device = open_gpu(&GpuArgs {
                kernels: kernels.clone(),
                ..gpu
            })?;
            let measured = app::sweep::finish(&setup, &device, part)?;
            report_sweep(
                SweepRun {
                    case_path: &case_path,
                    command_line: &command_line,
                    dir: &dir,
                    started,
                    raw: None,
                },
                &setup,
                &measured,
                None,
                &gate,
            )
        }
        Command::Eval {
            input,
            output,
            methods: specs,
            attribution,
            gpu,
        } => {
            let mut inputs = vec![("--input", input.as_path())];
            inputs.extend(kernel_inputs(&gpu.kernels));
            check_output("--output", &output, &inputs, &[])?;
            let kernels = methods::kernel_set(&gpu.kernels)?;
            let specs = if specs.is_empty() {
                kernels.iter().map(|k| k.id.clone()).collect()
            } else {
                specs
            };
            methods::check_unique(&specs, "--methods")?;
            let methods = specs
                .iter()
                .map(|s| methods::resolve(s, &kernels))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let lines = eval::count_lines(&input)?;
            limits::check(
                &format!("eval of {} ({lines} lines)", input.display()),
                // One chunk of configurations, values and rows at a time, plus the ids (checked
                // for repeats over the whole input).
                limits::Bytes(
                    limits::eval_estimate(lines.min(eval_chunk() as u64), methods.len() as u64)
                        .0
                        .saturating_add(64u64.saturating_mul(lines)),
                ),
                limits::max_memory(),
            )
            .map_err(anyhow::Error::msg)?;
            // Every line checked before the GPU is touched; then the input is streamed a chunk
            // at a time (GPU, references, rows), in constant memory and input order.
            eval::for_each_config(&input, eval_chunk(), true, &mut |_| Ok(()))?;
            let device = open_gpu(&gpu)?;
            let pipelines = methods
                .iter()
                .map(|m| device.pipeline(m))
                .collect::<Result<Vec<_>, _>>()?;
            let mut written = 0;
            // The output is staged: a reference that cannot be computed (an error) leaves
            // nothing in place of what was there.
            write_output(&output, &mut |w| {
                let mut chunk = |configs: Vec<linelight::scene::Config>| -> anyhow::Result<()> {
                    let scenes: Vec<_> = configs.iter().map(linelight::scene::GpuScene::from).collect();
                    let mut f32s = Vec::new();
                    for p in &pipelines {
                        f32s.push(device.run(p, &scenes, gpu.chunk, &mut |_| {})?.values);
                    }
                    drop(scenes);
                    let references: Vec<_> = configs
                        .par_iter()
                        .map(|c| {
                            eval::targets_of(c)
                                .into_iter()
                                .filter_map(|t| linelight::reference::reference(c, t).map(|e| (t, e)))
                                .collect::<std::collections::BTreeMap<_, _>>()
                        })
                        .collect();
                    eval::check_references(&input, &configs, &references)?;
                    for (block, part) in configs.chunks(eval::ROW_BLOCK).enumerate() {
                        let at = block * eval::ROW_BLOCK..block * eval::ROW_BLOCK + part.len();
                        let values: Vec<&[f32]> = f32s.iter().map(|v| &v[at.clone()]).collect();
                        let rows = eval::rows(part, &methods, &values, &references[at], attribution)?;
                        w.write_all(&linelight::io::to_jsonl(&rows))?;
                    }
                    written += configs.len();
                    Ok(())
                };
                eval::for_each_config(&input, eval_chunk(), false, &mut chunk)
                    .map(|_| ())
                    .map_err(|e| std::io::Error::other(format!("{e:#}")))
            })?;
            eprintln!("wrote {written} results to {}", output.display());
            Ok(Status::Ok)
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
            let options = app::BenchOptions {
                case,
                methods,
                count,
                repeats,
                warmup,
                adapter,
                kernels,
                json,
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
        } => {
            if aniso {
                let size: [usize; 4] = aniso_size
                    .try_into()
                    .map_err(|v: Vec<usize>| anyhow::anyhow!("--aniso-size takes 4 numbers, got {}", v.len()))?;
                let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_aniso.csv"));
                linelight::ltc::aniso::fit_command(&out, size)?;
            } else {
                let out = out.unwrap_or_else(|| PathBuf::from("data/ltc_ggx_iso.csv"));
                linelight::ltc::fit_command(&out, size)?;
            }
            Ok(Status::Ok)
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
            Ok(Status::Ok)
        }
        Command::Diff {
            case,
            a,
            b,
            count,
            noise,
            output,
            adapter,
        } => {
            let outcome = linelight::diff::run(&linelight::diff::DiffOptions {
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

/// Where a sweep's report goes and how the run was called.
struct SweepRun<'a> {
    case_path: &'a str,
    command_line: &'a str,
    dir: &'a std::path::Path,
    started: std::time::Instant,
    raw: Option<&'a std::path::Path>,
}

/// Analyses a measured sweep (or merged shards), writes its report set, and gives the verdict's
/// exit code.
fn report_sweep(
    run: SweepRun,
    setup: &sweep::Setup,
    swept: &app::sweep::Swept,
    staged: Option<linelight::io::Staged>,
    gate: &linelight::baseline::GateRun,
) -> anyhow::Result<Status> {
    let SweepRun {
        case_path,
        command_line,
        dir,
        started,
        raw,
    } = run;
    let t = std::time::Instant::now();
    let measured = &swept.measured;
    let analysis = swept.accumulators.finish(&setup.case, &setup.methods);
    let facts = claims::Facts {
        analysis: Some(analysis.clone()),
        configurations: measured.natural.iter().sum(),
        costs: measured.costs.clone(),
        disagreements: measured.disagreements.clone(),
        found: measured.found.clone(),
        ..claims::dry_facts(&setup.case, setup.methods.iter().map(|m| m.label.clone()).collect())
    };
    let claim_results = claims::evaluate(&setup.case.claims, facts);
    let stages = summary::Stages {
        analysis_seconds: measured.timing.statistics_seconds + t.elapsed().as_secs_f64(),
        until_report_seconds: started.elapsed().as_secs_f64(),
    };
    let input = Summary::new(
        summary::RunInfo {
            case_path,
            command_line,
            stages,
        },
        setup,
        measured,
        swept.leak.clone(),
        analysis,
        claim_results,
    )?;
    for path in report::write_reports(dir, &input)? {
        eprintln!("wrote {}", path.display());
    }
    if let (Some(staged), Some(raw)) = (staged, &raw) {
        staged.commit()?;
        eprintln!("wrote {}", raw.display());
    }
    let (analysis, claim_results) = (&input.analysis, &input.claims);
    let gate_report = gate.finish(setup, (measured, swept.observations.as_ref()), &analysis.checks)?;
    let regressed = gate_report.as_ref().is_some_and(|g| g.regressed());
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
    if let Some(g) = &gate_report {
        println!("{}", g.summary());
    }
    // 3: a finding no longer holds (the report says which); 1: a tolerance failed.
    Ok(if !stale.is_empty() {
        Status::StaleClaim
    } else if analysis.verdict == Verdict::Fail || regressed {
        Status::ToleranceFail
    } else {
        Status::Ok
    })
}

/// Configurations eval holds at a time: `eval::EVAL_CHUNK`, or `LINELIGHT_EVAL_CHUNK` (tests
/// use a small one to cover several chunks with a few lines).
fn eval_chunk() -> usize {
    std::env::var("LINELIGHT_EVAL_CHUNK")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n: &usize| n > 0)
        .unwrap_or(eval::EVAL_CHUNK)
}

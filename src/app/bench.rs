//! `linelight bench`: the case sampled (the app layer's `prepare`), then the bench's
//! measure, analyse and report parts (src/measure/bench.rs).

use std::path::PathBuf;

/// What `linelight bench` was asked for.
#[derive(clap::Args, Clone, Debug)]
pub struct BenchOptions {
    /// Case file whose sampler makes the configurations and names the methods and pairs.
    #[arg(default_value = "cases/line_fwt.toml")]
    pub case: PathBuf,
    /// Comma-separated method specs (default: the case's methods).
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Configurations per dispatch, split evenly over the case's materials.
    #[arg(long, default_value_t = 65536)]
    pub count: usize,
    /// Timed rounds (every method once per round, in rotated order).
    #[arg(long, default_value_t = 9)]
    pub repeats: usize,
    /// Untimed rounds first.
    #[arg(long, default_value_t = 2)]
    pub warmup: usize,
    /// Adapter to use: any part of its name (default: lavapipe / llvmpipe).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Extra method kernel(s) to make available, validated like the built-ins.
    #[arg(long = "kernel", value_name = "FILE")]
    pub kernels: Vec<PathBuf>,
    /// Also write the costs (one object per method) as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Also time each method's envelope (docs/envelope.md) on N configurations spread over
    /// the dispatch's, beside the CPU f32 column, in the same rounds.
    #[arg(long, value_name = "N")]
    pub envelope: Option<usize>,
}

/// `linelight bench`: samples the case's configurations, measures, prints the report to
/// stdout (progress on stderr) and writes the JSON if asked.
pub fn bench(
    options: &BenchOptions,
    includes: &crate::kernel::Includes,
) -> anyhow::Result<crate::analyse::bench::BenchRun> {
    use crate::limits::{check_count, check_rounds, MAX_ROUNDS};
    check_count("--count", options.count as u64).map_err(anyhow::Error::msg)?;
    check_rounds("--repeats", options.repeats as u64, MAX_ROUNDS, false).map_err(anyhow::Error::msg)?;
    check_rounds("--warmup", options.warmup as u64, MAX_ROUNDS, true).map_err(anyhow::Error::msg)?;
    if let Some(n) = options.envelope {
        anyhow::ensure!(
            (1..=options.count).contains(&n),
            "--envelope {n}: configurations for the envelope's timing, from 1 to --count ({})",
            options.count
        );
    }
    if let Some(json) = &options.json {
        // Refused before any work: the case file or a kernel as the output.
        let mut plan = crate::io::OutputPlan::new();
        plan.input("the case file", &options.case);
        for k in &options.kernels {
            plan.input("--kernel", k);
        }
        plan.file("--json", json).check()?;
    }
    let mut case = crate::input::case::Case::load(&options.case)?;
    if !options.methods.is_empty() {
        crate::kernel::methods::check_unique(&options.methods, "--methods")?;
        case.methods = options.methods.clone();
    }
    let materials = case.materials.len();
    anyhow::ensure!(materials > 0, "case `{}` has no materials", case.name);
    // The methods measured decide which pairs are compared (and `prepare` checks them).
    case.compare
        .retain(|pair| pair.iter().all(|l| case.methods.contains(l)));
    let setup = crate::app::prepare(
        case,
        &options.kernels,
        includes,
        Some(options.count.div_ceil(materials)),
    )?;
    let configs = crate::measure::bench::split_evenly(&setup.samples, materials, options.count);
    for m in &setup.methods {
        let missing = configs.iter().filter(|c| !m.applies(c)).count();
        anyhow::ensure!(
            missing == 0,
            "{} (target {}) does not apply to {missing} of case `{}`'s configurations: \
             bench it with a case whose sampler makes {} configurations",
            m.label,
            m.target(),
            setup.case.name,
            m.target()
        );
    }

    let gpu = crate::measure::gpu::Gpu::new(options.adapter.as_deref())?;
    println!("adapter: {}", gpu.adapter);
    let pb = crate::measure::progress::styled(0, "bench", "{msg:>12} [{bar:40}] {pos}/{len} (eta {eta})");
    let times = crate::measure::bench::bench_methods_with(
        &gpu,
        &setup.methods,
        &configs,
        crate::measure::bench::Rounds {
            envelope: options.envelope,
            ..crate::measure::bench::Rounds::fixed(options.warmup, options.repeats)
        },
        &mut |done, total| {
            pb.set_length(total as u64);
            pb.set_position(done as u64);
        },
    )?;
    pb.finish_and_clear();
    let bench = crate::analyse::bench::BenchRun {
        adapter: gpu.adapter.to_string(),
        case: setup.case.name.clone(),
        materials,
        warmup: options.warmup,
        cpu_threads: rayon::current_num_threads(),
        pairs: setup.case.compare.clone(),
        costs: crate::analyse::bench::costs(&times),
    };
    print!("{}", crate::report::bench::render(&bench));
    if let Some(path) = &options.json {
        use crate::report::format::{write_file, Json, Layout};
        write_file(path, &Json::new("bench JSON", &bench.costs, Layout::PrettyLine))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(bench)
}

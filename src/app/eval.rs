//! `linelight eval`: explicit configurations (JSONL in, JSONL out; docs/eval-format.md), every
//! line checked before the GPU is touched, then streamed a chunk at a time.

use super::{kernel_inputs, open_gpu, GpuOptions, Status};
use crate::io::{write_output, OutputPlan};
use anyhow::Context;
use rayon::prelude::*;
use std::path::PathBuf;

/// Options of `linelight eval`.
#[derive(clap::Args)]
pub struct EvalOptions {
    #[arg(long)]
    pub input: PathBuf,
    #[arg(long)]
    pub output: PathBuf,
    /// Comma-separated method ids (`id` or `id@N`); default: every built-in and --kernel method.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Also give each line the kernel source lines where f32 rounding loses bits
    /// (local error per operation, docs/eval-format.md `attribution`).
    #[arg(long)]
    pub attribution: bool,
    /// Also give each line the envelope of every method: the interval of f32 results any
    /// WGSL implementation within the spec's accuracy rules may return (docs/envelope.md).
    #[arg(long)]
    pub envelope: bool,
    #[command(flatten)]
    pub gpu: GpuOptions,
}

pub fn eval(options: EvalOptions, includes: &crate::kernel::Includes) -> anyhow::Result<Status> {
    let EvalOptions {
        input,
        output,
        methods: specs,
        attribution,
        envelope,
        gpu,
    } = options;
    let gpu = &gpu;
    // The input is read three times (counted, checked, evaluated): a FIFO or a device
    // would give its lines once, or never end.
    if std::fs::metadata(&input).is_ok_and(|m| !m.is_file()) {
        anyhow::bail!(
            "--input {}: not a regular file (it is read three times: counted, checked, then evaluated)",
            input.display()
        );
    }
    let mut plan = OutputPlan::new();
    plan.input("--input", &input);
    for (what, path) in kernel_inputs(&gpu.kernels) {
        plan.input(what, path);
    }
    plan.file("--output", &output).check()?;
    let kernels = crate::kernel::methods::kernel_set(&gpu.kernels, includes)?;
    let specs = if specs.is_empty() {
        kernels.iter().map(|k| k.id.clone()).collect()
    } else {
        specs
    };
    crate::kernel::methods::check_unique(&specs, "--methods")?;
    let methods = specs
        .iter()
        .map(|s| crate::kernel::methods::resolve(s, &kernels))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let size = crate::measure::eval_rows::count_lines(&input)?;
    let lines = size.lines;
    let chunk = eval_chunk() as u64;
    // One chunk of configurations, values and rows at a time, the text of its lines (a
    // texture makes a line long), plus the ids (checked for repeats over the whole input).
    let mut budget = crate::limits::Budget::new();
    budget
        .add(
            format!("{} configurations evaluated at once", lines.min(chunk)),
            crate::limits::eval_estimate(lines.min(chunk), methods.len() as u64),
        )
        .add(
            format!("their lines (the longest {} bytes)", size.longest),
            crate::limits::line_estimate(size.chunk_bytes(chunk)),
        )
        .add(
            format!("the ids of {lines} lines"),
            crate::limits::Bytes(crate::measure::eval_rows::ID_BYTES.saturating_mul(lines)),
        );
    budget
        .check(&format!("eval of {} ({lines} lines)", input.display()))
        .map_err(anyhow::Error::msg)?;
    // Every line checked before the GPU is touched; then the input is streamed a chunk
    // at a time (GPU, references, rows), in constant memory and input order.
    crate::measure::eval_rows::for_each_config(&input, eval_chunk(), true, &mut |_| Ok(()))?;
    let device = open_gpu(gpu.adapter.as_deref())?;
    let pipelines = methods
        .iter()
        .map(|m| device.pipeline(m))
        .collect::<Result<Vec<_>, _>>()?;
    let mut written = 0;
    // An error of the run itself (a GPU failure, the loop limit, a reference): kept whole, so
    // its message and exit code are its own (4 for a GPU failure), not a failed write's.
    let mut stopped: Option<anyhow::Error> = None;
    // The output is staged: a reference that cannot be computed (an error) leaves
    // nothing in place of what was there.
    let done = write_output(&output, &mut |w| {
        let mut chunk = |configs: Vec<crate::input::scene::Config>| -> anyhow::Result<()> {
            let (scenes, texels) = crate::input::scene::gpu_scenes(&configs);
            let mut f32s = Vec::new();
            for p in &pipelines {
                f32s.push(device.run_textured(p, &scenes, &texels, gpu.chunk, &mut |_| {})?.values);
            }
            drop((scenes, texels));
            let references: Vec<_> = configs
                .par_iter()
                .map(|c| crate::reference::references(c, &crate::measure::eval_rows::targets_of(c, &methods)))
                .collect();
            crate::measure::eval_rows::check_references(&input, &configs, &references)?;
            // The same targets at the configuration rounded to f32 (input rounding apart).
            let references_f32: Vec<_> = configs
                .par_iter()
                .zip(&references)
                .map(|(c, exact)| {
                    let targets = exact.keys().copied().collect();
                    crate::measure::eval_rows::references_f32_inputs(c, &targets, exact)
                })
                .collect();
            for (block, part) in configs.chunks(crate::measure::eval_rows::ROW_BLOCK).enumerate() {
                let at = block * crate::measure::eval_rows::ROW_BLOCK
                    ..block * crate::measure::eval_rows::ROW_BLOCK + part.len();
                let values: Vec<&[f32]> = f32s.iter().map(|v| &v[at.clone()]).collect();
                let rows = crate::measure::eval_rows::rows(
                    part,
                    &methods,
                    &values,
                    &references[at.clone()],
                    Some(&references_f32[at]),
                    attribution,
                    envelope,
                )?;
                w.write_all(&crate::io::to_jsonl(&rows))
                    .with_context(|| format!("cannot write {}", output.display()))?;
            }
            written += configs.len();
            Ok(())
        };
        crate::measure::eval_rows::for_each_config(&input, eval_chunk(), false, &mut chunk)
            .map(|_| ())
            .map_err(|e| {
                stopped = Some(e);
                std::io::Error::other("eval stopped")
            })
    });
    if let Some(e) = stopped {
        return Err(e);
    }
    done?;
    eprintln!("wrote {written} results to {}", output.display());
    Ok(Status::Ok)
}

/// Configurations eval holds at a time: `crate::measure::eval_rows::EVAL_CHUNK`, or
/// `LINELIGHT_EVAL_CHUNK` (src/tuning.rs).
fn eval_chunk() -> usize {
    crate::tuning::tuning()
        .eval_chunk
        .unwrap_or(crate::measure::eval_rows::EVAL_CHUNK)
}

//! A render's values (docs/render.md): each method's GPU f32 on the floor pixels'
//! configurations, the f64 references of the targets they need (checked), and the rows of
//! pixels.jsonl with the CPU evaluator's columns (eval's path), each stage timed.

use crate::input::scene::Config;
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::measure::eval_rows;
use crate::measure::gpu::Gpu;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// Seconds since `t`, rounded to the millisecond (as render.json writes them).
pub fn secs(t: Instant) -> f64 {
    (t.elapsed().as_secs_f64() * 1000.0).round() / 1000.0
}

/// A render's measured values, per floor pixel in configuration order.
pub struct RenderValues {
    /// Per method: its GPU f32 values.
    pub f32s: Vec<Vec<f32>>,
    pub references: Vec<BTreeMap<Target, crate::reference::Estimate>>,
    /// The rows of pixels.jsonl (eval's format).
    pub rows: Vec<serde_json::Value>,
    pub gpu_s: f64,
    pub references_s: f64,
    pub cpu_columns_s: f64,
}

/// Runs every method on the GPU, the references and the CPU columns over `configs`; `scene`
/// names the scene file in a reference's error.
pub fn measure(
    device: &Gpu,
    methods: &[Method],
    configs: &[Config],
    chunk: usize,
    scene: &Path,
) -> anyhow::Result<RenderValues> {
    let started = Instant::now();
    let scenes: Vec<_> = configs.iter().map(crate::input::scene::GpuScene::from).collect();
    let mut f32s = Vec::new();
    for m in methods {
        let p = device.pipeline(m)?;
        f32s.push(device.run(&p, &scenes, chunk, &mut |_| {})?.values);
    }
    drop(scenes);
    let gpu_s = secs(started);
    let started = Instant::now();
    let references: Vec<BTreeMap<Target, crate::reference::Estimate>> = configs
        .par_iter()
        .map(|c| crate::reference::references(c, &eval_rows::targets_of(c, methods)))
        .collect();
    eval_rows::check_references(scene, configs, &references)?;
    let references_s = secs(started);
    let started = Instant::now();
    let mut rows = Vec::with_capacity(configs.len());
    for (block, part) in configs.chunks(eval_rows::ROW_BLOCK).enumerate() {
        let at = block * eval_rows::ROW_BLOCK..block * eval_rows::ROW_BLOCK + part.len();
        let values: Vec<&[f32]> = f32s.iter().map(|v| &v[at.clone()]).collect();
        rows.extend(eval_rows::rows(
            part,
            methods,
            &values,
            &references[at],
            None,
            false,
            false,
        )?);
    }
    Ok(RenderValues {
        f32s,
        references,
        rows,
        gpu_s,
        references_s,
        cpu_columns_s: secs(started),
    })
}

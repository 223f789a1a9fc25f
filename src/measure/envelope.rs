//! The sweep's "Any conforming driver" measurement (docs/envelope.md): each method's
//! envelope on a stated subsample of the configurations the attribution subset spreads over,
//! with the references it is judged against, and on a smaller part of it where the freedom goes.

use crate::eval::interp::{EnvelopeStop, Line};
use crate::input::scene::{Config, GpuScene};
use crate::input::target::Target;
use crate::kernel::methods::Method;
use crate::measure::gpu::{Gpu, MethodPipeline};
use std::collections::BTreeMap;

/// Configurations per method on which "where the freedom goes" re-evaluates the envelope once
/// per loose line.
pub const FREEDOM_CONFIGURATIONS: usize = 32;

/// One configuration's envelope.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct EnvelopeRow {
    /// Index into the case's materials.
    pub material: usize,
    pub config: Config,
    /// The GPU's f32 value on this configuration (the envelope's gate check).
    pub gpu: f32,
    /// The method's own target and its `_upper` view where there is one.
    pub references: BTreeMap<Target, f64>,
    /// `[lo, hi]`, or why there is no finite bound (and the line, when one is named).
    pub interval: Result<(f64, f64), (String, Option<Line>)>,
}

/// One method's envelopes and freedom.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct MethodEnvelope {
    pub label: String,
    pub target: Target,
    pub rows: Vec<EnvelopeRow>,
    /// Per line: the mean bits of envelope width its allowance adds, and on how many
    /// configurations it used one; most first.
    pub freedom: Vec<(Line, f64, usize)>,
    pub freedom_configurations: usize,
    pub seconds: f64,
}

/// The references an envelope is judged against: the method's target and its `_upper` view.
fn targets(t: Target) -> Vec<Target> {
    let mut out = vec![t];
    out.extend(Target::from_name(&format!("{}_upper", t.name())));
    out
}

/// Every method's envelopes on at most `sample` of its spread subset (evenly spaced), with the
/// GPU's values there (one dispatch per method, `pipelines` in method order). Each row names the
/// material its configuration was drawn for, carried in the subset (global index, material, configuration: `sweep::Spread`, written out here so that this file does not import the sweep).
pub fn any_driver(
    methods: &[Method],
    subsets: &[Vec<(usize, usize, crate::input::scene::Config)>],
    sample: usize,
    (gpu, pipelines): (&Gpu, &[MethodPipeline]),
) -> anyhow::Result<Vec<MethodEnvelope>> {
    use rayon::prelude::*;
    methods
        .iter()
        .zip(subsets)
        .zip(pipelines)
        .map(|((m, subset), pipeline)| {
            let t = std::time::Instant::now();
            let step = subset.len().div_ceil(sample.max(1)).max(1);
            let picked: Vec<&(usize, usize, crate::input::scene::Config)> =
                subset.iter().step_by(step).take(sample).collect();
            let program = crate::eval::interp::program(m)?;
            let scenes: Vec<GpuScene> = picked.iter().map(|(_, _, c)| GpuScene::from(c)).collect();
            let values = if scenes.is_empty() {
                Vec::new()
            } else {
                gpu.run(pipeline, &scenes, scenes.len(), &mut |_| {})?.values
            };
            let rows = picked
                .par_iter()
                .zip(&values)
                .map(|((_, material, c), &value)| -> anyhow::Result<EnvelopeRow> {
                    let out =
                        crate::eval::interp::envelope(m, c)?.expect("the subset holds configurations it applies to");
                    let interval = match out.value {
                        Ok(v) => Ok((v.lo, v.hi)),
                        Err(EnvelopeStop::Gap { gap, line, .. }) => {
                            let why = match gap {
                                crate::eval::envelope::interval::Gap::NonFinite(w) => format!("Inf/NaN: {w}"),
                                crate::eval::envelope::interval::Gap::Domain(w) => {
                                    format!("outside the spec's domain: {w}")
                                }
                            };
                            Err((why, line.map(|l| program.lines[l].clone())))
                        }
                        Err(EnvelopeStop::TooWide(w)) => Err((format!("too wide: {w}"), None)),
                        Err(EnvelopeStop::Unsupported(w)) => Err((w, None)),
                    };
                    let references = targets(m.target())
                        .into_iter()
                        .filter_map(|t| crate::reference::reference(c, t).map(|e| (t, e.value)))
                        .collect();
                    Ok(EnvelopeRow {
                        material: *material,
                        config: c.clone(),
                        gpu: value,
                        references,
                        interval,
                    })
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let fstep = picked.len().div_ceil(FREEDOM_CONFIGURATIONS).max(1);
            let freed: Vec<_> = picked.iter().step_by(fstep).collect();
            let per = freed
                .par_iter()
                .map(|(_, _, c)| crate::eval::interp::freedom(m, c))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let mut by_line: BTreeMap<(String, usize), (Line, f64, usize)> = BTreeMap::new();
            for lines in &per {
                for (l, bits) in lines {
                    let e = by_line.entry((l.path.clone(), l.line)).or_insert((l.clone(), 0.0, 0));
                    e.1 += bits;
                    e.2 += 1;
                }
            }
            let n = freed.len().max(1) as f64;
            let mut freedom: Vec<_> = by_line.into_values().map(|(l, s, k)| (l, s / n, k)).collect();
            freedom.sort_by(|a, b| b.1.total_cmp(&a.1));
            Ok(MethodEnvelope {
                label: m.label.clone(),
                target: m.target(),
                rows,
                freedom,
                freedom_configurations: freed.len(),
                seconds: t.elapsed().as_secs_f64(),
            })
        })
        .collect()
}

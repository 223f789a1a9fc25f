//! A sweep's measuring with its folds: the measure stage yields measured chunks
//! (`measure::sweep::measure_chunks`), and each is folded into the statistics
//! (`analysis::Accumulators`), the leak below the horizon and, for the gate and `diff`, the
//! per-configuration observations before it is dropped; then the searches, the cost pass and
//! the attribution. Sweep, merge and diff share it.

use crate::analyse::analysis::{Accumulators, Fold, Leak, LeakAccumulator};
use crate::analyse::observations::Observations;
use crate::analyse::partial::{Partial, SHARD_FORMAT};
use crate::analyse::stats::{add_to_each, Accumulate};
use crate::measure::gpu::Gpu;
use crate::measure::sweep::{self, MeasureOptions, Measured, Setup};
use std::time::Instant;

/// A measured sweep with its folded statistics: what the analysis, the report and the gate
/// are made from.
pub struct Swept {
    pub measured: Measured,
    pub accumulators: Accumulators,
    /// How much of `line` lies below the horizon, per family (line cases).
    pub leak: Vec<Leak>,
    /// The gate's observations (`observe`).
    pub observations: Option<Observations>,
}

/// Measures the configurations (all, or one shard's) chunk by chunk, folding each into the
/// statistics and, when `observe`, into the gate's observations.
pub fn measure_part(setup: &Setup, gpu: &Gpu, options: MeasureOptions, observe: bool) -> anyhow::Result<Partial> {
    let case = &setup.case;
    let methods = &setup.methods;
    let shard = options.shard.unwrap_or((0, 1));
    let mut accumulators = Accumulators::new(case, methods);
    let mut leak = LeakAccumulator::new(case.materials.len());
    let mut observations = observe.then(|| crate::app::gate::observations(methods.len(), case.materials.len()));
    let mut statistics_seconds = 0.0;
    let mut measured = sweep::measure_chunks(setup, gpu, options, &mut |c| {
        let t = Instant::now();
        add_to_each(&mut [&mut accumulators, &mut leak], Fold { case, chunk: c });
        statistics_seconds += t.elapsed().as_secs_f64();
        if let Some(obs) = &mut observations {
            obs.add(Fold { case, chunk: c });
        }
        Ok(())
    })?;
    measured.timing.statistics_seconds += statistics_seconds;
    Ok(Partial {
        format: SHARD_FORMAT,
        case: case.name.clone(),
        seed: case.seed,
        count_override: setup.count_override,
        shard,
        methods: methods.iter().map(|m| m.label.clone()).collect(),
        accumulators,
        leak,
        measured,
        observations,
    })
}

/// The searches, the cost pass and the attribution after measuring: a swept sweep.
pub fn finish(setup: &Setup, gpu: &Gpu, part: Partial) -> anyhow::Result<Swept> {
    Ok(Swept {
        measured: sweep::search_and_cost(setup, gpu, part.measured)?,
        accumulators: part.accumulators,
        leak: part.leak.finish(&setup.case),
        observations: part.observations,
    })
}

/// Measures a whole sweep: its configurations chunk by chunk ([`measure_part`]), then the
/// searches, the cost pass and the attribution ([`finish`]).
pub fn measure(setup: &Setup, gpu: &Gpu, options: MeasureOptions, observe: bool) -> anyhow::Result<Swept> {
    let part = measure_part(setup, gpu, options, observe)?;
    finish(setup, gpu, part)
}

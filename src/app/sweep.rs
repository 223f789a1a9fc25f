//! The sweep's orchestration: the measure stage yields measured chunks (`sweep::measure_part`),
//! and each is folded here into the statistics (`analysis::Accumulators`), the leak below the
//! horizon and, for the gate, the per-configuration observations (`baseline::observe_chunk`)
//! before it is dropped. Also the shard state files (`--shard`, `linelight merge`,
//! docs/scale.md), which hold both the measure stage's kept state and the statistics.

use crate::analysis::{Accumulators, Chunk, Leak, LeakAccumulator};
use crate::baseline::Observations;
use crate::gpu::Gpu;
use crate::sweep::{self, MeasureOptions, Measured, Setup};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The version of the shard state file (`--shard`, docs/scale.md).
pub const SHARD_FORMAT: u32 = 2;

/// What measuring a sweep's configurations, or one shard's, leaves before the searches and
/// the cost pass: mergeable (`linelight merge`). Written by `sweep --shard i/n`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Partial {
    pub format: u32,
    pub case: String,
    pub seed: u64,
    pub count_override: Option<usize>,
    /// (i, n): this part is shard i of n; (0, 1) for a whole run.
    pub shard: (usize, usize),
    pub methods: Vec<String>,
    /// The statistics, folded in chunk by chunk.
    pub accumulators: Accumulators,
    pub leak: LeakAccumulator,
    /// The measure stage's kept state, draws and times.
    pub measured: sweep::Part,
    /// The gate's observations, when asked for (never in a shard file: the gate is unsharded).
    #[serde(skip)]
    pub observations: Option<Observations>,
}

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
    let mut observations = observe.then(|| crate::baseline::observations(methods.len(), case.materials.len()));
    let mut statistics_seconds = 0.0;
    let mut measured = sweep::measure_part(setup, gpu, options, &mut |c| {
        let t = Instant::now();
        let chunk = Chunk {
            samples: c.samples,
            references: c.references,
            runs: c.runs,
        };
        accumulators.add(case, &chunk);
        leak.add(&chunk);
        statistics_seconds += t.elapsed().as_secs_f64();
        if let Some(obs) = &mut observations {
            crate::baseline::observe_chunk(obs, &chunk);
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
        measured: sweep::finish(setup, gpu, part.measured)?,
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

impl Partial {
    /// Merges shards 0..n of one sweep (each exactly once) into the state of the whole run.
    pub fn merge_all(setup: &Setup, mut parts: Vec<Partial>) -> anyhow::Result<Partial> {
        anyhow::ensure!(!parts.is_empty(), "merge: no shard states given");
        parts.sort_by_key(|p| p.shard.0);
        let n = parts[0].shard.1;
        let labels: Vec<String> = setup.methods.iter().map(|m| m.label.clone()).collect();
        for (k, p) in parts.iter().enumerate() {
            anyhow::ensure!(
                p.format == SHARD_FORMAT,
                "merge: shard state format {} (this linelight reads {SHARD_FORMAT})",
                p.format
            );
            anyhow::ensure!(
                p.case == setup.case.name && p.seed == setup.case.seed && p.count_override == setup.count_override,
                "merge: shard {}/{} is of case `{}` seed {} --count {:?}, not `{}` seed {} --count {:?}",
                p.shard.0,
                p.shard.1,
                p.case,
                p.seed,
                p.count_override,
                setup.case.name,
                setup.case.seed,
                setup.count_override
            );
            anyhow::ensure!(
                p.methods == labels,
                "merge: shard {}/{} measured methods {:?}, the case has {:?}",
                p.shard.0,
                p.shard.1,
                p.methods,
                labels
            );
            anyhow::ensure!(
                p.shard == (k, n),
                "merge: expected shards 0..{n} of {n} once each, found {}/{} in place {k}",
                p.shard.0,
                p.shard.1
            );
        }
        anyhow::ensure!(parts.len() == n, "merge: {} of {n} shards given", parts.len());
        let mut it = parts.into_iter();
        let mut all = it.next().expect("not empty");
        for p in it {
            all.accumulators.merge(&p.accumulators).map_err(anyhow::Error::msg)?;
            all.leak.merge(&p.leak);
            all.measured.merge(p.measured, &setup.case);
        }
        all.shard = (0, 1);
        Ok(all)
    }
}

/// A shard state file: the case file and kernels the shard ran (merge reads them again, so
/// every shard and the merge run from the same checkout) and its [`Partial`].
#[derive(serde::Serialize, serde::Deserialize)]
struct ShardFile {
    case_file: String,
    kernels: Vec<PathBuf>,
    state: Partial,
}

/// Writes `OUT/shard-I-of-N.cbor` (atomically); returns its path.
pub fn write_shard(out: &Path, case_file: &Path, kernels: &[PathBuf], part: &Partial) -> anyhow::Result<PathBuf> {
    let (i, n) = part.shard;
    let path = out.join(format!("shard-{i}-of-{n}.cbor"));
    std::fs::create_dir_all(out).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", out.display()))?;
    let file = ShardFile {
        case_file: case_file.display().to_string(),
        kernels: kernels.to_vec(),
        state: part.clone(),
    };
    let mut bytes = Vec::new();
    ciborium::into_writer(&file, &mut bytes).map_err(|e| anyhow::anyhow!("cannot encode the shard state: {e}"))?;
    crate::io::write_bytes(&path, &bytes)?;
    Ok(path)
}

/// Every `shard-*-of-*.cbor` in the given directories: the case file, the kernels, the states.
pub fn read_shards(dirs: &[PathBuf]) -> anyhow::Result<(String, Vec<PathBuf>, Vec<Partial>)> {
    let mut files = Vec::new();
    for d in dirs {
        let entries = std::fs::read_dir(d).map_err(|e| anyhow::anyhow!("merge: cannot read {}: {e}", d.display()))?;
        for e in entries {
            let p = e?.path();
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            if name.starts_with("shard-") && name.ends_with(".cbor") {
                files.push(p);
            }
        }
    }
    files.sort();
    anyhow::ensure!(!files.is_empty(), "merge: no shard-I-of-N.cbor in {:?}", dirs);
    let mut first: Option<(String, Vec<PathBuf>)> = None;
    let mut parts = Vec::new();
    for p in files {
        let text = std::fs::read(&p).map_err(|e| anyhow::anyhow!("merge: cannot read {}: {e}", p.display()))?;
        let f: ShardFile = ciborium::from_reader(text.as_slice())
            .map_err(|e| anyhow::anyhow!("merge: {}: not a shard state: {e}", p.display()))?;
        match &first {
            None => first = Some((f.case_file.clone(), f.kernels.clone())),
            Some((c, k)) => anyhow::ensure!(
                c == &f.case_file && k == &f.kernels,
                "merge: {} ran case file {} with kernels {:?}; the first shard {} with {:?}",
                p.display(),
                f.case_file,
                f.kernels,
                c,
                k
            ),
        }
        parts.push(f.state);
    }
    let (case_file, kernels) = first.expect("at least one file");
    Ok((case_file, kernels, parts))
}

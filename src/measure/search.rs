//! Searches in a family's dimensionless parameters (the uniforms the sampler draws from):
//! - the worst case of one method: the configuration of largest relative error;
//! - the disagreements of a compared pair: the configurations that maximise
//!   err_A / max(err_B, ε), searched both ways.
//!
//! Random restarts are the family's own random sample (its highest-scoring configurations);
//! local refinement is a (1, λ) hill climb in the uniforms with a shrinking step. Every
//! candidate batch is one GPU dispatch per method; references run on all cores. Errors are
//! relative with no floor, over configurations whose reference is not 0 (docs/statistics.md).

use crate::eval::interp::CpuColumns;
use crate::input::case::{Case, DisagreeSpec, SearchSpec};
use crate::input::sampler::{sample_from_units, Axes, Sample};
use crate::input::scene::{Config, GpuScene};
use crate::kernel::methods::Method;
use crate::measure::gpu::{Gpu, MethodPipeline};
use crate::reference::{self, Estimate};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

/// The worst configuration found for one method in one family.
#[derive(Clone, Debug, Serialize)]
pub struct Found {
    pub method: String,
    pub family: String,
    /// Worst relative error in the family's random sample (∞ for NaN/inf).
    pub sample_worst: f64,
    /// Worst relative error after refinement (∞ for NaN/inf).
    pub worst: f64,
    pub value: f32,
    pub reference: Estimate,
    pub config: Config,
    /// Candidates evaluated by the refinement.
    pub evaluations: usize,
}

/// One configuration where method `a` is much less accurate than method `b`.
#[derive(Clone, Debug, Serialize)]
pub struct Disagreement {
    pub a: String,
    pub b: String,
    pub family: String,
    /// err_a / max(err_b, ε) (∞ when a is NaN/inf and b is finite).
    pub ratio: f64,
    /// The largest ratio in the family's random sample, where the search started.
    pub sample_ratio: f64,
    pub err_a: f64,
    pub err_b: f64,
    pub value_a: f32,
    pub value_b: f32,
    /// The same formulas in f64, where a CPU evaluation exists.
    pub f64_a: Option<f64>,
    pub f64_b: Option<f64>,
    pub reference: Estimate,
    pub axes: Axes,
    pub config: Config,
}

/// Relative error with no floor; NaN and ±inf rank above every finite error. None where the
/// reference is 0 (no relative error there).
pub fn rel_error(value: f32, r: &Estimate) -> Option<f64> {
    if r.value == 0.0 {
        return None;
    }
    Some(if value.is_finite() {
        (value as f64 - r.value).abs() / r.value.abs()
    } else {
        f64::INFINITY
    })
}

/// How much less accurate a is than b: err_a / max(err_b, ε); a NaN/inf b scores 0.
pub fn disagreement_ratio(err_a: f64, err_b: f64, epsilon: f64) -> f64 {
    if err_b.is_infinite() {
        0.0
    } else {
        err_a / err_b.max(epsilon)
    }
}

/// Evaluates candidates: each method on the GPU (one dispatch each), references on all cores,
/// then `score` on (values, reference). One result per candidate, in order.
fn evaluate(
    gpu: &Gpu,
    methods: &[(&Method, &MethodPipeline)],
    candidates: Vec<Sample>,
    score: &(dyn Fn(&[f32], &Estimate) -> Option<f64> + Sync),
) -> anyhow::Result<Vec<Option<Start>>> {
    let target = methods[0].0.target();
    let configs: Vec<_> = candidates.iter().map(|s| s.config.clone()).collect();
    let (scenes, texels): (Vec<GpuScene>, _) = crate::input::scene::gpu_scenes(&configs);
    drop(configs);
    let mut per_method = Vec::new();
    for (_, pipeline) in methods {
        per_method.push(gpu.run_textured(pipeline, &scenes, &texels, 0, &mut |_| {})?.values);
    }
    Ok(candidates
        .into_par_iter()
        .enumerate()
        .map(|(k, sample)| {
            let reference = reference::reference(&sample.config, target)?;
            let values: Vec<f32> = per_method.iter().map(|v| v[k]).collect();
            let score = score(&values, &reference)?;
            Some(Start {
                sample,
                values,
                reference,
                score,
            })
        })
        .collect())
}

/// How hard a hill climb looks.
struct Climb {
    steps: usize,
    population: usize,
    seed: u64,
}

/// What a start is known by: its uniforms, bit for bit (a configuration is a pure function of
/// them, so two starts with one key are one configuration and climb alike).
pub fn start_key(sample: &Sample) -> Vec<u64> {
    sample.units.iter().map(|u| u.to_bits()).collect()
}

/// SplitMix64's finaliser: a well-mixed word from a counter.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of one start's climb: the search's seed and the start's uniforms. A start climbs
/// alike whatever other starts climb beside it (in a shard or in the whole run).
fn start_seed(search: u64, key: &[u64]) -> u64 {
    key.iter()
        .fold(mix(search), |h, &w| mix(h.wrapping_add(0x9E37_79B9_7F4A_7C15) ^ w))
}

/// One start's climb: the start's key, where the climb ended, the candidates it evaluated and,
/// for a disagreement, both methods' f64 values there (where it disagrees, score > 1).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Climbed {
    pub key: Vec<u64>,
    pub end: Start,
    pub evaluations: usize,
    pub f64: Vec<Option<f64>>,
}

/// Moves every start to the best-scoring candidate near it, step after step; returns one
/// climb per start, in order. Each start draws its candidates from its own stream
/// ([`start_seed`]), so its climb does not depend on the others: the climbs of a shard's starts
/// are those the whole run makes of the same starts.
fn climb(
    case: &Case,
    family: usize,
    starts: Vec<Start>,
    how: &Climb,
    accept: &dyn Fn(&Config) -> bool,
    eval: &mut dyn FnMut(Vec<Sample>) -> anyhow::Result<Vec<Option<Start>>>,
) -> anyhow::Result<Vec<Climbed>> {
    let keys: Vec<Vec<u64>> = starts.iter().map(|s| start_key(&s.sample)).collect();
    let mut rngs: Vec<ChaCha8Rng> = keys
        .iter()
        .map(|k| ChaCha8Rng::seed_from_u64(start_seed(how.seed, k)))
        .collect();
    let mut evaluations = vec![0; starts.len()];
    let mut current = starts;
    let name = &case.materials[family].name;
    for step in 0..how.steps {
        let sigma = 0.2 * 0.8f64.powi(step as i32);
        let mut candidates = Vec::new();
        let mut owner = Vec::new();
        for (k, p) in current.iter().enumerate() {
            // Once a start has reached an infinite score there is nothing higher to find.
            if p.score.is_infinite() {
                continue;
            }
            let rng = &mut rngs[k];
            for c in 0..how.population {
                let units: Vec<f64> = p
                    .sample
                    .units
                    .iter()
                    .map(|&u| {
                        // A normal step from two uniforms (Box–Muller), reflected into [0, 1).
                        let (a, b): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
                        let n = (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos();
                        let x = (u + sigma * n).rem_euclid(2.0);
                        (if x > 1.0 { 2.0 - x } else { x }).min(1.0 - f64::EPSILON)
                    })
                    .collect();
                let id = format!("{name}-search-{step}-{c}");
                if let Some(s) = sample_from_units(case, family, &units, id) {
                    if accept(&s.config) {
                        candidates.push(s);
                        owner.push(k);
                        evaluations[k] += 1;
                    }
                }
            }
        }
        // No candidate this step: the next step's smaller steps may still find some.
        if candidates.is_empty() {
            continue;
        }
        let points = eval(candidates)?;
        let mut best: Vec<Option<Start>> = current.iter().map(|_| None).collect();
        for (p, &k) in points.into_iter().zip(&owner).filter_map(|(p, k)| Some((p?, k))) {
            if best[k].as_ref().is_none_or(|b| p.score > b.score) {
                best[k] = Some(p);
            }
        }
        for (cur, b) in current.iter_mut().zip(best) {
            if let Some(b) = b.filter(|b| b.score > cur.score) {
                *cur = b;
            }
        }
    }
    Ok(keys
        .into_iter()
        .zip(current)
        .zip(evaluations)
        .map(|((key, end), evaluations)| Climbed {
            key,
            end,
            evaluations,
            f64: Vec::new(),
        })
        .collect())
}

/// A seed from a tag and the case's seed: the same search on every machine.
fn seed_of(case: &Case, family: usize, tag: &str) -> u64 {
    tag.bytes()
        .fold(case.seed ^ family as u64, |h, b| h.rotate_left(5) ^ b as u64)
}

/// A configuration of the sweep's sample a search may start from: the sample, the searched
/// methods' values on it, its reference and its score.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Start {
    pub sample: Sample,
    pub values: Vec<f32>,
    pub reference: Estimate,
    pub score: f64,
}

/// The `k` highest-scoring starts seen, in bounded memory (a sweep streams its sample past it).
/// Ties keep the earlier configuration, as a stable sort of the whole sample would.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct TopK {
    k: usize,
    /// (the configuration's global index, the start).
    items: Vec<(usize, Start)>,
}

impl TopK {
    pub fn new(k: usize) -> TopK {
        TopK { k, items: Vec::new() }
    }

    /// How many starts it keeps at most.
    pub fn k(&self) -> usize {
        self.k
    }

    /// How many kept starts score at least `score` (all of the part's that do, while fewer
    /// than `k`).
    pub fn at_least(&self, score: f64) -> usize {
        self.items.iter().filter(|(_, s)| s.score >= score).count()
    }

    /// Whether a start of this score would be kept (checked before building it).
    pub fn wants(&self, score: f64) -> bool {
        self.items.len() < self.k || self.items.iter().any(|(_, s)| score >= s.score)
    }

    /// Offers configuration `index` (global: ties keep the lower index).
    pub fn push(&mut self, index: usize, start: Start) {
        if self.k == 0 {
            return;
        }
        if self.items.len() < self.k {
            self.items.push((index, start));
            return;
        }
        // The weakest kept: lowest score, latest among equals.
        let (w, _) = self
            .items
            .iter()
            .enumerate()
            .min_by(|(_, a), (_, b)| a.1.score.total_cmp(&b.1.score).then(b.0.cmp(&a.0)))
            .expect("k > 0 items");
        let weakest = &self.items[w];
        if start.score > weakest.1.score || (start.score == weakest.1.score && index < weakest.0) {
            self.items[w] = (index, start);
        }
    }

    /// Adds another part's starts: the k best of both.
    pub fn merge_from(&mut self, o: &TopK) {
        for (index, start) in &o.items {
            self.push(*index, start.clone());
        }
    }

    /// Best first.
    pub fn into_sorted(mut self) -> Vec<Start> {
        self.items
            .sort_by(|a, b| b.1.score.total_cmp(&a.1.score).then(a.0.cmp(&b.0)));
        self.items.into_iter().map(|(_, s)| s).collect()
    }
}

/// The climbs of the starts `starts` (best first), found among `climbs` by key: every start a
/// search keeps must have been climbed (by the run, or by the shard that measured it).
fn climbs_of<'a>(starts: &[Start], climbs: &'a [Climbed], what: &str) -> anyhow::Result<Vec<&'a Climbed>> {
    let by_key: std::collections::HashMap<&[u64], &Climbed> = climbs.iter().map(|c| (c.key.as_slice(), c)).collect();
    starts
        .iter()
        .map(|s| {
            by_key.get(start_key(&s.sample).as_slice()).copied().ok_or_else(|| {
                anyhow::anyhow!(
                    "{what}: the start {} of the whole sample was not climbed by any part (a shard of another \
                     linelight?): re-run the shards with this linelight",
                    crate::input::names::clip(&s.sample.config.id)
                )
            })
        })
        .collect()
}

/// Climbs one method's starts in one family towards its largest error (one climb per start,
/// in order; each start's climb is the same wherever it runs).
pub fn search_climbs(
    case: &Case,
    spec: &SearchSpec,
    starts: Vec<Start>,
    method: &Method,
    (gpu, pipeline): (&Gpu, &MethodPipeline),
    family: usize,
) -> anyhow::Result<Vec<Climbed>> {
    if starts.is_empty() || spec.restarts == 0 {
        return Ok(Vec::new());
    }
    let accept = |c: &Config| method.applies(c) && method.supports(c);
    let how = Climb {
        steps: spec.steps,
        population: spec.population,
        seed: seed_of(case, family, &method.label),
    };
    let score = |v: &[f32], r: &Estimate| rel_error(v[0], r);
    climb(case, family, starts, &how, &accept, &mut |c| {
        evaluate(gpu, &[(method, pipeline)], c, &score)
    })
}

/// The worst case of one method in one family, from the whole sample's highest-error
/// configurations (`starts`, best first, the search's `restarts` of them) and their climbs.
pub fn search(
    case: &Case,
    spec: &SearchSpec,
    starts: Vec<Start>,
    method: &str,
    climbs: &[Climbed],
    family: usize,
) -> anyhow::Result<Option<Found>> {
    if starts.is_empty() || spec.restarts == 0 {
        return Ok(None);
    }
    let starts: Vec<Start> = starts.into_iter().take(spec.restarts).collect();
    let sample_worst = starts[0].score;
    let mine = climbs_of(&starts, climbs, &format!("worst-case search of `{method}`"))?;
    let evaluations = mine.iter().map(|c| c.evaluations).sum();
    let worst = mine
        .into_iter()
        .map(|c| &c.end)
        .max_by(|a, b| a.score.total_cmp(&b.score))
        .expect("at least one start");
    let mut config = worst.sample.config.clone();
    config.id = format!("worst-{method}-{}", case.materials[family].name);
    Ok(Some(Found {
        method: method.to_string(),
        family: case.materials[family].name.clone(),
        sample_worst,
        worst: worst.score,
        value: worst.values[0],
        reference: worst.reference,
        config,
        evaluations,
    }))
}

/// Climbs the starts of one family towards where `a` is least accurate relative to `b` (one
/// climb per start, in order, with both methods' f64 values where it ends disagreeing).
pub fn disagreement_climbs(
    case: &Case,
    spec: &DisagreeSpec,
    starts: Vec<Start>,
    gpu: &Gpu,
    (a, pa): (&Method, &MethodPipeline),
    (b, pb): (&Method, &MethodPipeline),
    family: usize,
) -> anyhow::Result<Vec<Climbed>> {
    if starts.is_empty() || spec.restarts == 0 {
        return Ok(Vec::new());
    }
    let eps = spec.epsilon;
    let accept = |c: &Config| a.applies(c) && b.applies(c) && a.supports(c) && b.supports(c);
    let ratio_of = |va: f32, vb: f32, r: &Estimate| -> Option<f64> {
        Some(disagreement_ratio(rel_error(va, r)?, rel_error(vb, r)?, eps))
    };
    let how = Climb {
        steps: spec.steps,
        population: spec.population,
        seed: seed_of(case, family, &format!("{}/{}", a.label, b.label)),
    };
    let score = |v: &[f32], r: &Estimate| ratio_of(v[0], v[1], r);
    let mut climbs = climb(case, family, starts, &how, &accept, &mut |c| {
        evaluate(gpu, &[(a, pa), (b, pb)], c, &score)
    })?;
    for c in climbs.iter_mut().filter(|c| c.end.score > 1.0) {
        let config = &c.end.sample.config;
        c.f64 = vec![a.eval_f64(config), b.eval_f64(config)];
    }
    Ok(climbs)
}

/// The configurations of one family where `a` is least accurate relative to `b`, from the
/// whole sample's best starts (best first) and their climbs: every restart's final point that
/// disagrees, best first.
pub fn disagreements(
    case: &Case,
    spec: &DisagreeSpec,
    starts: Vec<Start>,
    (a, b): (&str, &str),
    climbs: &[Climbed],
    family: usize,
) -> anyhow::Result<Vec<Disagreement>> {
    if starts.is_empty() || spec.restarts == 0 {
        return Ok(Vec::new());
    }
    let starts: Vec<Start> = starts.into_iter().take(spec.restarts).collect();
    let sample_ratio = starts[0].score;
    let mut points = climbs_of(&starts, climbs, &format!("disagreement search of `{a}` against `{b}`"))?;
    points.sort_by(|x, y| y.end.score.total_cmp(&x.end.score));
    let name = &case.materials[family].name;
    let found = points
        .into_iter()
        .enumerate()
        .filter(|(_, p)| p.end.score > 1.0)
        .map(|(k, c)| {
            let p = &c.end;
            let mut config = p.sample.config.clone();
            config.id = format!("disagree-{a}-worse-than-{b}-{name}-{k}");
            let err = |v: f32| rel_error(v, &p.reference).unwrap_or(f64::NAN);
            Disagreement {
                a: a.to_string(),
                b: b.to_string(),
                family: name.clone(),
                ratio: p.score,
                sample_ratio,
                err_a: err(p.values[0]),
                err_b: err(p.values[1]),
                value_a: p.values[0],
                value_b: p.values[1],
                f64_a: c.f64.first().copied().flatten(),
                f64_b: c.f64.get(1).copied().flatten(),
                reference: p.reference,
                axes: p.sample.axes.clone(),
                config,
            }
        })
        .collect();
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_ranks_nan_above_and_divides_by_at_least_epsilon() {
        let r = Estimate { value: 1.0, error: 0.0 };
        assert_eq!(rel_error(f32::NAN, &r), Some(f64::INFINITY));
        assert_eq!(rel_error(1.0, &Estimate { value: 0.0, error: 0.0 }), None);
        assert_eq!(disagreement_ratio(1e-3, 0.0, 1e-7), 1e4);
        assert_eq!(disagreement_ratio(1e-3, 1e-4, 1e-7), 10.0);
        assert_eq!(disagreement_ratio(1e-3, f64::INFINITY, 1e-7), 0.0);
    }
}

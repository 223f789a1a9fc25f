//! Worst-case search: for a method and a family, the configuration of largest error.
//! Random restarts are the family's own random sample (its worst configurations); local
//! refinement is a (1, λ) hill climb in the family's uniforms (the dimensionless parameters
//! the sampler draws from), with a shrinking step. Every candidate batch is one GPU dispatch.

use crate::analysis::MethodRun;
use crate::case::{Case, SearchSpec};
use crate::gpu::Gpu;
use crate::reference::{self, Estimate};
use crate::sampler::{sample_from_units, Sample};
use crate::scene::{Config, GpuScene};
use crate::stats::relative_error;
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

/// Relative error as the search ranks it: NaN and ±inf rank above every finite error.
fn score(value: f32, r: &Estimate, floor: f64) -> f64 {
    if value.is_finite() {
        relative_error(value as f64, r.value, floor)
    } else {
        f64::INFINITY
    }
}

struct Point {
    sample: Sample,
    value: f32,
    reference: Estimate,
    score: f64,
}

/// Evaluates candidates: the method on the GPU (one dispatch), references on all cores.
/// One result per candidate, in order (None where the target has no reference).
fn evaluate(
    case: &Case,
    gpu: &Gpu,
    pipeline: &crate::gpu::MethodPipeline,
    run: &MethodRun,
    candidates: Vec<Sample>,
) -> anyhow::Result<Vec<Option<Point>>> {
    let target = run.method.target();
    let scenes: Vec<GpuScene> = candidates.iter().map(|s| GpuScene::from(&s.config)).collect();
    let values = gpu.run(pipeline, &scenes, 0, &mut |_| {})?.values;
    Ok(candidates
        .into_par_iter()
        .zip(values)
        .map(|(sample, value)| {
            let reference = reference::reference(&sample.config, target)?;
            let score = score(value, &reference, case.floor_for(target, &sample.config));
            Some(Point {
                sample,
                value,
                reference,
                score,
            })
        })
        .collect())
}

/// Searches one method over one family, starting from the sweep's own sample of it.
pub fn search(
    case: &Case,
    spec: &SearchSpec,
    samples: &[Sample],
    references: &crate::analysis::References,
    run: &MethodRun,
    (gpu, pipeline): (&Gpu, &crate::gpu::MethodPipeline),
    family: usize,
) -> anyhow::Result<Option<Found>> {
    let target = run.method.target();
    let members: Vec<usize> = (0..samples.len())
        .filter(|&i| samples[i].material == family && run.method.applies(&samples[i].config))
        .filter(|&i| run.method.supports(&samples[i].config))
        .collect();
    let ranked = |i: usize| {
        references[i]
            .get(&target)
            .map(|r| score(run.f32[i], r, case.floor_for(target, &samples[i].config)))
    };
    let mut starts: Vec<(usize, f64)> = members.iter().filter_map(|&i| Some((i, ranked(i)?))).collect();
    if starts.is_empty() {
        return Ok(None);
    }
    starts.sort_by(|a, b| b.1.total_cmp(&a.1));
    let sample_worst = starts[0].1;
    let mut current: Vec<Point> = starts
        .iter()
        .take(spec.restarts)
        .map(|&(i, s)| Point {
            sample: samples[i].clone(),
            value: run.f32[i],
            reference: references[i][&target],
            score: s,
        })
        .collect();

    // Seeded per method and family: the same search on every machine.
    let tag = run
        .method
        .label
        .bytes()
        .fold(case.seed ^ family as u64, |h, b| h.rotate_left(5) ^ b as u64);
    let mut rng = ChaCha8Rng::seed_from_u64(tag);
    let mut evaluations = 0;
    for step in 0..spec.steps {
        let sigma = 0.2 * 0.8f64.powi(step as i32);
        let mut candidates = Vec::new();
        let mut owner = Vec::new();
        for (k, p) in current.iter().enumerate() {
            // Once a start has reached NaN/inf there is nothing worse to find.
            if p.score.is_infinite() {
                continue;
            }
            for _ in 0..spec.population {
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
                let id = format!("{}-search-{}", case.materials[family].name, candidates.len());
                if let Some(s) = sample_from_units(case, family, &units, id) {
                    if run.method.supports(&s.config) {
                        candidates.push(s);
                        owner.push(k);
                    }
                }
            }
        }
        if candidates.is_empty() {
            break;
        }
        evaluations += candidates.len();
        let points = evaluate(case, gpu, pipeline, run, candidates)?;
        // Each start moves to its best candidate if that is worse (for the method) than where it is.
        let mut best: Vec<Option<Point>> = current.iter().map(|_| None).collect();
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
    let worst = current
        .into_iter()
        .max_by(|a, b| a.score.total_cmp(&b.score))
        .expect("at least one start");
    let mut config = worst.sample.config;
    config.id = format!("worst-{}-{}", run.method.label, case.materials[family].name);
    Ok(Some(Found {
        method: run.method.label.clone(),
        family: case.materials[family].name.clone(),
        sample_worst,
        worst: worst.score,
        value: worst.value,
        reference: worst.reference,
        config,
        evaluations,
    }))
}

//! The fit of seed 004 (Kt, Heitz, Dupuy, Narayanan, Sec. 4.2, Eqs. 9–10, Algorithms 1–3),
//! written here from its description: the sliced-Wasserstein (SW) distance between direction
//! samples of the GGX lobe and of the LTC, descended by stochastic gradient descent on M.
//!
//! One step (Algorithm 3): `samples` directions from the cosine-weighted GGX lobe (Algorithm 1:
//! visible normals, Heitz 2018, kept with probability G2/G1 ≤ 1, so the kept ones are
//! distributed exactly as D), `samples` from the LTC (Algorithm 2: cosine samples ω_o, ω =
//! M ω_o/‖M ω_o‖), both projected on each of `directions` random unit directions, each list
//! sorted, and the loss the mean over directions and ranks of |a_(k) − b_(k)| (Eq. 10, the
//! sorted projections' absolute differences). Its gradient flows back through the sort (a
//! permutation), the projection and the normalisation to M (the seed's PyTorch autograd; here
//! by hand, checked against finite differences in the tests), and M takes one SGD step.
//!
//! What the seed leaves open (its copy has lost the digits), chosen here and recorded in every
//! run: the samples per step, the learning rate and its schedule. M is the full 3×3 matrix in
//! the roughness frame; the loss does not see its scale (ω is normalised), so after each step
//! M is divided by the length of its third column (the seed's storage convention, Sec. 7),
//! which keeps the step size meaningful. The learning rate decays linearly to 0 over the
//! steps, so the last steps average the sampling noise out instead of jittering on it.
//!
//! Deterministic: every random number comes from a ChaCha8 stream seeded per entry.

use super::fit::M3;
use super::ggx::{Ggx, V3};
use crate::input::geometry::{dot, mat_vec};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;

/// The hyperparameters of one SW fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Gradient steps (the seed: 10 000).
    pub steps: usize,
    /// Random projection directions per step (the seed: 64).
    pub directions: usize,
    /// Samples of each distribution per step (lost from the seed's copy).
    pub samples: usize,
    /// The first step's learning rate; it decays linearly to 0 at the last step.
    pub learning_rate: f64,
}

/// What `linelight fit --aniso --objective sw` uses by default: the seed's 64 directions per
/// step, 128 samples of each distribution per step (the seed's number is lost), and 2 000
/// steps, not the seed's 10 000 (`--sw-steps` sets them): one step is about 0.44 ms of CPU
/// (169 s for the subset's 192 × 2 000), so the seed's count is 14 CPU-minutes for the subset,
/// but the committed run got a quarter of one core on this shared 2-core machine (load 11 to
/// 14) and took 11 minutes at 2 000 steps; 10 000 would have taken about an hour. Learning
/// rate 0.5 decaying linearly, tried on five entries before the run (docs/ggx.md).
pub const PARAMS: Params = Params {
    steps: 2_000,
    directions: 64,
    samples: 128,
    learning_rate: 0.5,
};

/// A uniformly distributed unit vector.
fn sphere(rng: &mut ChaCha8Rng) -> V3 {
    let z = 2.0 * rng.random::<f64>() - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (TAU * rng.random::<f64>()).sin_cos();
    [r * c, r * s, z]
}

/// A cosine-distributed direction (Algorithm 2's ω_o).
fn cosine(rng: &mut ChaCha8Rng) -> V3 {
    let u1: f64 = rng.random();
    let r = u1.sqrt();
    let (s, c) = (TAU * rng.random::<f64>()).sin_cos();
    [r * c, r * s, (1.0 - u1).max(0.0).sqrt()]
}

/// Algorithm 1: a direction distributed as the cosine-weighted GGX lobe D, by rejection from
/// visible-normal samples (accepted with probability D/pdf = G2/G1 ≤ 1).
pub fn ggx_sample(g: &Ggx, rng: &mut ChaCha8Rng) -> V3 {
    loop {
        let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
        let (w, pdf) = g.sample(u1, u2);
        if pdf <= 0.0 || w[2] <= 0.0 {
            continue;
        }
        if u3 * pdf < g.eval(w) {
            return w;
        }
    }
}

/// Eq. 10 estimated with `target` (samples of the lobe, fixed) against `n` LTC samples of M,
/// over `directions` random directions: the loss and, if asked, its gradient with respect to M.
fn loss_and_gradient(m: &M3, target: &[V3], directions: usize, rng: &mut ChaCha8Rng, gradient: bool) -> (f64, M3) {
    let n = target.len();
    // The LTC samples: ω_o, y = M ω_o, ω = y/‖y‖.
    let origin: Vec<V3> = (0..n).map(|_| cosine(rng)).collect();
    let ys: Vec<V3> = origin.iter().map(|&o| mat_vec(m, o)).collect();
    let lengths: Vec<f64> = ys.iter().map(|y| dot(*y, *y).sqrt()).collect();
    let ws: Vec<V3> = ys.iter().zip(&lengths).map(|(y, l)| y.map(|x| x / l)).collect();
    // dL/dω per LTC sample, summed over directions.
    let mut dw = vec![[0.0f64; 3]; n];
    let mut loss = 0.0;
    let mut a: Vec<f64> = Vec::with_capacity(n);
    let mut b: Vec<(f64, usize)> = Vec::with_capacity(n);
    let scale = 1.0 / (n * directions) as f64;
    for _ in 0..directions {
        let d = sphere(rng);
        a.clear();
        a.extend(target.iter().map(|x| dot(*x, d)));
        a.sort_unstable_by(f64::total_cmp);
        b.clear();
        b.extend(ws.iter().enumerate().map(|(j, w)| (dot(*w, d), j)));
        b.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        for (k, &(p, j)) in b.iter().enumerate() {
            let diff = p - a[k];
            loss += diff.abs();
            if gradient && diff != 0.0 {
                let s = diff.signum() * scale;
                for c in 0..3 {
                    dw[j][c] += s * d[c];
                }
            }
        }
    }
    let mut grad = [[0.0f64; 3]; 3];
    if gradient {
        for j in 0..n {
            // dω/dy = (I − ω ωᵀ)/‖y‖; dy/dM_rc = δ ω_o,c.
            let w = ws[j];
            let g = dw[j];
            let gw = dot(g, w);
            let dy = [0, 1, 2].map(|r| (g[r] - gw * w[r]) / lengths[j]);
            for r in 0..3 {
                for c in 0..3 {
                    grad[r][c] += dy[r] * origin[j][c];
                }
            }
        }
    }
    (loss * scale, grad)
}

/// M divided by the length of its third column.
fn unit_third_column(m: &M3) -> M3 {
    let l = (m[0][2].powi(2) + m[1][2].powi(2) + m[2][2].powi(2)).sqrt();
    m.map(|r| r.map(|x| x / l))
}

/// The SW fit of the LTC to the lobe `g` from `start` (M in the lobe's frame), seeded by
/// `seed`: `params.steps` SGD steps of Algorithm 3. Returns M (third column of unit length)
/// and the mean loss over the last tenth of the steps (the objective as the descent saw it).
pub fn fit(g: &Ggx, start: &M3, params: &Params, seed: u64) -> (M3, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut m = unit_third_column(start);
    let tail = (params.steps / 10).max(1);
    let mut tail_loss = 0.0;
    let mut target = vec![[0.0; 3]; params.samples];
    for step in 0..params.steps {
        for t in target.iter_mut() {
            *t = ggx_sample(g, &mut rng);
        }
        let (loss, grad) = loss_and_gradient(&m, &target, params.directions, &mut rng, true);
        if step + tail >= params.steps {
            tail_loss += loss;
        }
        let lr = params.learning_rate * (1.0 - step as f64 / params.steps as f64);
        let mut next = m;
        for r in 0..3 {
            for c in 0..3 {
                next[r][c] -= lr * grad[r][c];
            }
        }
        let next = unit_third_column(&next);
        // A step that leaves the matrices of a distribution (singular, or not finite) is not
        // taken: the LTC needs an invertible M.
        if next.iter().flatten().all(|x| x.is_finite()) && crate::input::geometry::det(&next).abs() > 1e-12 {
            m = next;
        }
    }
    (m, tail_loss / tail as f64)
}

/// The SW distance (Eq. 10) between the lobe and the LTC of M, estimated with `samples`
/// samples of each and `directions` directions from the stream `seed`: with the same seed,
/// two matrices are judged on the same lobe samples and directions (common random numbers).
/// A finite-sample estimate: it has a floor (two sample sets of one distribution are not at
/// distance 0), the same for every M.
pub fn distance(g: &Ggx, m: &M3, samples: usize, directions: usize, seed: u64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let target: Vec<V3> = (0..samples).map(|_| ggx_sample(g, &mut rng)).collect();
    loss_and_gradient(m, &target, directions, &mut rng, false).0
}

/// The subset of the 8⁴ table fitted with the SW objective: every entry (8 θ × 8 α_max) of
/// three (φ, r) slices, given by index (iφ, ir): φ = 0 with r = 1 (isotropic, the view in the
/// xz-plane), φ = 38.6° with r = 1/4 (oblique view, the strongest anisotropy) and φ = 90°
/// with r = 0.571 (the view along the smoother axis). 192 entries, chosen by hand to span
/// isotropic, oblique and axis-aligned anisotropic lobes.
pub const SUBSET_SLICES: [[usize; 2]; 3] = [[0, 7], [3, 0], [7, 3]];

/// The indices (iθ, iφ, iα, ir) of the subset in a table of `size` (slices past the size
/// are left out), in table order.
pub fn subset(size: [usize; 4]) -> Vec<[usize; 4]> {
    let mut v = Vec::new();
    for t in 0..size[0] {
        for &[p, r] in &SUBSET_SLICES {
            if p >= size[1] || r >= size[3] {
                continue;
            }
            for a in 0..size[2] {
                v.push([t, p, a, r]);
            }
        }
    }
    v.sort_by_key(|&i| super::aniso::index(size, i));
    v
}

/// The seed of entry `i`'s stream: a fixed base mixed with the entry's indices, so each
/// entry's fit is reproducible alone, in any order and on any thread count.
pub fn entry_seed(i: [usize; 4]) -> u64 {
    let key = ((i[0] * 64 + i[1]) * 64 + i[2]) * 64 + i[3];
    0x5357_0004_2024_u64 ^ (key as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// The cold start of every SW fit: diag(αx, αy, 1), the lobe's roughness without its view
/// (the seed's point: the SW loss needs no start near the answer).
pub fn cold_start(g: &Ggx) -> M3 {
    [[g.ax, 0.0, 0.0], [0.0, g.ay, 0.0], [0.0, 0.0, 1.0]]
}

/// One table entry fitted with the SW objective, cold, from its own seed, then post-processed
/// as every fitted entry is (`aniso::post_process`): the magnitude and Schlick term are the
/// L1 fit's (the same quadrature), the lobe errors those of the stored M.
pub fn fit_entry(size: [usize; 4], i: [usize; 4], params: &Params) -> super::aniso::Entry {
    use super::aniso;
    let g = aniso::lobe(aniso::entry_point(size, i));
    let (magnitude, fresnel, _) = g.moments(super::fit::MOMENT_GRID);
    let (m, _) = fit(&g, &cold_start(&g), params, entry_seed(i));
    aniso::post_process(size, i, &m, magnitude, fresnel)
}

/// The subset fitted in parallel (`progress` told of each entry), in table order.
pub fn fit_subset(size: [usize; 4], params: &Params, progress: &(dyn Fn() + Sync)) -> Vec<super::aniso::Fitted> {
    use rayon::prelude::*;
    subset(size)
        .into_par_iter()
        .map(|i| {
            let e = fit_entry(size, i, params);
            progress();
            (i, e)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lobe() -> Ggx {
        let (st, ct) = 0.9f64.sin_cos();
        let (sp, cp) = 0.4f64.sin_cos();
        Ggx {
            ax: 0.4,
            ay: 0.15,
            view: [st * cp, st * sp, ct],
        }
    }

    /// The hand-written gradient against central differences of the same loss (the same
    /// samples and directions: the loss is piecewise linear in M, so a small step keeps the
    /// sort orders).
    #[test]
    fn the_gradient_matches_finite_differences() {
        let g = lobe();
        let m: M3 = [[0.5, 0.1, 0.3], [0.05, 0.2, 0.1], [-0.2, 0.05, 0.9]];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let target: Vec<V3> = (0..64).map(|_| ggx_sample(&g, &mut rng)).collect();
        let at = |m: &M3, grad: bool| {
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            loss_and_gradient(m, &target, 8, &mut rng, grad)
        };
        let (_, grad) = at(&m, true);
        let h = 1e-7;
        for r in 0..3 {
            for c in 0..3 {
                let (mut p, mut q) = (m, m);
                p[r][c] += h;
                q[r][c] -= h;
                let fd = (at(&p, false).0 - at(&q, false).0) / (2.0 * h);
                assert!(
                    (fd - grad[r][c]).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "dL/dM[{r}][{c}]: analytic {}, finite differences {fd}",
                    grad[r][c]
                );
            }
        }
    }

    /// Algorithm 1's samples follow D: their mean direction matches the quadrature's.
    #[test]
    fn lobe_samples_have_the_lobes_mean() {
        let g = lobe();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = 40_000;
        let mut mean = [0.0; 3];
        for _ in 0..n {
            let w = ggx_sample(&g, &mut rng);
            for k in 0..3 {
                mean[k] += w[k] / n as f64;
            }
        }
        let (norm, _, m) = g.moments(512);
        for k in 0..3 {
            let exact = m[k] / (512.0 * 512.0) / norm;
            assert!((mean[k] - exact).abs() < 0.01, "mean[{k}] {} against {exact}", mean[k]);
        }
    }

    /// The descent lowers the distance: from the diffuse LTC, a short fit ends far nearer
    /// the lobe, judged on samples the fit never saw.
    #[test]
    fn a_short_fit_approaches_the_lobe() {
        let g = lobe();
        let id: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let p = Params {
            steps: 400,
            directions: 16,
            samples: 128,
            learning_rate: 0.5,
        };
        let (m, _) = fit(&g, &id, &p, 1);
        let before = distance(&g, &id, 2048, 64, 99);
        let after = distance(&g, &m, 2048, 64, 99);
        assert!(after < 0.3 * before, "SW distance {before} → {after}");
    }
}

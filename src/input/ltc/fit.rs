//! Fitting LTCs to GGX in f64 (Heitz et al. 2016, Sec. 4 and their `fit_ltc.cpp`, written
//! here from the description): the LTC's magnitude is the lobe's integral, and its shape
//! minimises an error between `mag·D_ltc` and `D_ggx` over the sphere (`OBJECTIVE`: L1; the
//! paper's L3 is available), estimated by multiple importance sampling (balance heuristic)
//! of both distributions on deterministic midpoint grids, so a fit is a pure function of its
//! inputs. The minimiser is Nelder–Mead, as in the
//! paper (a 60-line routine: no crate was worth the dependency tree on this machine).
//!
//! Isotropic: M = [X Y Z]·[[m11,0,m13],[0,m22,0],[0,0,1]] with Z the lobe's mean direction
//! (in the xz-plane, where the view lies), so M⁻¹ has the sparse form of docs/conventions.md. General
//! (anisotropic, any view): the same frame and [[m00,m01,m02],[m10,m11,m12],[0,0,1]], started
//! from several guesses, keeping the best (seed 004, Sec. 4, explains why a single start fails).

use super::ggx::{Ggx, V3};
use crate::input::geometry::{cross, det, dot, inverse, mat_mul, mat_vec, normalize};
use crate::limits::MAX_TABLE_ENTRIES;
use std::f64::consts::PI;

pub type M3 = [[f64; 3]; 3];

/// The normalised LTC of matrix M (ω = M ω_o/‖M ω_o‖, ω_o cosine-distributed).
#[derive(Clone, Copy, Debug)]
pub struct Ltc {
    pub m: M3,
    pub minv: M3,
    det_minv: f64,
}

impl Ltc {
    pub fn new(m: M3) -> Ltc {
        let minv = inverse(&m);
        Ltc {
            m,
            minv,
            det_minv: det(&minv).abs(),
        }
    }

    /// The density (integrates to 1), the `ltc` form of docs/conventions.md.
    pub fn eval(&self, w: V3) -> f64 {
        let wo = mat_vec(&self.minv, w);
        let l = dot(wo, wo).sqrt();
        (wo[2] / l).max(0.0) * self.det_minv / (PI * l * l * l)
    }

    pub fn sample(&self, u1: f64, u2: f64) -> V3 {
        let r = u1.sqrt();
        let (s, c) = (2.0 * PI * u2).sin_cos();
        normalize(mat_vec(&self.m, [r * c, r * s, (1.0 - u1).sqrt()]))
    }
}

/// Samples per axis of the objective's grids (two grids of n² directions).
pub const OBJECTIVE_GRID: usize = 32;
/// Samples per axis for the magnitude, Fresnel term and mean direction.
pub const MOMENT_GRID: usize = 512;

/// Refuses a table size (entries per axis, given as `flag`) of more than [`MAX_TABLE_ENTRIES`].
pub fn check_table_size(flag: &str, sizes: &[usize]) -> anyhow::Result<()> {
    let entries = sizes
        .iter()
        .try_fold(1usize, |n, &s| n.checked_mul(s))
        .filter(|&n| n <= MAX_TABLE_ENTRIES);
    if entries.is_none() {
        let shown: Vec<String> = sizes.iter().map(usize::to_string).collect();
        anyhow::bail!(
            "{flag} {}: more than the {MAX_TABLE_ENTRIES} entries a fitted table may have (256 × 256; a fit \
             takes about 0.25 s per core)",
            shown.join(" × ")
        );
    }
    Ok(())
}

/// `(L3 error, relative L1 error)` of `mag·ltc` against the lobe, both by MIS over n×n grids.
pub fn errors(ggx: &Ggx, ltc: &Ltc, mag: f64, n: usize) -> (f64, f64) {
    let e = all_errors(ggx, ltc, mag, n);
    (e[0], e[1])
}

/// What the shape minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Objective {
    /// The paper's ∫|mag·D_ltc − D|³ dω.
    L3,
    /// ∫|mag·D_ltc − D| dω.
    L1,
    /// ∫(mag·D_ltc − D)²/(mag·D_ltc + D) dω: a relative error, bounded where either is 0.
    Chi2,
}

/// The lobe's half of the objective's MIS grid, which does not depend on the LTC: each
/// visible-normal sample with D and the GGX pdf there, computed once per fit instead of once
/// per Nelder–Mead evaluation (the same numbers in the same order, so the same bits).
pub struct LobeSamples<'a> {
    ggx: &'a Ggx,
    n: usize,
    samples: Vec<(V3, f64, f64)>,
}

impl<'a> LobeSamples<'a> {
    pub fn new(ggx: &'a Ggx, n: usize) -> LobeSamples<'a> {
        let mut samples = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                let (u1, u2) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let w = ggx.sample(u1, u2).0;
                samples.push((w, ggx.eval(w), ggx.pdf(w)));
            }
        }
        LobeSamples { ggx, n, samples }
    }

    /// `[L3, relative L1, χ²]` of `mag·ltc` against the lobe (see [`all_errors`]).
    pub fn errors(&self, ltc: &Ltc, mag: f64) -> [f64; 3] {
        let (mut l3, mut l1, mut chi2) = (0.0, 0.0, 0.0);
        let mut add = |f: f64, p_ggx: f64, p_ltc: f64| {
            let g = mag * p_ltc;
            let e = (g - f).abs();
            let p = p_ggx + p_ltc;
            if p > 0.0 {
                l3 += e * e * e / p;
                l1 += e / p;
                if g + f > 0.0 {
                    chi2 += e * e / (g + f) / p;
                }
            }
        };
        let n = self.n;
        for i in 0..n {
            for j in 0..n {
                let (w, f, p_ggx) = self.samples[i * n + j];
                add(f, p_ggx, ltc.eval(w));
                let (u1, u2) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let w = ltc.sample(u1, u2);
                add(self.ggx.eval(w), self.ggx.pdf(w), ltc.eval(w));
            }
        }
        let scale = 1.0 / (n * n) as f64;
        [l3 * scale, l1 * scale / mag, chi2 * scale / mag]
    }
}

/// `[L3, relative L1, χ²]` of `mag·ltc` against the lobe, by MIS over n×n grids.
pub fn all_errors(ggx: &Ggx, ltc: &Ltc, mag: f64, n: usize) -> [f64; 3] {
    LobeSamples::new(ggx, n).errors(ltc, mag)
}

/// Nelder–Mead on `f` from `x0` with initial steps `step`: standard coefficients
/// (reflection 1, expansion 2, contraction ½, shrink ½), stopped when the simplex's values
/// agree to `ftol` relatively or after `max_evals` evaluations. Deterministic.
pub fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    ftol: f64,
    max_evals: usize,
) -> (Vec<f64>, f64) {
    let n = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += step[i];
        let v = f(&x);
        simplex.push((x, v));
    }
    let mut evals = n + 1;
    let at = |c: &[f64], w: &[f64], t: f64| c.iter().zip(w).map(|(a, b)| a + t * (b - a)).collect::<Vec<f64>>();
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        if (worst - best).abs() <= ftol * best.abs().max(1e-300) {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|k| simplex[..n].iter().map(|s| s.0[k]).sum::<f64>() / n as f64)
            .collect();
        let xr = at(&centroid, &simplex[n].0, -1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = at(&centroid, &simplex[n].0, -2.0);
            let fe = f(&xe);
            evals += 1;
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = at(&centroid, &xr, 0.5);
                let v = f(&x);
                (x, v)
            } else {
                let x = at(&centroid, &simplex[n].0, 0.5);
                let v = f(&x);
                (x, v)
            };
            evals += 1;
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                let x0 = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 = at(&x0, &s.0, 0.5);
                    s.1 = f(&s.0);
                }
                evals += n;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// One fitted LTC: M⁻¹ (row-major, scaled so that its largest |entry| of the last row… see
/// `normalized`), the magnitude ∫D, the Schlick term ∫D(1 − v·h)⁵, and the fit errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub minv: M3,
    pub magnitude: f64,
    pub fresnel: f64,
    /// The paper's objective at the optimum, ∫|mag·D_ltc − D|³ dω (reported, not minimised).
    pub l3: f64,
    /// ∫|mag·D_ltc − D| dω / ∫D: the lobe's relative L1 error (what is minimised).
    pub l1: f64,
    /// The parameters found (iso: m11, m22, m13), to warm-start the neighbouring entry.
    pub params: [f64; 3],
}

/// The frame [X Y Z] (as columns) with Z the lobe's mean direction and Y the y axis made
/// perpendicular to it (for a mean in the xz-plane X = (Z.z, 0, −Z.x), as in the paper): the
/// same orientation for every entry, so that neighbouring matrices interpolate.
fn mean_frame(mean: V3) -> M3 {
    let z = normalize(mean);
    let y = normalize([-z[1] * z[0], 1.0 - z[1] * z[1], -z[1] * z[2]]);
    let x = cross(y, z);
    [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
}

/// M⁻¹ scaled so that its (2,2) entry is 1 (the sparse form of docs/conventions.md) when that is safe.
fn normalized(minv: M3) -> M3 {
    let s = minv[2][2];
    if s.abs() > 1e-12 {
        minv.map(|r| r.map(|x| x / s))
    } else {
        minv
    }
}

/// Fits an isotropic lobe whose view is in the xz-plane, starting from `start` (m11, m22,
/// m13; None: the diffuse LTC). At normal incidence the lobe is symmetric and only m11 = m22
/// is fitted, as in the paper.
pub fn fit_iso(ggx: &Ggx, start: Option<[f64; 3]>) -> Fit {
    fit_iso_with(ggx, start, OBJECTIVE)
}

/// The objective of our table and exact fits: L1 rather than the paper's L3, chosen on a pilot
/// (docs/ggx.md): at 6 table points × 300 random line lights (seed 5, not the report's), the
/// median relative error of the exact LTC line integral against GGX was lower with L1 at 5 of 6.
pub const OBJECTIVE: Objective = Objective::L1;

fn objective_value(e: [f64; 3], kind: Objective) -> f64 {
    match kind {
        Objective::L3 => e[0],
        Objective::L1 => e[1],
        Objective::Chi2 => e[2],
    }
}

/// [`fit_iso`] with a chosen objective.
pub fn fit_iso_with(ggx: &Ggx, start: Option<[f64; 3]>, objective_kind: Objective) -> Fit {
    let (magnitude, fresnel, mean) = ggx.moments(MOMENT_GRID);
    let mut mean = mean;
    mean[1] = 0.0;
    let frame = mean_frame(mean);
    let normal = ggx.view[0].abs() < 1e-12;
    let make = |p: [f64; 3]| Ltc::new(mat_mul(&frame, &[[p[0], 0.0, p[2]], [0.0, p[1], 0.0], [0.0, 0.0, 1.0]]));
    let lobe = LobeSamples::new(ggx, OBJECTIVE_GRID);
    let objective = |x: &[f64]| {
        let p = if normal { [x[0], x[0], 0.0] } else { [x[0], x[1], x[2]] };
        if p[0] <= 0.0 || p[1] <= 0.0 {
            return f64::INFINITY;
        }
        objective_value(lobe.errors(&make(p), magnitude), objective_kind)
    };
    let s = start.unwrap_or([1.0, 1.0, 0.0]);
    let (x, _) = if normal {
        nelder_mead(&objective, &[s[0]], &[0.05 * s[0]], 1e-9, 400)
    } else {
        nelder_mead(
            &objective,
            &s,
            &[0.05 * s[0], 0.05 * s[1], 0.05 * s[0].max(0.02)],
            1e-9,
            1200,
        )
    };
    let params = if normal { [x[0], x[0], 0.0] } else { [x[0], x[1], x[2]] };
    let ltc = make(params);
    let (l3, l1) = errors(ggx, &ltc, magnitude, OBJECTIVE_GRID);
    Fit {
        minv: normalized(ltc.minv),
        magnitude,
        fresnel,
        l3,
        l1,
        params,
    }
}

/// An exact fit of any GGX lobe (anisotropic, any view) with a general M in the mean
/// direction's frame, from several starting points; the best by the objective is kept.
pub fn fit_general(ggx: &Ggx) -> Fit {
    fit_general_from(ggx, None).0
}

/// [`fit_general`], optionally warm-started: with `warm` (the six parameters of a
/// neighbouring entry's fit, in that entry's mean frame), Nelder–Mead starts from them and
/// from the geometric-mean guess only, as the paper's table fits start from the neighbour
/// (seed 004 Sec. 4.1); without, from the three cold guesses. Returns the fit and its six
/// parameters, the next entry's warm start.
pub fn fit_general_from(ggx: &Ggx, warm: Option<[f64; 6]>) -> (Fit, [f64; 6]) {
    let (magnitude, fresnel, mean) = ggx.moments(MOMENT_GRID);
    let frame = mean_frame(mean);
    let make = |p: &[f64]| {
        Ltc::new(mat_mul(
            &frame,
            &[[p[0], p[1], p[2]], [p[3], p[4], p[5]], [0.0, 0.0, 1.0]],
        ))
    };
    let lobe = LobeSamples::new(ggx, OBJECTIVE_GRID);
    let objective = |x: &[f64]| {
        let ltc = make(x);
        if !(det(&ltc.m) > 0.0) || !ltc.minv.iter().flatten().all(|v| v.is_finite()) {
            return f64::INFINITY;
        }
        objective_value(lobe.errors(&ltc, magnitude), OBJECTIVE)
    };
    let (a, b) = (ggx.ax, ggx.ay);
    let g = (a * b).sqrt();
    let cold = [
        [a, 0.0, 0.0, 0.0, b, 0.0],
        [b, 0.0, 0.0, 0.0, a, 0.0],
        [g, 0.0, 0.0, 0.0, g, 0.0],
    ];
    let starts: Vec<[f64; 6]> = match warm {
        Some(w) if objective(&w).is_finite() => vec![w, cold[2]],
        _ => cold.to_vec(),
    };
    let mut best: Option<(Vec<f64>, f64)> = None;
    for start in starts {
        let step: Vec<f64> = [0.1 * a, 0.1 * g, 0.1 * g, 0.1 * g, 0.1 * b, 0.1 * g].to_vec();
        let mut x = start.to_vec();
        let mut fx = f64::INFINITY;
        // Restarts from the last optimum: Nelder–Mead stalls on 6 parameters otherwise.
        for _ in 0..3 {
            let (y, fy) = nelder_mead(&objective, &x, &step, 1e-10, 1500);
            let done = fy >= fx * (1.0 - 1e-6);
            (x, fx) = (y, fy.min(fx));
            if done {
                break;
            }
        }
        if best.as_ref().is_none_or(|(_, f)| fx < *f) {
            best = Some((x, fx));
        }
    }
    let (x, _) = best.expect("at least two starts");
    let ltc = make(&x);
    let (l3, l1) = errors(ggx, &ltc, magnitude, OBJECTIVE_GRID);
    let fit = Fit {
        minv: normalized(ltc.minv),
        magnitude,
        fresnel,
        l3,
        l1,
        params: [x[0], x[4], x[2]],
    };
    (fit, [x[0], x[1], x[2], x[3], x[4], x[5]])
}

/// Fits the whole isotropic table (entry (a, t) at `a + size·t`, table::entry_point):
/// each view angle t is a chain from the roughest entry (started from the diffuse LTC) to
/// the smoothest, each started from the previous fit, as in the paper. The chains run in
/// parallel; each is sequential, so the table does not depend on the thread count.
pub fn fit_table(size: usize, progress: &(dyn Fn() + Sync)) -> Vec<Fit> {
    use rayon::prelude::*;
    let rows: Vec<Vec<Fit>> = (0..size)
        .into_par_iter()
        .map(|t| {
            let mut row = vec![None; size];
            let mut start = None;
            for a in (0..size).rev() {
                let (alpha, ct) = super::table::entry_point(size, a, t);
                let st = (1.0 - ct * ct).max(0.0).sqrt();
                let g = Ggx {
                    ax: alpha,
                    ay: alpha,
                    view: [st, 0.0, ct],
                };
                let f = fit_iso(&g, start);
                start = Some(f.params);
                row[a] = Some(f);
                progress();
            }
            row.into_iter().map(|f| f.expect("every entry fitted")).collect()
        })
        .collect();
    let mut out = Vec::with_capacity(size * size);
    for row in rows {
        out.extend(row);
    }
    out
}
